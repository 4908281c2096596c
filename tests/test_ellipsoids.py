"""Unit spheres held by one Mitsuba ``ellipsoids`` shape are spheres to the Whitted integrator
(plugins/geometry.py reads their centres per primitive; whitted/sealed.py builds them)."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted import sealed


def article(color, reflect=0.0):
    return {"type": "article", "color": {"type": "rgb", "value": list(color)}, "reflect": reflect}


RED, MIRROR, FLOOR = article((0.9, 0.2, 0.2)), article((0.9, 0.9, 0.9), 0.8), article((0.7, 0.7, 0.6))


def balls(seed=2, count=24):
    """Unit balls on a grid (jittered, apart), a floor sphere under them; alternate materials."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(np.arange(6), np.arange(4), indexing="ij")).reshape(2, -1).T[:count]
    centre = np.c_[grid[:, 0] * 3.0 - 7.5, np.zeros(count), grid[:, 1] * -3.0 - 2.0] + rng.uniform(-0.4, 0.4, (count, 3))
    return centre, (np.arange(count) % 2 == 0)


def scene_dict(centre, red, grouped):
    scene = {"type": "scene", "floor": {"type": "sphere", "center": [0.0, -1001.0, 0.0], "radius": 1000.0, "bsdf": FLOOR}}
    if grouped:
        scene["red"] = sealed.ellipsoids(centre[red], RED)
        scene["mirror"] = sealed.ellipsoids(centre[~red], MIRROR)
    else:
        for k, c in enumerate(centre):
            scene[f"ball_{k}"] = {"type": "sphere", "center": c.tolist(), "radius": 1.0, "bsdf": RED if red[k] else MIRROR}
    return scene


def rays(n=4000, seed=3):
    rng = np.random.default_rng(seed)
    target = np.c_[rng.uniform(-9, 9, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-13, 0, n)]
    origin = np.tile([0.0, 6.0, 12.0], (n, 1))
    d = target - origin
    return mi.Ray3f(mi.Point3f(origin.T.astype(np.float32)), mi.Vector3f((d / np.linalg.norm(d, axis=1)[:, None]).T.astype(np.float32)))


def colours(scene, bsdf_ids):
    """Each hit's base colour, looked up from its BSDF's instance ID."""
    by_id = {int(dr.reinterpret_array(mi.UInt32, mi.BSDFPtr(s.bsdf()))[0]): tuple(float(c[0]) for c in s.bsdf().color.eval(dr.zeros(mi.SurfaceInteraction3f)))
             for s in scene.shapes()}
    return [by_id.get(int(k)) for k in np.asarray(bsdf_ids)]


@pytest.fixture
def llvm():
    whitted.set_variant("llvm_ad_rgb")


def test_the_sphere_table_serves_ellipsoid_primitives_as_their_spheres(llvm):
    from whitted.plugins import geometry
    centre, red = balls()
    ray = rays()
    found = {}
    for grouped in (False, True):
        scene = mi.load_dict(scene_dict(centre, red, grouped))
        assert geometry.SphereHits.applies(scene)
        hits = geometry.hit_finder(scene, need_uv=False)
        hit, si, bsdf, error = hits.intersect(ray, coherent=False)
        found[grouped] = (np.array(hit), np.array(si.t), np.array(si.n), np.array(si.p), np.array(error),
                          colours(scene, bsdf))
    plain, packed = found[False], found[True]
    assert plain[0].mean() > 0.5 and (plain[0] == packed[0]).all()
    h = plain[0]
    np.testing.assert_allclose(packed[1][h], plain[1][h], rtol=1e-5)
    np.testing.assert_allclose(packed[2][:, h], plain[2][:, h], atol=1e-4)
    np.testing.assert_allclose(packed[3][:, h], plain[3][:, h], atol=1e-4)
    # the same error bound, primitive by primitive (a sphere shape's comes from its bounding box)
    np.testing.assert_allclose(packed[4][h], plain[4][h], rtol=1e-6)
    assert [c for c, k in zip(packed[5], h) if k] == [c for c, k in zip(plain[5], h) if k]


@pytest.mark.parametrize("variant", ["llvm_ad_rgb", "scalar_rgb"])
def test_mitsuba_interactions_get_each_primitive_s_error_bound(variant):
    """Beside a shape of other primitives (a rectangle: two triangles), which keeps one bound."""
    whitted.set_variant(variant)
    from whitted.plugins import geometry
    centre, red = balls(count=6)
    description = scene_dict(centre, red, grouped=True)
    description["wall"] = {"type": "rectangle", "bsdf": FLOOR,
                           "to_world": mi.ScalarTransform4f().translate([0.0, 0.0, -30.0]).scale(50.0)}
    scene = mi.load_dict(description)
    assert not geometry.SphereHits.applies(scene)
    hits = geometry.MitsubaHits(scene, need_uv=False)
    expected = geometry.hit_error(1.0, np.abs(np.float32(centre)).max(axis=1))
    for k, c in enumerate(centre):   # straight down onto each ball
        ray = mi.Ray3f(mi.Point3f(*(float(x) for x in c + [0, 5, 0])), mi.Vector3f(0, -1, 0))
        hit, si, _, error = hits.intersect(ray, coherent=False)
        assert bool(np.array(hit).reshape(-1)[0])
        assert np.array(error, float).reshape(-1)[0] == pytest.approx(expected[k], rel=1e-6)
    wall = geometry.hit_error(50.0, 30.0)
    for x, y in ((-20.0, 20.0), (20.0, -20.0), (20.0, 20.0), (-20.0, -20.0)):   # both triangles
        hit, si, _, error = hits.intersect(mi.Ray3f(mi.Point3f(x, y, 0.0), mi.Vector3f(0, 0, -1)), coherent=False)
        assert bool(np.array(hit).reshape(-1)[0])
        assert np.array(error, float).reshape(-1)[0] == pytest.approx(wall, rel=1e-6)


def test_a_light_on_a_grouped_sphere_is_found_on_it(llvm):
    from whitted.plugins import geometry
    centre, red = balls(count=4)
    scene = mi.load_dict(scene_dict(centre, red, grouped=True))
    hits = geometry.hit_finder(scene, need_uv=False)
    error, normal = hits.surface_at(centre[3] + [0.0, 1.0, 0.0])
    assert error == pytest.approx(geometry.hit_error(1.0, np.abs(np.float32(centre[3])).max()), rel=1e-6)
    assert normal == pytest.approx((0.0, 1.0, 0.0), abs=1e-6)


def test_ellipsoids_that_are_not_spheres_leave_the_sphere_table_out(llvm):
    from whitted.plugins import geometry
    shape = sealed.ellipsoids(np.zeros((2, 3)), RED)
    shape["scales"] = mi.TensorXf(np.array([[1, 1, 1], [1, 2, 1]], np.float32))
    assert not geometry.SphereHits.applies(mi.load_dict({"type": "scene", "e": shape}))
    shape = sealed.ellipsoids(np.zeros((2, 3)), RED)
    shape["quaternions"] = mi.TensorXf(np.array([[0, 0, 0, 1], [0, 0.6, 0, 0.8]], np.float32))
    assert not geometry.SphereHits.applies(mi.load_dict({"type": "scene", "e": shape}))
    assert geometry.SphereHits.applies(mi.load_dict({"type": "scene", "e": sealed.ellipsoids(np.zeros((2, 3)), RED)}))
