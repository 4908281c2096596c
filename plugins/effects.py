"""What a loaded scene calls for: its lights, background, materials and effects.

The Whitted integrator reads the scene through :func:`analyse` (at most
once per scene state: see :mod:`.scene_state`), and builds its kernels from
the answer: a scene without
mirrors gets no reflection code and spawns no reflection rays, a scene without
lights traces no shadow rays, and a scene without reflective or transparent
surfaces is traced to depth 1 whatever its ``max_depth``.

Effect names (also reported by ``whitted render --stats``):

``lights``      point lights: the direct term and its shadow rays
``reflection``  a surface with KR > 0, and a max depth above 1
``refraction``  a surface with KT > 0, and a max depth above 1
``textures``    a surface whose base color varies over it (a bitmap)
``background``  an environment emitter (the scene's non-black background)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError

from .scene_state import memo
from .surfaces import Materials, scene_materials

EFFECTS = ("lights", "reflection", "refraction", "textures", "background")


@dataclass(frozen=True)
class PointLight:
    """A point emitter, with both readings of its strength.

    ``intensity`` is Mitsuba's radiant intensity I (physical lighting divides
    it by r^2); ``color`` is the article's light color ``I / (pi d^2)``, d
    the distance from the light to the integrator's ``light_reference`` point
    (1 when zero): the converter wrote ``I = color·pi·d^2`` with d measured to
    the scene's ``lookat``, which is the origin of the frame it writes
    positions in and the ``light_reference`` it writes, (0, 0, 0); so this
    recovers the scene file's color to float32 rounding, wherever the file
    put the scene (docs/numerics.md, hazard 6b, also for hand-edited XML).
    """
    position: tuple[float, float, float]
    intensity: tuple[float, float, float]
    color: tuple[float, float, float]


@dataclass
class SceneAnalysis:
    lights: list[PointLight]
    environment: object | None           # mi.Emitter or None
    surfaces: Materials                  # the distinct BSDFs (see :mod:`.surfaces`)
    max_depth: int                       # the depth asked for
    effects: tuple[str, ...] = field(init=False)
    depth: int = field(init=False)       # the depth actually needed

    def __post_init__(self):
        deep = self.max_depth > 1
        present = {
            "lights": bool(self.lights),
            "reflection": deep and self.surfaces.reflective,
            "refraction": deep and self.surfaces.refractive,
            "textures": self.surfaces.textured,
            "background": self.environment is not None,
        }
        self.effects = tuple(name for name in EFFECTS if present[name])
        # Only reflected and refracted rays make a tree deeper than its root.
        self.depth = self.max_depth if ("reflection" in self.effects
                                        or "refraction" in self.effects) else 1

    def has(self, effect: str) -> bool:
        return effect in self.effects


def _floats(value) -> tuple[float, ...]:
    """A Mitsuba vector or color (scalar or width-1 JIT array) as Python floats."""
    return tuple(float(x) for x in np.array(value, dtype=np.float64).reshape(-1))


def article_color(intensity, position, reference) -> tuple[float, float, float]:
    """The article's light color ``I / (pi d^2)`` (d = |position - reference|, 1 when 0)."""
    d2 = sum((p - r) ** 2 for p, r in zip(position, reference))
    if d2 == 0.0:
        d2 = 1.0
    return tuple(i / (math.pi * d2) for i in intensity)


def _point_light(emitter) -> tuple:
    """``(position, intensity)`` of a point emitter."""
    params = mi.traverse(emitter)
    if "position" not in params or "intensity.value" not in params:
        raise WhittedError(f"the whitted integrator cannot read the point light {emitter.id()!r}: "
                           "give it a 'position' and an RGB 'intensity'")
    position = _floats(params["position"])
    intensity = _floats(params["intensity.value"])
    if len(intensity) == 1:
        intensity = intensity * 3
    return position, intensity


def _lights(scene) -> list[tuple]:
    """``(position, intensity)`` of every point light of ``scene``."""
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        if emitter.class_name() != "PointLight":
            raise WhittedError(f"the whitted integrator supports point lights and a background; "
                               f"emitter {emitter.id()!r} is a {emitter.class_name()}")
        lights.append(_point_light(emitter))
    return lights


def analyse(scene, max_depth: int, light_reference) -> SceneAnalysis:
    """Read lights, background and materials from ``scene`` (a ``mi.Scene``).

    What is read from the scene is computed once per scene state (:mod:`.scene_state`).
    """
    reference = _floats(light_reference)
    lights = [PointLight(position, intensity, article_color(intensity, position, reference))
              for position, intensity in memo(scene, "lights", lambda: _lights(scene))]
    materials = scene_materials(scene)
    return SceneAnalysis(lights, scene.environment(), materials, max_depth)
