"""Adaptive depth control (plugins/recursion.py): ``min_weight``, ``--min-weight``, on by default.

Branches are left untraced as long as, together, they cannot change a pixel
by more than ``min_weight``. Expectations come from the weights themselves:
with the eye at the center of a mirrored sphere every camera ray bounces
along the same diameter for ever (its refracted rays escape to the
background), so the weights of its tree, and so which rays the rule traces,
follow from KR and KT alone (:func:`predicted`, the module docstring's rule
in float64). The error is checked against exact renders (``min_weight=0``)
and the brightest color against hand computations.
"""

from __future__ import annotations

import json
import math

import mitsuba as mi
import numpy as np
import pytest

import whitted
import whitted.rendering
from whitted import defaults as D
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.errors import WhittedError

from conftest import REPO

#: plugins/recursion.py's ROUND_OFF_MARGIN (ε is taken this much smaller than min_weight / L)
MARGIN = 1e-5


def load(model: Scene):
    return mi.load_string(scene_to_xml(model, base_dir=None))


def inside_mirror(kr: float, kt: float, depth: int = 16, width: int = 8, height: int = 6) -> Scene:
    """The eye at the center of a sphere with KR = ``kr``, KT = ``kt``: every ray meets the
    sphere head-on, its reflection comes back through the center, its refraction escapes."""
    return Scene(width=width, height=height, eye=(0.0, 0.0, 0.0), lookat=(0.0, 0.0, -1.0),
                 background=(0.2, 0.3, 0.4), depth=depth, lights=[Light((0.0, 0.5, 0.0))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 5.0,
                                 Material(color=(0.9, 0.8, 0.7), reflect=kr, refract=kt, ior=1.5))])


def brightest(model: Scene) -> float:
    """The article model's brightest color for ``model`` (article lighting): a point's color is
    at most max B·(A + (1 - A)·Σ max light), a miss's the background."""
    base = max(max(s.material.color) for s in model.spheres)
    lights = sum(max(light.color) for light in model.lights)
    return max(base * (model.ambient + (1 - model.ambient) * lights), max(model.background))


def predicted(kr: float, kt: float, min_weight: float, depth: int, bright: float) -> dict:
    """One camera ray's tree in :func:`inside_mirror` under the rule of plugins/recursion.py."""
    counts = {"reflection": 0, "refraction": 0, "culled": 0, "culled_weight": 0.0, "deepest": 1,
              "closest_call": math.inf}
    allowance = min_weight / bright * (1 - MARGIN) if min_weight > 0 else 0.0
    weight, level = 1.0, 1   # the ray on the reflection chain that hits the sphere at ``level``
    while level < depth:
        mirror, refracted = weight * kr, weight * kt
        light, heavy = min(mirror, refracted), max(mirror, refracted)
        light_traced = light > allowance
        rest = allowance / 2 if light_traced else allowance - light
        heavy_traced = heavy > rest
        if allowance > 0:   # how near a decision came to going the other way
            counts["closest_call"] = min(counts["closest_call"], abs(light - allowance) / allowance,
                                         abs(heavy - rest) / rest if rest else math.inf)
        traced = {"reflection": light_traced if mirror <= refracted else heavy_traced,
                  "refraction": heavy_traced if mirror <= refracted else light_traced}
        for kind, child in (("reflection", mirror), ("refraction", refracted)):
            if traced[kind]:
                counts[kind] += 1
                counts["deepest"] = level + 1
            elif child > 0:
                counts["culled"] += 1
                counts["culled_weight"] += child
        if not traced["reflection"]:
            break
        weight, allowance, level = mirror, rest, level + 1
    return counts


# -- on by default ----------------------------------------------------------------------------------


def test_on_by_default_and_zero_is_the_exact_tree(variant):
    model = inside_mirror(0.5, 0.0)
    scene = load(model)
    default, exact = whitted.render(scene), whitted.render(scene, min_weight=0)
    assert D.MIN_WEIGHT == pytest.approx(1 / 255)
    assert default.stats["min_weight"] == D.MIN_WEIGHT
    assert exact.stats["culled_rays"] == 0 and exact.stats["error_bound"] == 0
    n = 8 * 6
    assert exact.stats["rays"]["reflection"] == 15 * n and exact.stats["max_depth_reached"] == 16
    expected = predicted(0.5, 0.0, D.MIN_WEIGHT, 16, brightest(model))
    assert default.stats["rays"]["reflection"] == expected["reflection"] * n < 15 * n
    assert default.stats["max_depth_reached"] == expected["deepest"]
    # a camera sample changes by at most min_weight, here by exactly the culled weight times B·(A + 1 - A)
    assert np.abs(default.image - exact.image).max() <= default.stats["error_bound"] + 1e-6
    assert 0 < default.stats["error_bound"] <= D.MIN_WEIGHT


# -- what is culled ------------------------------------------------------------------------------


@pytest.mark.parametrize("kr,kt,min_weight", [
    (0.5, 0.0, 0.01),     # a pure mirror: one child, which keeps the whole allowance
    (0.3, 0.6, 0.05),     # the light child continues the chain: culled once the allowance halved 4 times
    (0.8, 0.1, 0.01),     # a traced side branch at each level halves the allowance faster than
    (0.5, 0.3, 0.01),     # the chain's weight falls: nothing is culled (the exact tree)
    (0.9, 0.05, 0.3),     # a large allowance: the refracted rays are culled at once, the chain is not
])
def test_counts_follow_the_weights(variant, kr, kt, min_weight):
    depth = 16
    model = inside_mirror(kr, kt, depth)
    stats = whitted.render(load(model), min_weight=min_weight).stats
    expected = predicted(kr, kt, min_weight, depth, brightest(model))
    assert expected["closest_call"] > 1e-3   # float32 round-off cannot tip a decision
    n = 8 * 6
    assert stats["min_weight"] == min_weight
    assert stats["rays"]["camera"] == n
    assert stats["rays"]["reflection"] == expected["reflection"] * n
    assert stats["rays"]["refraction"] == expected["refraction"] * n
    assert stats["culled_rays"] == expected["culled"] * n
    assert stats["culled_weight"] == pytest.approx(expected["culled_weight"] * n, rel=1e-5)
    assert stats["max_depth_reached"] == expected["deepest"]
    # every sample's tree is the same: the bound is its culled weight times the brightest color
    assert stats["error_bound"] == pytest.approx(expected["culled_weight"] * brightest(model), rel=1e-5)
    assert stats["error_bound"] <= min_weight


# -- the error it makes ------------------------------------------------------------------------


def mirrors_and_glass(spp: int) -> Scene:
    return Scene(width=32, height=24, eye=(0.0, 1.0, 7.0), lookat=(0.0, 0.3, 0.0), samples=spp,
                 background=(0.3, 0.4, 0.6), depth=8, lights=[Light((3.0, 5.0, 5.0)), Light((-4.0, 3.0, 2.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 99.5, Material(color=(0.8, 0.8, 0.7), reflect=0.3)),
                          Sphere((-1.6, 0.6, -0.5), 1.1, Material(color=(0.9, 0.9, 0.9), reflect=0.85)),
                          Sphere((1.6, 0.6, -0.5), 1.1, Material(color=(0.9, 0.9, 0.9), reflect=0.85)),
                          Sphere((0.0, 0.2, 1.2), 0.6, Material(reflect=0.1, refract=0.85, ior=1.5))])


@pytest.mark.parametrize("spp,min_weight", [(1, 0.05), (3, 0.05), (1, 1 / 255)])
def test_no_pixel_changes_by_more_than_the_bound(variant, spp, min_weight):
    """Culling only removes non-negative terms: 0 <= exact - culled <= error_bound <= min_weight."""
    scene = load(mirrors_and_glass(spp))
    exact = whitted.render(scene, min_weight=0)
    culled = whitted.render(scene, min_weight=min_weight)
    traced = lambda stats: sum(stats["rays"][k] for k in ("shadow", "reflection", "refraction"))
    assert traced(culled.stats) < traced(exact.stats)
    assert culled.stats["culled_rays"] > 0
    bound = culled.stats["error_bound"]
    assert 0 < bound <= min_weight
    error = exact.image.astype(np.float64) - culled.image
    assert error.min() >= -1e-5
    assert error.max() <= bound + 1e-5
    assert error.max() > bound / 20   # the bound is not vacuous here


def test_brightest_color_by_hand(llvm):
    from whitted.plugins.scene_tables import analyse, scene_tables
    from whitted.plugins.recursion import brightest as plugin_brightest
    model = Scene(width=4, height=4, eye=(0.0, 0.0, 10.0), ambient=0.3, background=(0.1, 0.2, 0.5),
                  lights=[Light((0.0, 4.0, 0.0), (0.6, 0.5, 0.4)), Light((5.0, 0.0, 0.0), (0.2, 0.3, 0.1))],
                  spheres=[Sphere((0.0, 0.0, 0.0), 1.0, Material(color=(0.5, 0.7, 0.6), reflect=0.2)),
                           Sphere((0.0, 8.0, 0.0), 2.0, Material(color=(0.4, 0.4, 0.4)))])
    scene = load(model)
    analysis = analyse(scene_tables(scene), 5, mi.ScalarPoint3f(model.lookat))
    # article: max B · (A + (1 - A)·Σ max light)
    assert plugin_brightest(analysis, "article", 0.3) == pytest.approx(0.7 * (0.3 + 0.7 * (0.6 + 0.3)))
    # physical: (max B / π)·Σ max I / d², d to the nearest surface; I = color·π·d_ref² (lookat: origin)
    intensity = [0.6 * math.pi * 16, 0.3 * math.pi * 25]
    distance = [2.0, 4.0]   # light 0: 3 above the unit sphere, 2 below the one at y = 8; light 1: 4 off
    expected = 0.7 / math.pi * sum(i / d ** 2 for i, d in zip(intensity, distance))
    assert plugin_brightest(analysis, "physical", 0.3) == pytest.approx(expected, rel=1e-5)
    # a light on a surface has no bound in physical lighting: the tree is then traced exactly
    model.lights[0] = Light((0.0, 1.0, 0.0))
    scene = load(model)
    analysis = analyse(scene_tables(scene), 5, mi.ScalarPoint3f(model.lookat))
    assert plugin_brightest(analysis, "physical", 0.3) is None
    stats = whitted.render(scene, lighting="physical").stats
    assert stats["culled_rays"] == 0 and stats["error_bound"] == 0


# -- bounded trees -------------------------------------------------------------------------------


def test_deep_glass_is_bounded(tmp_path):
    """Deep glass stays bounded (counted in rays, not timed): scenes/tir.scn at depth 64 traces
    at most twice the rays of depth 24, reports a bound <= 1/255, and culls what the exact tree
    would trace."""
    def rays(depth, *extra):
        stats = tmp_path / f"d{depth}{''.join(extra)}.json"
        assert main(["render", str(REPO / "scenes" / "tir.scn"), "-o", str(tmp_path / "out.exr"),
                     "--variant", "llvm_ad_rgb", "--max-depth", str(depth), "--stats", str(stats),
                     "-q", *extra]) == 0
        data = json.loads(stats.read_text())
        return sum(data["rays"].values()) - data["merged_rays"], data

    deep, deep_stats = rays(64)
    shallow, shallow_stats = rays(24)
    exact, _ = rays(64, "--min-weight", "0")
    assert deep_stats["max_depth_reached"] == 64   # light stays trapped: the chains do go deep
    assert deep <= 2 * shallow
    assert deep < exact
    assert 0 < deep_stats["error_bound"] <= 1 / 255
    assert 0 < shallow_stats["error_bound"] <= 1 / 255


# -- progress and Ctrl-C ---------------------------------------------------------------------------


def test_progress_moves_level_by_level(variant):
    """After each level of a pass (JIT) or each sample (scalar), summing to every sample."""
    scene = load(inside_mirror(0.5, 0.3, depth=6))
    integrator = mi.load_dict({"type": "whitted", "max_depth": 6, "min_weight": 0.0})
    steps = []
    rendering = integrator.render_detailed(scene, spp=2, progress=steps.append)
    total = 8 * 6 * 2
    assert sum(steps) == pytest.approx(total)
    assert all(step > 0 for step in steps)
    if variant == "scalar_rgb":
        assert steps == [1] * total
    else:
        # One pass, six levels. After level k a sample's tree still has to shade the chain's next
        # ray (weight 0.5^k) and the refracted ray that escapes (0.3·0.5^(k-1)): 0.8·0.5^(k-1)
        # of its weight is pending, none after the last level.
        assert rendering.passes == 1 and len(steps) == rendering.rays.max_depth_reached == 6
        finished = [1 - 0.8 * 0.5 ** (k - 1) for k in range(1, 6)] + [1.0]
        np.testing.assert_allclose(np.cumsum(steps), np.array(finished) * total, rtol=1e-5)


def test_ctrl_c_stops_between_levels(variant):
    """A KeyboardInterrupt raised while a pass is under way (here by the progress callback, as
    the CLI's signal handler would) ends the render there; the next render is whole."""
    scene = load(inside_mirror(0.5, 0.3, depth=16))
    integrator = mi.load_dict({"type": "whitted", "max_depth": 16, "min_weight": 0.0})
    calls = []

    def interrupt_on_the_third(samples):
        calls.append(samples)
        if len(calls) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        integrator.render_detailed(scene, progress=interrupt_on_the_third)
    assert len(calls) == 3
    again = integrator.render_detailed(scene)
    assert again.rays.reflection == 15 * 8 * 6


# -- settings ----------------------------------------------------------------------------------


def test_scene_property_and_override(llvm):
    xml = scene_to_xml(inside_mirror(0.5, 0.0), base_dir=None).replace(
        '<string name="lighting" value="$lighting"/>',
        '<string name="lighting" value="$lighting"/>\n        <float name="min_weight" value="0.01"/>')
    scene = mi.load_string(xml)
    assert whitted.render(scene).stats["max_depth_reached"] == 7
    assert whitted.render(scene, min_weight=0).stats["max_depth_reached"] == 16


@pytest.mark.parametrize("value", (-0.1, 1.5, float("nan")))
def test_bad_thresholds_are_refused(llvm, value):
    scene = load(inside_mirror(0.5, 0.0))
    with pytest.raises(WhittedError, match="min weight"):
        whitted.render(scene, min_weight=value)
    with pytest.raises((ValueError, RuntimeError), match="min_weight must be in"):  # Mitsuba wraps it
        mi.load_dict({"type": "whitted", "min_weight": value})


def test_path_integrator_refuses_a_threshold(llvm):
    scene = load(inside_mirror(0.5, 0.0))
    with pytest.raises(WhittedError, match="whitted integrator only"):
        whitted.render(scene, integrator="path", min_weight=0.1)
    stats = whitted.render(scene, integrator="path", spp=1).stats
    assert not {"min_weight", "culled_rays", "culled_weight", "error_bound"} & set(stats)


def test_command_line(tmp_path, capsys, llvm):
    scene = tmp_path / "scene.xml"
    scene.write_text(scene_to_xml(inside_mirror(0.5, 0.0), base_dir=tmp_path))
    out, stats = tmp_path / "out.exr", tmp_path / "stats.json"
    assert main(["render", str(scene), "-o", str(out), "--min-weight", "0.01",
                 "--stats", str(stats), "-q", "-v"]) == 0
    data = json.loads(stats.read_text())
    assert data["min_weight"] == 0.01
    assert data["culled_rays"] == 8 * 6 and data["max_depth_reached"] == 7
    assert data["error_bound"] == pytest.approx(0.5 ** 7 * 0.9, rel=1e-5)
    assert "48 rays culled, error at most 0.007 (min weight 0.01)" in capsys.readouterr().err

    assert main(["render", str(scene), "-o", str(out), "--min-weight", "0", "--stats", str(stats), "-q"]) == 0
    data = json.loads(stats.read_text())
    assert data["culled_rays"] == 0 and data["max_depth_reached"] == 16

    bad = tmp_path / "bad.exr"
    assert main(["render", str(scene), "-o", str(bad), "--min-weight", "2", "-q"]) == 2
    assert "min weight must be in [0, 1], got 2" in capsys.readouterr().err
    assert not bad.exists()
