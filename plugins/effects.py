"""What a loaded scene calls for: its lights, background, materials and effects.

The Whitted integrator reads the scene once per render through
:func:`analyse`, and builds its kernels from the answer: a scene without
mirrors gets no reflection code and spawns no reflection rays, a scene without
lights traces no shadow rays, and a scene without reflective or transparent
surfaces is traced to depth 1 whatever its ``max_depth``.

Effect names (also reported by ``whitted render --stats``):

``lights``      point lights: the direct term and its shadow rays
``reflection``  a surface with KR > 0, and a max depth above 1
``refraction``  a surface with KT > 0, and a max depth above 1
``textures``    a surface whose base colour varies over it (a bitmap)
``background``  an environment emitter (the scene's non-black background)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError

EFFECTS = ("lights", "reflection", "refraction", "textures", "background")


@dataclass(frozen=True)
class PointLight:
    """A point emitter, with both readings of its strength.

    ``intensity`` is Mitsuba's radiant intensity I (physical lighting divides
    it by r^2); ``colour`` is the article's light colour ``I / (pi d^2)``, d
    the distance from the light to the integrator's ``light_reference`` point
    (1 when zero): the converter wrote ``I = colour·pi·d^2`` with d measured to
    the scene's ``lookat``, which is the origin of the frame it writes
    positions in and the ``light_reference`` it writes, (0, 0, 0); so this
    recovers the scene file's colour to float32 rounding, wherever the file
    put the scene (docs/numerics.md, hazard 6b, also for hand-edited XML).
    """
    position: tuple[float, float, float]
    intensity: tuple[float, float, float]
    colour: tuple[float, float, float]


@dataclass(frozen=True)
class Surface:
    """One ``article`` BSDF, as numbers: base colour (or texture) and coefficients."""
    bsdf: object
    colour: tuple[float, float, float]   # the base colour B when untextured
    texture: object | None               # mi.Texture when B varies over the surface
    reflect: float                       # KR
    refract: float                       # KT
    ior: float


@dataclass
class SceneAnalysis:
    lights: list[PointLight]
    environment: object | None           # mi.Emitter or None
    surfaces: list[Surface]              # distinct BSDFs, in scene order
    max_depth: int                       # the depth asked for
    effects: tuple[str, ...] = field(init=False)
    depth: int = field(init=False)       # the depth actually needed

    def __post_init__(self):
        deep = self.max_depth > 1
        present = {
            "lights": bool(self.lights),
            "reflection": deep and any(s.reflect > 0 for s in self.surfaces),
            "refraction": deep and any(s.refract > 0 for s in self.surfaces),
            "textures": any(s.texture is not None for s in self.surfaces),
            "background": self.environment is not None,
        }
        self.effects = tuple(name for name in EFFECTS if present[name])
        # Only reflected and refracted rays make a tree deeper than its root.
        self.depth = self.max_depth if ("reflection" in self.effects
                                        or "refraction" in self.effects) else 1

    def has(self, effect: str) -> bool:
        return effect in self.effects


def _floats(value) -> tuple[float, ...]:
    """A Mitsuba vector or colour (scalar or width-1 JIT array) as Python floats."""
    return tuple(float(x) for x in np.array(value, dtype=np.float64).reshape(-1))


def _colour(value) -> tuple[float, ...]:
    """A constant colour's channels as Python floats.

    Read by indexing rather than through numpy (:func:`_floats`): this runs for
    every material at every render, and numpy's conversion, at 8 µs a call, was
    most of a render's time in a scene of 10 000 materials.
    """
    return tuple(float(c[0]) if dr.is_jit_v(c) else float(c) for c in value)


def article_colour(intensity, position, reference) -> tuple[float, float, float]:
    """The article's light colour ``I / (pi d^2)`` (d = |position - reference|, 1 when 0)."""
    d2 = sum((p - r) ** 2 for p, r in zip(position, reference))
    if d2 == 0.0:
        d2 = 1.0
    return tuple(i / (math.pi * d2) for i in intensity)


def _point_light(emitter, reference) -> PointLight:
    params = mi.traverse(emitter)
    if "position" not in params or "intensity.value" not in params:
        raise WhittedError(f"the whitted integrator cannot read the point light {emitter.id()!r}: "
                           "give it a 'position' and an RGB 'intensity'")
    position = _floats(params["position"])
    intensity = _floats(params["intensity.value"])
    if len(intensity) == 1:
        intensity = intensity * 3
    return PointLight(position, intensity, article_colour(intensity, position, reference))


def _surface(bsdf, shape) -> Surface:
    missing = [a for a in ("color", "reflect", "refract", "ior") if not hasattr(bsdf, a)]
    if missing:
        raise WhittedError(
            f"the whitted integrator needs the 'article' BSDF on every shape; shape "
            f"{shape.id()!r} has {bsdf.class_name() if bsdf is not None else 'none'}")
    texture = bsdf.color
    varying = texture.is_spatially_varying()
    colour = (0.0, 0.0, 0.0) if varying else _colour(texture.eval(dr.zeros(mi.SurfaceInteraction3f)))
    if len(colour) == 1:
        colour = colour * 3
    return Surface(bsdf, colour, texture if varying else None,
                   float(bsdf.reflect), float(bsdf.refract), float(bsdf.ior))


def analyse(scene, max_depth: int, light_reference) -> SceneAnalysis:
    """Read lights, background and materials from ``scene`` (a ``mi.Scene``)."""
    reference = _floats(light_reference)
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        if emitter.class_name() != "PointLight":
            raise WhittedError(f"the whitted integrator supports point lights and a background; "
                               f"emitter {emitter.id()!r} is a {emitter.class_name()}")
        lights.append(_point_light(emitter, reference))
    surfaces: dict[int, Surface] = {}
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if id(bsdf) not in surfaces:
            surfaces[id(bsdf)] = _surface(bsdf, shape)
    return SceneAnalysis(lights, scene.environment(), list(surfaces.values()), max_depth)
