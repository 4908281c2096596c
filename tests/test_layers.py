"""Spheres of several radii loaded as ``ellipsoids`` shapes: the Whitted integrator traces each
radius in a frame of its own (plugins/primitives.py, plugins/hits.py), where
Mitsuba's ellipsoid test is exact. The image is the one the same scene gives as sphere shapes,
and the float64 reference's, with several radii, glass, a textured sphere, a giant floor and
the camera inside a sphere."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import whitted
from conftest import aimed_rays
from float64_reference import assert_matches, render_reference
from whitted import sealed
from whitted.plugins.primitives import ellipsoids_shape
from whitted.converter import Light, Material, Scene, Sphere

GLASS = Material(color=(1.0, 1.0, 1.0), reflect=0.1, refract=0.85, ior=1.5)


def balls(rng, radius: float, count: int, height: float = -1.0) -> list[Sphere]:
    """``count`` balls of ``radius`` resting on the plane y = ``height``, colors of their own."""
    spheres = []
    for _ in range(count):
        x, z = rng.uniform(-3, 3, 2)
        color = tuple(float(c) for c in rng.uniform(0.2, 0.9, 3))
        spheres.append(Sphere((float(x), height + radius, float(z)), radius,
                              Material(color=color, reflect=float(rng.choice([0.0, 0.4])))))
    return spheres


def many_radii(texture=None, inside: bool = False, counts=(30, 12, 40)) -> Scene:
    """``counts`` balls of radii 0.1, 0.25 and 0.05 (the commonest is scaled to 1) on a giant
    floor sphere, a glass ball, optionally a textured ball, and optionally a sky sphere
    around the camera."""
    rng = np.random.default_rng(3)
    spheres = [Sphere((0.0, -1001.0, 0.0), 1000.0, Material(color=(0.8, 0.8, 0.75), reflect=0.2))]
    spheres += balls(rng, 0.1, counts[0]) + balls(rng, 0.25, counts[1]) + balls(rng, 0.05, counts[2])
    spheres.append(Sphere((0.5, -0.2, 0.5), 0.8, GLASS))
    if texture is not None:
        spheres.append(Sphere((-1.6, -0.4, -0.8), 0.6, Material(texture=texture)))
    if inside:
        spheres.append(Sphere((0.0, 0.0, 0.0), 40.0, Material(color=(0.45, 0.6, 0.9))))
    return Scene(width=64, height=48, eye=(0.0, 1.5, 6.0), lookat=(0.0, -0.5, 0.0), depth=5,
                 lights=[Light((3.0, 6.0, 4.0)), Light((-4.0, 3.0, 5.0), (0.4, 0.4, 0.4))], spheres=spheres)


def test_choose_groups_the_other_radius_classes_for_the_whitted_integrator_only():
    model = many_radii()
    path = sealed.choose(model, min_group=1)
    whitted_grouping = sealed.choose(model, min_group=1, classes=sealed.MAX_LAYERS)
    assert path.radii == (0.05,) and path.member.sum() == 40
    # the floor is float32-coarse (it may be giant): it stays for the converter to judge
    assert whitted_grouping.radii == (0.05, 0.1, 0.25)   # the commonest, then by count
    assert whitted_grouping.member.sum() == 82 and not whitted_grouping.member[0]
    assert sealed.choose(model, min_group=1, classes=1).radii == (0.05, 0.1)
    assert sealed.choose(model, min_group=41, classes=8) is None


#: the layers' radii in the scaled frame: the commonest radius 0.05 (scaled by 20), or 0.25 (by 4)
LAYERS = {(30, 12, 40): [2.0, 5.0], (30, 40, 12): [0.2, 0.4]}


#: case -> the float64 reference of its scene (the same in both variants: rendered once)
REFERENCES = {}


@pytest.mark.parametrize("case", ["radii", "larger commonest", "texture", "inside"])
def test_layers_render_the_scene_as_sphere_shapes_do(variant, tmp_path, texture_png, case):
    counts = (30, 40, 12) if case == "larger commonest" else (30, 12, 40)
    model = many_radii(texture=texture_png() if case == "texture" else None, inside=case == "inside",
                       counts=counts)
    path = tmp_path / "layers.scn"
    path.write_text("# the scene model of tests/test_layers.py\n")
    model = replace(model, source=path)
    shapes = whitted.load_scene(path, model=model, ellipsoids=False)
    grouped = whitted.load_scene(path, model=model, ellipsoids=True)
    from whitted.plugins.scene_tables import scene_tables
    tables = scene_tables(grouped)
    assert sorted(layer.radius for layer in tables.layers) == pytest.approx(LAYERS[counts], rel=1e-6)
    assert all(grouped.shapes()[k].class_name() == "Ellipsoids" for k in tables.layered)
    plain, layered = whitted.render(shapes).image, whitted.render(grouped).image
    if case not in REFERENCES:
        REFERENCES[case] = render_reference(model)
    expected = REFERENCES[case]
    assert_matches(plain, expected)
    assert_matches(layered, expected)
    assert np.abs(layered - plain).mean() < 1e-4


def test_layers_find_the_hits_mitsubas_ellipsoid_test_loses(llvm):
    """Spheres of radius 0.01 in an ``ellipsoids`` shape, each aimed at from 300 radii away in
    a random direction, with an impact parameter below 0.9 r: Mitsuba's ellipsoid test (exact at radius 1 only)
    loses many of them; the integrator's layer finds every one at the analytic distance."""
    import mitsuba as mi

    from whitted.plugins.scene_tables import scene_tables
    from whitted.plugins.hits import scene_hits
    rng = np.random.default_rng(5)
    radius, count = 0.01, 400
    centers = np.c_[rng.uniform(-1, 1, (count, 2)), np.zeros(count)]
    scene = mi.load_dict({"type": "scene", "balls": ellipsoids_shape(
        centers, {"type": "article"}, radius)})
    # from a random direction, 300 r away, at a random impact parameter b below 0.9 r
    origin, direction = aimed_rays(rng, centers, radius, 0.9)
    ray = mi.Ray3f(mi.Point3f(origin.T), mi.Vector3f(direction.T))
    # the float64 distance along each float32 ray to the nearest sphere (another may be in front)
    o, d = origin.astype(np.float64), direction.astype(np.float64) / np.linalg.norm(direction, axis=1)[:, None]
    f = o[:, None, :] - centers[None, :, :]                    # ray × sphere
    along = -(f * d[:, None, :]).sum(axis=2)
    miss2 = ((f + along[..., None] * d[:, None, :]) ** 2).sum(axis=2)
    t = along - np.sqrt(np.maximum(radius ** 2 - miss2, 0.0))
    expected = np.where((miss2 < radius ** 2) & (along > 0), t, np.inf).min(axis=1)
    mitsuba = np.array(scene.ray_intersect_preliminary(ray).is_valid())
    tables = scene_tables(scene)
    assert [layer.radius for layer in tables.layers] == pytest.approx([radius])
    hit, si, _, _ = scene_hits(scene, tables, need_uv=False).intersect(ray, coherent=False)
    assert mitsuba.mean() < 0.9
    assert np.array(hit).all()
    np.testing.assert_allclose(np.array(si.t), expected, rtol=0, atol=1e-4 * radius)
