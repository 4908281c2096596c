"""How far Mitsuba's 32-bit numbers may place a surface: the bound both sides of the project use.

Mitsuba stores positions in float32 and, in the JIT variants, intersects
spheres in float32. The converter decides from this bound which spheres are
too coarse for float32 (converter/giants.py) and when a scene's size deserves
a warning (converter/frame.py); the Whitted integrator moves secondary and
shadow rays off a surface by it (plugins/hits.py). One definition, so
that what the converter promises is what the integrator does. docs/numerics.md
("The error bound behind the ray offsets") derives it.

It also holds the ``exact_spheres`` text, the one format the converter and the
integrator share. Plain arithmetic only: the functions take Python floats, numpy arrays and
Dr.Jit arrays alike, and the converter imports this module without Mitsuba.
"""

from __future__ import annotations

#: float32's unit round-off, 2^-24
UNIT_ROUNDOFF = 2.0 ** -24
#: the error bound of a hit point, in round-offs of its shape's radius and of its center's
#: largest coordinate
RADIUS_ULPS = 8
CENTER_ULPS = 4


def hit_error(radius, center):
    """How far a float32 hit point on a shape may lie off its surface, and how far off
    a float32 ray-shape test near it may place the surface.

    ``radius`` is the shape's radius (half its bounding box's widest side) and
    ``center`` its center's largest coordinate magnitude. Both terms come from
    rounding: re-projecting the point (``C + r·N``), subtracting the center,
    and Mitsuba's float32 quadratic, whose self-intersection root is off by
    up to about two ulps of r (head-on rays) and an ulp of |C|. A floor sphere of
    radius 10^4 under the origin gets 7e-3, a unit sphere at 10^4 2.4e-3, a
    unit sphere at the origin 5e-7.
    """
    return (RADIUS_ULPS * UNIT_ROUNDOFF) * radius + (CENTER_ULPS * UNIT_ROUNDOFF) * center


# The ``exact_spheres`` property: the spheres too coarse for float32 (converter/giants.py
# decides which) with their exact centers and radii, written by the converter and read by the
# integrator (plugins/hits.py intersects them in float64). ``id: x y z r`` per sphere, joined
# by ``"; "``, each number the shortest text that reads back as the same float64 (``repr``).

Vec3 = tuple[float, float, float]


def exact_spheres(entries) -> str:
    """The ``exact_spheres`` property of ``(id, center, radius)`` entries."""
    return "; ".join(f"{key}: {' '.join(repr(float(v)) for v in (*center, radius))}"
                     for key, center, radius in entries)


def parse_exact_spheres(text: str) -> list[tuple[str, Vec3, float]]:
    """``(id, center, radius)`` of each entry of an ``exact_spheres`` property (ValueError
    when malformed)."""
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
