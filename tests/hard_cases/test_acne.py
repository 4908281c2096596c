"""Self-intersection ("acne") at every scale, ray by ray.

One sphere of center C and radius r, over six orders of magnitude of each. Rays
from random points around it hit it at random places; from each hit, the
integrator's own ray spawning and hit finding (plugins/hits.py)
must give:

- a ray leaving outwards (grazing ones included) that never meets the sphere
  again (a convex surface cannot be hit from outside by a ray leaving it),
- a ray leaving inwards that meets the sphere's far side, not the point it left,
- a shadow segment to a light outside that the sphere does not block.

Expectations are geometric facts, so any failure is acne (or a lost hit).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import whitted

#: (center, radius, cap): hits are spread over the part of the sphere within ``cap`` radians
#: of its top. From a speck at the origin to balls at 10^4, and floors (spheres under the
#: origin, seen near their top) of radius 10^2 to 10^6.
SIZES = {
    "speck": ((0.0, 0.0, 0.0), 1e-3, np.pi), "unit ball": ((0.0, 0.0, 0.0), 1.0, np.pi),
    "huge ball": ((0.0, 0.0, 0.0), 1e4, np.pi), "speck at 1": ((1.0, -0.7, 0.3), 1e-3, np.pi),
    "unit ball at 1": ((1.0, -0.7, 0.3), 1.0, np.pi), "small ball at 1e2": ((1e2, -70.0, 30.0), 0.1, np.pi),
    "unit ball at 1e4": ((1e4, -7e3, 3e3), 1.0, np.pi), "huge ball at 1e4": ((1e4, -7e3, 3e3), 1e4, np.pi),
    "ball at 1e5": ((1e5, -7e4, 3e4), 10.0, np.pi), "floor r=1e2": ((0.0, -1e2, 0.0), 1e2, 0.05),
    "floor r=1e4": ((0.0, -1e4, 0.0), 1e4, 1e-3), "floor r=1e6": ((0.0, -1e6, 0.0), 1e6, 1e-5),
}
#: rays per size: the JIT variants take them in one wavefront, scalar one by one
RAYS = {"llvm_ad_rgb": 20000, "scalar_rgb": 2000}
#: (variant, hit finder): the sphere table serves all-sphere scenes in the JIT variants,
#: Mitsuba's surface interactions every other scene and the scalar variants
FINDERS = [("llvm_ad_rgb", "sphere table"), ("llvm_ad_rgb", "mitsuba"), ("scalar_rgb", "mitsuba")]
#: rays leaving closer than this to the tangent plane may legitimately point inwards once
#: their direction is rounded to float32; they are not judged
GRAZING = 1e-4


def unit(v):
    return v / np.linalg.norm(v, axis=0)


def hits_and_directions(center, radius, cap, n, rng):
    """Rays aimed at random points of the sphere's cap from random points around it, and for
    each hit an outward and an inward direction making angle acos(cosine) with the tangent
    plane."""
    polar = np.arccos(rng.uniform(np.cos(cap), 1, n))
    azimuth = rng.uniform(0, 2 * np.pi, n)
    normal = np.stack([np.sin(polar) * np.cos(azimuth), np.cos(polar), np.sin(polar) * np.sin(azimuth)])
    reach = min(3.0, 1 + 10 * cap)   # origins about as far from the cap as the cap is wide
    origin = center[:, None] + radius * (normal + (reach - 1) * unit(normal + 0.5 * rng.normal(size=(3, n))))
    direction = unit(center[:, None] + radius * normal - origin)
    tangent = rng.normal(size=(3, n))
    cosine = rng.uniform(0, 1, n) ** 3   # many grazing ones
    return origin, direction, tangent, cosine


def leaving(si_n, tangent, cosine):
    """Outward and inward unit directions at ``cosine`` from the tangent plane of ``si_n``."""
    t = unit(tangent - (tangent * si_n).sum(axis=0) * si_n)
    sine = np.sqrt(1 - cosine ** 2)
    return unit(t * sine + si_n * cosine), unit(t * sine - si_n * cosine)


def failures_jit(scene, hits, center, radius, cap, n, rng):
    from whitted.plugins.hits import blocked, spawn_ray, spawn_ray_to
    origin, direction, tangent, cosine = hits_and_directions(center, radius, cap, n, rng)
    hit, si, _, error = hits.intersect(mi.Ray3f(mi.Point3f(origin), mi.Vector3f(direction)), False)
    hit = np.array(hit)
    normal = np.array(si.n)
    out, into = leaving(normal, tangent, cosine)
    out_hit = np.array(hits.intersect(spawn_ray(si, error, mi.Vector3f(out)), False)[0])
    in_hit, in_si, _, _ = hits.intersect(spawn_ray(si, error, mi.Vector3f(into)), False)
    light = mi.Point3f(np.array(si.p) + radius * (2 * normal + out))
    shadowed = np.array(blocked(scene, spawn_ray_to(si, error, light), mi.Bool(hit)))
    judged = hit & (cosine > GRAZING)
    chord = 2 * radius * cosine
    lost = ~np.array(in_hit) | (np.array(in_si.t) < 0.5 * chord)
    return int(hit.sum()), int((out_hit & judged).sum()), int((lost & judged).sum()), int((shadowed & hit).sum())


def failures_scalar(scene, hits, center, radius, cap, n, rng):
    from whitted.plugins.hits import blocked, spawn_ray, spawn_ray_to
    origin, direction, tangent, cosine = hits_and_directions(center, radius, cap, n, rng)
    counts = np.zeros(4, int)
    for k in range(n):
        hit, si, _, error = hits.intersect(mi.Ray3f(mi.Point3f(origin[:, k]), mi.Vector3f(direction[:, k])), False)
        if not hit:
            continue
        normal = np.array(si.n, np.float64)
        out, into = (v[:, 0] for v in leaving(normal[:, None], tangent[:, k:k + 1], cosine[k:k + 1]))
        out_hit = hits.intersect(spawn_ray(si, error, mi.Vector3f(out)), False)[0]
        in_hit, in_si, _, _ = hits.intersect(spawn_ray(si, error, mi.Vector3f(into)), False)
        light = mi.Point3f(np.array(si.p) + radius * (2 * normal + out))
        judged = cosine[k] > GRAZING
        counts += (1, out_hit and judged, judged and (not in_hit or in_si.t < radius * cosine[k]),
                   blocked(scene, spawn_ray_to(si, error, light), True))
    return tuple(int(c) for c in counts)


@pytest.mark.parametrize("variant,finder", FINDERS)
@pytest.mark.parametrize("size", list(SIZES))
def test_no_ray_meets_the_surface_it_leaves(variant, finder, size, monkeypatch):
    whitted.set_variant(variant)
    from whitted.plugins.scene_tables import scene_tables
    from whitted.plugins import hits as geometry
    center, radius, cap = SIZES[size]
    center = np.array(center)
    scene = mi.load_dict({"type": "scene", "ball": {"type": "sphere", "center": center.tolist(),
                                                     "radius": radius, "bsdf": {"type": "article"}}})
    hits = geometry.hit_finder(scene, scene_tables(scene), need_uv=False, sphere_table=finder == "sphere table")
    assert isinstance(hits, geometry.SphereHits) == (finder == "sphere table")
    check = failures_jit if dr.is_jit_v(mi.Float) else failures_scalar
    n, outward, inward, shadowed = check(scene, hits, center, radius, cap, RAYS[variant], np.random.default_rng(5))
    assert n > 0.9 * RAYS[variant]
    assert (outward, inward, shadowed) == (0, 0, 0), \
        f"{n} hits: {outward} outward rays met the sphere again, {inward} inward rays lost its far " \
        f"side, {shadowed} shadow rays were blocked by it"
