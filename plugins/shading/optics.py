"""The article's optics: the facing normal, mirror reflection and Snell refraction.

Each formula of docs/scene-format.md ("Shading", steps 2, 5 and 6) is written
here once, with Dr.Jit operations, so the same code runs on one ray (scalar
variants) or on a wavefront of rays (JIT variants). Directions are unit vectors
and ``v`` is the incoming ray's direction (pointing *into* the surface).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def facing_normal(v, n):
    """``(N', inside)``: the normal on the side the ray arrives from.

    A ray arriving from inside a sphere (``v·N > 0``) is shaded and refracted
    with ``N' = -N``.
    """
    inside = dr.dot(v, n) > 0
    return dr.select(inside, -n, n), inside


def cos_incidence(v, n_facing):
    """``c1 = -N'·V``, the cosine between the facing normal and the reversed ray (>= 0)."""
    return -dr.dot(n_facing, v)


def reflect(v, n_facing, c1):
    """Mirror direction ``R = V + 2·c1·N'``."""
    return dr.fma(2 * c1, n_facing, v)


def relative_ior(ior, inside):
    """``n = n1/n2``: entering, n1 = 1 and n2 = IOR; leaving, the reverse.

    Outside every sphere the index is 1, even when spheres nest: each surface
    is judged on its own, by the side the ray arrives from.
    """
    return dr.select(inside, ior, dr.rcp(ior))


def refract(v, n_facing, c1, eta):
    """``(T, tir)``: Snell's refraction ``T = n·V + (n·c1 - sqrt(k))·N'``.

    ``k = 1 - n^2 (1 - c1^2)``; when ``k < 0`` (total internal reflection,
    ``tir`` is True) there is no transmitted ray and the caller sends the
    refracted share along the mirror direction instead. ``T`` is then
    meaningless but finite (``sqrt`` is never taken of a negative number).
    """
    k = 1 - eta * eta * (1 - c1 * c1)
    tir = k < 0
    t = dr.fma(eta, v, (eta * c1 - dr.safe_sqrt(k)) * n_facing)
    return t, tir


def unit(v):
    """``v`` normalized; float32 round-off would otherwise drift along deep mirror chains."""
    return dr.normalize(mi.Vector3f(v))
