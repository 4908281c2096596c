"""Ray statistics and effect analysis: only the effects a scene calls for are simulated.

Ray counts are checked against the float64 reference renderer's own counts
(tests/float64_reference.py counts the rays its recursion traces), and the kernels of
a diffuse scene at depth 16 against those at depth 1.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import whitted
import whitted.rendering
from float64_reference import Reference
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml

W, H = 24, 16
#: the keys issue 6 requires; the adaptive depth control adds its own (tests/test_adaptive.py)
KEYS = {"rays", "seconds", "compile_seconds", "effects", "max_depth_reached", "peak_memory_bytes"}


def load(model: Scene, variant: str):
    whitted.set_variant(variant)
    return mi.load_string(scene_to_xml(model, base_dir=None))


def diffuse(depth=16, lights=True, background=(0.0, 0.0, 0.0)) -> Scene:
    return Scene(width=W, height=H, depth=depth, background=background,
                 lights=[Light((3.0, 5.0, 5.0)), Light((-4.0, 2.0, 3.0), (0.3, 0.3, 0.3))] if lights else [],
                 spheres=[Sphere((0.0, -100.0, 0.0), 99.0, Material(color=(0.7, 0.7, 0.7))),
                          Sphere((0.0, 0.2, 0.0), 1.0, Material(color=(0.9, 0.3, 0.2)))])


def mixed(depth=5) -> Scene:
    return Scene(width=W, height=H, depth=depth, background=(0.2, 0.2, 0.3), lights=[Light((3.0, 5.0, 5.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 99.0, Material(color=(0.7, 0.7, 0.7))),
                          Sphere((-1.2, 0.0, 0.0), 1.0, Material(color=(0.9, 0.9, 0.9), reflect=0.7)),
                          Sphere((1.2, 0.0, 0.5), 0.9, Material(reflect=0.1, refract=0.85, ior=1.5))])


def test_diffuse_scene_at_depth_16_traces_no_secondary_rays(variant):
    stats = whitted.render(load(diffuse(depth=16), variant), spp=3).stats
    assert KEYS <= set(stats)
    assert stats["rays"]["camera"] == W * H * 3
    assert stats["rays"]["reflection"] == 0 and stats["rays"]["refraction"] == 0
    assert stats["rays"]["shadow"] > 0
    assert stats["max_depth_reached"] == 1
    assert stats["effects"] == ["lights"]


def test_scene_without_lights_casts_no_shadow_rays(variant):
    stats = whitted.render(load(diffuse(lights=False), variant)).stats
    assert stats["rays"]["shadow"] == 0
    assert "lights" not in stats["effects"]


@pytest.mark.parametrize("depth", (1, 2, 5))
def test_ray_counts_match_the_reference(variant, depth):
    """Every ray the article's recursion traces is counted once, and no other.

    The reference's recursion traces the exact tree, so the adaptive depth control is
    off here (min_weight=0); the scene has no total internal reflection, whose merged
    rays the reference would trace twice (tests/test_total_internal_reflection.py)."""
    model = mixed(depth)
    reference = Reference(model)
    reference.render()
    stats = whitted.render(load(model, variant), min_weight=0).stats
    assert stats["rays"]["camera"] == reference.rays["camera"] == W * H
    for kind in ("shadow", "reflection", "refraction"):
        # float32 and float64 may disagree about a grazing ray or two
        assert abs(stats["rays"][kind] - reference.rays[kind]) <= 2 + 0.002 * reference.rays[kind], kind
    assert stats["max_depth_reached"] == reference.deepest


@pytest.mark.parametrize("model,depth,effects", [
    (diffuse(), 16, ["lights"]),
    (diffuse(lights=False, background=(0.1, 0.2, 0.3)), 16, ["background"]),
    (mixed(), 5, ["lights", "reflection", "refraction", "background"]),
    (mixed(), 1, ["lights", "background"]),   # depth 1: mirrors and glass spawn nothing
])
def test_effects_are_those_the_scene_calls_for(model, depth, effects):
    stats = whitted.render(load(model, "llvm_ad_rgb"), max_depth=depth).stats
    assert stats["effects"] == effects


def test_textures_are_an_effect(tmp_path):
    path = tmp_path / "t.png"
    mi.Bitmap(np.full((2, 4, 3), 100, np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    model = diffuse()
    model.spheres[1] = Sphere((0.0, 0.2, 0.0), 1.0, Material(texture=path))
    assert "textures" in whitted.render(load(model, "llvm_ad_rgb")).stats["effects"]


def kernels(scene, **options):
    """Hashes of the JIT kernels that one ``mi.render`` of ``scene`` launches, once the
    tables the integrator reads from the scene exist (built by a first render, then kept)."""
    mi.render(scene, **options)
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history_clear()
        mi.render(scene, **options)
        dr.eval()
        hashes = [k["hash"] for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
    assert hashes, "no kernel was recorded: the comparison would prove nothing"
    return hashes


def whitted_integrator(max_depth):
    return mi.load_dict({"type": "whitted", "max_depth": max_depth, "light_reference": [0.0, 0.0, 0.0]})


def test_depth_16_runs_the_kernels_of_depth_1():
    """A diffuse scene pays nothing for a deep max depth: the very same kernels run."""
    scene = load(diffuse(), "llvm_ad_rgb")
    assert kernels(scene, integrator=whitted_integrator(16)) == kernels(scene, integrator=whitted_integrator(1))


def test_mirrors_deepen_the_kernels():
    """The kernel comparison can tell depths apart when the scene calls for them."""
    scene = load(mixed(), "llvm_ad_rgb")
    assert kernels(scene, integrator=whitted_integrator(5)) != kernels(scene, integrator=whitted_integrator(1))


def test_a_new_seed_compiles_no_new_kernel():
    """The seed is an input of the kernels, not a constant baked into them."""
    scene = load(diffuse(), "llvm_ad_rgb")
    assert kernels(scene, spp=4, seed=1) == kernels(scene, spp=4, seed=2)


def test_timings_and_memory_are_reported():
    scene = load(mixed(), "llvm_ad_rgb")
    import time
    start = time.perf_counter()
    stats = whitted.render(scene).stats
    wall = time.perf_counter() - start
    assert stats["seconds"] > 0 and stats["compile_seconds"] >= 0
    assert stats["seconds"] + stats["compile_seconds"] <= wall
    assert isinstance(stats["peak_memory_bytes"], int) and stats["peak_memory_bytes"] > 0


def test_path_integrator_stats():
    stats = whitted.render(load(mixed(), "llvm_ad_rgb"), integrator="path", spp=2).stats
    # Only what is known without Mitsuba counting: the camera samples, times, effects, memory.
    assert stats["rays"] == {"camera": W * H * 2}
    assert set(stats) == {"rays", "spp", "seconds", "compile_seconds", "effects", "peak_memory_bytes",
                          "peak_resident_bytes"}
    assert None not in stats.values()
