"""The hazard catalogue (docs/numerics.md): one scene per hazard, in both variants, against
the float64 reference renderer.

Every render must be finite and match the reference: mean absolute difference
<= 0.004 and at most 1% of pixels off by more than 0.02. Some hazards also get
a sharper check of the pixels or rays where they strike.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
import whitted
import whitted.rendering
from float64_reference import Reference, assert_matches, lat_long, load_texels, texel
from whitted.converter import scene_to_xml


@pytest.fixture(scope="module")
def hazards(tmp_path_factory):
    """``hazards(name, what)``: the scene model, its reference ("reference", a Reference
    after rendering) or its render in a variant (a RenderResult), each computed once."""
    tmp_dir = tmp_path_factory.mktemp("hazards")
    cache = {}

    def get(name: str, what: str):
        if (name, "model") not in cache:
            cache[(name, "model")] = hs.build(name, tmp_dir)
        model = cache[(name, "model")]
        if (name, what) not in cache:
            if what == "reference":
                reference = Reference(model)
                reference.image = reference.render()
                cache[(name, what)] = reference
            else:
                previous = mi.variant()
                whitted.set_variant(what)
                cache[(name, what)] = whitted.render(mi.load_string(scene_to_xml(model, base_dir=None)))
                whitted.set_variant(previous)
        return cache[(name, what)]
    return get


@pytest.mark.parametrize("name", list(hs.HAZARDS))
def test_hazard_scene_matches_the_reference(hazards, name, variant):
    assert_matches(hazards(name, variant).image, hazards(name, "reference").image)


# -- sharper checks where a hazard strikes -------------------------------------------------------

@pytest.mark.parametrize("name", ["texture_poles", "arccos_range"])
def test_the_pole_pixel_shows_u_0(hazards, name, variant):
    """The middle pixel's ray meets a pole: sin(phi) = 0, so u = 0, and v is 1 (the north
    pole of texture_poles: the top row) or 0 (the south pole of arccos_range: the bottom
    row), though there the float32 Vn·Vp rounds beyond -1, and Mitsuba's own UV would miss
    the pole by a rounding error. texture_poles' pole is exact in float64 too, so the
    reference shows the same texel; arccos_range's tilted axis is not, and the reference's
    hit lies 1e-8 off the pole, where u is arbitrary."""
    model = hazards(name, "model")
    globe = model.spheres[0]
    v = 1.0 if name == "texture_poles" else 0.0
    row, column = model.height // 2, model.width // 2
    expected = texel(load_texels(globe.material.texture), 0.0, v)
    np.testing.assert_allclose(hazards(name, variant).image[row, column], expected, atol=1e-5)
    if name == "texture_poles":
        pole = tuple(c + globe.radius * n for c, n in zip(globe.center, globe.north))
        assert lat_long(globe, pole) == (0.0, 1.0)
        np.testing.assert_allclose(hazards(name, "reference").image[row, column], expected, atol=1e-12)


@pytest.mark.parametrize("name", ["total_internal_reflection", "grazing", "low_ior"])
def test_scenes_exercise_total_internal_reflection(hazards, name):
    assert hazards(name, "reference").tir_events > 0


def test_facing_mirrors_trace_to_the_last_level(hazards, variant):
    """Rays bounce between the mirrors down to depth 64, as many as in the reference."""
    stats = hazards("facing_mirrors", variant).stats
    reference = hazards("facing_mirrors", "reference")
    assert stats["max_depth_reached"] == reference.deepest == 64
    assert stats["rays"]["reflection"] == pytest.approx(reference.rays["reflection"], rel=0.005)


def test_light_at_the_hit_point_adds_nothing_there(hazards, variant):
    """The middle pixel's hit is the first light's position: L has no direction, and the
    spec's s is taken as its limit along the surface, 0. The pixel shows the ambient term
    and the second light only, as in the reference."""
    model = hazards("light_at_hit", "model")
    row, column = model.height // 2, model.width // 2
    reference = hazards("light_at_hit", "reference").image[row, column]
    ambient_only = np.array(model.spheres[0].material.color) * model.ambient
    assert np.all(reference > ambient_only)   # the second light does reach it
    np.testing.assert_allclose(hazards("light_at_hit", variant).image[row, column], reference, atol=1e-4)


# -- the formulas at their singular points -------------------------------------------------------

SINGULAR = {
    "north pole": (0.0, 0.0, 1.0), "south pole": (0.0, 0.0, -1.0),
    "seam": (1.0, 0.0, 0.0), "seam, -0": (1.0, -0.0, 0.0), "anti-seam": (-1.0, 0.0, 0.0),
    "anti-seam, -0": (-1.0, -0.0, 0.0), "east": (0.0, 1.0, 0.0), "west": (0.0, -1.0, 0.0),
    "beyond the pole": (0.0, 0.0, 1.0000001), "beyond the south pole": (0.0, 0.0, -1.0000001),
}


@pytest.mark.parametrize("where", list(SINGULAR))
def test_lat_long_uv_at_singular_points(variant, where):
    """The integrator's UV (plugins/hits.py) is the spec's (u, 1 - v) at the poles, on the
    seam and an ulp beyond |Vn·Vp| = 1, where arccos and the division by sin(phi) fail."""
    from whitted.converter import Sphere
    from whitted.plugins.hits import lat_long_uv
    n = SINGULAR[where]
    axes = [mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1)]
    uv = lat_long_uv(mi.Vector3f(*n), *axes)
    u, v = (float(dr.ravel(c)[0]) if dr.is_jit_v(c) else float(c) for c in (uv.x, uv.y))
    assert math.isfinite(u) and math.isfinite(v)
    sphere = Sphere((0.0, 0.0, 0.0), 1.0, north=(0.0, 0.0, 1.0), equator=(1.0, 0.0, 0.0))
    expected_u, expected_v = lat_long(sphere, np.array(n, np.float32).astype(np.float64))
    assert u == pytest.approx(expected_u, abs=1e-6)
    assert 1 - v == pytest.approx(expected_v, abs=1e-6)


def test_a_shadow_ray_to_its_own_origin_is_finite(variant):
    """A light exactly at the offset origin: the shadow segment has length 0 (no 0/0)."""
    from whitted.plugins.hits import offset_origin, spawn_ray_to
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.p, si.n = mi.Point3f(1.0, 2.0, 3.0), mi.Vector3f(0.0, 1.0, 0.0)
    error = 1e-6
    target = offset_origin(si.p, si.n, error, mi.Vector3f(0.0, 1.0, 0.0))
    ray = spawn_ray_to(si, error, target)
    values = np.concatenate([np.ravel(np.array(ray.o)), np.ravel(np.array(ray.d)), np.ravel(np.array(ray.maxt))])
    assert np.all(np.isfinite(values))
    assert np.all(np.array(ray.maxt) <= 0)   # an empty segment: nothing can block it


def test_refraction_stays_finite_beyond_the_critical_angle(variant):
    """k = 1 - n²(1 - c1²) < 0: the caller takes the mirror direction, but T itself must
    stay finite (plugins/hits.py), from grazing (c1 = 0) to just past the critical angle,
    and for c1 an ulp above 1."""
    from whitted.plugins import hits as optics
    n = mi.Vector3f(0.0, 0.0, 1.0)
    for eta in (1.5, 1 / 0.6, 50.0):
        critical = math.sqrt(1 - 1 / eta ** 2)
        for c1 in (0.0, 1e-7, 0.5 * critical, math.nextafter(critical, 0.0), critical, 1.0000001):
            sine = math.sqrt(max(0.0, 1 - c1 * c1))
            v = mi.Vector3f(sine, 0.0, -c1)
            t, tir = optics.refract(v, n, optics.cos_incidence(v, n), eta)
            assert np.all(np.isfinite(np.ravel(np.array(t))))
            if c1 < 0.99 * critical:
                assert bool(np.ravel(np.array(tir))[0])


def test_directions_stay_unit_along_a_deep_mirror_chain(variant):
    """64 reflections (the deepest tree the format allows) off random normals: the ray
    direction keeps |d| = 1 to float32 round-off, so c1 and k keep their meaning at depth 64."""
    from whitted.plugins import hits as optics
    rng = np.random.default_rng(2)
    lanes = 1000 if dr.is_jit_v(mi.Float) else 20
    start = rng.normal(size=(3, lanes))
    normals = rng.normal(size=(64, 3, lanes))
    worst = 0.0
    for lane in ([slice(None)] if dr.is_jit_v(mi.Float) else [slice(k, k + 1) for k in range(lanes)]):
        def vector(a):
            a = a[:, lane] / np.linalg.norm(a[:, lane], axis=0)
            return mi.Vector3f(a) if dr.is_jit_v(mi.Float) else mi.Vector3f(*a[:, 0])
        d = vector(start)
        for level in range(64):
            n_facing, _ = optics.facing_normal(d, vector(normals[level]))
            d = optics.unit(optics.reflect(d, n_facing, optics.cos_incidence(d, n_facing)))
        worst = max(worst, float(np.abs(np.linalg.norm(np.array(d).reshape(3, -1), axis=0) - 1).max()))
    assert worst <= 2.5e-7
