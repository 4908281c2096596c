"""Total internal reflection: the refracted share follows the mirror ray, which is traced once.

The scene: the eye inside a glass sphere (radius R, IOR n), off its center by
R/2 and looking past it, so that every camera ray meets the wall from inside
at sin θ ≈ 1/2 > 1/n: total internal reflection. A ray reflected inside a
sphere meets the wall again at the same angle (the chords of a sphere's
mirror path all make the same angle with the normal), so every hit of every
camera ray's tree is totally reflected. The article's recursion traces two
identical children at each hit (2^(D-1) - 1 of each kind per camera ray at
depth D); traced once, the tree is a chain of D - 1 rays, each counted as a
reflection and as a refraction. The image must be the float64 reference's,
which traces both children.
"""

from __future__ import annotations

import math

import mitsuba as mi
import pytest

import whitted
from float64_reference import Reference, assert_matches
from whitted.converter import Material, Scene, Sphere, scene_to_xml

W, H = 8, 6


def trapped(kr: float, kt: float, depth: int) -> Scene:
    radius, ior = 10.0, 4.0
    return Scene(width=W, height=H, eye=(radius / 2, 0.0, 0.0), lookat=(radius / 2, 0.0, -1.0), fov=10.0,
                 ambient=0.5, depth=depth,
                 spheres=[Sphere((0.0, 0.0, 0.0), radius, Material(color=(0.9, 0.6, 0.3), reflect=kr,
                                                                   refract=kt, ior=ior))])


def test_the_scene_is_totally_reflecting_everywhere():
    """The premise, from the reference: every hit below the camera rays is a TIR event."""
    depth = 5
    reference = Reference(trapped(0.2, 0.7, depth))
    reference.render()
    rays_per_camera_ray = 2 ** (depth - 1) - 1
    assert reference.rays["reflection"] == reference.rays["refraction"] == W * H * rays_per_camera_ray
    assert reference.tir_events == W * H * rays_per_camera_ray   # every refraction ray took the mirror
    # and from the geometry: sin θ = distance of the lines from the center / R > 1/n
    half_fov = math.radians(10.0) / 2
    assert 0.5 * math.cos(half_fov * math.hypot(1, H / W)) > 1 / 4.0


@pytest.mark.parametrize("variant", ("scalar_rgb", "llvm_ad_rgb"))
@pytest.mark.parametrize("kr,kt", [(0.2, 0.7), (0.0, 0.9), (0.6, 0.0)])
def test_a_totally_reflected_ray_is_traced_once(variant, kr, kt):
    depth = 8
    model = trapped(kr, kt, depth)
    reference = Reference(model)
    expected = reference.render()
    whitted.set_variant(variant)
    result = whitted.render(mi.load_string(scene_to_xml(model, base_dir=None)), min_weight=0)
    assert_matches(result.image, expected, mean_tol=1e-5, outliers=0)

    chain = W * H * (depth - 1)      # one ray per level below each camera ray
    rays, merged = result.stats["rays"], result.stats["merged_rays"]
    assert rays["reflection"] == (chain if kr > 0 else 0)
    assert rays["refraction"] == (chain if kt > 0 else 0)
    assert merged == (chain if kr > 0 and kt > 0 else 0)
    traced = rays["reflection"] + rays["refraction"] - merged
    assert traced == chain
    # the recursion, counted by the reference, traces a full binary tree when both shares exist
    assert reference.rays["reflection"] + reference.rays["refraction"] == (
        W * H * 2 * (2 ** (depth - 1) - 1) if kr > 0 and kt > 0 else chain)
    assert result.stats["max_depth_reached"] == depth
