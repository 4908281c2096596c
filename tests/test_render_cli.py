"""``whitted render``: outputs, options, and clean failures that write nothing.

Scenes are written as converted XML (scene model -> scene_to_xml), plus one
legacy .scn file for the end-to-end path. Most runs call the CLI's ``main``
in-process; one runs the real command to check its exit status.
"""

from __future__ import annotations

import json
import subprocess
import sys

import mitsuba as mi
import numpy as np
import pytest

import whitted
import whitted.rendering
from whitted import defaults as D
from float64_reference import render_reference, srgb_to_linear
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.images import read_image

W, H = 32, 24
MODEL = Scene(width=W, height=H, eye=(0.0, 1.0, 7.0), lookat=(0.0, 0.3, 0.0), background=(0.2, 0.3, 0.5),
              depth=4, lights=[Light((3.0, 5.0, 5.0))],
              spheres=[Sphere((0.0, -100.0, 0.0), 99.5, Material(color=(0.8, 0.8, 0.7))),
                       Sphere((-0.8, 0.4, 0.0), 0.8, Material(color=(0.9, 0.9, 0.9), reflect=0.8)),
                       Sphere((0.9, 0.3, 0.8), 0.6, Material(color=(1.0, 1.0, 1.0), refract=0.9, ior=1.5))])


@pytest.fixture
def scene_xml(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(scene_to_xml(MODEL, base_dir=tmp_path))
    return path


def render(*args) -> int:
    return main(["render", *map(str, args)])


def files(folder):
    return sorted(p.name for p in folder.iterdir())


def test_exr_holds_the_linear_render(scene_xml, tmp_path, capsys):
    out = tmp_path / "out.exr"
    assert render(scene_xml, "-o", out, "-q") == 0
    assert capsys.readouterr() == ("", "")
    image = read_image(out)
    expected = whitted.render(mi.load_file(str(scene_xml))).image
    np.testing.assert_array_equal(image, expected)
    assert np.abs(image - render_reference(MODEL)).mean() < 0.004


def test_png_holds_srgb_clipped(scene_xml, tmp_path):
    out = tmp_path / "out.png"
    assert render(scene_xml, "-o", out, "-q") == 0
    raw = np.array(mi.Bitmap(str(out)))
    assert raw.dtype == np.uint8 and raw.shape == (H, W, 3)
    linear = whitted.render(mi.load_file(str(scene_xml))).image
    # decoding the stored bytes gives back the clipped linear image (to 8-bit precision)
    decoded = srgb_to_linear(raw / 255.0)
    clipped = np.clip(linear, 0, 1)
    step = np.abs(srgb_to_linear(np.minimum(raw / 255.0 + 1 / 255, 1)) - decoded)
    assert np.all(np.abs(decoded - clipped) <= step + 1e-6)


def test_spp_and_stats(scene_xml, tmp_path):
    out, stats = tmp_path / "out.exr", tmp_path / "stats.json"
    assert render(scene_xml, "-o", out, "--spp", 3, "--stats", stats, "-q") == 0
    data = json.loads(stats.read_text())
    assert data["rays"]["camera"] == W * H * 3
    assert {"rays", "seconds", "compile_seconds", "effects", "max_depth_reached",
            "peak_memory_bytes"} <= set(data)


def test_max_depth_option(scene_xml, tmp_path):
    stats = tmp_path / "stats.json"
    assert render(scene_xml, "-o", tmp_path / "d1.exr", "--max-depth", 1, "--stats", stats, "-q") == 0
    data = json.loads(stats.read_text())
    assert data["max_depth_reached"] == 1
    assert data["rays"]["reflection"] == data["rays"]["refraction"] == 0
    expected = render_reference(MODEL, max_depth=1)
    assert np.abs(read_image(tmp_path / "d1.exr") - expected).mean() < 0.004


def test_ambient_and_lighting_options(scene_xml, tmp_path):
    assert render(scene_xml, "-o", tmp_path / "a.exr", "--ambient", 0.7, "-q") == 0
    expected = render_reference(MODEL, ambient=0.7)
    assert np.abs(read_image(tmp_path / "a.exr") - expected).mean() < 0.004
    assert render(scene_xml, "-o", tmp_path / "p.exr", "--lighting", "physical", "-q") == 0
    expected = render_reference(MODEL, lighting="physical")
    assert np.abs(read_image(tmp_path / "p.exr") - expected).mean() < 0.004


def test_scalar_variant_renders_the_same_image(scene_xml, tmp_path):
    assert render(scene_xml, "-o", tmp_path / "s.exr", "--variant", "scalar_rgb", "-q") == 0
    assert render(scene_xml, "-o", tmp_path / "l.exr", "--variant", "llvm_ad_rgb", "-q") == 0
    diff = np.abs(read_image(tmp_path / "s.exr") - read_image(tmp_path / "l.exr"))
    assert diff.mean() < 1e-4


def test_path_integrator_runs(scene_xml, tmp_path):
    stats = tmp_path / "stats.json"
    assert render(scene_xml, "-o", tmp_path / "path.exr", "--integrator", "path", "--spp", 8,
                  "--stats", stats, "-q") == 0
    image = read_image(tmp_path / "path.exr")
    assert image.shape == (H, W, 3) and np.all(np.isfinite(image))
    whitted_image = whitted.render(mi.load_file(str(scene_xml))).image
    assert 0.5 < image.mean() / whitted_image.mean() < 2.0
    assert json.loads(stats.read_text())["rays"]["camera"] == W * H * 8


def test_legacy_scene_file(tmp_path):
    scn = tmp_path / "two.scn"
    scn.write_text("size 24 16\nlight 5 5 10\nsphere 0 0 0 1 color 0.9 0.2 0.2 reflect 0.3\n"
                   "sphere 2 0 -1 0.7 refract 0.8 1.5\n")
    assert render(scn, "-o", tmp_path / "two.png", "-q") == 0
    model = Scene(width=24, height=16, lights=[Light((5.0, 5.0, 10.0))],
                  spheres=[Sphere((0.0, 0.0, 0.0), 1.0, Material(color=(0.9, 0.2, 0.2), reflect=0.3)),
                           Sphere((2.0, 0.0, -1.0), 0.7, Material(refract=0.8, ior=1.5))])
    image = read_image(tmp_path / "two.png")
    assert np.abs(image - np.clip(render_reference(model), 0, 1)).mean() < 0.01


def test_verbose_prints_one_summary_line(scene_xml, tmp_path, capsys):
    assert render(scene_xml, "-o", tmp_path / "v.exr", "-v", "-q") == 0
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and "camera" in err and "shadow" in err


@pytest.mark.parametrize("options, spp", [([], 1), (["--spp", 3], 3), (["--integrator", "path"], D.PATH_MIN_SPP),
                                           (["--integrator", "path", "--spp", 2], 2)])
def test_verbose_summary_says_the_spp_rendered(options, spp, scene_xml, tmp_path, capsys):
    """The path tracer without --spp takes at least PATH_MIN_SPP samples, not the scene's 1."""
    stats = tmp_path / "stats.json"
    assert render(scene_xml, "-o", tmp_path / "v.exr", "-v", "-q", "--stats", stats, *options) == 0
    assert f" at {spp} spp with " in capsys.readouterr().err
    assert json.loads(stats.read_text())["rays"]["camera"] == W * H * spp


# -- failures: a clean line, status 2, nothing written -------------------------------------------------

@pytest.mark.parametrize("case", ["missing scene", "bad extension", "bad scene", "zero spp", "depth 0",
                                  "missing folder", "bad ambient", "missing stats folder",
                                  "lighting of the path tracer", "exposure out of range"])
def test_bad_input_fails_cleanly_and_writes_nothing(case, scene_xml, tmp_path, capsys):
    out = tmp_path / "out.exr"
    args = {
        "missing scene": [tmp_path / "nope.xml", "-o", out],
        "bad extension": [scene_xml, "-o", tmp_path / "out.jpg"],
        "bad scene": [tmp_path / "broken.xml", "-o", out],
        "zero spp": [scene_xml, "-o", out, "--spp", 0],
        "depth 0": [scene_xml, "-o", out, "--max-depth", 0],
        "missing folder": [scene_xml, "-o", tmp_path / "no" / "out.exr"],
        "bad ambient": [scene_xml, "-o", out, "--ambient", 2],
        "missing stats folder": [scene_xml, "-o", out, "--stats", tmp_path / "no" / "s.json"],
        "lighting of the path tracer": [scene_xml, "-o", out, "--integrator", "path", "--lighting", "physical"],
        "exposure out of range": [scene_xml, "-o", tmp_path / "out.png", "--exposure", 100],
    }[case]
    (tmp_path / "broken.xml").write_text("<scene version='3.0.0'><shape type='sphere'><float name='radius' "
                                         "value='oops'/></shape></scene>")
    before = files(tmp_path)
    assert render(*args, "-q") == 2
    out_text, err = capsys.readouterr()
    assert out_text == ""
    assert err.startswith("whitted: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert files(tmp_path) == before


@pytest.mark.parametrize("output, message", [
    ("/dev/full", "/dev/full: is not a regular file"),
    ("/proc/x.png", "/proc/x.png: cannot write in /proc"),
    ("{tmp}/no/x.png", "{tmp}/no/x.png: output folder {tmp}/no does not exist"),
])
def test_output_path_errors_say_what_is_wrong_with_the_path(output, message, scene_xml, tmp_path, capsys):
    before = files(tmp_path)
    assert render(scene_xml, "-o", output.format(tmp=tmp_path), "-q") == 2
    err = capsys.readouterr().err
    assert err.startswith("whitted: error: " + message.format(tmp=tmp_path)) and err.count("\n") == 1
    assert files(tmp_path) == before


def test_an_existing_folder_receives_the_image_named_after_the_scene(scene_xml, tmp_path, capsys):
    """-o naming a folder means what it means to convert: the image goes into it, as
    FOLDER/NAME.png (it used to be an error: "is a folder")."""
    folder = tmp_path / "images"
    folder.mkdir()
    assert render(scene_xml, "-o", folder, "-q") == 0
    assert files(folder) == ["scene.png"]
    assert capsys.readouterr().err.startswith("whitted: rendered 1 of 1 scenes")


def test_an_unknown_option_shows_the_commands_own_usage(scene_xml, tmp_path):
    run = subprocess.run([sys.executable, "-m", "whitted", "render", str(scene_xml), "-o",
                          str(tmp_path / "x.png"), "--bogus"], capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.startswith("usage: whitted render ")
    assert "whitted render: error: unrecognized arguments: --bogus" in run.stderr
    assert not (tmp_path / "x.png").exists()


def test_scene_without_article_materials_is_refused(tmp_path, capsys):
    xml = tmp_path / "plain.xml"
    xml.write_text("<scene version='3.0.0'><sensor type='perspective'><film type='hdrfilm'>"
                   "<integer name='width' value='8'/><integer name='height' value='8'/></film></sensor>"
                   "<shape type='sphere'/></scene>")
    assert render(xml, "-o", tmp_path / "x.exr", "-q") == 2
    assert "article" in capsys.readouterr().err
    assert not (tmp_path / "x.exr").exists()


def test_scene_without_a_sensor_is_refused(tmp_path, capsys):
    xml = tmp_path / "blind.xml"
    xml.write_text("<scene version='3.0.0'><shape type='sphere'/></scene>")
    assert render(xml, "-o", tmp_path / "x.exr", "-q") == 2
    assert "sensor" in capsys.readouterr().err


def test_exit_status_of_the_real_command(scene_xml, tmp_path):
    ok = subprocess.run([sys.executable, "-m", "whitted", "render", str(scene_xml), "-o",
                         str(tmp_path / "ok.png"), "-q"], capture_output=True, text=True)
    assert ok.returncode == 0 and (tmp_path / "ok.png").is_file()
    bad = subprocess.run([sys.executable, "-m", "whitted", "render", str(scene_xml), "-o",
                          str(tmp_path / "bad.tiff"), "-q"], capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert not (tmp_path / "bad.tiff").exists()


def test_path_tracer_renders_in_passes_and_averages_them(scene_xml, monkeypatch):
    """Memory stays bounded for the path tracer too: passes of whole spp, averaged."""
    scene = mi.load_file(str(scene_xml))
    sensor = scene.sensors()[0]
    own_spp = sensor.sampler().sample_count()
    monkeypatch.setattr(whitted.rendering, "PATH_SAMPLES_PER_PASS", W * H * 2)   # 2 spp per pass
    result = whitted.render(scene, integrator="path", spp=5, seed=3)
    assert sensor.sampler().sample_count() == own_spp   # mi.render's change is undone
    path = mi.load_dict({"type": "path", "max_depth": MODEL.depth + 1})
    seeds = [3] + [(3 * D.SEED_STRIDE + k) & 0xFFFFFFFF for k in (1, 2)]
    passes = [np.array(mi.render(scene, integrator=path, spp=n, seed=s), dtype=np.float64)
              for n, s in zip((2, 2, 1), seeds)]
    expected = (2 * passes[0] + 2 * passes[1] + passes[2]) / 5
    np.testing.assert_allclose(result.image, expected, rtol=1e-5, atol=1e-6)


def test_a_variant_given_is_set_once(scene_xml, tmp_path):
    """``whitted render --variant scalar_rgb`` in a fresh process: Mitsuba's variant is set
    once, to it (not to the default first, the plugins built, then switched and rebuilt)."""
    program = (
        "import sys\n"
        "import whitted.variant as V\n"
        "changes = []\n"
        "V.on_variant_changed = lambda old, new, seen=V.on_variant_changed: (changes.append((old, new)), seen(old, new))\n"
        "from whitted.cli import main\n"
        "status = main(['render', sys.argv[1], '-o', sys.argv[2], '--variant', 'scalar_rgb', '--quiet'])\n"
        "import mitsuba as mi\n"
        "from whitted import plugins\n"
        "print(status, changes, mi.variant(), sorted({v for v, _ in plugins._classes}))\n")
    out = tmp_path / "once.exr"
    run = subprocess.run([sys.executable, "-c", program, str(scene_xml), str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "0 [(None, 'scalar_rgb')] scalar_rgb ['scalar_rgb']", run.stdout
    assert out.exists()


@pytest.mark.parametrize("command", [
    ["render", "{scene}", "-o", ""], ["render", "{scene}", "{scene}", "-o", ""],
    ["render", "", "-o", "{tmp}/x.png"], ["render", "{scene}", "-o", "{tmp}/x.png", "--stats", ""],
    ["convert", "{scene}", "-o", ""], ["video", "{tmp}", "-o", ""], ["fit", "{scene}", "--to", "",
                                                                     "-o", "{tmp}/f.scn"],
    ["trace", "{scene}", "--pixel", "1", "1", "-o", ""], ["compare", "{scene}", "-o", ""],
    ["compare", "{scene}", "-o", "{tmp}/c", "--cache", ""]])
def test_an_empty_path_is_refused(command, scene_xml, tmp_path, monkeypatch, capsys):
    """An empty path (an unset shell variable) is no file: it used to mean the current folder,
    and -o "" of several scenes wrote their images into the root folder."""
    monkeypatch.chdir(tmp_path)
    before = files(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main([word.format(scene=scene_xml, tmp=tmp_path) for word in command])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.splitlines()[-1].endswith(": an empty path names no file or folder"), err
    assert files(tmp_path) == before


LONG = "n" * 300   # longer than a file name may be (255 bytes on Linux file systems)


@pytest.mark.parametrize("command", [
    ["render", "{scene}", "-o", "{long}.png"], ["render", "{scene}", "-o", "{long}/x.png"],
    ["render", "{scene}", "{scene}", "-o", "{long}/"], ["render", "{scene}", "-o", "x.png", "--stats", "{long}"],
    ["convert", "{scene}", "-o", "{long}.xml"], ["compare", "{scene}", "-o", "{long}"],
    ["trace", "{scene}", "--pixel", "1", "1", "-o", "{long}.html"]])
def test_a_name_the_system_refuses_is_one_line(command, scene_xml, tmp_path, monkeypatch, capsys):
    """A name longer than the file system allows: stat's OSError ended render, convert and
    compare in a traceback."""
    monkeypatch.chdir(tmp_path)
    before = files(tmp_path)
    assert main([word.format(scene=scene_xml, long=LONG) for word in command]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("whitted: error: ") and LONG in err, err
    assert err.rstrip().endswith("File name too long"), err
    assert files(tmp_path) == before
