"""Texture mapping: Mitsuba's UV on the converted sphere is the article's lat/long mapping,
and the integrator shows the texel the row/column rule picks, on every face and at the poles.

Expectations come from the spec's formulas as written in tests/float64_reference.py (float64).
Scenes use ambient 1 and no lights, so a pixel's color is its texel B.
"""

from __future__ import annotations

import math

import mitsuba as mi
import numpy as np
import pytest

import whitted
import whitted.rendering
from float64_reference import camera_ray, cross, lat_long, load_texels, nearest_hit, normalize, srgb_to_linear, sub, texel
from whitted.converter import Material, Scene, Sphere, scene_to_xml

from conftest import VARIANTS
CENTER, RADIUS = (0.3, -0.2, 0.5), 1.3
NORTH, EQUATOR = (1.0, 1.0, 0.2), (0.0, 0.3, 1.0)
TEX_W, TEX_H = 15, 7   # odd: the faces' centers do not fall on texel edges


def frame():
    """(Ve, Vb, Vn): the seam direction, Vn × Ve, and north, as unit vectors."""
    vn = normalize(NORTH)
    d = sum(e * n for e, n in zip(EQUATOR, vn))
    ve = normalize(tuple(e - d * n for e, n in zip(EQUATOR, vn)))
    return ve, cross(vn, ve), vn


def faces():
    ve, vb, vn = frame()
    neg = lambda v: tuple(-c for c in v)  # noqa: E731
    return {"+seam": ve, "-seam": neg(ve), "+east": vb, "-east": neg(vb), "north": vn, "south": neg(vn)}


@pytest.fixture(scope="module")
def texture(tmp_path_factory):
    """An 8-bit sRGB PNG: R encodes the column, G the row, so every texel differs."""
    path = tmp_path_factory.mktemp("tex") / "grid.png"
    rows, cols = np.mgrid[0:TEX_H, 0:TEX_W]
    srgb = np.stack([(cols + 0.5) / TEX_W, (rows + 0.5) / TEX_H, np.full(rows.shape, 0.6)], axis=-1)
    mi.Bitmap((srgb * 255).round().astype(np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    return path


def globe(texture, **camera) -> Scene:
    return Scene(ambient=1.0, spheres=[Sphere(CENTER, RADIUS, Material(texture=texture), north=NORTH,
                                              equator=EQUATOR)], **camera)


def load(model: Scene, variant: str):
    whitted.set_variant(variant)
    return mi.load_string(scene_to_xml(model, base_dir=None))


def face_camera(direction, size=17):
    """A camera looking at the sphere's center from ``direction``."""
    ve, vb, vn = frame()
    up = ve if abs(sum(a * b for a, b in zip(direction, vn))) > 0.9 else vn
    eye = tuple(c + 6.0 * d for c, d in zip(CENTER, direction))
    return dict(width=size, height=size, eye=eye, lookat=CENTER, up=up, fov=30.0)


# -- Mitsuba's (u, v) ----------------------------------------------------------------------------

def hit_uv(loaded, directions: np.ndarray) -> np.ndarray:
    """Mitsuba's si.uv where rays aimed at the center from ``directions`` hit the sphere."""
    origins = np.array(CENTER) + directions * (RADIUS + 5.0)
    if dr_is_jit():
        ray = mi.Ray3f(mi.Point3f(origins.T.astype(np.float32)), mi.Vector3f((-directions).T.astype(np.float32)))
        si = loaded.ray_intersect(ray)
        assert np.all(np.array(si.is_valid()))
        return np.array(si.uv).T
    uvs = []
    for o, d in zip(origins, directions):
        si = loaded.ray_intersect(mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*(-d))))
        assert si.is_valid()
        uvs.append((si.uv.x, si.uv.y))
    return np.array(uvs)


def dr_is_jit() -> bool:
    import drjit as dr
    return dr.is_jit_v(mi.Float)


@pytest.mark.parametrize("variant", VARIANTS)
def test_mitsuba_uv_is_the_article_mapping(texture, variant):
    """On the converted sphere Mitsuba's u is the article's u and its v is 1 − v."""
    rng = np.random.default_rng(3)
    random = rng.normal(size=(300, 3))
    named = np.array(list(faces().values()))
    directions = np.concatenate([named, random / np.linalg.norm(random, axis=1, keepdims=True)])
    loaded = load(globe(texture, width=4, height=4), variant)
    uv = hit_uv(loaded, directions)
    assert np.all(np.isfinite(uv))
    _, _, vn = frame()
    for (u_m, v_m), d in zip(uv, directions):
        point = tuple(c + RADIUS * x for c, x in zip(CENTER, d))
        u, v = lat_long(Sphere(CENTER, RADIUS, north=NORTH, equator=EQUATOR), point)
        assert v_m == pytest.approx(1 - v, abs=1e-4)
        if abs(np.dot(d, vn)) < 1 - 1e-6:    # u is undefined at the poles
            wrapped = (u_m - u + 0.5) % 1.0 - 0.5  # the seam: u = 0 and u = 1 are one place
            assert abs(wrapped) < 1e-4, (d, u_m, u)


# -- texels on every face -------------------------------------------------------------------------

def near_texel_edge(u: float, v: float, margin=1e-3) -> bool:
    x, y = u * TEX_W, (1 - v) * TEX_H
    return min(x % 1, 1 - x % 1) < margin or min(y % 1, 1 - y % 1) < margin


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("face", list(faces()))
def test_texels_on_every_face(texture, variant, face):
    """Every pixel that sees the sphere shows the texel the spec's mapping picks."""
    model = globe(texture, **face_camera(faces()[face]))
    image = whitted.render(load(model, variant)).image
    assert np.all(np.isfinite(image))
    texels = load_texels(texture)
    sphere = model.spheres[0]
    checked = 0
    for j in range(model.height):
        for i in range(model.width):
            origin, direction = camera_ray(model, i + 0.5, j + 0.5)
            hit = nearest_hit(model, origin, direction)
            if hit is None:
                np.testing.assert_array_equal(image[j, i], 0.0)
                continue
            point = tuple(o + hit[0] * d for o, d in zip(origin, direction))
            normal = normalize(sub(point, CENTER))
            u, v = lat_long(sphere, point)
            if near_texel_edge(u, v) or -sum(a * b for a, b in zip(normal, direction)) < 0.05:
                continue  # a texel edge or the silhouette: float32 may pick the neighbour
            np.testing.assert_allclose(image[j, i], texel(texels, u, v), atol=1e-5,
                                       err_msg=f"pixel ({i}, {j}) at (u, v) = ({u:.4f}, {v:.4f})")
            checked += 1
    assert checked > 100


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("pole,row", [("north", 0), ("south", TEX_H - 1)])
def test_poles_show_the_top_and_bottom_rows(texture, variant, pole, row):
    """The ray through the center pixel hits the pole: the north pole is the image's top
    row, the south pole its bottom row (any column: u is a convention there), finite."""
    model = globe(texture, **face_camera(faces()[pole]))
    image = whitted.render(load(model, variant)).image
    assert np.all(np.isfinite(image))
    center = image[model.height // 2, model.width // 2]
    texels = load_texels(texture)
    assert np.any(np.all(np.abs(texels[row] - center) < 1e-5, axis=1)), center


# -- color encoding ------------------------------------------------------------------------------

@pytest.mark.parametrize("variant", VARIANTS)
def test_8bit_textures_are_decoded_from_srgb(tmp_path, variant):
    path = tmp_path / "grey.png"
    mi.Bitmap(np.full((4, 8, 3), 128, np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    model = globe(path, **face_camera(faces()["-east"], size=5))
    image = whitted.render(load(model, variant)).image
    np.testing.assert_allclose(image[2, 2], srgb_to_linear(128 / 255), rtol=1e-5)
    assert srgb_to_linear(128 / 255) == pytest.approx(0.2158605, rel=1e-6)


@pytest.mark.parametrize("variant", VARIANTS)
def test_float_textures_are_linear(tmp_path, variant):
    """An EXR's values are used as they are, even above 1."""
    path = tmp_path / "grid.exr"
    rows, cols = np.mgrid[0:TEX_H, 0:TEX_W]
    values = np.stack([cols * 0.3, rows * 0.7, np.full(rows.shape, 2.5)], axis=-1).astype(np.float32)
    mi.Bitmap(values, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    model = globe(path, **face_camera(faces()["-seam"], size=5))
    image = whitted.render(load(model, variant)).image
    u, v = lat_long(model.spheres[0], tuple(c + RADIUS * d for c, d in zip(CENTER, faces()["-seam"])))
    np.testing.assert_allclose(image[2, 2], texel(values.astype(np.float64), u, v), rtol=1e-6)
    assert image[2, 2, 2] == pytest.approx(2.5)
    assert math.isclose(u, 0.5, abs_tol=1e-9)
