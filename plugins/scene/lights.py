"""A scene's lights as numbers: point lights' positions and intensities, and the background.

The article's light color is read back from Mitsuba's radiant intensity
(:func:`article_color`): the converter writes a light of color c at
distance d from the scene's ``lookat`` as ``I = c·π·d²``, and the
integrator's ``light_reference`` is that ``lookat`` in the frame the
converter writes (docs/numerics.md, hazard 6b, also for hand-edited XML).
"""

from __future__ import annotations

import math

import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError


def floats(value) -> tuple[float, ...]:
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
    position = floats(params["position"])
    intensity = floats(params["intensity.value"])
    if len(intensity) == 1:
        intensity = intensity * 3
    return position, intensity


def point_lights(scene) -> tuple[tuple, ...]:
    """``(position, intensity)`` of every point light of ``scene``; a clean error for an
    emitter the integrator cannot render (neither a point light nor the environment)."""
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        if emitter.class_name() != "PointLight":
            raise WhittedError(f"the whitted integrator cannot render the emitter {emitter.id()!r} "
                               f"(a {emitter.class_name()}): it renders point lights and a "
                               "background only")
        lights.append(_point_light(emitter))
    return tuple(lights)


def largest_emission(emitter) -> float | None:
    """The largest channel of a constant environment's radiance (None for other emitters)."""
    params = mi.traverse(emitter)
    if emitter.class_name() != "ConstantBackgroundEmitter" or "radiance.value" not in params:
        return None
    return float(np.array(params["radiance.value"], np.float64).max())
