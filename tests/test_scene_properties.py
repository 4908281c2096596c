"""Property tests (hypothesis).

1. Random valid scenes, written out in random legal styles (any statement order,
   keyword case, blanks, comments, continuations, number notations), survive
   text -> parse -> XML -> ``mi.load_file``: every sphere, light, camera and
   material value read back from Mitsuba matches what the text said, against
   expectations computed here in float64 from the scene format's formulas.
2. Mutated valid files (bytes, tokens and lines deleted, inserted, replaced)
   either parse to a scene whose XML Mitsuba loads, or fail with a clean
   ``SceneError`` that names the file and a line of it. Nothing else happens.
"""

from __future__ import annotations

import math
import re
import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from whitted.converter import parse_file, scene_to_xml
from whitted.errors import SceneError

REPO = Path(__file__).resolve().parent.parent
SETTINGS = settings(max_examples=80, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
#: Texture files made for the generated scenes: name as written -> (file name, width, height).
TEXTURES = {"tex.png": ("tex.png", 4, 2), '"my maps/a #1.png"': ("my maps/a #1.png", 3, 5)}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """One folder for the module: the textures, and each example's scene and XML."""
    path = tmp_path_factory.mktemp("properties")
    for name, width, height in TEXTURES.values():
        (path / name).parent.mkdir(parents=True, exist_ok=True)
        pixels = (np.arange(width * height * 3).reshape(height, width, 3) * 7 % 256).astype(np.uint8)
        mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path / name))
    shutil.copy(REPO / "scenes" / "earth.png", path / "earth.png")
    return path


# ------------------------------------------------------------- generation


@st.composite
def number(draw, low: float, high: float):
    """(text, value): a number in [low, high] in one of the format's notations."""
    x = draw(st.floats(low, high, allow_nan=False, allow_infinity=False))
    style = draw(st.sampled_from(["repr", "exp", "fixed", "int"]))
    text = {"repr": repr(x), "exp": f"{x:.6e}", "fixed": f"{x:.4f}", "int": str(round(x))}[style]
    value = float(text)
    assume(low <= value <= high)
    return text, value


def vector(low, high):
    return st.tuples(number(low, high), number(low, high), number(low, high))


def values(v):
    return tuple(x for _, x in v)


def texts(v):
    return [t for t, _ in v]


@dataclass
class Statement:
    keyword: str
    tokens: list[str]
    kind: str = "global"          # global | light | sphere
    expect: dict = field(default_factory=dict)


@st.composite
def sphere_statement(draw):
    center = draw(vector(-100, 100))
    radius = draw(number(0.01, 100))
    expect = {"center": values(center), "radius": radius[1], "color": (1.0, 1.0, 1.0),
              "reflect": 0.0, "refract": 0.0, "ior": 1.0, "texture": None,
              "north": (0.0, 1.0, 0.0), "equator": (0.0, 0.0, -1.0)}
    attributes = []
    if draw(st.booleans()):
        color = draw(vector(0, 1))
        attributes.append(["color", *texts(color)])
        expect["color"] = values(color)
    kr = draw(st.integers(0, 100))
    kt = draw(st.integers(0, 100 - kr))
    if kr or draw(st.booleans()):
        attributes.append(["reflect", repr(kr / 100)])
        expect["reflect"] = kr / 100
    if kt or draw(st.booleans()):
        ior = draw(number(0.1, 3))
        attributes.append(["refract", repr(kt / 100), ior[0]])
        expect["refract"], expect["ior"] = kt / 100, ior[1]
    if draw(st.booleans()):
        name = draw(st.sampled_from(sorted(TEXTURES)))
        attributes.append(["texture", name])
        expect["texture"] = TEXTURES[name]
    for key in ("north", "equator"):
        if draw(st.booleans()):
            v = draw(vector(-1, 1))
            attributes.append([key, *texts(v)])
            expect[key] = values(v)
    assume(sine(expect["north"], expect["equator"]) > 0.05)
    attributes = draw(st.permutations(attributes))
    tokens = [*texts(center), radius[0]] + [t for a in attributes for t in a]
    return Statement("sphere", tokens, "sphere", expect)


@st.composite
def light_statement(draw):
    position = draw(vector(-100, 100))
    tokens, color = texts(position), (1.0, 1.0, 1.0)
    if draw(st.booleans()):
        c = draw(vector(0, 10))
        tokens, color = tokens + texts(c), values(c)
    return Statement("light", tokens, "light", {"position": values(position), "color": color})


@st.composite
def scenes(draw):
    """(statements, expected globals): a valid scene, not yet written out."""
    g = {"size": (640, 400), "eye": (0.0, 0.0, 10.0), "lookat": (0.0, 0.0, 0.0),
         "up": (0.0, 1.0, 0.0), "fov": 45.0, "background": (0.0, 0.0, 0.0), "ambient": 0.2,
         "depth": 5, "samples": 1}
    statements = []

    def maybe(name, strategy, expect=values, to_tokens=texts):
        if draw(st.booleans()):
            v = draw(strategy)
            g[name] = expect(v)
            statements.append(Statement(name, to_tokens(v)))

    maybe("size", st.tuples(st.integers(1, 2000), st.integers(1, 2000)), tuple, lambda v: [str(x) for x in v])
    maybe("eye", vector(-100, 100))
    maybe("lookat", vector(-100, 100))
    maybe("up", vector(-1, 1))
    maybe("fov", number(0.5, 170), lambda v: v[1], lambda v: [v[0]])
    maybe("background", vector(0, 5))
    maybe("ambient", number(0, 1), lambda v: v[1], lambda v: [v[0]])
    maybe("depth", st.integers(1, 64), int, lambda v: [str(v)])
    maybe("samples", st.integers(1, 65536), int, lambda v: [str(v)])
    view = np.subtract(g["lookat"], g["eye"])
    assume(np.linalg.norm(view) > 0.01 and sine(view, g["up"]) > 0.01)
    statements += draw(st.lists(light_statement(), max_size=4))
    statements += draw(st.lists(sphere_statement(), max_size=5))
    return draw(st.permutations(statements)), g


@st.composite
def written(draw, statements):
    """The scene's text in a random legal style, the first line of each statement, and what the
    converter's ids of each end with (its comment's slug)."""
    lines, first_lines, slugs = [], [], []
    blank = st.sampled_from([" ", "\t", "  ", " \t "])
    for statement in statements:
        for _ in range(draw(st.integers(0, 2))):
            lines.append(draw(st.sampled_from(["", "   ", "# a comment", "\t# sphere 0 0 0 -1"])))
        first_lines.append(len(lines) + 1)
        case = draw(st.sampled_from([str.lower, str.upper, str.title, lambda s: s]))
        words = [case(statement.keyword)] + statement.tokens
        line = draw(blank).lstrip(" \t") if draw(st.booleans()) else ""
        for k, word in enumerate(words):
            if k and draw(st.integers(0, 9)) == 0:
                lines.append(line + " \\")    # continue on the next line
                line = draw(blank)
            elif k:
                line += draw(blank)
            line += word
        comment = draw(st.sampled_from(["", " # done", "#x", '  # "quoted" \\']))
        slugs.append({"": "", " # done": "_done", "#x": "_x", '  # "quoted" \\': "_quoted"}[comment])
        lines.append(line + comment)
    ending = draw(st.sampled_from(["\n", "\r\n"]))
    return ending.join(lines) + (ending if draw(st.booleans()) else ""), first_lines, slugs


# ----------------------------------------------------------- expectations


def sine(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na == 0 or nb == 0:
        return 0.0
    return float(np.linalg.norm(np.cross(a / na, b / nb)))


def spec_ray(g, i, j):
    """The scene format's primary ray direction through pixel (i, j)'s center."""
    (w, h), fov = g["size"], g["fov"]
    f = np.subtract(g["lookat"], g["eye"])
    f = f / np.linalg.norm(f)
    right = np.cross(f, g["up"])
    right /= np.linalg.norm(right)
    true_up = np.cross(right, f)
    x, y = 2 * (i + 0.5) / w - 1, 1 - 2 * (j + 0.5) / h
    t = math.tan(math.radians(fov) / 2)
    d = f + x * t * right + y * t * (h / w) * true_up
    return d / np.linalg.norm(d)


def sphere_to_world(e, origin) -> np.ndarray:
    """Object-to-world of a sphere: plain scale + translation, or the texture frame
    (Ve, Vn x Ve, Vn) of the format's lat/long mapping, times the radius; the
    translation relative to the scene's ``origin``."""
    m = np.eye(4)
    if e["texture"] is None:
        m[:3, :3] *= e["radius"]
    else:
        vn = unit(e["north"])
        eq = np.array(e["equator"])
        ve = unit(eq - eq.dot(vn) * vn)
        m[:3, :3] = np.column_stack([ve, np.cross(vn, ve), vn]) * e["radius"]
    m[:3, 3] = np.subtract(e["center"], origin)
    return m


def unit(v) -> np.ndarray:
    """``v`` normalized; scaled first, since |v|² of a vector like (0, 3e-161, 0) is subnormal
    and np.linalg.norm then loses digits (hypothesis found one)."""
    v = np.asarray(v, dtype=float)
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)


def arr(x) -> np.ndarray:
    return np.array(x, dtype=float).ravel()


def scalar(x) -> float:
    return float(arr(x)[0])


def matrix(transform) -> np.ndarray:
    return np.array(transform.matrix, dtype=float).reshape(4, 4)


def close(a, b, scale=1.0, rel=2e-6):
    np.testing.assert_allclose(arr(a), arr(b), rtol=rel, atol=rel * scale)


# ------------------------------------------------------------- property 1


@SETTINGS
@given(data=st.data())
def test_random_valid_scenes_survive_parse_xml_and_load(folder, data):
    statements, g = data.draw(scenes())
    text, first_lines, slugs = data.draw(written(statements))
    source = folder / "random.scn"
    source.write_bytes(text.encode("utf-8"))
    scene = parse_file(source)
    event(f"{len(statements)} statements")

    # The model holds what the text says.
    lights = [s for s in statements if s.kind == "light"]
    spheres = [s for s in statements if s.kind == "sphere"]
    lines = dict(zip(map(id, statements), first_lines))
    ids = {id(s): f"sphere_l{line}{slug}" for s, line, slug in zip(statements, first_lines, slugs)}
    assert (scene.width, scene.height) == g["size"]
    assert (scene.eye, scene.lookat, scene.up, scene.fov) == (g["eye"], g["lookat"], g["up"], g["fov"])
    assert (scene.background, scene.ambient, scene.depth, scene.samples) == \
        (g["background"], g["ambient"], g["depth"], g["samples"])
    assert [(l.position, l.color, l.line) for l in scene.lights] == \
        [(s.expect["position"], s.expect["color"], lines[id(s)]) for s in lights]
    assert [s.line for s in scene.spheres] == [lines[id(s)] for s in spheres]

    # Mitsuba holds it too.
    target = folder / "random.xml"
    target.write_text(scene_to_xml(scene, folder), encoding="utf-8")
    root = ET.parse(target).getroot()
    defaults = {d.get("name"): d.get("value") for d in root.iter("default")}
    assert (int(defaults["max_depth"]), float(defaults["ambient"])) == (g["depth"], g["ambient"])
    # Positions are written relative to the scene origin, the lookat point (docs/CONTRACTS.md).
    text = target.read_text(encoding="utf-8")
    origin = np.array([float(c) for c in re.search(r"world point ([^:]+):", text).group(1).split(",")])
    assert list(origin) == list(g["lookat"])

    def frame(p):
        return np.subtract(p, origin)
    loaded = mi.load_file(str(target))
    params = mi.traverse(loaded)

    sensor = loaded.sensors()[0]
    assert tuple(sensor.film().size()) == g["size"]
    assert sensor.sampler().sample_count() == g["samples"]
    close(params[_key(params, "x_fov")], g["fov"])
    w, h = g["size"]
    scale = max(1.0, *map(abs, frame(g["eye"])))
    # Mitsuba's float32 camera: about 2^-24 tan(θ/2), θ the wider field (docs/numerics.md)
    widest = math.tan(math.radians(g["fov"]) / 2) * max(1.0, h / w)
    for i, j in {(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (w // 2, h // 2)}:
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((i + 0.5) / w, (j + 0.5) / h), mi.Point2f(0.5))
        close(ray.d, spec_ray(g, i, j), rel=2e-5 + 2.0 ** -24 * widest)
        close(ray.o, frame(g["eye"]), scale=scale, rel=1e-5)

    reference = np.array(g["lookat"])
    for k, s in enumerate(lights):
        d2 = float(np.sum((np.array(s.expect["position"]) - reference) ** 2)) or 1.0
        close(params[f"light_{k}.position"], frame(s.expect["position"]), scale=100)
        close(params[f"light_{k}.intensity.value"], np.array(s.expect["color"]) * math.pi * d2,
              scale=1e-3, rel=1e-5)
    if any(g["background"]):
        close(params["background.radiance.value"], g["background"])
    assert len(loaded.emitters()) == len(lights) + (1 if any(g["background"]) else 0)

    shapes = {shape.id(): shape for shape in loaded.shapes()}
    assert len(shapes) == len(spheres)
    si = dr.zeros(mi.SurfaceInteraction3f)
    for k, s in enumerate(spheres):
        e, shape = s.expect, shapes[ids[id(s)]]   # named by its line and comment
        close(matrix(params[f"{ids[id(s)]}.to_world"]), sphere_to_world(e, origin), scale=100, rel=2e-6)
        bsdf = shape.bsdf()
        for name in ("reflect", "refract", "ior"):
            close(scalar(bsdf.eval_attribute_1(name, si)), e[name])
        color = mi.traverse(bsdf)  # (Mitsuba shares one bitmap between materials)
        if e["texture"] is None:
            close(color["color.value"], e["color"])
        else:
            _, width, height = e["texture"]
            assert np.array(color["color.data"]).shape == (height, width, 3)


def _key(params, suffix: str) -> str:
    (key,) = [k for k in params.keys() if k.endswith("." + suffix)]
    return key


def test_light_at_lookat_keeps_its_color(folder):
    """d = 0 would give no intensity: the converter then uses d = 1 (docs/CONTRACTS.md)."""
    source = folder / "at_lookat.scn"
    source.write_text("lookat 1 2 3\nlight 1 2 3 0.5 1 2\n")
    loaded = mi.load_string(scene_to_xml(parse_file(source), None))
    close(mi.traverse(loaded)["light_0.intensity.value"], np.array([0.5, 1, 2]) * math.pi)


# ------------------------------------------------------------- property 2


def _bases() -> list[bytes]:
    bases = [p.read_bytes() for p in sorted((REPO / "scenes").glob("*.scn"))]
    bases.append(b'size 32 24\nsphere 0 0 0 1 texture "earth.png" color 1 1 1 \\\n'
                 b'  reflect 0.2 refract 0.3 1.5 north 0 1 0 equator 1 0 0 # globe\n'
                 b'light 1 2 3 0.5 0.5 0.5\r\nEYE 0 0 5\nfov 40\n')
    return bases


BASES = _bases()
PIECES = [b"#", b'"', b"\\", b"\n", b"\r", b"\\\n", b" ", b"\t", b"-", b".", b"e", b"E", b"+",
          b"0", b"1", b"9", b"nan", b"inf", b"1e999", b"1e-300", b"_", b"x", b"\x00", b"\xff",
          b"\xc3", "é".encode(), "\u2028".encode(), b"sphere", b"color", b"texture", b"light",
          b"size", b"fov", b"reflect", b"refract", b"north", b"equator", b"up", b"eye",
          b" 0", b" -1", b"99999", b"16384", b" 1 1 1", b"0.5", b'"earth.png"', b'"a b"']


@st.composite
def mutated(draw):
    data = bytearray(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "insert", "replace", "token", "line"]))
        at = draw(st.integers(0, len(data)))
        if kind == "delete":
            del data[at:at + draw(st.integers(1, 6))]
        elif kind == "insert":
            data[at:at] = draw(st.sampled_from(PIECES))
        elif kind == "replace":
            data[at:at + 1] = draw(st.sampled_from(PIECES))
        elif kind == "token":
            tokens = list(re.finditer(rb"[^ \t\r\n]+", bytes(data)))
            if tokens:
                m = draw(st.sampled_from(tokens))
                data[m.start():m.end()] = draw(st.sampled_from(PIECES))
        else:
            lines = bytes(data).split(b"\n")
            i, j = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines) - 1))
            action = draw(st.sampled_from(["drop", "duplicate", "swap"]))
            if action == "drop":
                del lines[i]
            elif action == "duplicate":
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            data = bytearray(b"\n".join(lines))
    return bytes(data)


@SETTINGS
@given(data=mutated())
def test_mutated_files_parse_or_fail_cleanly(folder, data):
    source = folder / "mutant.scn"
    source.write_bytes(data)
    try:
        scene = parse_file(source)
    except SceneError as error:
        event("rejected")
        line_count = len(re.split(rb"\r\n|\r|\n", data))
        assert error.path == str(source)
        assert error.line is not None and 1 <= error.line <= line_count, str(error)
        assert str(error).startswith(f"{source}:{error.line}: ")
        # every error of the file, in file order, each one clean line
        lines = [line for _, line, _ in error.errors]
        assert all(1 <= line <= line_count for line in lines) and lines == sorted(lines), str(error)
        assert all(m and "\n" not in m and "\r" not in m for _, _, m in error.errors)
        assert str(error).split("\n")[:20] == [f"{source}:{line}: {m}" for _, line, m in error.errors][:20]
        return
    # Accepted: then Mitsuba must load it, with nothing non-finite in it.
    event("accepted")
    loaded = mi.load_string(scene_to_xml(scene, None))
    assert len(loaded.shapes()) == len(scene.spheres)
    for key, value in mi.traverse(loaded).items():
        if hasattr(value, "matrix"):
            value = value.matrix
        if isinstance(value, (float, int)) or "drjit" in type(value).__module__:
            assert np.isfinite(np.array(value, dtype=float)).all(), key
