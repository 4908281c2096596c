"""Adaptive depth control (Hall and Greenberg 1983): ``min_weight``, ``--min-weight``.

A reflected or refracted ray whose path weight (the product of the KR and KT
factors above it) is below the threshold is not traced. Expectations come
from the weights themselves: with the eye at the centre of a mirrored sphere
every camera ray bounces along the same diameter for ever, so the weights of
its tree, and hence which rays are traced, follow from KR and KT alone. The
error of a culled image is bounded by the culled weight times the brightest
colour the article's model can produce.
"""

from __future__ import annotations

import json

import mitsuba as mi
import numpy as np
import pytest

import whitted.rendering
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.errors import WhittedError


def load(model: Scene):
    return mi.load_string(scene_to_xml(model, base_dir=None))


def inside_mirror(kr: float, kt: float, depth: int = 16, width: int = 8, height: int = 6) -> Scene:
    """The eye at the centre of a sphere with KR = ``kr``, KT = ``kt``: every ray meets the
    sphere head-on, its reflection comes back through the centre, its refraction escapes."""
    return Scene(width=width, height=height, eye=(0.0, 0.0, 0.0), lookat=(0.0, 0.0, -1.0),
                 background=(0.2, 0.3, 0.4), depth=depth, lights=[Light((0.0, 0.5, 0.0))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 5.0,
                                 Material(color=(0.9, 0.8, 0.7), reflect=kr, refract=kt, ior=1.5))])


def predicted(kr: float, kt: float, min_weight: float, depth: int) -> dict:
    """Rays of one camera ray's tree in :func:`inside_mirror`, from the weights alone (float64)."""
    counts = {"reflection": 0, "refraction": 0, "culled": 0, "culled_weight": 0.0, "deepest": 1}
    weight, level = 1.0, 1   # the hit of the ray at ``level`` on the reflection chain
    while level < depth:
        traced = {}
        for kind, factor in (("reflection", kr), ("refraction", kt)):
            child = weight * factor
            traced[kind] = child > 0 and child >= min_weight
            if traced[kind]:
                counts[kind] += 1
                counts["deepest"] = level + 1
            elif child > 0:
                counts["culled"] += 1
                counts["culled_weight"] += child
        if not traced["reflection"]:
            break
        weight, level = weight * kr, level + 1
    return counts


def brightest(model: Scene) -> float:
    """An upper bound on any colour the article's model gives ``model``: a point's colour is at
    most A + (1 - A)·Σ lights (base colours are <= 1), a miss is the background, and a
    surface mixes its point colour and its children's colours with weights summing to <= 1."""
    lights = sum(max(light.color) for light in model.lights)
    return max(model.ambient + (1 - model.ambient) * lights, max(model.background))


# -- off by default ------------------------------------------------------------------------------


def test_off_by_default_changes_nothing(variant):
    scene = load(inside_mirror(0.5, 0.3, depth=6))
    default = whitted.render(scene)
    off = whitted.render(scene, min_weight=0)
    np.testing.assert_array_equal(default.image, off.image)
    assert default.stats["rays"] == off.stats["rays"]
    assert default.stats["min_weight"] == 0
    assert default.stats["culled_rays"] == 0 and default.stats["culled_weight"] == 0
    expected = predicted(0.5, 0.3, 0.0, 6)
    n = 8 * 6
    assert default.stats["rays"]["reflection"] == expected["reflection"] * n == 5 * n
    assert default.stats["max_depth_reached"] == 6


def test_a_threshold_below_every_weight_changes_nothing(variant):
    """The smallest weight at depth 5 is 0.3·0.5³ = 0.0375: a threshold under it culls nothing."""
    scene = load(inside_mirror(0.5, 0.3, depth=5))
    off = whitted.render(scene)
    low = whitted.render(scene, min_weight=0.03)
    np.testing.assert_array_equal(off.image, low.image)
    assert off.stats["rays"] == low.stats["rays"]
    assert low.stats["culled_rays"] == 0


# -- what is culled ------------------------------------------------------------------------------


@pytest.mark.parametrize("kr,kt,min_weight", [
    (0.5, 0.0, 0.01),     # a pure mirror: weights 2^-k, traced up to 2^-6, depth 7
    (0.5, 0.3, 0.01),     # a refracted ray at each level, culled one level before the chain
    (0.9, 0.05, 0.2),     # the chain goes deep (0.9^15 = 0.206), its refractions are culled at once
    (0.5, 0.3, 0.125),    # a weight exactly at the threshold is traced (0.5^3 = 0.125)
])
def test_counts_follow_the_weights(variant, kr, kt, min_weight):
    depth = 16
    scene = load(inside_mirror(kr, kt, depth))
    stats = whitted.render(scene, min_weight=min_weight).stats
    expected = predicted(kr, kt, min_weight, depth)
    n = 8 * 6
    assert stats["min_weight"] == min_weight
    assert stats["rays"]["camera"] == n
    assert stats["rays"]["reflection"] == expected["reflection"] * n
    assert stats["rays"]["refraction"] == expected["refraction"] * n
    assert stats["culled_rays"] == expected["culled"] * n
    assert stats["culled_weight"] == pytest.approx(expected["culled_weight"] * n, rel=1e-5)
    assert stats["max_depth_reached"] == expected["deepest"]


def test_pure_mirror_depth_is_where_the_weight_falls_below_the_threshold(variant):
    """KR^k < W first at k = 7 for KR = 0.5, W = 0.01: the deepest ray is at depth 7 (weight 2^-6)."""
    kr, min_weight = 0.5, 0.01
    k = next(k for k in range(1, 64) if kr ** k < min_weight)
    stats = whitted.render(load(inside_mirror(kr, 0.0)), min_weight=min_weight).stats
    assert k == 7
    assert stats["max_depth_reached"] == k
    assert stats["rays"]["reflection"] == (k - 1) * 8 * 6


# -- the error it makes ------------------------------------------------------------------------


def mirrors_and_glass(spp: int) -> Scene:
    return Scene(width=32, height=24, eye=(0.0, 1.0, 7.0), lookat=(0.0, 0.3, 0.0), samples=spp,
                 background=(0.3, 0.4, 0.6), depth=8, lights=[Light((3.0, 5.0, 5.0)), Light((-4.0, 3.0, 2.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 99.5, Material(color=(0.8, 0.8, 0.7), reflect=0.3)),
                          Sphere((-1.6, 0.6, -0.5), 1.1, Material(color=(0.9, 0.9, 0.9), reflect=0.85)),
                          Sphere((1.6, 0.6, -0.5), 1.1, Material(color=(0.9, 0.9, 0.9), reflect=0.85)),
                          Sphere((0.0, 0.2, 1.2), 0.6, Material(reflect=0.1, refract=0.85, ior=1.5))])


@pytest.mark.parametrize("spp", (1, 3))
def test_error_is_within_the_culled_weight(variant, spp):
    """Culling only removes non-negative terms, each at most its weight times the brightest
    colour: 0 <= full - culled, and the sum over pixels <= culled_weight / spp · brightest."""
    model = mirrors_and_glass(spp)
    scene = load(model)
    full = whitted.render(scene)
    culled = whitted.render(scene, min_weight=0.05)
    traced = lambda stats: sum(stats["rays"][k] for k in ("shadow", "reflection", "refraction"))
    assert traced(culled.stats) < traced(full.stats)
    assert culled.stats["culled_rays"] > 0
    error = full.image.astype(np.float64) - culled.image
    assert error.min() >= -1e-5
    bound = culled.stats["culled_weight"] / spp * brightest(model)
    for channel in range(3):
        total = error[..., channel].sum()
        assert 0 < total <= bound * (1 + 1e-4) + 1e-4


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
    assert stats["min_weight"] is None and stats["culled_rays"] is None


def test_command_line(tmp_path, capsys, llvm):
    scene = tmp_path / "scene.xml"
    scene.write_text(scene_to_xml(inside_mirror(0.5, 0.0), base_dir=tmp_path))
    out, stats = tmp_path / "out.exr", tmp_path / "stats.json"
    assert main(["render", str(scene), "-o", str(out), "--min-weight", "0.01",
                 "--stats", str(stats), "-q", "-v"]) == 0
    data = json.loads(stats.read_text())
    assert data["min_weight"] == 0.01
    assert data["culled_rays"] == 8 * 6 and data["max_depth_reached"] == 7
    assert "48 rays culled below weight 0.01" in capsys.readouterr().err

    bad = tmp_path / "bad.exr"
    assert main(["render", str(scene), "-o", str(bad), "--min-weight", "2", "-q"]) == 2
    assert "min weight must be in [0, 1], got 2" in capsys.readouterr().err
    assert not bad.exists()
