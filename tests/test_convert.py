"""``whitted convert`` and the XML it writes: CLI behaviour, the XML contract
(docs/CONTRACTS.md), escaping, determinism, and the example scenes."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted.cli import main
from whitted.converter import parse_file, parse_text, scene_to_xml

REPO = Path(__file__).resolve().parent.parent
SCENES = sorted((REPO / "scenes").glob("*.scn"))
BAD = "# a broken scene\nsize 320 200\n\n\nlight 5 5 10\n\nsphere 0 0 0 -1\n"


def convert(*args: str) -> int:
    return main(["convert", *map(str, args)])


# --------------------------------------------------------------------- CLI


def test_default_output_is_beside_the_input(write_scene, capsys):
    scene = write_scene("light 5 5 5\nsphere 0 0 0 1\n", "demo.scn")
    assert convert(scene) == 0
    xml = scene.with_suffix(".xml")
    assert xml.read_text().startswith('<?xml version="1.0" encoding="utf-8"?>')
    assert capsys.readouterr() == ("", "")


def test_the_default_xml_says_how_to_render_it(write_scene):
    """The stock ``mitsuba`` command cannot load the default XML (``Plugin "whitted" not
    found!``): its header says what can, and names the portable file for that command."""
    scene = write_scene("light 5 5 5\nsphere 0 0 0 1\n", "demo.scn")
    assert convert(scene) == 0
    header = scene.with_suffix(".xml").read_text().split("<scene ")[0]
    header = " ".join(header.split())   # the comment's lines joined
    for said in ("`whitted render demo.xml -o demo.png`", "`import whitted`", "mi.load_file",
                 'Plugin "whitted" not found', "demo.portable.xml", "docs/portable.md"):
        assert said in header
    ET.fromstring(scene.with_suffix(".xml").read_text())   # still well-formed


def test_output_option(write_scene, tmp_path, capsys):
    scene = write_scene("sphere 0 0 0 1\n")
    (tmp_path / "out").mkdir()
    assert convert(scene, "-o", tmp_path / "out" / "x.xml", "-v") == 0
    assert (tmp_path / "out" / "x.xml").is_file()
    assert not scene.with_suffix(".xml").exists()
    assert "wrote" in capsys.readouterr().err


def test_error_is_one_line_with_file_and_line_and_writes_nothing(write_scene, tmp_path, capsys):
    scene = write_scene(BAD)
    assert convert(scene) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"{scene}:7: sphere radius must be > 0, got -1" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.scn"]  # no output, no temp file


def test_error_leaves_an_existing_output_untouched(write_scene, tmp_path):
    target = tmp_path / "keep.xml"
    target.write_text("old")
    assert convert(write_scene(BAD), "-o", target) == 2
    assert target.read_text() == "old"


@pytest.mark.parametrize("case, message", [
    ("missing", "no such file"),
    ("empty_folder", "no .scn files in this folder"),
    ("no_output_folder", "output folder"),
    ("overwrite_input", "output would overwrite the input"),
    ("binary", ":1: binary file"),
])
def test_cli_user_errors(case, message, write_scene, tmp_path, capsys):
    good = write_scene("sphere 0 0 0 1\n")
    empty = tmp_path / "empty"
    empty.mkdir()
    args = {
        "missing": [tmp_path / "nope.scn"],
        "empty_folder": [empty],
        "no_output_folder": [good, "-o", tmp_path / "no" / "such" / "x.xml"],
        "overwrite_input": [good, "-o", good],
        "binary": [write_scene(b"\x00\x01\x02", "bin.scn")],
    }[case]
    before = sorted(tmp_path.rglob("*"))
    assert convert(*args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert sorted(tmp_path.rglob("*")) == before
    assert good.read_text() == "sphere 0 0 0 1\n"


def test_an_output_folder_is_created_for_one_file_as_for_many(write_scene, tmp_path, capsys):
    """One rule: -o naming a folder (a trailing / or several inputs) is created when missing."""
    scene = write_scene("light 5 5 5\nsphere 0 0 0 1\n", "ball.scn")
    assert convert(scene, "-o", f"{tmp_path / 'one' / 'deep'}/") == 0
    assert (tmp_path / "one" / "deep" / "ball.xml").is_file()
    other = write_scene("light 5 5 5\nsphere 0 0 0 2\n", "other.scn")
    assert convert(scene, other, "-o", tmp_path / "many") == 0
    assert sorted(p.name for p in (tmp_path / "many").iterdir()) == ["ball.xml", "other.xml"]
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("output, message", [
    ("{tmp}/missing/x.xml", "{tmp}/missing/x.xml: output folder {tmp}/missing does not exist"),
    ("/proc/x.xml", "/proc/x.xml: cannot write in /proc"),
    ("/proc/sub/", "/proc/sub: cannot write in /proc"),
])
def test_output_errors_name_only_the_users_paths(output, message, write_scene, tmp_path, capsys):
    scene = write_scene("sphere 0 0 0 1\n")
    assert convert(scene, "-o", output.format(tmp=tmp_path)) == 2
    err = capsys.readouterr().err
    assert err.startswith("whitted: error: " + message.format(tmp=tmp_path)) and err.count("\n") == 1
    assert ".whitted" not in err
    assert not (tmp_path / "missing").exists()


def test_output_folder_receives_the_xml(write_scene, tmp_path):
    scene = write_scene("sphere 0 0 0 1\n", "ball.scn")
    out = tmp_path / "out"
    out.mkdir()
    assert convert(scene, "-o", out) == 0
    assert parse_file(scene) is not None and (out / "ball.xml").is_file()
    assert not scene.with_suffix(".xml").exists()


def test_several_files_and_folders_go_on_past_a_bad_file(tmp_path, capsys):
    """Every good file is converted; each bad one is reported as FILE:LINE and written nowhere."""
    folder = tmp_path / "legacy"
    folder.mkdir()
    (folder / "a.scn").write_text("sphere 0 0 0 1\n")
    (folder / "b.scn").write_text(BAD)
    (folder / "notes.txt").write_text("not a scene")
    c = tmp_path / "c.scn"
    c.write_text("size 10 10\nsphere 0 0 0 2\n")
    bad2 = tmp_path / "d.scn"
    bad2.write_text("sphere 0 0 0 1\nsphear 1 1 1 1\n")
    assert convert(folder, c, bad2) == 2
    err = capsys.readouterr().err
    assert f"{folder / 'b.scn'}:7: sphere radius must be > 0" in err
    assert f"{bad2}:2: " in err and "2 of 4 scene files not converted" in err
    assert "Traceback" not in err
    assert (folder / "a.xml").is_file() and c.with_suffix(".xml").is_file()
    assert not (folder / "b.xml").exists() and not bad2.with_suffix(".xml").exists()
    assert not (folder / "notes.xml").exists()
    # the XML of each good file is what converting it alone gives
    assert (folder / "a.xml").read_text() == scene_to_xml(parse_file(folder / "a.scn"), base_dir=folder)


def test_several_files_into_one_output_folder(tmp_path):
    for name in ("a", "b"):
        (tmp_path / f"{name}.scn").write_text("sphere 0 0 0 1\n")
    out = tmp_path / "new" / "xml"
    assert convert(tmp_path / "a.scn", tmp_path / "b.scn", "-o", out) == 0
    assert sorted(p.name for p in out.iterdir()) == ["a.xml", "b.xml"]


def test_two_inputs_that_would_write_one_file_are_refused_before_any_work(tmp_path, capsys):
    for sub in ("x", "y"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "same.scn").write_text("sphere 0 0 0 1\n")
    out = tmp_path / "out"
    out.mkdir()
    assert convert(tmp_path / "x" / "same.scn", tmp_path / "y" / "same.scn", "-o", out) == 2
    assert "would be written here" in capsys.readouterr().err
    assert list(out.iterdir()) == []


def test_convert_loads_neither_mitsuba_nor_drjit(write_scene, tmp_path):
    """The converter stands alone: importing it, and the whole ``whitted convert`` command,
    leave Mitsuba and Dr.Jit unloaded (checked in a fresh interpreter)."""
    scene = write_scene("size 8 8\nlight 1 1 1\nsphere 0 0 0 1 reflect 0.5\n", "light.scn")
    code = ("import sys\n"
            "import whitted.converter as c\n"
            "from whitted.cli import main\n"
            f"status = main(['convert', {str(scene)!r}])\n"
            "heavy = sorted(m for m in ('mitsuba', 'drjit') if m in sys.modules)\n"
            "print(status, ','.join(heavy) or '-')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["0", "-"]
    assert scene.with_suffix(".xml").is_file()


#: scenes that convert and render but draw nothing useful -> the one warning each gets
NOTHING_USEFUL = [
    ("size 8 6\nsphere 0 0 0 1\n", "scene.scn: no light: only the ambient term (0.2) lights the scene; "
     "add `light X Y Z`"),
    ("size 8 6\nlight 5 5 5\nlookat 0 0 20\nsphere 0 0 0 1\nsphere 3 0 -2 1\n",
     "scene.scn: no sphere is in the camera's view: the image is only the background; point `lookat` at "
     "the spheres (or widen `fov`)"),
    ("size 8 6\nlight 5 5 5\neye 0 -1 10\nsphere 0 -100 0 100\nsphere 0 1 0 1\n",
     "scene.scn:4: the eye is inside this opaque sphere, which holds no other sphere: the image shows "
     "only its inside; move `eye` out of it (or make it `refract`)"),
    ("size 8 6\nlight 0 5 5\neye 0 0 2\nsphere 0 0 0 2 color 0.5 0.5 0.5\n",
     "scene.scn:4: the eye is on this sphere's surface: what the camera rays see first is decided by "
     "rounding; move `eye` off it"),
]


@pytest.mark.parametrize("text, warning", NOTHING_USEFUL,
                         ids=["no_light", "looking_away", "eye_shut_in", "eye_on_surface"])
def test_a_scene_that_draws_nothing_useful_gets_one_warning(text, warning, write_scene, tmp_path, capsys):
    """Convert, render and load_scene all say what the user probably meant, in one line; the
    scene stays valid (exit 0, the outputs written)."""
    scene = write_scene(text)
    line = f"whitted: warning: {tmp_path / warning}"
    for args in (["convert", scene], ["render", scene, "-o", tmp_path / "out.png", "-q"]):
        assert main(list(map(str, args))) == 0
        assert capsys.readouterr() == ("", line + "\n")
    assert scene.with_suffix(".xml").is_file() and (tmp_path / "out.png").is_file()
    whitted.load_scene(scene)
    assert capsys.readouterr().err == line + "\n"


@pytest.mark.parametrize("text", ["ambient 1\nsphere 0 0 0 1\n",                   # flat on purpose
                                  "light 5 5 5\nsphere 0 0 0 1\nsphere 0 0 0 50\n",   # a room around it
                                  "light 5 5 5\neye 0 0 0.5\nsphere 0 0 0 1 refract 0.9 1.5\n",   # glass
                                  "light 5 5 5\nlookat 0 0 20\nfov 179\nsphere 9 0 11 1\n"])   # at the edge
def test_scenes_that_draw_something_get_no_warning(text, write_scene, capsys):
    assert convert(write_scene(text)) == 0
    assert capsys.readouterr() == ("", "")


def test_the_example_scenes_convert_without_a_warning(tmp_path, capsys):
    assert convert(REPO / "scenes", "-o", tmp_path) == 0
    assert capsys.readouterr() == ("", "")


def test_scenes_held_as_arrays_convert_as_lists_do(texture_png, tmp_path, capsys):
    """A parsed scene holds its spheres as arrays (converter/scene.py), written in a block
    (converter/xml_writer.py): the same bytes as from a list of spheres, giant, meshed,
    textured and odd ones included."""
    from whitted.converter.frame import warn_precision
    text = (f"size 16 12\neye 0 2e5 3\nlookat 0.5 0 0.25\nlight 1 2 3\n"
            f"sphere 0 -1e4 0 1e4 color 0.8 0.8 0.75 reflect 0.3\nsphere 0 1 0 1 reflect 0.5\n"
            f"sphere -0 2 -0.0 0.25 color 1 0.9 0.7 reflect 0.5\nsphere 3 1 0 0.5\n"
            f"sphere 1 1 1 1 texture {texture_png().name} north 0 0 1 equator 1 0 0\nsphere 2 2 2 1e-6 refract 0.9 1.5\n"
            f"sphere 1e5 0 0 9e4 color 0.2 0.3 0.4\nsphere 4 0 0 0.5 color 1 0.9 0.7 reflect 0.5\n")
    for portable in (False, True):
        xml = []
        for arrays in (False, True):
            scene = parse_text(text, tmp_path / "s.scn")
            if not arrays:
                scene.spheres = list(scene.spheres)
            xml.append(scene_to_xml(scene, tmp_path, portable=portable))
            warn_precision(scene, integrator="path")
            assert (scene.held_sphere_arrays() is not None) is arrays   # nothing made the list
        assert xml[0] == xml[1]
    warnings = capsys.readouterr().err.splitlines()
    assert len(warnings) == 4 and warnings[0] == warnings[1] and warnings[2] == warnings[3]


def test_two_processes_write_the_same_bytes(write_scene, tmp_path):
    """A large block of spheres is formatted by two processes (converter/xml_writer.py):
    the same file as by one, special spheres in either half included. In a process of its
    own, as ``whitted convert`` runs: one that runs Dr.Jit (this one) never forks."""
    lines = ["size 8 8", "eye 0 2e5 3", "light 1 2 3", "sphere 0 -1e4 0 1e4 color 0.8 0.8 0.75"]
    lines += [f"sphere {i} {i % 7} -{i % 3} 0.{i % 5 + 1} color 1 0.9 0.7 reflect 0.5" for i in range(1, 40)]
    lines += ["sphere 1e5 0 0 9e4", "sphere 5 5 5 1"]
    scene = write_scene("\n".join(lines) + "\n", "many.scn")
    script = f"""
import sys
from whitted.cli import main
from whitted.converter import xml_writer
forks = []
fork = xml_writer._fork_writer
xml_writer._fork_writer = lambda *args: forks.append(1) or fork(*args)
for parallel_from in (10**9, 2, 3):
    xml_writer.PARALLEL_FROM = parallel_from
    for portable in ([], ["--portable"]):
        out = rf"{tmp_path}/out" + str(parallel_from) + str(len(portable)) + ".xml"
        assert main(["convert", rf"{scene}", "-o", out, *portable]) == 0
print(len(forks))
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["4"]   # the child ran four times
    written = [(tmp_path / f"out{p}{n}.xml").read_bytes() for p in (10**9, 2, 3) for n in (0, 1)]
    assert b"exact_spheres" in written[0] and b'type="ply"' in written[0]
    assert written[0] == written[2] == written[4] and written[1] == written[3] == written[5] != written[0]


def test_cli_process_exit_status_and_stderr(write_scene, tmp_path):
    """The real command: non-zero status, the spec's message, no traceback, no file."""
    scene = write_scene(BAD)
    run = subprocess.run([sys.executable, "-m", "whitted", "convert", str(scene)],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode != 0
    assert f"{scene}:7: sphere radius must be > 0, got -1" in run.stderr
    assert "Traceback" not in run.stderr and run.stdout == ""
    assert not scene.with_suffix(".xml").exists()


def test_cli_process_relative_name_in_message(write_scene, tmp_path):
    write_scene("size 10 10\nfov 200\n", "rel.scn")
    run = subprocess.run([sys.executable, "-m", "whitted", "convert", "rel.scn"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 2
    assert "rel.scn:2: fov must be > 0 and < 180, got 200" in run.stderr
    assert run.stderr.strip().endswith("rel.scn:2: fov must be > 0 and < 180, got 200")


def test_conversion_is_deterministic(write_scene, texture_png, tmp_path, monkeypatch):
    texture_png("tex.png")
    scene = write_scene("light 1 2 3 0.5 0.25 1\nsphere 0 0 0 1 texture tex.png reflect 0.2\n"
                        "sphere 1 1 1 0.5 color 0.1 0.2 0.3\nsphere 2 2 2 0.5 color 0.1 0.2 0.3\n")
    assert convert(scene, "-o", tmp_path / "a.xml") == 0
    monkeypatch.chdir(tmp_path)
    assert convert("scene.scn", "-o", "b.xml") == 0
    assert (tmp_path / "a.xml").read_bytes() == (tmp_path / "b.xml").read_bytes()
    assert scene_to_xml(parse_file(scene), tmp_path) == (tmp_path / "a.xml").read_text()


# ------------------------------------------------------------ texture paths


def test_texture_paths_are_relative_to_the_output_folder(write_scene, texture_png, tmp_path,
                                                         monkeypatch):
    texture_png("scenes/maps/tex.png")
    scene = write_scene("sphere 0 0 0 1 texture maps/tex.png\n", "scenes/a.scn")
    (tmp_path / "out" / "deep").mkdir(parents=True)
    target = tmp_path / "out" / "deep" / "a.xml"
    assert convert(scene, "-o", target) == 0
    (filename,) = [e.get("value") for e in ET.parse(target).iter("string")
                   if e.get("name") == "filename"]
    assert filename == "../../scenes/maps/tex.png"
    monkeypatch.chdir(REPO)  # Mitsuba resolves it against the XML's folder, not the cwd
    loaded = mi.load_file(str(target))
    assert np.array(mi.traverse(loaded)["material_l1.color.data"]).shape == (2, 4, 3)   # line 1


def test_xml_moved_with_its_texture_still_loads(write_scene, texture_png, tmp_path):
    texture_png("t.png")
    scene = write_scene("sphere 0 0 0 1 texture t.png\n")
    assert convert(scene) == 0
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    for name in ("scene.xml", "t.png"):
        (tmp_path / name).rename(moved / name)
    assert len(mi.load_file(str(moved / "scene.xml")).shapes()) == 1


def test_xml_from_memory_uses_absolute_paths(write_scene, texture_png):
    texture = texture_png("t.png")
    xml = scene_to_xml(parse_file(write_scene("sphere 0 0 0 1 texture t.png\n")), base_dir=None)
    assert f'value="{texture}"' in xml
    assert len(mi.load_string(xml).shapes()) == 1


@pytest.mark.parametrize("name", ["a&b.png", "<tag>.png", 'quo"te.png', "it's.png",
                                  "cost $spp.png", "x--y.png", "sp ace#.png", "ünï €.png"])
def test_odd_texture_names_are_escaped(tmp_path, texture_png, name):
    texture_png(name)
    quoted = name.replace('"', "")  # a quote cannot appear inside a quoted path
    if quoted != name:
        texture_png(quoted)
    scene = parse_text(f'sphere 0 0 0 1 texture "{quoted}"\n', tmp_path / "a.scn")
    xml = scene_to_xml(scene, tmp_path)
    ET.fromstring(xml.encode("utf-8"))  # well-formed
    (tmp_path / "a.xml").write_text(xml, encoding="utf-8")
    assert len(mi.load_file(str(tmp_path / "a.xml")).shapes()) == 1


@pytest.mark.parametrize("name", ["x--y.scn", "a-.scn", "<&>.scn", "tab\tname.scn", "--.scn"])
def test_odd_scene_names_give_well_formed_xml(write_scene, name):
    xml = scene_to_xml(parse_file(write_scene("sphere 0 0 0 1\n", name)), None)
    root = ET.fromstring(xml.encode("utf-8"))
    assert root.tag == "scene" and root.get("version") == "3.0.0"


# ------------------------------------------------------------- the contract


def xml_of(text: str, tmp_path=None) -> ET.Element:
    return ET.fromstring(scene_to_xml(parse_text(text, Path("s.scn")), None).encode("utf-8"))


def test_xml_contract_defaults_integrator_sensor():
    root = xml_of("size 32 24\nfov 60\nlookat 1 2 3\nambient 0.4\ndepth 7\nsamples 9\n")
    defaults = {d.get("name"): d.get("value") for d in root.findall("default")}
    assert defaults == {"spp": "9", "max_depth": "7", "ambient": "0.4", "lighting": "article",
                        "width": "32", "height": "24"}
    # positions are relative to lookat, which a comment records (no parameter: nothing uses it)
    assert "world point 1.0, 2.0, 3.0:" in scene_to_xml(parse_text(
        "size 32 24\nfov 60\nlookat 1 2 3\nambient 0.4\ndepth 7\nsamples 9\n", Path("s.scn")), None)
    (integrator,) = root.findall("integrator")
    assert integrator.get("type") == "whitted"
    props = {e.get("name"): (e.tag, e.get("value")) for e in integrator}
    assert props == {"max_depth": ("integer", "$max_depth"), "ambient": ("float", "$ambient"),
                     "lighting": ("string", "$lighting"),
                     "light_reference": ("point", "0.0, 0.0, 0.0")}   # lookat, in the frame
    (sensor,) = root.findall("sensor")
    assert sensor.get("type") == "perspective"
    values = {e.get("name"): e.get("value") for e in sensor if e.get("name")}
    assert values["fov_axis"] == "x" and values["fov"] == "60.0"
    assert sensor.find("sampler").get("type") == "independent"
    assert sensor.find("sampler/integer").get("value") == "$spp"
    film = {e.get("name"): e.get("value") for e in sensor.find("film")}
    assert (film["width"], film["height"]) == ("$width", "$height")   # 32, 24: the defaults
    assert sensor.find("film/rfilter").get("type") == "box"


def test_background_is_an_emitter_only_when_not_black():
    assert xml_of("").findall("emitter") == []
    (emitter,) = xml_of("background 0 0.5 0\n").findall("emitter")
    assert (emitter.get("type"), emitter.get("id")) == ("constant", "background")
    assert emitter.find("rgb").get("value") == "0.0 0.5 0.0"


def test_materials_are_shared_and_textures_ignore_color(texture_png, tmp_path):
    texture_png("t.png")
    scene = parse_text("sphere 0 0 0 1 color 0.5 0.5 0.5\nsphere 1 0 0 1 color 0.5 0.5 0.5\n"
                       "sphere 2 0 0 1 color 0.5 0.5 0.6\nsphere 3 0 0 1 texture t.png\n"
                       "sphere 4 0 0 1 texture t.png color 0 0 0\n"
                       "sphere 5 0 0 1 texture t.png reflect 0.5\n", tmp_path / "a.scn")
    root = ET.fromstring(scene_to_xml(scene, tmp_path).encode())
    assert len(root.findall("bsdf")) == 4
    refs = [s.find("ref").get("id") for s in root.findall("shape")]
    # each named by the line of its first sphere
    assert refs == ["material_l1", "material_l1", "material_l3", "material_l4", "material_l4", "material_l6"]


def test_numbers_are_written_exactly():
    root = xml_of("sphere 0.1 -1e-07 123456.789 0.3333333333333333 color 0.1 0.2 0.3\n")
    shape = root.find("shape")
    center = [float(c) for c in shape.find("point").get("value").split(",")]
    assert center == [0.1, -1e-07, 123456.789]
    assert float(shape.find("float").get("value")) == 0.3333333333333333


# ------------------------------------------------------------ example scenes


def test_the_example_scenes_show_every_effect_of_the_format():
    """Together the examples call for every effect the article's model has (and the
    parametrized tests below have scenes to run on)."""
    models = {p.stem: parse_file(p) for p in SCENES}
    assert set(models) >= {"spheres", "globe", "mirrors", "tir"}
    spheres = [s for m in models.values() for s in m.spheres]
    assert any(s.material.reflect > 0 for s in spheres), "no mirror"
    assert any(s.material.refract > 0 and s.material.ior != 1 for s in spheres), "no glass"
    assert any(s.material.texture is not None for s in spheres), "no texture"
    assert any(len(m.lights) > 1 for m in models.values()), "no scene with several lights"
    assert any(any(m.background) for m in models.values()), "no background color"


@pytest.mark.parametrize("portable", [False, True], ids=["default", "portable"])
@pytest.mark.parametrize("scn", SCENES, ids=lambda p: p.stem)
def test_scenes_xml_is_not_stale(scn, portable):
    """scenes_xml/ must be what `make scenes` writes now (run it after editing scenes/)."""
    xml = REPO / "scenes_xml" / f"{scn.stem}{'.portable' if portable else ''}.xml"
    assert xml.is_file(), f"{xml} is missing: run `make scenes`"
    assert scene_to_xml(parse_file(scn), xml.parent, portable=portable) == xml.read_text(encoding="utf-8"), \
        f"{xml} is stale: run `make scenes`"


def test_no_xml_without_its_scene():
    names = {p.name for p in (REPO / "scenes_xml").glob("*.xml")}
    assert names == {f"{p.stem}{suffix}" for p in SCENES for suffix in (".xml", ".portable.xml")}


def test_texture_image_is_not_stale():
    spec = importlib.util.spec_from_file_location("make_textures", REPO / "scenes" / "make_textures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    pixels = module.earth()
    assert pixels.shape == (128, 256, 3) and pixels.dtype == np.uint8
    stored = np.array(mi.Bitmap(str(REPO / "scenes" / "earth.png")))
    assert np.array_equal(stored, pixels), "scenes/earth.png is stale: run `make scenes`"


def test_globe_texture_is_north_up():
    """The map's markers: the white cap is at the top rows, the red arrow points up."""
    pixels = np.array(mi.Bitmap(str(REPO / "scenes" / "earth.png"))).astype(int)
    white = (pixels > 240).all(axis=-1)
    assert white[:3].mean() > 0.8 and white[-3:].mean() < 0.1  # grid lines cross the cap
    red = (pixels[..., 0] > 200) & (pixels[..., 1] < 60)
    column = red[:, 120:136]  # the arrow at the center column: narrow tip above a wide head
    rows = np.nonzero(column.any(axis=1))[0]
    widths = column[rows].sum(axis=1)
    assert widths[0] < widths[8]


@pytest.fixture
def each_variant():
    """Runs the test body in scalar_rgb and llvm_ad_rgb, then restores the variant."""
    previous = mi.variant()
    yield ("scalar_rgb", "llvm_ad_rgb")
    whitted.set_variant(previous)


@pytest.mark.parametrize("scn", SCENES, ids=lambda p: p.stem)
def test_example_xml_loads_in_both_variants(scn, each_variant):
    scene = parse_file(scn)
    lights = len(scene.lights) + (1 if any(scene.background) else 0)
    for variant in each_variant:
        whitted.set_variant(variant)
        loaded = mi.load_file(str(REPO / "scenes_xml" / f"{scn.stem}.xml"))
        assert len(loaded.shapes()) == len(scene.spheres)
        assert len(loaded.emitters()) == lights
        assert type(loaded.integrator()).__name__ == "WhittedIntegrator"
        assert all(type(s.bsdf()).__name__ == "ArticleBSDF" for s in loaded.shapes())
        assert len(whitted.load_scene(scn).shapes()) == len(scene.spheres)  # .scn from memory


@pytest.mark.parametrize("content, line", [
    ("size 10 10\n\nsphre 0 0 0 1\n", 3),                       # unknown statement
    ("sphere 0 0 0 1 \\\n  colr 1 1 1\n", 1),                   # unknown attribute, continued
    ("fov 30\nfov 40\n", 2),                                     # global twice
    ("\nambient 1.5\n", 2),                                      # range
    ("depth 2.5\n", 1),                                          # integer
    ("light 0 0 nan\n", 1),                                      # nan
    ("# c\neye 0 0 0\n", 2),                                     # camera
    ("\n\nsphere 0 0 0 1 texture missing.png\n", 3),             # texture
    ('sphere 0 0 0 1 texture "a.png\n', 1),                      # quote
    (b"size 1 1\n\xfe\n", 2),                                    # not UTF-8
    (b"size 1 1\n\n\x00", 3),                                    # binary
])
def test_cli_names_file_and_line_for_each_error_class(write_scene, capsys, content, line):
    scene = write_scene(content)
    assert convert(scene) == 2
    err = capsys.readouterr().err
    assert f"{scene}:{line}: " in err and err.count("\n") == 1
    assert not scene.with_suffix(".xml").exists()


def test_convert_names_the_mesh_files_it_writes_and_why(write_scene, tmp_path, capsys):
    scene = write_scene("light 5 5 5\nsphere 0 -100000 0 100000 color 0.5 0.5 0.5\nsphere 0 0 0 1\n",
                        "floor.scn")
    assert convert(scene) == 0
    err = capsys.readouterr().err.strip().splitlines()
    meshes = sorted(p.name for p in tmp_path.glob("floor.sphere_*.ply"))
    assert meshes == ["floor.sphere_l2.ply"]   # the sphere of line 2
    size = (tmp_path / meshes[0]).stat().st_size
    assert len(err) == 1 and "floor.sphere_l2.ply" in err[0] and f"{size / 1e6:.1f} MB" in err[0]
    assert "giant sphere" in err[0] and "path tracer" in err[0]


def test_a_converted_scene_s_missing_texture_is_not_taken_from_the_current_folder(
        write_scene, texture_png, tmp_path, monkeypatch, capsys):
    texture_png("scenes/earth.png")
    scene = write_scene("light 5 5 5\nsphere 0 0 0 1 texture earth.png\n", "scenes/t.scn")
    assert convert(scene) == 0
    (tmp_path / "scenes" / "earth.png").rename(tmp_path / "earth.png")   # now only in the current folder
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert main(["render", "scenes/t.xml", "-o", "out.png", "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("whitted: error: scenes/t.xml: the file it names, earth.png, does not exist "
                   f"(looked for {Path('scenes') / 'earth.png'})")
    assert not (tmp_path / "out.png").exists()


def test_a_path_traced_scene_without_light_or_background_is_warned_black(write_scene, tmp_path, capsys):
    """The path tracer has no ambient term: a scene with no light and a black background renders
    all black, and says so (not 'only the ambient term lights it', and even with ambient 1);
    a background lights it (a constant environment), which is not warned about."""
    for text in ("size 8 6\nsphere 0 0 0 1\n", "size 8 6\nambient 1\nsphere 0 0 0 1\n"):
        scene = write_scene(text)
        assert main(["render", str(scene), "-o", str(tmp_path / "out.exr"), "-q",
                     "--integrator", "path", "--spp", "1"]) == 0
        assert capsys.readouterr().err == (
            f"whitted: warning: {scene}: no light and a black background: the path tracer has no "
            "ambient term, so the image is all black; add `light X Y Z`\n")
        whitted.load_scene(scene, integrator="path")
        assert "all black" in capsys.readouterr().err
    whitted.load_scene(write_scene("size 8 6\nbackground 0.2 0.3 0.4\nsphere 0 0 0 1\n"), integrator="path")
    assert capsys.readouterr().err == ""
