"""The parser against docs/scene-format.md: every statement, default and constraint.

Expected values are the spec's own (its tables and example); every rejected
input is checked for the file and line its message names.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from whitted.converter import parse_file, parse_text
from whitted.converter.scene import Light, Material, Scene, Sphere
from whitted.errors import SceneError

SPEC_EXAMPLE = """\
# two spheres and a light
size 320 200
eye 0 0 8
fov 50
ambient 0.2
light 5 5 10
sphere 0 0 0 1   color 0.9 0.2 0.2  reflect 0.3
sphere 2 0 -1 0.7 color 1 1 1  refract 0.8 1.5
sphere -2 0 0 1  texture earth.png  north 0 1 0  equator 0 0 -1
"""


def parse(text: str, source="scene.scn") -> Scene:
    return parse_text(text, Path(source))


def error_of(text: str, source="scene.scn") -> SceneError:
    with pytest.raises(SceneError) as info:
        parse(text, source)
    return info.value


def assert_error(text: str, line: int, message: str, source="scene.scn") -> None:
    """The error names ``source`` and ``line`` and says ``message`` (a substring)."""
    error = error_of(text, source)
    assert (error.path, error.line) == (str(source), line), str(error)
    assert message in error.message, str(error)
    assert str(error) == f"{source}:{line}: {error.message}"


# ---------------------------------------------------------------- defaults


def test_empty_file_is_the_default_scene():
    scene = parse("")
    assert (scene.width, scene.height) == (640, 400)
    assert scene.eye == (0, 0, 10) and scene.lookat == (0, 0, 0) and scene.up == (0, 1, 0)
    assert scene.fov == 45 and scene.background == (0, 0, 0) and scene.ambient == 0.2
    assert scene.depth == 5 and scene.samples == 1
    assert scene.lights == [] and scene.spheres == []


def test_comments_and_blank_lines_only():
    assert parse("# nothing\n\n   \t\n# more # comments\n") == parse("")


def test_sphere_and_light_defaults():
    scene = parse("light 1 2 3\nsphere 0 0 0 1\n")
    assert scene.lights == [Light((1, 2, 3), (1, 1, 1), line=1)]
    (sphere,) = scene.spheres
    assert sphere.material == Material((1, 1, 1), 0.0, 0.0, 1.0, None)
    assert sphere.north == (0, 1, 0) and sphere.equator == (0, 0, -1)
    assert sphere.line == 2


def test_spec_example(tmp_path, texture_png):
    texture = texture_png("earth.png")
    path = tmp_path / "scene.scn"
    path.write_text(SPEC_EXAMPLE)
    scene = parse_file(path)
    assert scene.source == path
    assert (scene.width, scene.height, scene.eye, scene.fov, scene.ambient) == \
        (320, 200, (0, 0, 8), 50, 0.2)
    assert scene.lights == [Light((5, 5, 10), (1, 1, 1), line=6)]
    a, b, c = scene.spheres
    assert (a.center, a.radius, a.line) == ((0, 0, 0), 1, 7)
    assert a.material == Material((0.9, 0.2, 0.2), 0.3, 0.0, 1.0)
    assert (b.center, b.radius) == ((2, 0, -1), 0.7)
    assert b.material == Material((1, 1, 1), 0.0, 0.8, 1.5)
    assert c.material.texture == texture and c.material.texture.is_absolute()
    assert (c.north, c.equator, c.line) == ((0, 1, 0), (0, 0, -1), 9)


# -------------------------------------------------------------- statements


def test_every_global_statement():
    scene = parse("size 16384 1\neye 1 2 3\nlookat -1 -2 -3.5\nup 0 0 1\nfov 179\n"
                  "background 0.5 2 0\nambient 1\ndepth 64\nsamples 65536\n")
    assert (scene.width, scene.height) == (16384, 1)
    assert scene.eye == (1, 2, 3) and scene.lookat == (-1, -2, -3.5) and scene.up == (0, 0, 1)
    assert scene.fov == 179 and scene.background == (0.5, 2, 0) and scene.ambient == 1
    assert scene.depth == 64 and scene.samples == 65536


def test_lower_bounds_of_globals():
    scene = parse("size 1 1\nambient 0\ndepth 1\nsamples 1\nfov 0.001\nbackground 0 0 0\n")
    assert (scene.width, scene.height, scene.ambient, scene.depth, scene.samples, scene.fov) == \
        (1, 1, 0, 1, 1, 0.001)


def test_lights_any_number_and_colors():
    scene = parse("light 0 0 0\nlight 1 2 3 0 0.5 7\n" + "light 9 9 9\n" * 10)
    assert len(scene.lights) == 12
    assert scene.lights[1] == Light((1, 2, 3), (0, 0.5, 7), line=2)


def test_every_sphere_attribute_in_any_order(texture_png):
    texture = texture_png("tex.png")
    text = (f"sphere 1 2 3 4 equator 1 0 0 refract 0.25 1.33 texture tex.png "
            f"north 0 0 1 reflect 0.75 color 0 0.5 1\n")
    (sphere,) = parse_text(text, texture.parent / "a.scn").spheres
    assert (sphere.center, sphere.radius) == ((1, 2, 3), 4)
    assert sphere.material == Material((0, 0.5, 1), 0.75, 0.25, 1.33, texture)
    assert (sphere.north, sphere.equator) == ((0, 0, 1), (1, 0, 0))


def test_coefficients_at_their_bounds():
    scene = parse("sphere 0 0 0 1 reflect 1\nsphere 0 0 0 1 refract 1 0.5\n"
                  "sphere 0 0 0 1 reflect 0.1 refract 0.9 2\nsphere 0 0 0 1 color 0 1 0\n")
    assert [s.material.reflect + s.material.refract for s in scene.spheres] == [1, 1, 1, 0]


def test_keywords_are_case_insensitive():
    scene = parse("SIZE 10 20\nEye 0 0 5\nLookAt 0 0 1\nsPhErE 0 0 0 1 COLOR 0 0 0 Reflect 0.5\n")
    assert (scene.width, scene.height, scene.eye, scene.lookat) == (10, 20, (0, 0, 5), (0, 0, 1))
    assert scene.spheres[0].material.reflect == 0.5


@pytest.mark.parametrize("text, value", [
    ("1", 1.0), ("-0.5", -0.5), ("2e-3", 2e-3), ("+3", 3.0), ("1.", 1.0), (".5", 0.5),
    ("1E2", 100.0), ("1.5e+1", 15.0), ("007", 7.0), ("-0", 0.0),
])
def test_ordinary_decimal_and_scientific_numbers(text, value):
    assert parse(f"eye 0 0 {text}\nlookat 0 0 99\n").eye[2] == value


def test_tabs_and_extra_blanks_separate():
    assert parse("  size\t 10 \t 20   \n").width == 10


def test_line_continuation_joins_a_statement():
    scene = parse("\n# intro\nsphere 0 0 0 1 \\\n   color 0.5 0.5 0.5 \\\n\n"
                  "light 1 1 1\nsphere 1 1 1 1\\\nreflect 0.5\n")
    assert [s.line for s in scene.spheres] == [3, 7]
    assert scene.spheres[0].material.color == (0.5, 0.5, 0.5)
    assert scene.spheres[1].material.reflect == 0.5
    assert scene.lights[0].line == 6


def test_comment_after_continuation_and_backslash_in_comment():
    scene = parse("sphere 0 0 0 1 \\  # the color follows\n color 0 0 0\n"
                  "# a comment ending in \\\nlight 1 2 3\n")
    assert scene.spheres[0].material.color == (0, 0, 0)
    assert scene.lights[0].line == 4


def test_comment_ends_a_token():
    assert parse("fov 30#wide\n").fov == 30


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_line_endings(ending):
    scene = parse(ending.join(["size 10 20", "", "light 1 2 3", "sphere 0 0 0 1"]) + ending)
    assert scene.width == 10 and scene.spheres[0].line == 4 and scene.lights[0].line == 3


def test_byte_order_mark_and_no_final_newline(write_scene):
    assert parse_file(write_scene(b"\xef\xbb\xbfsize 10 20")).width == 10


def test_globals_may_come_after_spheres():
    scene = parse("sphere 0 0 0 1\nlight 1 1 1\nsize 20 10\nsphere 1 1 1 1\n")
    assert scene.width == 20 and len(scene.spheres) == 2


# ----------------------------------------------------------------- textures


def test_quoted_texture_path_with_spaces_and_hash(tmp_path, texture_png):
    texture = texture_png("my maps/earth #2.png")
    (sphere,) = parse_text('sphere 0 0 0 1 texture "my maps/earth #2.png" # a comment\n',
                           tmp_path / "s.scn").spheres
    assert sphere.material.texture == texture


def test_relative_texture_is_relative_to_the_scene_folder(tmp_path, texture_png, monkeypatch):
    texture = texture_png("scenes/sub/tex.png")
    monkeypatch.chdir(tmp_path)  # not the scene's folder
    (sphere,) = parse_text("sphere 0 0 0 1 texture sub/tex.png\n", Path("scenes/a.scn")).spheres
    assert sphere.material.texture == texture
    assert sphere.material.texture.is_absolute()


def test_absolute_texture_path(tmp_path, texture_png):
    texture = texture_png("abs.png")
    (sphere,) = parse_text(f'sphere 0 0 0 1 texture "{texture}"\n', Path("/elsewhere/a.scn")).spheres
    assert sphere.material.texture == texture


def test_exr_texture(tmp_path):
    import mitsuba as mi
    import numpy as np
    mi.Bitmap(np.ones((2, 4, 3), np.float32)).write(str(tmp_path / "t.exr"))
    (sphere,) = parse_text("sphere 0 0 0 1 texture t.exr\n", tmp_path / "a.scn").spheres
    assert sphere.material.texture == tmp_path / "t.exr"


@pytest.mark.parametrize("make, message", [
    (None, "no such file"),
    (lambda p: p.mkdir(), "is a folder, not an image"),
    (lambda p: p.write_bytes(b""), "is not an image Mitsuba can read"),
    (lambda p: p.write_text("this is text, not a picture " * 10), "is not an image Mitsuba can read"),
    (lambda p: p.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40), "is not an image Mitsuba can read"),
])
def test_missing_and_unreadable_textures(tmp_path, make, message):
    target = tmp_path / "tex.png"
    if make:
        make(target)
    source = tmp_path / "a.scn"
    error = error_of("size 10 10\n\nsphere 0 0 0 1 texture tex.png\n", source)
    assert (error.path, error.line) == (str(source), 3)
    assert message in error.message and "texture 'tex.png'" in error.message


@pytest.mark.parametrize("suffix", ["png", "jpg", "exr", "hdr", "pfm", "ppm"])
def test_textures_are_checked_as_mitsuba_reads_them(tmp_path, suffix):
    """Every format Mitsuba writes is accepted whole (the converter checks it without Mitsuba:
    converter/textures.py), and refused cut in half, where Mitsuba refuses it too: but for a
    JPEG, which libjpeg reads truncated (Mitsuba warns, and renders it)."""
    import mitsuba as mi
    import numpy as np
    pixels = np.linspace(0.05, 0.95, 9 * 13 * 3, dtype=np.float32).reshape(9, 13, 3)
    whole = tmp_path / f"whole.{suffix}"
    data = pixels if suffix in ("exr", "hdr", "pfm") else (pixels * 255).astype(np.uint8)
    mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(whole))
    cut = tmp_path / f"cut.{suffix}"
    cut.write_bytes(whole.read_bytes()[:whole.stat().st_size // 2])
    assert parse_text(f"sphere 0 0 0 1 texture whole.{suffix}\n", tmp_path / "a.scn").spheres
    for path in (whole, cut):
        try:
            mi.load_dict({"type": "bitmap", "filename": str(path)})
            mitsuba_reads = True
        except RuntimeError:
            mitsuba_reads = False
        text = f"size 10 10\nsphere 0 0 0 1 texture {path.name}\n"
        if mitsuba_reads:
            assert parse_text(text, tmp_path / "a.scn").spheres
        else:
            error = error_of(text, tmp_path / "a.scn")
            assert error.line == 2 and "is not an image Mitsuba can read" in error.message
    assert suffix == "jpg" or not mitsuba_reads   # the cut file: the case this test is about


def _png_chunks(data: bytes) -> dict[bytes, int]:
    """Each chunk's name -> where it starts in the PNG ``data`` (its length field)."""
    chunks, at = {}, 8
    while at < len(data):
        chunks.setdefault(data[at + 4:at + 8], at)
        at += 12 + int.from_bytes(data[at:at + 4], "big")
    return chunks


def _flipped(data: bytes, at: int) -> bytes:
    return data[:at] + bytes([data[at] ^ 0x80]) + data[at + 1:]


def _rgbe_headers(data: bytes) -> dict[str, bytes]:
    head, rest = data.split(b"\n\n", 1)
    size, pixels = rest.split(b"\n", 1)
    lines = {"no blank line": head + b"\n" + size, "no FORMAT line": b"#?RGBE\n\n" + size,
             "an EXPOSURE line": head + b"\nEXPOSURE=1.0\n\n" + size,
             "+Y H +X W": head + b"\n\n" + size.replace(b"-Y", b"+Y"),
             "+X W -Y H": head + b"\n\n" + b" ".join(size.split()[2:] + size.split()[:2]),
             "two spaces": head + b"\n\n" + size.replace(b" ", b"  "),
             "commas": head + b"\n\n" + size.replace(b" ", b","),
             "tabs": head + b"\n\n" + size.replace(b" ", b"\t"),
             "CR LF": head.replace(b"\n", b"\r\n") + b"\r\n\r\n" + size + b"\r",
             "letters for a size": head + b"\n\n" + size.replace(size.split()[1], b"ab")}
    return {name: header + b"\n" + pixels for name, header in lines.items()}


def _damaged(suffix: str, data: bytes) -> dict[str, bytes]:
    if suffix == "hdr":
        return _rgbe_headers(data)
    chunks = _png_chunks(data)
    idat, text, end = chunks[b"IDAT"], chunks[b"tEXt"], chunks[b"IEND"]
    idat_crc = idat + 8 + int.from_bytes(data[idat:idat + 4], "big")
    return {"an ancillary chunk's byte": _flipped(data, text + 10),
            "an ancillary chunk's name": _flipped(data, text + 5),
            "the pixels' checksum": _flipped(data, idat_crc),
            "the pixels' length": _flipped(data, idat),
            "the end chunk's name": _flipped(data, end + 5)}


@pytest.mark.parametrize("suffix", ["hdr", "png"])
def test_damaged_textures_are_judged_as_mitsuba_judges_them(tmp_path, suffix):
    """RGBE headers that Mitsuba's ``read_rgbe`` reads (no blank line, an extra line, spaces
    or commas between the numbers, CR LF) or refuses (no FORMAT line, another axis order,
    tabs, letters); PNG chunks damaged where libpng, as Mitsuba uses it, warns and reads on
    (an ancillary chunk's bytes, anything past the pixels) or stops (a critical chunk's
    checksum, or its length past the end; a name that is not four letters): the converter
    accepts what Mitsuba reads and refuses the rest, naming the line."""
    import mitsuba as mi
    import numpy as np
    pixels = np.linspace(0.05, 0.95, 9 * 13 * 3, dtype=np.float32).reshape(9, 13, 3)
    whole = tmp_path / f"whole.{suffix}"
    mi.Bitmap(pixels if suffix == "hdr" else (pixels * 255).astype(np.uint8),
              pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(whole))
    judged = set()
    for k, (damage, data) in enumerate(_damaged(suffix, whole.read_bytes()).items()):
        path = tmp_path / f"damaged{k}.{suffix}"
        path.write_bytes(data)
        try:
            mi.load_dict({"type": "bitmap", "filename": str(path)})
            mitsuba_reads = True
        except (RuntimeError, ValueError):
            mitsuba_reads = False
        text = f"size 10 10\nsphere 0 0 0 1 texture {path.name}\n"
        if mitsuba_reads:
            assert parse_text(text, tmp_path / "a.scn").spheres, damage
        else:
            error = error_of(text, tmp_path / "a.scn")
            assert error.line == 2 and "is not an image Mitsuba can read" in error.message, damage
        judged.add(mitsuba_reads)
    assert judged == {True, False}


def test_texture_without_read_permission(tmp_path, texture_png, monkeypatch):
    texture = texture_png("tex.png")
    real_access = os.access
    monkeypatch.setattr(os, "access",
                        lambda p, mode, **kw: False if Path(p) == texture else real_access(p, mode, **kw))
    error = error_of("sphere 0 0 0 1 texture tex.png\n", tmp_path / "a.scn")
    assert error.line == 1 and "permission denied" in error.message


@pytest.mark.parametrize("text, message", [
    ('sphere 0 0 0 1 texture ""\n', "texture path is empty"),
    ('sphere 0 0 0 1 texture "a\tb.png"\n', "control character"),
    ("sphere 0 0 0 1 texture\n", "texture takes 1 value (PATH), got 0"),
])
def test_bad_texture_paths(text, message):
    assert_error(text, 1, message)


# ----------------------------------------------------------- constraints


@pytest.mark.parametrize("text, message", [
    # size
    ("size 0 10", "size width must be >= 1 and <= 16384, got 0"),
    ("size 10 16385", "size height must be >= 1 and <= 16384, got 16385"),
    ("size 10 -5", "size height must be >= 1 and <= 16384, got -5"),
    ("size 99999999999999999999999999 1", "size width must be >= 1 and <= 16384"),
    ("size 1.5 10", "size width must be an integer, got 1.5"),
    ("size 640.0 10", "size width must be an integer, got 640.0"),
    ("size 1e3 10", "size width must be an integer, got 1e3"),
    ("size 10", "size takes 2 values (W H), got 1"),
    ("size 10 10 10", "size takes 2 values (W H), got 3"),
    # camera
    ("eye 0 0", "eye takes 3 values (X Y Z), got 2"),
    ("lookat 0 0 0 0", "lookat takes 3 values (X Y Z), got 4"),
    ("up 0 0 0", "up must not be zero"),
    ("fov 0", "fov must be > 0 and < 180, got 0"),
    ("fov 180", "fov must be > 0 and < 180, got 180"),
    ("fov -10", "fov must be > 0 and < 180, got -10"),
    ("fov 179.9999999999", "rounds to 180 in 32-bit floats"),
    ("fov 1e-9", "fov must be at least 1e-6"),
    ("fov", "fov takes 1 value (DEG), got 0"),
    # background, ambient, depth, samples
    ("background 0 -0.1 0", "background color must be >= 0, got -0.1"),
    ("background 1 1", "background takes 3 values (R G B), got 2"),
    ("ambient -0.01", "ambient must be >= 0 and <= 1, got -0.01"),
    ("ambient 1.0000000000000000001", "ambient must be >= 0 and <= 1"),
    ("depth 0", "depth must be >= 1 and <= 64, got 0"),
    ("depth 65", "depth must be >= 1 and <= 64, got 65"),
    ("depth 2.5", "depth must be an integer, got 2.5"),
    ("samples 0", "samples must be >= 1 and <= 65536, got 0"),
    ("samples 65537", "samples must be >= 1 and <= 65536, got 65537"),
    ("samples 1e2", "samples must be an integer, got 1e2"),
    # lights
    ("light 1 2", "light takes 3 or 6 values (X Y Z [R G B]), got 2"),
    ("light 1 2 3 1 1", "light takes 3 or 6 values (X Y Z [R G B]), got 5"),
    ("light 1 2 3 1 1 -1", "light color must be >= 0, got -1"),
    # spheres
    ("sphere 0 0 0 -1", "sphere radius must be > 0, got -1"),
    ("sphere 0 0 0 0", "sphere radius must be > 0, got 0"),
    ("sphere 0 0 0 1e-7", "sphere radius must be at least 1e-6"),
    ("sphere 0 0 1", "sphere takes 4 numbers (CX CY CZ RADIUS), got 3"),
    ("sphere", "sphere takes 4 numbers (CX CY CZ RADIUS), got 0"),
    ("sphere 0 0 0 color 1 1 1", "sphere takes 4 numbers (CX CY CZ RADIUS), got 3"),
    ("sphere 0 0 0 1 2", "sphere takes 4 numbers (CX CY CZ RADIUS) before its attributes, got 5"),
    ("sphere 0 0 0 1 color 1 1 1 0.5", "expected a sphere attribute name, got the number 0.5"),
    ("sphere 0 0 0 1 color 1.1 0 0", "sphere color must be >= 0 and <= 1, got 1.1"),
    ("sphere 0 0 0 1 color 0 -1 0", "sphere color must be >= 0 and <= 1, got -1"),
    ("sphere 0 0 0 1 color 1 1", "sphere color takes 3 values (R G B), got 2"),
    ("sphere 0 0 0 1 color 1 1 reflect 0.5", "sphere color takes 3 values (R G B), got 2"),
    ("sphere 0 0 0 1 reflect 1.5", "sphere reflect must be >= 0 and <= 1, got 1.5"),
    ("sphere 0 0 0 1 reflect -0.5", "sphere reflect must be >= 0 and <= 1, got -0.5"),
    ("sphere 0 0 0 1 refract 2 1.5", "sphere refract KT must be >= 0 and <= 1, got 2"),
    ("sphere 0 0 0 1 refract 0.5 0", "sphere refract IOR must be > 0, got 0"),
    ("sphere 0 0 0 1 refract 0.5 -1.5", "sphere refract IOR must be > 0, got -1.5"),
    ("sphere 0 0 0 1 refract 0.5", "sphere refract takes 2 values (KT IOR), got 1"),
    ("sphere 0 0 0 1 reflect 0.6 refract 0.5 1.5", "reflect + refract must be <= 1, got 0.6 + 0.5"),
    ("sphere 0 0 0 1 refract 0.41 1 reflect 0.6", "reflect + refract must be <= 1, got 0.6 + 0.41"),
    ("sphere 0 0 0 1 north 0 0 0", "sphere north must not be zero"),
    ("sphere 0 0 0 1 equator 0 0 0", "sphere equator must not be zero"),
    ("sphere 0 0 0 1 north 0 0 1", "equator 0 0 -1 (the default) must not be parallel to north 0 0 1"),
    ("sphere 0 0 0 1 north 1 1 0 equator -2 -2 0", "equator -2 -2 0 must not be parallel to north 1 1 0"),
    ("sphere 0 0 0 1 equator 0 3 0", "must not be parallel to north 0 1 0"),
    ("sphere 0 0 0 1 color 1 1 1 color 1 1 1", "sphere attribute color given twice"),
    ("sphere 0 0 0 1 reflect 0 REFLECT 0", "sphere attribute reflect given twice"),
    ("sphere 0 0 0 1 north 0 1 0", ""),  # valid: checked below not to raise
])
def test_constraints(text, message):
    if not message:
        parse(text)
        return
    assert_error(f"# header\n\n{text}\n", 3, message)


@pytest.mark.parametrize("token", ["nan", "NaN", "inf", "-inf", "+Infinity", "INF"])
def test_nan_and_inf_are_errors(token):
    assert_error(f"sphere 0 0 0 1 color 1 1 1\nfov {token}\n", 2, f"fov must be a finite number, got {token}")
    assert_error(f"sphere 0 {token} 0 1\n", 1, "sphere center must be a finite number")


@pytest.mark.parametrize("token", ["1_000", "0x10", "1e", "e5", "1.2.3", "--1", "1e+", "½", "١",
                                   "1,5", "0b1", "1j", "1f", "five", "'1'"])
def test_python_isms_and_other_non_numbers_are_errors(token):
    assert_error(f"light 0 0 {token}\n", 1, "light position must be a number")


def test_out_of_range_magnitudes():
    assert_error("eye 0 0 1e13\n", 1, "eye must lie within -1e12 and 1e12, got 1e13")
    assert_error("light 0 0 0 1 1 1e999\n", 1, "light color must lie within -1e12 and 1e12")
    assert parse("eye 0 0 1e12\n").eye == (0, 0, 1e12)


def test_camera_constraints_name_the_right_line():
    assert_error("eye 0 0 0\n", 1, "eye and lookat must differ, both are 0 0 0")
    assert_error("eye 1 2 3\nfov 30\nlookat 1 2 3\n", 3, "eye and lookat must differ")
    assert_error("lookat 1 2 3\n\neye 1 2 3\n", 3, "eye and lookat must differ")
    assert_error("up 0 0 1\n", 1, "up 0 0 1 must not be parallel to the viewing direction")
    assert_error("fov 40\nup 0 0 -3\nsize 10 10\n", 2, "must not be parallel")
    # the default up made parallel by the eye: the eye's line is named
    assert_error("size 10 10\neye 0 5 0\n", 2, "up 0 1 0 (the default) must not be parallel")
    assert_error("eye 0 0 1e-200\n", 1, "eye and lookat are too close together")
    assert parse("eye 0 5 0.001\n").eye == (0, 5, 0.001)  # nearly, not quite, parallel


@pytest.mark.parametrize("name", ["size", "eye", "lookat", "up", "fov", "background",
                                  "ambient", "depth", "samples"])
def test_globals_at_most_once(name):
    values = {"size": "10 10", "fov": "30", "ambient": "0.5", "depth": "3", "samples": "2",
              "background": "0 0 0", "up": "0 1 0", "eye": "0 0 5", "lookat": "0 0 1"}[name]
    assert_error(f"{name} {values}\nlight 1 1 1\n{name.upper()} {values}\n", 3,
                 f"{name} given twice (first on line 1)")


def test_lights_and_spheres_may_repeat():
    assert len(parse("sphere 0 0 0 1\nsphere 0 0 0 1\n").spheres) == 2


# ----------------------------------------------------------- unknown names


@pytest.mark.parametrize("text, message", [
    ("sphre 0 0 0 1", "unknown statement 'sphre'; did you mean 'sphere'?"),
    ("lite 1 2 3", "unknown statement 'lite'; did you mean 'light'?"),
    ("look_at 0 0 0", "did you mean 'lookat'?"),
    ("Backround 0 0 0", "did you mean 'background'?"),
    ("sample 4", "did you mean 'samples'?"),
    ("zzzz", "unknown statement 'zzzz'; known names: size, eye, lookat, up, fov, background"),
    ("sphere 0 0 0 1 colour 1 1 1", "unknown sphere attribute 'colour'; did you mean 'color'?"),  # British spelling
    ("sphere 0 0 0 1 refrct 0.5 1.5", "did you mean 'refract'?"),
    ("sphere 0 0 0 1 texure a.png", "did you mean 'texture'?"),
    ("sphere 0 0 0 1 nort 0 1 0", "did you mean 'north'?"),
    ("sphere 0 0 0 1 equater 1 0 0", "did you mean 'equator'?"),
    ("sphere 0 0 0 1 reflection 0.5", "did you mean 'reflect'?"),
    ('"sphere" 0 0 0 1', "expected a statement name, got the quoted text 'sphere'"),
    ('sphere 0 0 0 1 "color" 1 1 1', "expected a sphere attribute name, got the quoted text"),
    ('fov "45"', "fov must be a number, got the quoted text '45'"),
])
def test_unknown_names_suggest_the_nearest(text, message):
    assert_error(f"\n{text}\n", 2, message)


# ---------------------------------------------------------- syntax errors


@pytest.mark.parametrize("text, line, message", [
    ('sphere 0 0 0 1 texture "a.png\n', 1, "unterminated quote"),
    ('sphere 0 0 0 1 texture "a.png"x\n', 1, "a closing quote must be followed by a blank"),
    ('fov 4"5"\n', 1, "a quote may only start a value"),
    ("size 10 10\nsphere 0 0 \\\n  0 -1\n", 2, "sphere radius must be > 0, got -1"),
    ("\n\nsphere 0 0 0 1 \\\n color 1 1 \\\n  1 \\\n reflect 9\n", 3, "reflect must be >= 0"),
    ('sphere 0 0 0 1 \\\n texture "a\n', 1, "unterminated quote"),
    ("size 10 10\nfov 30 \\", 2, "ends with '\\' but no line follows"),
    ("size 10 10\nfov 30 \\\n", 2, "ends with '\\' but no line follows"),
    ("fov 30 \\\n\nfov 40\n", 3, "fov given twice"),  # the blank line ended the statement
    ("fov 30 \\ 40\n", 1, "fov takes 1 value (DEG), got 3"),  # a lone backslash mid-line is a token
])
def test_syntax_errors_name_the_first_line_of_the_statement(text, line, message):
    assert_error(text, line, message)


def test_spec_message_format(write_scene):
    path = write_scene("# example\nsize 320 200\n\n\nlight 5 5 10\n\nsphere 0 0 0 -1\n")
    with pytest.raises(SceneError) as info:
        parse_file(path)
    assert str(info.value) == f"{path}:7: sphere radius must be > 0, got -1"


def test_message_shows_long_or_odd_tokens_on_one_line():
    error = error_of("sphere 0 0 0 1 " + "x" * 500 + "\n")
    assert "\n" not in str(error) and len(str(error)) < 200
    error = error_of("fov 4\x1b[31m\n")
    assert "\x1b" not in str(error) and "\\x1b" in str(error)


# ------------------------------------------------------ whole-file errors


def test_missing_file(tmp_path):
    with pytest.raises(SceneError) as info:
        parse_file(tmp_path / "nope.scn")
    assert str(info.value) == f"{tmp_path / 'nope.scn'}: no such file" and info.value.line is None


def test_folder(tmp_path):
    with pytest.raises(SceneError) as info:
        parse_file(tmp_path)
    assert str(info.value) == f"{tmp_path}: is a folder, not a scene file"


def test_not_a_regular_file(tmp_path):
    fifo = tmp_path / "pipe.scn"
    os.mkfifo(fifo)  # reading it would block forever
    with pytest.raises(SceneError) as info:
        parse_file(fifo)
    assert str(info.value) == f"{fifo}: is not a regular file"


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_unreadable_file(write_scene):
    path = write_scene("size 10 10\n")
    path.chmod(0)
    with pytest.raises(SceneError) as info:
        parse_file(path)
    assert str(info.value) == f"{path}: cannot read: Permission denied"


def test_unreadable_file_simulated(write_scene, monkeypatch):
    path = write_scene("size 10 10\n")

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))
    monkeypatch.setattr(Path, "read_bytes", denied)
    with pytest.raises(SceneError) as info:
        parse_file(path)
    assert str(info.value) == f"{path}: cannot read: Permission denied"


@pytest.mark.parametrize("data, line, message", [
    (b"size 10 10\nfov 3\x000\n", 2, "binary file (NUL byte)"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 3, "binary file (NUL byte)"),  # PNG header: 2 line breaks
    (b"size 10 10\n\nfov \xff30\n", 3, "not UTF-8 text (byte 0xff)"),
    (b"# caf\xe9\nsize 10 10\n", 1, "not UTF-8 text (byte 0xe9)"),
    (b"# \xc3\xa9t\xc3\xa9 \xe2\x82\xac\r\n\r\nsize 1 1\r\n\xc3", 4, "not UTF-8 text (byte 0xc3)"),
    (b"light 1 2 3\n# surrogate \xed\xa0\x80\n", 2, "not UTF-8 text (byte 0xed)"),
])
def test_binary_and_non_utf8_files(write_scene, data, line, message):
    path = write_scene(data)
    with pytest.raises(SceneError) as info:
        parse_file(path)
    assert (info.value.path, info.value.line) == (str(path), line)
    assert str(info.value).startswith(f"{path}:{line}: {message}")


@pytest.mark.parametrize("text, line", [('<?xml version="1.0"?>\n<scene version="3.0.0"/>\n', 1),
                                        ("\ufeff\r\n\n  <scene version='3.0.0'>\n", 3)])
def test_an_xml_file_is_one_error_not_one_per_line(write_scene, text, line):
    """A Mitsuba scene given where a legacy one goes (convert, fit, a .scn name) is said to be
    XML, once: it was an error per line, the first of them about a quote."""
    path = write_scene(text.encode())
    with pytest.raises(SceneError) as info:
        parse_file(path)
    assert len(info.value.errors) == 1 and (info.value.path, info.value.line) == (str(path), line)
    assert info.value.message.startswith("XML, not a legacy scene")


def test_utf8_in_comments_and_texture_names(tmp_path, texture_png):
    texture = texture_png("Erde ü €.png")
    scene = parse_text('# Grüße, 地球\nsphere 0 0 0 1 texture "Erde ü €.png" # ok\n', tmp_path / "s.scn")
    assert scene.spheres[0].material.texture == texture


def test_nul_character_in_text():
    assert_error("size 10 10\n\x00\n", 2, "binary file")


def test_parse_text_names_the_source_given():
    error = error_of("fov 0\n", "relative/dir/x.scn")
    assert str(error).startswith("relative/dir/x.scn:1: ")


# ------------------------------------------------- the fast path = the careful path
#
# parse_text reads the spheres of plain lines a batch at a time and leaves every doubt to
# the statement reader; careful=True reads every statement on its own. Both must give the
# same scene, or the same errors, for any text.

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from whitted.converter import parser as parser_module  # noqa: E402

#: numbers at and around every bound the format checks, and numbers it rejects
BOUNDARY_NUMBERS = [
    "0", "-0", "+0", "0.0", "0.", ".0", "0e5", "00", "1", "1.0", "1.", "+1", "01", "1e0", "10e-1",
    "1.00000000000000001", "0.99999999999999999", "1.0000000000000002", "0.9999999999999999",
    "1e-400", "-1e-400", "-0.00000000000000000001", "0.00000000000000000001",
    "1e-6", "0.000001", "0.0000010", "1.0e-6", "0.00000099999999999999999", "0.00000100000000000000001",
    "9.999999999999999e-7", "1.0000000000000001e-6", "1e12", "1000000000000", "-1e12",
    "1000000000000.00000000001", "999999999999.99999999999", "-1000000000000.00000000001",
    "1e13", "1e999", "-1e999", "0.5", "0.25", "0.75", "0.6", "0.4", "0.7", "0.3", "0.41", "0.59",
    "0.3333333333333333", "0.6666666666666667", "2", "-2", "-0.5", "1.5", "179", "180", "1e-7",
    "nan", "inf", "-Infinity", "1_0", "0x1", "1e", ".", "-", "\u0661", "1,5", "½", "+-1", "e1",
]
KEYWORDS = ["sphere", "SPHERE", "Sphere", "light", "LIGHT", "size", "fov", "eye", "lookat", "up",
            "ambient", "depth", "samples", "background", "sphre", "lite"]
ATTRIBUTE_NAMES = ["color", "COLOR", "reflect", "Reflect", "refract", "north", "equator", "color", "texture"]
SEPARATORS = [" ", "  ", "\t", " \t ", "\x0b", "\x0c"]


def _number():
    return st.one_of(st.sampled_from(BOUNDARY_NUMBERS),
                     st.floats(-3, 3, allow_nan=False).map(repr),
                     st.floats(0, 1).map(lambda x: f"{x:.3g}"),
                     st.integers(-5, 5).map(str))


@st.composite
def _sphere_line(draw):
    """Mostly well-formed spheres, with a random attribute list (sometimes broken)."""
    words = [draw(st.sampled_from(["sphere", "sphere", "sphere", "SPHERE", "Sphere"]))]
    words += [draw(_number()) for _ in range(draw(st.sampled_from([4, 4, 4, 3, 5])))]
    for _ in range(draw(st.integers(0, 3))):
        name = draw(st.sampled_from(ATTRIBUTE_NAMES))
        arity = {"color": 3, "reflect": 1, "refract": 2, "north": 3, "equator": 3,
                 "color": 3, "texture": 1}[name.lower()]
        words += [name] + [draw(_number()) for _ in range(draw(st.sampled_from([arity, arity, arity - 1])))]
    return words


@st.composite
def _any_line(draw):
    kind = draw(st.sampled_from(["sphere", "sphere", "light", "other", "blank"]))
    if kind == "sphere":
        words = draw(_sphere_line())
    elif kind == "light":
        words = [draw(st.sampled_from(["light", "Light"]))] + \
                [draw(_number()) for _ in range(draw(st.sampled_from([3, 6, 6, 2, 5])))]
    elif kind == "other":
        words = [draw(st.sampled_from(KEYWORDS))] + [draw(_number()) for _ in range(draw(st.integers(0, 4)))]
    else:
        words = []
    separator = draw(st.sampled_from(SEPARATORS))
    line = draw(st.sampled_from(["", "", " ", "\t"])) + separator.join(words)
    line += draw(st.sampled_from(["", "", " # a comment", "#x", "  ", " # é \u00a0"]))
    if draw(st.integers(0, 20)) == 0:
        line += draw(st.sampled_from(["\u00a0", " é", " \u2003 1"]))  # blanks the format does not know
    return line


def _outcome(text: str, fast: bool):
    """The parsed scene's full repr (floats and -0.0 included), or the error's text and line."""
    try:
        return "scene", repr(parse_text(text, "scene.scn", careful=not fast))
    except SceneError as error:
        return "error", str(error), error.line


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_any_line(), min_size=1, max_size=12), st.sampled_from(["\n", "\r\n", "\r"]),
       st.booleans())
def test_fast_path_and_careful_path_agree(lines, ending, final_break):
    text = ending.join(lines) + (ending if final_break else "")
    assert _outcome(text, fast=True) == _outcome(text, fast=False)


def test_spheres_read_in_batches_come_back_in_file_order(monkeypatch):
    """Spheres are read a batch at a time; spheres from both paths come back in file order."""
    monkeypatch.setattr(parser_module, "_BATCH", 4)
    lines = ["# batches", "size 8 8"]
    for i in range(60):
        lines.append([f"sphere {i} 0 0 0.5 color 1 0.9 0.7 reflect 0.5", f"Sphere {i} 1 0 1  # c",
                      f"sphere {i} 2 0 1 north 0 0 1 equator 1 0 0", f"light {i} 9 9",
                      f"sphere {i} 3 0 1 reflect 0.2 color 0.5 0.5 0.5\t", ""][i % 6])
    for ending in ("\n", "\r\n"):
        text = ending.join(lines)
        assert _outcome(text, fast=True) == _outcome(text, fast=False)
        scene = parse_text(text, "s.scn")
        assert scene.held_sphere_arrays() is not None
        assert [s.line for s in scene.spheres] == [n for n, line in enumerate(lines, 1)
                                                   if line.lower().startswith("sphere")]


@pytest.mark.parametrize("template", [
    "sphere 0 0 0 1 color {v} 0.5 0.5", "sphere 0 0 0 1 color 1 1 {v}", "sphere 0 0 0 1 reflect {v}",
    "sphere 0 0 0 1 refract {v} 1.5", "sphere 0 0 0 1 refract 0.5 {v}", "sphere 0 0 0 {v}",
    "sphere {v} 0 0 1", "sphere 0 0 0 1 reflect 0.5 refract {v} 1", "light 0 {v} 0", "light 0 0 0 1 {v} 1",
])
def test_fast_path_at_every_bound(template):
    for value in BOUNDARY_NUMBERS:
        text = f"size 8 8\n{template.format(v=value)}\nsphere 1 2 3 0.5 color 1 0 0.5\n"
        careful = _outcome(text, fast=False)
        assert _outcome(text, fast=True) == careful, text


def test_fast_path_reads_plain_spheres_itself(monkeypatch):
    """A plain file's valid spheres never reach the sphere statement reader."""
    def careful(*args):
        raise AssertionError("the careful path was taken")
    monkeypatch.setattr(parser_module._Parser, "statement_sphere", careful)
    scene = parse("size 8 8\nlight 1 2 3\nlight 0 0 1 0.5 0 1\n"
                  "sphere 0 0 0 1 color 1 0.9 0.7 reflect 0.5\nSPHERE 1 1 1 0.5 REFRACT 0.9 1.5 Color 0 0 0\n"
                  "sphere 1e-3 -2.5e2 3 2e-6\nsphere 2 2 2 1 # a comment\n")
    assert [s.line for s in scene.spheres] == [4, 5, 6, 7] and len(scene.lights) == 2
    assert scene.spheres[1].material == Material((0, 0, 0), 0.0, 0.9, 1.5)
    assert scene.spheres[2].center == (1e-3, -250.0, 3.0) and scene.spheres[2].radius == 2e-6


def test_a_text_with_quotes_reads_its_plain_lines_as_a_plain_text_does(texture_png, monkeypatch):
    """Plain lines among quoted, continued and non-ASCII ones still go to the batch; the
    scene, and the errors, are those of every statement read on its own."""
    source = texture_png("tex.png").parent / "mixed.scn"
    monkeypatch.setattr(parser_module, "_BATCH", 2)
    lines = ["sphere 0 0 0 1 color 1 0.9 0.7  # café", 'sphere 1 0 0 1 texture "tex.png"',
             "sphere 2 0 0 1 \\", " reflect 0.5", "sphere 3 0 0 1e-6", "sphere 4 0 0 1 color 1 1 1",
             "sphere 5 0 0 1 reflect 1.0", "sphere 6 0 0 0.5 texture tex.png"]
    text = "\n".join(lines) + "\n"
    scene = parse_text(text, source)
    assert [s.line for s in scene.spheres] == [1, 2, 3, 5, 6, 7, 8]
    assert repr(scene) == repr(parse_text(text, source, careful=True))
    text += 'sphere 7 0 0 1e13\nsphere 8 0 0 1 texture "none.png"\nsphere 9 0 0 1 reflect 2\n'
    errors = []
    for careful in (False, True):
        with pytest.raises(SceneError) as error:
            parse_text(text, source, careful=careful)
        errors.append(str(error.value))
    assert errors[0] == errors[1]
    assert [line.split(": ")[0].rsplit(":", 1)[1] for line in errors[0].splitlines()
            if "mixed.scn:" in line] == ["9", "10", "11"]


def test_spheres_that_share_attributes_share_nothing_else():
    scene = parse("sphere 0 0 0 1 color 1 0.9 0.7 reflect 0.5\nsphere 1 0 0 2 color 1 0.9 0.7 reflect 0.5\n")
    a, b = scene.spheres
    assert a.material == b.material == Material((1, 0.9, 0.7), 0.5, 0.0, 1.0)
    assert (a.center, a.radius, a.line, b.center, b.radius, b.line) == ((0, 0, 0), 1, 1, (1, 0, 0), 2, 2)


@settings(max_examples=500, deadline=None)
@given(st.text(alphabet="0123456789+-.eEinfatyIN ", min_size=1, max_size=8))
def test_float_reads_exactly_the_formats_numbers(token):
    """The fast path's premise: in ASCII without '_', Python's float() accepts a token
    exactly when the format's number syntax does, or it is a nan/inf word."""
    try:
        float(token)
        accepted = token.strip() == token and token.lower().lstrip("+-") not in ("nan", "inf", "infinity")
    except ValueError:
        accepted = False
    assert accepted == bool(parser_module._NUMBER.fullmatch(token))


# ------------------------------------------------------------ every error of a file


SEVERAL_ERRORS = """\
size 10 10
sphre 0 0 0 1
sphere 0 0 0 -1
light 1 2 3
fov 30
sphere 0 0 0 1 texture "a.png
FOV 40
sphere 0 0 0 1 color 1 1 2 \\
   reflect 0.5
sphere 1 1 1 1 reflect 0.2
ambient 2
"""


@pytest.mark.parametrize("fast", [True, False])
def test_every_error_of_a_file_in_file_order(fast):
    with pytest.raises(SceneError) as info:
        parse_text(SEVERAL_ERRORS, "s.scn", careful=not fast)
    error = info.value
    expected = [
        ("s.scn", 2, "unknown statement 'sphre'; did you mean 'sphere'?"),
        ("s.scn", 3, "sphere radius must be > 0, got -1"),
        ("s.scn", 6, "unterminated quote: '\"a.png'"),
        ("s.scn", 7, "fov given twice (first on line 5)"),
        ("s.scn", 8, "sphere color must be >= 0 and <= 1, got 2"),
        ("s.scn", 11, "ambient must be >= 0 and <= 1, got 2"),
    ]
    assert error.errors == expected
    assert (error.path, error.line, error.message) == expected[0]
    assert str(error) == "\n".join(f"{p}:{n}: {m}" for p, n, m in expected)


def test_a_failed_global_still_counts_as_given():
    error = error_of("fov 0\nfov 30\n")
    assert [(line, message) for _, line, message in error.errors] == \
        [(1, "fov must be > 0 and < 180, got 0"), (2, "fov given twice (first on line 1)")]


def test_the_line_after_a_broken_continued_line_is_not_a_statement():
    error = error_of('sphere 0 0 0 1 texture "a.png"x \\\n  reflect 0.5\nlight 1 2\n')
    assert [line for _, line, _ in error.errors] == [1, 3]


def test_camera_errors_come_in_file_order_and_do_not_follow_from_others():
    error = error_of("eye 0 0 0\nfov 0\n")
    assert [(line, message.split(",")[0]) for _, line, message in error.errors] == \
        [(1, "eye and lookat must differ"), (2, "fov must be > 0 and < 180")]
    # an up that failed its own check is not checked again against the view
    assert [line for _, line, _ in error_of("up 0 0 0\n").errors] == [1]
    assert [line for _, line, _ in error_of("eye 0 0\nlookat 0 0 10\n").errors] == [1]


def test_at_most_twenty_errors_are_listed_then_counted():
    text = "".join(f"sphere 0 0 0 -{i}\n" for i in range(1, 26))
    for careful in (False, True):
        with pytest.raises(SceneError) as info:
            parse_text(text, "many.scn", careful=careful)
        lines = str(info.value).split("\n")
        assert len(info.value.errors) == 25 and len(lines) == 21
        assert lines[0] == "many.scn:1: sphere radius must be > 0, got -1"
        assert lines[19] == "many.scn:20: sphere radius must be > 0, got -20"
        assert lines[20] == "... and 5 more errors"
    assert str(error_of("sphere 0 0 0 -1\n" * 21)).endswith("\n... and 1 more error")


def test_the_command_line_prints_every_error(write_scene, tmp_path, capsys):
    from whitted.cli import main
    scene = write_scene(SEVERAL_ERRORS)
    assert main(["convert", str(scene), "-o", str(tmp_path / "out.xml")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 6 and all(line.startswith(f"whitted: error: {scene}:") for line in err)
    assert err[1] == f"whitted: error: {scene}:3: sphere radius must be > 0, got -1"
    assert not (tmp_path / "out.xml").exists()


# ------------------------------------------------------------------ minweight


def test_minweight_statement():
    assert parse("").min_weight is None  # absent: the integrator's default applies
    assert parse("minweight 0.004\n").min_weight == 0.004
    assert parse("MinWeight 0\n").min_weight == 0.0 and parse("minweight 1\n").min_weight == 1.0


@pytest.mark.parametrize("text, message", [
    ("minweight 1.5", "minweight must be >= 0 and <= 1, got 1.5"),
    ("minweight -0.001", "minweight must be >= 0 and <= 1, got -0.001"),
    ("minweight 1.00000000000000001", "minweight must be >= 0 and <= 1, got 1.00000000000000001"),
    ("minweight", "minweight takes 1 value (W), got 0"),
    ("minweight 0.1 0.2", "minweight takes 1 value (W), got 2"),
    ("minweight nan", "minweight must be a finite number, got nan"),
    ("minweight x", "minweight must be a number, got 'x'"),
    ("minweight 0.1\nminweight 0.1", "minweight given twice (first on line 3)"),
    ("min_weight 0.1", "unknown statement 'min_weight'; did you mean 'minweight'?"),
])
def test_minweight_errors(text, message):
    error = error_of(f"# header\n\n{text}\n")
    assert message in error.message and error.line == text.count("\n") + 3, str(error)


def test_minweight_reaches_the_integrator_through_the_xml():
    import mitsuba as mi
    from whitted import defaults
    from whitted.converter import scene_to_xml
    scene = mi.load_string(scene_to_xml(parse("size 4 4\nminweight 0.125\n"), base_dir=None))
    assert scene.integrator().min_weight == 0.125
    plain = mi.load_string(scene_to_xml(parse("size 4 4\n"), base_dir=None))
    assert plain.integrator().min_weight == defaults.MIN_WEIGHT
    assert 'name="min_weight"' not in scene_to_xml(parse("size 4 4\n"), base_dir=None)


def test_every_error_of_a_statement_is_reported():
    """A bad radius does not hide a bad color on the same line: each independent part of a
    statement (center, radius, each attribute; a light's position and color) is checked."""
    error = error_of("light 5 5 5 -1 0 0\n"
                     "sphere 0 0 0 -0.5 color 1.2 0 0 reflect 2\n"
                     "sphere 0 0 0 1 refract 0.5 0 north 0 0 0\n")
    assert [(line, message) for _, line, message in error.errors] == [
        (1, "light color must be >= 0, got -1"),
        (2, "sphere radius must be > 0, got -0.5"),
        (2, "sphere color must be >= 0 and <= 1, got 1.2"),
        (2, "sphere reflect must be >= 0 and <= 1, got 2"),
        (3, "sphere refract IOR must be > 0, got 0"),
    ]
    # the checks across a statement's parts run once its parts are good
    assert_error("sphere 0 0 0 1 reflect 0.6 refract 0.6 1.5\n", 1,
                 "sphere reflect + refract must be <= 1, got 0.6 + 0.6")


def test_many_distinct_materials_are_numbered_by_first_use():
    colors = [(k / 20, 1 - k / 20, 0.5) for k in range(20)]
    uses = [7, 3, 19, 3, 0, 12, 7, 5, 18, 1, 2, 4, 6, 8, 9, 10, 11, 13, 14, 15, 16, 17, 0, 19] * 3
    text = "".join(f"sphere {i} 0 0 0.5 color {' '.join(map(repr, colors[u]))}\n"
                   for i, u in enumerate(uses))
    scene = parse(text)
    arrays = scene.sphere_arrays()
    first_use = list(dict.fromkeys(uses))
    assert [m.color for m in arrays.materials] == [colors[u] for u in first_use]
    assert [m.color for m in (arrays.materials[int(k)] for k in arrays.material)] == \
        [colors[u] for u in uses]
    assert [s.material.color for s in scene.spheres] == [colors[u] for u in uses]
