"""How far Mitsuba's 32-bit numbers may place a surface, and the ``exact_spheres`` text: one
definition for the converter (which spheres are too coarse) and the integrator (its ray
offsets), docs/numerics.md, "The error bound behind the ray offsets".
"""

from __future__ import annotations

from .defaults import Vec3

#: float32's unit round-off, 2^-24
UNIT_ROUNDOFF = 2.0 ** -24
#: the error bound of a hit point, in round-offs of its shape's radius and of its center's
#: largest coordinate
RADIUS_ULPS = 8
CENTER_ULPS = 4


def hit_error(radius, center):
    """How far a float32 hit point on a shape of ``radius`` whose center's largest coordinate
    is ``center`` may lie off its surface, or a float32 ray test near it place the surface."""
    return (RADIUS_ULPS * UNIT_ROUNDOFF) * radius + (CENTER_ULPS * UNIT_ROUNDOFF) * center


def exact_spheres(entries) -> str:
    """The ``exact_spheres`` property of ``(id, center, radius)`` entries: ``id: x y z r`` per
    sphere too coarse for float32, joined by ``"; "``, each number as ``repr`` writes a float64."""
    return "; ".join(f"{key}: {' '.join(repr(float(v)) for v in (*center, radius))}"
                     for key, center, radius in entries)


def parse_exact_spheres(text: str) -> list[tuple[str, Vec3, float]]:
    """``(id, center, radius)`` of each entry of an ``exact_spheres`` property."""
    entries = []
    for part in (p.strip() for p in text.split(";")):
        if not part:
            continue
        key, sep, numbers = part.rpartition(":")
        values = numbers.split()
        if not sep or not key.strip() or len(values) != 4:
            raise ValueError(f"exact_spheres: expected 'id: x y z r', got {part!r}")
        try:
            x, y, z, r = (float(v) for v in values)
        except ValueError:
            raise ValueError(f"exact_spheres: expected four numbers in {part!r}") from None
        if not r > 0:
            raise ValueError(f"exact_spheres: the radius must be positive in {part!r}")
        entries.append((key.strip(), (x, y, z), r))
    return entries
