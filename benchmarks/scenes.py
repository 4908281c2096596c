"""The benchmark scenes, written as scene models and converted like any user scene.

For Mitsuba's ``direct`` integrator the same XML gets Mitsuba's C++ ``diffuse`` BSDF in
place of each ``article`` BSDF, so that both see the same scene and Mitsuba runs in C++.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import mitsuba as mi
import numpy as np

from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml


def random_spheres(count: int, seed: int = 1, *, reflect: float = 0.0,
                   low=(-5.0, -5.0, -5.0), high=(5.0, 5.0, 5.0)) -> list[Sphere]:
    """``count`` non-overlapping spheres in the box from ``low`` to ``high``, each jittered in a
    grid cell of its own, so that they cover about as much of a view whatever their number;
    each has its own color and a reflection up to ``reflect``."""
    rng = np.random.default_rng(seed)
    side = max(1, math.ceil(round(count ** (1 / 3), 9)))
    low, high = np.asarray(low, float), np.asarray(high, float)
    size = (high - low) / side
    k = rng.permutation(side ** 3)[:count]
    cell = np.stack([k % side, k // side % side, k // side ** 2], axis=1)
    radius = rng.uniform(0.2, 0.45, count) * size.min()
    center = low + (cell + 0.5) * size + rng.uniform(-1, 1, (count, 3)) * (size / 2 - radius[:, None])
    colors, reflects = rng.uniform(0.2, 0.9, (count, 3)).tolist(), (rng.random(count) * reflect).tolist()
    materials = [Material(color=tuple(c), reflect=r) for c, r in zip(colors, reflects)]
    return [Sphere(tuple(c), r, m) for c, r, m in zip(center.tolist(), radius.tolist(), materials)]


def diffuse_spheres(count: int, width: int, height: int, spp: int) -> Scene:
    """``count`` diffuse spheres (a ground sphere and ``count - 1`` :func:`random_spheres`, each
    its own color, in a box above it) under one light."""
    ground = Sphere((0.0, -1000.0, 0.0), 1000.0, Material(color=(0.8, 0.8, 0.75)))
    balls = random_spheres(count - 1, low=(-5.0, 0.0, -6.0), high=(5.0, 5.0, 3.0))
    return Scene(width=width, height=height, eye=(0.0, 3.0, 12.0), lookat=(0.0, 0.8, 0.0), fov=50.0,
                 samples=spp, depth=1, lights=[Light((6.0, 10.0, 8.0))], spheres=[ground, *balls])


def every_effect(texture: Path, width: int, height: int, spp: int, depth: int = 5) -> Scene:
    """A scene calling for every effect: two lights, mirrors, glass, a texture, a background."""
    return Scene(width=width, height=height, eye=(0.0, 2.0, 9.0), lookat=(0.0, 0.8, 0.0), fov=50.0,
                 samples=spp, depth=depth, background=(0.35, 0.5, 0.8),
                 lights=[Light((6.0, 9.0, 7.0)), Light((-8.0, 6.0, 3.0), (0.3, 0.3, 0.35))],
                 spheres=[Sphere((0.0, -1000.0, 0.0), 1000.0, Material(color=(0.8, 0.8, 0.7), reflect=0.2)),
                          Sphere((-2.2, 1.0, 0.0), 1.0, Material(color=(0.9, 0.3, 0.2), reflect=0.6)),
                          Sphere((0.0, 1.0, 1.0), 1.0, Material(color=(1.0, 1.0, 1.0), reflect=0.1,
                                                                 refract=0.85, ior=1.5)),
                          Sphere((2.2, 1.0, 0.0), 1.0, Material(texture=texture)),
                          Sphere((0.8, 0.4, 2.6), 0.4, Material(color=(0.2, 0.5, 0.9)))])


def write_texture(path: Path) -> Path:
    """A 64×32 checker of two colors (8-bit sRGB)."""
    rows, cols = np.mgrid[0:32, 0:64]
    checker = ((rows // 4 + cols // 4) % 2).astype(bool)
    pixels = np.where(checker[..., None], [230, 200, 60], [40, 90, 160]).astype(np.uint8)
    mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    return path


def load(model: Scene):
    """The scene as ``whitted render`` loads it."""
    return mi.load_string(scene_to_xml(model, base_dir=None))


_ARTICLE = re.compile(r'<bsdf type="article" id="(\w+)">\s*<rgb name="color" value="([^"]*)"/>.*?</bsdf>', re.S)


def load_for_direct(model: Scene):
    """The same scene with Mitsuba's C++ ``diffuse`` BSDF (reflectance = the sphere's color)."""
    if any(s.material.reflect or s.material.refract or s.material.texture for s in model.spheres):
        raise ValueError("Mitsuba's direct integrator is compared on diffuse, untextured spheres only")
    xml = scene_to_xml(model, base_dir=None)
    diffuse, replaced = _ARTICLE.subn(
        r'<bsdf type="diffuse" id="\1"><rgb name="reflectance" value="\2"/></bsdf>', xml)
    assert replaced == xml.count('<bsdf type="article"') and replaced > 0
    return mi.load_string(diffuse)


def load_whitted(model: Scene, **properties):
    """A ``whitted`` integrator with the scene's own settings, ``properties`` overriding them."""
    return mi.load_dict({"type": "whitted", "max_depth": model.depth, "ambient": model.ambient,
                         "light_reference": mi.ScalarPoint3f(model.lookat), **properties})


def direct_integrator():
    """Mitsuba's ``direct`` doing a Whitted render's work at depth 1: one emitter sample per
    hit (for a point light: one shadow ray to it, no random choice), no BSDF samples."""
    return mi.load_dict({"type": "direct", "emitter_samples": 1, "bsdf_samples": 0})
