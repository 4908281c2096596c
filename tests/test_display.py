"""What is displayed (PNG, FLIP, notebooks) against what is kept (EXR, relative MSE).

Expectations are independent of whitted.images's code: the sRGB transfer curve written
out from IEC 61966-2-1, Mitsuba's own 8-bit sRGB encoding, and OpenColorIO's processor
built here from the config and view names.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import whitted
from whitted import metrics
from whitted.cli import main
from whitted.images import clipped_fraction, default_view, to_display, to_srgb
from whitted.images import read_image

REPO = Path(__file__).resolve().parent.parent


def srgb_curve(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def png_pixels(path) -> np.ndarray:
    import mitsuba as mi
    return np.asarray(mi.Bitmap(str(path)))


@pytest.fixture(scope="module")
def physical_example(tmp_path_factory) -> Path:
    """scenes/spheres.scn (a physically lit example whose floor runs far above 1 near its
    light), shrunk to 80x50."""
    folder = tmp_path_factory.mktemp("display")
    text = (REPO / "scenes" / "spheres.scn").read_text()
    text = re.sub(r"(?im)^\s*size\s+\d+\s+\d+\s*$", "size 80 50", text)
    scene = folder / "spheres.scn"
    scene.write_text(text)
    return scene


@pytest.mark.parametrize("how", [["--lighting", "physical"], ["--integrator", "path", "--spp", "16"]])
def test_physically_lit_png_is_not_clipped_and_its_exr_is_unchanged(physical_example, tmp_path, how):
    base = ["render", str(physical_example), "-q", *how]
    assert main([*base, "-o", str(tmp_path / "default.png")]) == 0
    assert main([*base, "-o", str(tmp_path / "clip.png"), "--view", "clip"]) == 0
    assert main([*base, "-o", str(tmp_path / "plain.exr")]) == 0
    assert main([*base, "-o", str(tmp_path / "exposed.exr"), "--exposure", "2", "--view", "aces"]) == 0
    exr = read_image(tmp_path / "plain.exr")
    # the example does need it: plain sRGB clips a large share of it
    assert np.mean(np.any(exr > 1, axis=-1)) > 0.1
    assert clipped_fraction(png_pixels(tmp_path / "clip.png")) > 0.1
    assert clipped_fraction(png_pixels(tmp_path / "default.png")) < 0.01
    # exposure and view never reach the EXR (two renders of the whitted integrator may differ
    # in the last bit: the order of its wavefront's sums)
    np.testing.assert_allclose(read_image(tmp_path / "exposed.exr"), exr, rtol=1e-6, atol=1e-7)
    whitted.write_image(tmp_path / "again.exr", exr, exposure=3, view="aces")
    np.testing.assert_array_equal(read_image(tmp_path / "again.exr"), exr)


def test_article_png_keeps_the_plain_srgb_clip(physical_example, tmp_path):
    import mitsuba as mi
    assert main(["render", str(physical_example), "-q", "-o", str(tmp_path / "a.png")]) == 0
    assert main(["render", str(physical_example), "-q", "-o", str(tmp_path / "a.exr")]) == 0
    exr = np.clip(read_image(tmp_path / "a.exr"), 0, 1)
    expected = mi.Bitmap(np.ascontiguousarray(exr)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8,
                                                            srgb_gamma=True)
    np.testing.assert_array_equal(png_pixels(tmp_path / "a.png"), np.asarray(expected))
    assert default_view("whitted", "article") == "clip"
    assert default_view("whitted", "physical") == default_view("path") == "aces"


def test_exposure_scales_the_linear_image_before_the_view(physical_example, tmp_path):
    assert main(["render", str(physical_example), "-q", "-o", str(tmp_path / "e.exr")]) == 0
    assert main(["render", str(physical_example), "-q", "-o", str(tmp_path / "e.png"), "--exposure", "-1.5"]) == 0
    expected = np.round(srgb_curve(read_image(tmp_path / "e.exr") * 2 ** -1.5) * 255)
    assert np.abs(png_pixels(tmp_path / "e.png").astype(float) - expected).max() <= 1


def test_aces_view_is_opencolorio_s():
    import PyOpenColorIO as ocio
    rng = np.random.default_rng(3)
    image = (rng.random((20, 30, 3)) ** 3 * 40).astype(np.float32)
    config = ocio.Config.CreateFromBuiltinConfig("cg-config-v4.0.0_aces-v2.0_ocio-v2.5")
    processor = config.getProcessor(ocio.DisplayViewTransform(
        src="Linear Rec.709 (sRGB)", display="sRGB - Display",
        view="ACES 2.0 - SDR 100 nits (Rec.709)")).getDefaultCPUProcessor()
    expected = image * 2.0
    processor.applyRGB(expected)
    np.testing.assert_allclose(to_display(image, exposure=1, view="aces"), np.clip(expected, 0, 1), atol=1e-6)
    # a tone curve: monotonic, and it rolls highlights off below white
    ramp = np.geomspace(1e-3, 50, 64, dtype=np.float32)[None, :, None].repeat(3, axis=2)
    shown = to_display(ramp, view="aces")[0, :, 1]
    assert np.all(np.diff(shown) > 0) and shown[-1] < 1.0
    assert to_srgb(ramp, view="aces").max() < 255 <= to_srgb(ramp, view="clip").max()


def test_flip_scores_the_displayed_images_and_relative_mse_the_linear_ones():
    rng = np.random.default_rng(7)
    reference = (rng.random((24, 32, 3)) * 4).astype(np.float32)   # mostly above 1
    image = (reference * 1.3).astype(np.float32)
    clipped = metrics.flip(image, reference, view="clip")
    toned = metrics.flip(image, reference, view="aces")
    assert clipped != toned
    # above 1 everywhere, clip shows two white images: only what stays below 1 differs
    assert metrics.flip(image + 2, reference + 2, view="clip") == 0
    assert metrics.flip(image + 2, reference + 2, view="aces") > 0
    import flip_evaluator
    _, expected, _ = flip_evaluator.evaluate(to_display(reference, 0.5, "aces"), to_display(image, 0.5, "aces"),
                                             "LDR", inputsRGB=True, applyMagma=False)
    assert metrics.flip(image, reference, exposure=0.5, view="aces") == pytest.approx(expected, abs=1e-6)
    # the relative MSE has no view
    assert metrics.relative_mse(image, reference) == pytest.approx(
        float(np.mean((image - reference) ** 2 / (reference.astype(np.float64) ** 2 + 0.01))), rel=1e-6)


def test_to_srgb_is_exported_and_checks_its_input():
    image = np.full((2, 3, 3), 0.5, np.float32)
    out = whitted.to_srgb(image)
    # sRGB(0.5) = 187.5 of 255: Mitsuba's 8-bit encoding dithers between the two neighbours
    assert out.dtype == np.uint8 and out.shape == (2, 3, 3) and set(np.unique(out)) <= {187, 188}
    with pytest.raises(whitted.WhittedError, match="view"):
        whitted.to_srgb(image, view="filmic")
    with pytest.raises(whitted.WhittedError, match="RGB image"):
        whitted.to_srgb(np.zeros((2, 3)))


def test_bad_view_and_exposure_are_one_line(physical_example, tmp_path):
    run = subprocess.run([sys.executable, "-m", "whitted", "render", str(physical_example), "-o",
                          str(tmp_path / "x.png"), "--exposure", "nan"], capture_output=True, text=True)
    assert run.returncode == 2 and "exposure" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "x.png").exists()


def test_path_tracer_without_spp_takes_the_default(physical_example, tmp_path):
    import json
    stats = tmp_path / "s.json"
    assert main(["render", str(physical_example), "-q", "--integrator", "path", "-o", str(tmp_path / "p.exr"),
                 "--stats", str(stats)]) == 0
    from whitted.defaults import PATH_MIN_SPP
    assert json.loads(stats.read_text())["rays"]["camera"] == 80 * 50 * PATH_MIN_SPP


def test_unknown_options_suggest_the_close_one(capsys):
    with pytest.raises(SystemExit):
        main(["render", "scene.scn", "-o", "x.png", "--samples", "4"])
    assert "did you mean --spp?" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["render", "scene.scn", "-o", "x.png", "--exposre", "1"])
    assert "did you mean --exposure?" in capsys.readouterr().err
