"""``whitted fit`` and :func:`whitted.fitting.fit` (issue 33): the article's model fitted to an
image by gradient descent through the whitted integrator's gradients."""

from __future__ import annotations

import re
import subprocess
from dataclasses import replace

import mitsuba as mi
import numpy as np
import pytest

import whitted
from conftest import MIRROR_AND_GLASS
from whitted.cli import main
from whitted.compare.curves import best_ambient
from whitted.converter import parse_file, parse_text
from whitted.defaults import FIT_RATE, SEALED_MIN_GROUP
from whitted.fitting import fit, fitted_model, material_ids, write_fitted
from whitted.images import write_image
from whitted.loading import _load_model, load_model_parts

#: shadows, a mirror, glass, four materials, two lights
SCENE = "size 40 25\n" + MIRROR_AND_GLASS + "sphere 0 0.5 1 0.5        color 0.3 0.5 0.8\n"
#: the same with comments: a header, a line between statements, trailing ones
COMMENTED = "# a scene to fit\n#   its comments stay\n" + SCENE.replace(
    "light 0 10 6\n", "\n# the lights\nlight 0 10 6   # the key\n").replace("0.6 0.65 0.6\n", "0.6 0.65 0.6  # the floor\n")


def render(model, **overrides) -> np.ndarray:
    return np.array(mi.render(_load_model(model, overrides, False, "whitted", False)), np.float64)


@pytest.fixture
def truth(llvm):
    return parse_text(SCENE, "truth.scn")


def perturbed(truth, ambient=0.25, seed=0):
    rng = np.random.default_rng(seed)
    colors = {mid: tuple(float(c) for c in np.clip(np.array(m.color) + rng.uniform(-0.1, 0.1, 3), 0, 1))
              for m, mid in material_ids(truth).items()}
    return fitted_model(truth, ambient, colors, [light.color for light in truth.lights])


def test_a_fit_recovers_perturbed_colors_and_ambient(truth):
    target = render(truth)
    start = perturbed(truth)
    assert start.ambient != truth.ambient
    result = fit(start, target, free=("ambient", "colors"), iterations=200, rate=(0.03, 1e-4),
                 min_gain=0)
    assert result.size == (40, 25)
    assert result.losses[0] > 1e-3 and result.error < 1e-6
    assert result.ambient == pytest.approx(truth.ambient, abs=1e-3)
    for material, mid in material_ids(truth).items():
        np.testing.assert_allclose(result.colors[mid], material.color, atol=1e-3)


def test_the_fitted_scene_parses_and_renders_to_the_fitted_image(truth, tmp_path):
    target = render(truth) * np.array([1.1, 0.95, 0.9])   # off the model's reach a little
    result = fit(perturbed(truth, seed=3), target, iterations=30)
    path = tmp_path / "fitted.scn"
    write_fitted(result, path, "truth.scn")
    again = parse_file(path)
    assert again.ambient == result.ambient
    assert [light.color for light in again.lights] == [tuple(c) for c in result.lights]
    np.testing.assert_allclose(render(again), result.image, rtol=1e-5, atol=1e-6)


def test_the_fit_with_only_the_ambient_free_lands_on_the_best_ambient(truth):
    """The one-parameter case has a closed form (compare's best_ambient): the fit finds it."""
    target = render(truth, lighting="physical") * 0.5 + render(perturbed(truth, 0.4, seed=5)) * 0.5
    dark, lit = render(fitted_model(truth, 0.0, {}, [l.color for l in truth.lights])), \
        render(fitted_model(truth, 1.0, {}, [l.color for l in truth.lights]))
    expected, error = best_ambient(dark, lit, target)
    assert 0.05 < expected < 0.95
    result = fit(truth, target, free=("ambient",), iterations=150, min_gain=0)
    assert result.ambient == pytest.approx(expected, abs=2e-3)
    assert result.error == pytest.approx(error, rel=1e-3)
    early = fit(truth, target, free=("ambient",))   # stops once the loss stops improving
    assert len(early.losses) < 150 and early.error < 1.05 * error


def whitted_cli(capsys, *args) -> subprocess.CompletedProcess:
    """``whitted ARGS`` run by :func:`whitted.cli.main` in this process: its exit status and
    what it printed, as a finished process reports them."""
    arguments = [str(arg) for arg in args]
    status = main(arguments)
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(arguments, status, out, err)


def test_fit_command_writes_a_fitted_scene(truth, tmp_path, capsys):
    """The fitted file is the scene's own text, its comments where they were, and the summary
    names each material by its line and comment."""
    scene = tmp_path / "scene.scn"
    scene.write_text(COMMENTED.replace("ambient 0.15", "ambient 0.3"))
    target = tmp_path / "target.exr"
    write_image(target, render(truth).astype(np.float32))
    out = tmp_path / "fitted.scn"
    run = whitted_cli(capsys, "fit", scene, "--to", target, "-o", out, "--iterations", "40")
    assert run.returncode == 0, run.stderr
    assert "step 40: relative MSE" in run.stderr and "wrote" in run.stderr
    fitted = parse_file(out)
    assert abs(fitted.ambient - 0.15) < abs(0.3 - 0.15)
    before, after = scene.read_text().splitlines(), out.read_text().splitlines()
    for n, line in enumerate(before, 1):
        if "#" in line:
            assert after[n - 1][after[n - 1].index("#"):] == line[line.index("#"):]
    floor = next(n for n, line in enumerate(before, 1) if line.endswith("# the floor"))
    assert f"line {floor} (the floor): color 0.6 0.65 0.6 -> " in run.stderr


#: a problem of ``whitted fit``'s command line -> (its options, the output, what the one line names)
COMMAND_PROBLEMS = {"size": ([], "fitted.scn", "target.exr"),
                    "unwritable": ([], "missing/fitted.scn", "fitted.scn"),
                    "not a .scn": ([], "fitted.xml", "fitted.xml: the fitted scene is a .scn file"),
                    "iterations": (["--iterations", "0"], "fitted.scn", "--iterations must be >= 1, got 0"),
                    "width": (["--width", "0"], "fitted.scn", "--width must be >= 1, got 0"),
                    "not finite": ([], "fitted.scn", "target.exr: 1 of its 1000 pixels are NaN or infinite")}


@pytest.mark.parametrize("problem", COMMAND_PROBLEMS)
def test_fit_command_errors_are_one_line(truth, tmp_path, problem, capsys):
    options, output, named = COMMAND_PROBLEMS[problem]
    scene = tmp_path / "scene.scn"
    scene.write_text(SCENE)
    target = tmp_path / "target.exr"
    image = render(truth).astype(np.float32)
    if problem == "not finite":   # it aborted the process
        image[3, 4, 1] = np.nan
    write_image(target, image[:, :20] if problem == "size" else image)
    out = tmp_path / output
    run = whitted_cli(capsys, "fit", scene, "--to", target, "-o", out, *options)
    assert run.returncode == 2
    assert len(run.stderr.strip().splitlines()) == 1 and "Traceback" not in run.stderr, run.stderr
    assert named in run.stderr
    assert not out.exists()


def test_fit_refuses_unknown_parameters_and_a_target_that_is_not_rgb(truth):
    from whitted.errors import WhittedError
    image = render(truth).astype(np.float32)
    for call, message in ((lambda: fit(truth, image, free=("colors", "fov")), "unknown free parameter(s) fov"),
                          (lambda: fit(truth, image, iterations=0), "iterations must be an integer >= 1, got 0"),
                          (lambda: fit(truth, image[..., :2]), "the target must be an RGB image"),
                          (lambda: fit(truth, image[..., 0]), "the target must be an RGB image"),
                          (lambda: fit(truth, image * np.inf), "pixels are NaN or infinite")):
        with pytest.raises(WhittedError, match=re.escape(message)):
            call()


def _crowd() -> str:
    """A scene of 1 024 small balls in two colors (grouped into ``ellipsoids`` shapes when
    loaded: whitted.sealed), one of them the floor's too (a giant sphere: a shape of its own)."""
    balls = "".join(f"sphere {-1.55 + 0.1 * i:.2f} 0.05 {-1.55 + 0.1 * j:.2f} 0.05  "
                    f"color {'0.8 0.3 0.2' if (i + j) % 2 else '0.2 0.5 0.8'}\n"
                    for i in range(32) for j in range(32))
    floor = "sphere 0 -1000 0 1000     color 0.6 0.65 0.6\n"
    assert floor in MIRROR_AND_GLASS
    return "size 40 25\n" + MIRROR_AND_GLASS.replace(floor, floor.replace("0.6 0.65 0.6", "0.2 0.5 0.8")) + balls


def test_a_fit_of_a_scene_with_grouped_spheres_writes_every_bsdf_of_a_material(llvm):
    """Grouped spheres (whitted.sealed: an ellipsoids shape per material, in a scaled frame) keep
    their own BSDFs: a fit must write each material's color into all of them, and the lights'
    colors through the scaled frame's distances. So the fitted model, rendered from sphere
    shapes, is the image the fit's grouped scene ended on (lights written 1.3x too bright leave
    0.18 between them), and the fit nears the target, rendered from sphere shapes."""
    from whitted import sealed
    truth = parse_text(_crowd(), "crowd.scn")
    assert sealed.choose(truth, SEALED_MIN_GROUP, sealed.MAX_LAYERS, smaller=True) is not None
    _, bsdfs, _ = load_model_parts(truth, {}, None, "whitted", False)
    assert sorted(map(len, bsdfs.values())) == [1, 1, 1, 2]   # the floor's and a group's color
    target = render(truth)
    dimmed = [tuple(0.7 * c for c in light.color) for light in truth.lights]
    for start, free, steps, rate, gain in ((perturbed(truth, seed=7), ("ambient", "colors"), 20, FIT_RATE, 10),
                                          (fitted_model(truth, truth.ambient, {}, dimmed), ("lights",), 60,
                                           (0.1, 1e-3), 300)):
        result = fit(start, target, free=free, iterations=steps, rate=rate, min_gain=0)
        assert result.losses[0] > 1e-3 and result.error < result.losses[0] / gain, free
        np.testing.assert_allclose(result.image, render(result.model), atol=1e-4, err_msg=str(free))


def test_the_fitted_file_is_the_scene_s_text_with_the_fitted_numbers(llvm, tmp_path, texture_png):
    """Only the fitted numbers change, where the statements write them (or added to them: a light
    or a sphere without a color, an ambient the file lacks); every other line stays as written,
    a texture path follows the file to another folder, and the file reads back as the fitted model."""
    texture_png("maps/t.png")
    text = (COMMENTED.replace("ambient 0.15\n", "").replace("light 5 4 -6   0.4 0.4 0.4", "light 5 4 -6")
            .replace("color 0.3 0.5 0.8", "\\\n   reflect 0.2 # two lines")
            + "sphere 1.5 0.4 1.5 0.4  texture maps/t.png\n").replace("\n", "\r\n")
    source = tmp_path / "scene.scn"
    source.write_bytes(text.encode())
    model = parse_file(source)
    target = render(model) * np.array([1.1, 0.95, 0.9])
    result = fit(model, target, iterations=3)
    out = tmp_path / "fitted" / "fitted.scn"
    out.parent.mkdir()
    write_fitted(result, out, "scene.scn", text)
    written = out.read_bytes().decode()
    again = parse_file(out)
    assert again == replace(result.model, source=again.source)
    assert again.comments == model.comments and again.ambient == result.ambient != model.ambient
    before, after = text.split("\r\n"), written.split("\r\n")
    changed = [n for n, (a, b) in enumerate(zip(before[:-1], after)) if a != b]
    assert changed and all(before[n].strip() and not before[n].lstrip().startswith("#") for n in changed)
    for a, b in zip(before, after):   # every comment as it was
        assert "#" not in a or b[b.index("#"):] == a[a.index("#"):]
    assert after[len(before) - 1:] == [f"ambient {result.ambient!r}", after[-2], ""]
    assert after[-2].startswith("# fitted by whitted fit from scene.scn")
    assert '"../maps/t.png"' in written
    assert re.search(r"\nlight 5 4 -6 [\d.]+ [\d.]+ [\d.]+\r", written)   # colors added where there were none
    assert re.search(r"\n   reflect 0.2  color [\d.]+ [\d.]+ [\d.]+ # two lines\r", written)


def test_compare_s_fitted_text_names_materials_and_lights_as_the_file_does(llvm):
    from whitted.compare.limits import fit_to_reference, fitted_text
    text = COMMENTED.replace("size 40 25", "size 16 10")
    model = parse_text(text, "scene.scn")
    fitted = fit_to_reference(model, render(model) * 0.9, depth=model.depth, spp=1, seed=0)
    said = fitted_text(fitted)
    floor, key, mirror = (next(n for n, line in enumerate(text.splitlines(), 1) if part in line)
                          for part in ("# the floor", "# the key", "reflect 0.6"))
    assert f"colors line {floor} (the floor): " in said and f", line {mirror}: " in said
    assert f"lights line {key} (the key): " in said and "material_" not in said


def test_a_fit_at_its_deadline_stops_between_steps_and_keeps_its_numbers(truth):
    """compare's fit under --budget: a deadline that comes during the fit stops it after the
    step that reached it, and the fitted scene is still scored and reported as stopped."""
    import time

    from whitted.compare.limits import fit_to_reference
    from whitted.defaults import FIT_ITERATIONS
    target = render(truth)
    fitted = fit_to_reference(perturbed(truth), target, truth.depth, 1, 0,
                              deadline=time.monotonic() + 0.05)
    assert 1 <= fitted.stopped < FIT_ITERATIONS
    assert np.isfinite(fitted.rel_mse) and 0 <= fitted.ambient <= 1
    assert fit_to_reference(truth, target, truth.depth, 1, 0, deadline=time.monotonic() + 1,
                            score_seconds=1) is None    # not even its scoring render fits
