"""The converter's vector arithmetic on 3-tuples of Python floats (float64), written once.

The scene model, the parser's checks and the description all compute with the
same few formulas; having one copy keeps their results bit for bit alike (the
parser's test that two directions are parallel and the description's texture
frame normalize the same way).
"""

from __future__ import annotations

import math

Vec3 = tuple[float, float, float]


def sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def length(a: Vec3) -> float:
    return math.sqrt(dot(a, a))


def normalize(a: Vec3) -> Vec3:
    """``a`` / |a|, scaled first so that tiny or huge components neither underflow nor overflow."""
    scale = max(abs(c) for c in a)
    a = (a[0] / scale, a[1] / scale, a[2] / scale)
    n = length(a)
    return (a[0] / n, a[1] / n, a[2] / n)
