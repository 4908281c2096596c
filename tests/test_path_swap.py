"""Swapping in Mitsuba's ``path`` integrator on converted scenes.

The path tracer must render the *same* scene the article's model renders: same
camera, same texels, and lights scaled so that brightness is comparable. The
expectations here are independent of both renderers: a float64 numpy tracer
written from the scene format (camera, sphere hits, lat/long texture mapping)
and the physically based reading of the scene documented in docs/radiometry.md
(a point light of intensity I = color·π·d², a Lambertian lobe (1−KR−KT)·B/π,
a mirror lobe KR). Images are compared with the compare tool's relative MSE,
mean over pixels and channels of (a − b)² / (b² + 10⁻²).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.converter.description import light_intensity
from whitted.metrics import relative_mse

from conftest import VARIANTS
SCENES = Path(__file__).resolve().parents[1] / "scenes"


def load(model: Scene) -> mi.Scene:
    return mi.load_string(scene_to_xml(model, base_dir=None))


def render_path(scene: mi.Scene, spp: int, max_depth: int, seed: int = 0) -> np.ndarray:
    """Mitsuba's stock ``path`` integrator, (H, W, 3) linear float64."""
    integrator = mi.load_dict({"type": "path", "max_depth": max_depth})
    return np.array(mi.render(scene, integrator=integrator, spp=spp, seed=seed), dtype=np.float64)


def luminance(image: np.ndarray) -> np.ndarray:
    return image @ np.array([0.2126, 0.7152, 0.0722])


# -- a float64 tracer written from the scene format ---------------------------

def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def camera_rays(model: Scene, sub: int):
    """Eye and unit directions of ``sub``×``sub`` stratified rays per pixel, as the
    scene format's camera defines them; shape (H, W, sub², 3)."""
    eye, lookat, up = (np.array(v, dtype=np.float64) for v in (model.eye, model.lookat, model.up))
    f = _normalize(lookat - eye)
    right = _normalize(np.cross(f, up))
    true_up = np.cross(right, f)
    w, h = model.width, model.height
    offsets = (np.arange(sub) + 0.5) / sub
    sx, sy = np.meshgrid(offsets, offsets)
    i = np.arange(w)[None, :, None] + sx.reshape(1, 1, -1)
    j = np.arange(h)[:, None, None] + sy.reshape(1, 1, -1)
    x, y = np.broadcast_arrays(2 * i / w - 1, 1 - 2 * j / h)
    tan = math.tan(math.radians(model.fov) / 2)
    d = f + (x * tan)[..., None] * right + (y * tan * h / w)[..., None] * true_up
    return eye, _normalize(d)


def nearest_hit(spheres, origin, direction):
    """(t, sphere index) of the nearest hit with t > ε; t = inf and index −1 on a miss."""
    origin = np.broadcast_to(origin, direction.shape)
    best_t = np.full(direction.shape[:-1], np.inf)
    best_i = np.full(direction.shape[:-1], -1)
    for index, sphere in enumerate(spheres):
        oc = origin - np.array(sphere.center)
        b = np.sum(oc * direction, axis=-1)
        c = np.sum(oc * oc, axis=-1) - sphere.radius ** 2
        disc = b * b - c
        root = np.sqrt(np.maximum(disc, 0.0))
        eps = 1e-9 * (1 + np.abs(b))
        t = np.where(-b - root > eps, -b - root, -b + root)
        t = np.where((disc >= 0) & (t > eps), t, np.inf)
        closer = t < best_t
        best_t = np.where(closer, t, best_t)
        best_i = np.where(closer, index, best_i)
    return best_t, best_i


def article_uv(sphere: Sphere, point):
    """The scene format's latitude/longitude mapping (u, v) of points on ``sphere``."""
    vn = _normalize(np.array(sphere.north, dtype=np.float64))
    e = np.array(sphere.equator, dtype=np.float64)
    ve = _normalize(e - (e @ vn) * vn)
    vp = _normalize(point - np.array(sphere.center))
    phi = np.arccos(np.clip(-(vp @ vn), -1, 1))
    v = phi / math.pi
    sin_phi = np.sin(phi)
    with np.errstate(divide="ignore", invalid="ignore"):
        theta = np.arccos(np.clip((vp @ ve) / sin_phi, -1, 1)) / (2 * math.pi)
    theta = np.where(sin_phi > 0, theta, 0.0)
    u = np.where((vp @ np.cross(vn, ve)) > 0, theta, 1 - theta)
    return np.where(sin_phi > 0, u, 0.0), v


def texel(image: np.ndarray, u, v):
    """Nearest texel: column floor(u·W), row floor((1 − v)·H), clamped; row 0 on top."""
    h, w = image.shape[:2]
    col = np.clip(np.floor(u * w).astype(int), 0, w - 1)
    row = np.clip(np.floor((1 - v) * h).astype(int), 0, h - 1)
    return image[row, col]


def physical_radiance(model: Scene, origin, direction, depth, textures=None):
    """Radiance along rays under the physical reading of the scene (docs/radiometry.md):
    point lights of intensity I = color·π·d² with inverse-square fall-off,
    (1−KR−KT)·B/π diffuse, KR mirror, hard shadows; ``depth`` as the article's max depth.
    Only what the scenes here use: no refraction, black background."""
    t, index = nearest_hit(model.spheres, origin, direction)
    result = np.zeros(direction.shape)
    for k, sphere in enumerate(model.spheres):
        hit = index == k
        if not hit.any():
            continue
        d = direction[hit]
        p = np.broadcast_to(origin, direction.shape)[hit] + t[hit][:, None] * d
        n = _normalize(p - np.array(sphere.center))
        inside = np.sum(d * n, axis=-1) > 0
        n = np.where(inside[:, None], -n, n)
        m = sphere.material
        if m.texture is not None:
            base = texel(textures[m.texture], *article_uv(sphere, p))
        else:
            base = np.broadcast_to(np.array(m.color, dtype=np.float64), p.shape)
        color = np.zeros(p.shape)
        for light in model.lights:
            to_light = np.array(light.position) - p
            dist = np.linalg.norm(to_light, axis=-1)
            l_dir = to_light / dist[:, None]
            cos = np.maximum(0.0, np.sum(n * l_dir, axis=-1))
            t_block, _ = nearest_hit(model.spheres, p + 1e-7 * n, l_dir)
            lit = (t_block >= dist) & (cos > 0)
            intensity = np.array(light_intensity(model, light.position, light.color))
            color += np.where(lit, cos / dist ** 2, 0.0)[:, None] * intensity
        color *= (1 - m.reflect - m.refract) * base / math.pi
        if m.reflect > 0 and depth > 1:
            c1 = -np.sum(n * d, axis=-1)
            r = d + 2 * c1[:, None] * n
            color += m.reflect * physical_radiance(model, p + 1e-7 * n, r, depth - 1, textures)
        result[hit] = color
    return result


def reference_physical(model: Scene, sub: int = 8, textures=None) -> np.ndarray:
    eye, directions = camera_rays(model, sub)
    return physical_radiance(model, eye, directions, model.depth, textures).mean(axis=2)


# -- scenes ----------------------------------------------------------------------

def single_diffuse_sphere(width=64, height=48) -> Scene:
    """One convex diffuse sphere, one light: the article's model is physically exact."""
    return Scene(width=width, height=height, eye=(0, 0, 6), lookat=(0, 0, 0), fov=40,
                 ambient=0.0, depth=3, lights=[Light((3, 4, 5), (1.0, 0.9, 0.8))],
                 spheres=[Sphere((0, 0, 0), 1.2, Material(color=(0.8, 0.5, 0.3)))])


def mirror_and_diffuse(width=64, height=48) -> Scene:
    """A diffuse sphere above a large mirror sphere, seen with its reflection.

    At article depth 2 (path max_depth 3) Mitsuba's path tracer follows
    camera → mirror → diffuse → light but not yet camera → diffuse → mirror →
    diffuse → light (one vertex more), and a convex diffuse sphere cannot light
    itself: the article's model is physically exact here too."""
    return Scene(width=width, height=height, eye=(0, 1.5, 7), lookat=(0, 0.2, 0), fov=40,
                 ambient=0.0, depth=2, lights=[Light((4, 0.8, 3), (1.0, 1.0, 1.0))],
                 spheres=[Sphere((0, -4, 0), 4, Material(color=(1, 1, 1), reflect=1.0)),
                          Sphere((-0.3, 1.1, 0.5), 0.8, Material(color=(0.3, 0.8, 0.4)))])


def every_feature(texture_path) -> Scene:
    return Scene(width=32, height=24, eye=(0, 0.5, 8), fov=50, background=(0.1, 0.1, 0.2),
                 ambient=0.2, depth=5,
                 lights=[Light((5, 5, 10)), Light((-4, 3, 6), (0.4, 0.4, 0.6))],
                 spheres=[Sphere((0, 0, 0), 1, Material(color=(0.9, 0.2, 0.2), reflect=0.3)),
                          Sphere((2.2, 0, -1), 0.7, Material(reflect=0.1, refract=0.8, ior=1.5)),
                          Sphere((-2.2, 0, 0), 1, Material(texture=texture_path),
                                 north=(0.3, 1, 0.2), equator=(1, 0, -1)),
                          Sphere((0, -101, 0), 100, Material(color=(0.6, 0.6, 0.6)))])


def write_texture(path, width=16, height=8, seed=1) -> np.ndarray:
    """A linear EXR of random, strongly contrasting texels."""
    texels = np.random.default_rng(seed).uniform(0.05, 1.0, (height, width, 3))
    mi.Bitmap(texels.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    return texels


# -- tests ------------------------------------------------------------------------

def test_path_renders_converted_scenes_in_both_variants(tmp_path):
    """Every material feature (diffuse, mirror, glass with TIR, texture), two lights,
    a background: finite images from both variants, alike up to noise."""
    model = every_feature(tmp_path / "texels.exr")
    write_texture(model.spheres[2].material.texture)
    previous = mi.variant()
    images = {}
    try:
        for name in VARIANTS:
            whitted.set_variant(name)
            images[name] = render_path(load(model), spp=64, max_depth=model.depth + 1)
    finally:
        whitted.set_variant(previous)
    for image in images.values():
        assert image.shape == (24, 32, 3)
        assert np.all(np.isfinite(image)) and np.all(image >= 0)
        assert luminance(image).mean() > 0.1
    means = [luminance(images[name]).mean() for name in VARIANTS]
    assert means[0] == pytest.approx(means[1], rel=0.05)
    assert relative_mse(images["scalar_rgb"], images["llvm_ad_rgb"]) < 0.05


def test_path_sees_the_articles_texels(llvm, tmp_path):
    """A textured diffuse sphere under a white environment of radiance 1 reflects
    exactly its albedo, so the path-traced image is the texture as the scene
    format maps it (north and equator not the defaults), up to noise. A mapping
    off by a flip or a turn is far outside the tolerance."""
    texture = tmp_path / "texels.exr"
    texels = write_texture(texture)
    model = Scene(width=48, height=36, eye=(0, 0, 4), fov=40, background=(1, 1, 1), depth=1,
                  spheres=[Sphere((0.1, -0.05, 0), 1, Material(texture=texture),
                                  north=(0.3, 1, 0.2), equator=(1, 0, -1))])
    image = render_path(load(model), spp=256, max_depth=2)

    def expected(tex):
        eye, directions = camera_rays(model, 8)
        t, index = nearest_hit(model.spheres, eye, directions)
        color = np.ones(directions.shape)
        hit = index == 0
        points = eye + t[hit][:, None] * directions[hit]
        color[hit] = texel(tex, *article_uv(model.spheres[0], points))
        return color.mean(axis=2)

    error = relative_mse(image, expected(texels))
    assert error < 5e-3
    for wrong in (texels[::-1], texels[:, ::-1], np.roll(texels, 4, axis=1)):
        assert relative_mse(image, expected(wrong)) > 10 * max(error, 5e-3)


def test_light_intensity_gives_the_article_brightness_at_lookat(variant):
    """A white diffuse surface at ``lookat`` facing a light of color c is c under the
    article's model with ambient 0; path-traced with I = c·π·d² it is c too."""
    c = (0.9, 0.6, 0.3)
    model = Scene(width=9, height=9, eye=(0, 0, 8), lookat=(0, 0, 0), fov=2, ambient=0.0,
                  lights=[Light((0, 0, 5), c)],
                  spheres=[Sphere((0, 0, -50), 50, Material(color=(1, 1, 1)))])
    image = render_path(load(model), spp=64, max_depth=2)
    np.testing.assert_allclose(image[4, 4], c, rtol=2e-3)


@pytest.mark.parametrize("make", [single_diffuse_sphere, mirror_and_diffuse])
def test_path_matches_the_float64_physical_reference(llvm, make):
    model = make()
    image = render_path(load(model), spp=1024, max_depth=model.depth + 1)
    reference = reference_physical(model)
    assert luminance(reference).mean() > 0.02
    assert relative_mse(image, reference) < 2e-3


# -- the article's integrator against the path tracer (the rendering API) ---------

SINGLE_SPHERE_SCN = """\
# one diffuse sphere, one light: the article's model is physically exact
size 64 48
eye 0 0 6
lookat 0 0 0
fov 40
ambient 0
depth 3
light 3 4 5   1 0.9 0.8
sphere 0 0 0 1.2   color 0.8 0.5 0.3
"""


def test_cli_physical_whitted_agrees_with_the_path_tracer(llvm, tmp_path):
    """The acceptance criterion as a user runs it: ``whitted render --lighting
    physical --spp 64`` against ``whitted render --integrator path --spp 1024``."""
    from whitted.cli import main
    from whitted.images import read_image

    scene = tmp_path / "sphere.scn"
    scene.write_text(SINGLE_SPHERE_SCN)
    common = ["render", str(scene), "--variant", "llvm_ad_rgb", "-q", "-o"]
    assert main(common + [str(tmp_path / "whitted.exr"), "--lighting", "physical",
                          "--spp", "64"]) == 0
    assert main(common + [str(tmp_path / "path.exr"), "--integrator", "path", "--spp", "1024"]) == 0
    whitted_image = read_image(tmp_path / "whitted.exr")
    path_image = read_image(tmp_path / "path.exr")
    assert luminance(path_image).mean() > 0.05
    assert relative_mse(whitted_image, path_image) <= 2e-3


@pytest.mark.parametrize("make", [single_diffuse_sphere, mirror_and_diffuse])
def test_physical_whitted_agrees_with_the_path_tracer(llvm, make):
    from whitted.rendering import render

    scene = load(make())
    whitted_image = render(scene, lighting="physical", spp=64).image
    path_image = render(scene, integrator="path", spp=1024).image
    assert relative_mse(whitted_image, path_image) <= 2e-3
    # Article lighting is another reading of the same scene, not this one.
    article_image = render(scene, lighting="article", spp=64).image
    assert relative_mse(article_image, path_image) > 2e-3


def test_physical_whitted_agrees_with_the_path_tracer_in_scalar_variant():
    from whitted.rendering import render

    previous = mi.variant()
    whitted.set_variant("scalar_rgb")
    try:
        scene = load(single_diffuse_sphere(32, 24))
        whitted_image = render(scene, lighting="physical", spp=16).image
        path_image = render(scene, integrator="path", spp=256).image
    finally:
        whitted.set_variant(previous)
    assert relative_mse(whitted_image, path_image) <= 2e-3


def test_path_sees_the_same_texels_as_the_whitted_integrator(llvm, tmp_path):
    """With ambient 1 and no lights the article's color is the texel itself; under
    a white sky the path tracer's is too. The same texels, up to noise."""
    from whitted.rendering import render

    texture = tmp_path / "texels.exr"
    write_texture(texture, width=24, height=12, seed=5)
    model = Scene(width=48, height=36, eye=(0.3, 0.4, 4), fov=40, background=(1, 1, 1),
                  ambient=1.0, depth=1,
                  spheres=[Sphere((0, 0, 0), 1, Material(texture=texture),
                                  north=(-0.2, 1, 0.4), equator=(0, 0, -1))])
    scene = load(model)
    whitted_image = render(scene, spp=64).image
    path_image = render(scene, integrator="path", spp=256).image
    assert relative_mse(whitted_image, path_image) < 5e-3


def example_scenes() -> list[Path]:
    return sorted(SCENES.glob("*.scn"))


def test_example_scenes_exist():
    assert len(example_scenes()) >= 3


@pytest.mark.parametrize("path", example_scenes(), ids=lambda p: p.stem)
def test_path_traced_brightness_is_comparable_on_the_example_scenes(llvm, path):
    """The light scaling makes path-traced and article images comparable: mean
    luminance within a factor 2 (at a quarter of the scenes' resolution)."""
    from whitted.converter import parse_file
    from whitted.rendering import render

    model = parse_file(path)
    model = dataclasses.replace(model, width=max(8, model.width // 4),
                                height=max(8, model.height // 4))
    scene = load(model)
    article = luminance(render(scene).image).mean()
    traced = luminance(render(scene, integrator="path", spp=128).image).mean()
    assert article > 0.01
    assert 0.5 <= traced / article <= 2.0
