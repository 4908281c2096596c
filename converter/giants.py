"""Giant spheres: the legacy floor, wall and sky, which float32 cannot place finely enough.

Why. A format that knows only spheres makes its floors, walls and skies out
of huge ones (``sphere 0 -100000 0 100000``; smallpt's box is six spheres of
radius 10^5). Mitsuba stores a sphere's center and radius in float32 and, in
its JIT variants, intersects it in float32 in world space, so it places the
surface only to ulps of the radius: about 1 near a floor of radius 10^7, next
to balls of radius 0.3 that must touch it. The Whitted integrator's ray
offsets, which must clear that uncertainty, then lift shadow and reflection
rays over those balls (docs/numerics.md, hazard 14).

What the converter does. It decides which spheres are *giant*: those whose
float32 error bound (the integrator's ``hit_error``: ε·(8 r + 4 max|C_i|) in
the frame) exceeds :data:`GIANT_FRACTION` of the scene's smallest radius,
where float32 can no longer keep the gaps the scene's details need. It lists
them, with their centers (in the frame, subtracted in float64) and radii as
float64 text, in the Whitted integrator's ``exact_spheres`` property, and the
integrator intersects those spheres itself in float64 (plugins/giants.py).
They stay ``sphere`` shapes too, for Mitsuba's own integrators and for
readers of the XML. A scene without giant spheres is written as before.
"""

from __future__ import annotations

from .scene import Scene, Sphere, Vec3

#: float32's unit round-off, 2^-24
EPSILON32 = 2.0 ** -24
#: the integrator's error bound of a float32 hit, in round-offs of the radius and of the
#: center's largest coordinate (plugins/geometry.py, ``hit_error``)
RADIUS_ULPS, CENTER_ULPS = 8, 4
#: a sphere is giant when that bound exceeds this fraction of the scene's smallest radius.
#: Measured (docs/numerics.md, hazard 14) on floors under balls of radius 0.3: radius 10^3
#: (bound 2.4e-3 of 0.3) renders from float32 as the float64 reference does; from 10^4
#: (2.4e-2) on, pixels go wrong as the radius grows (0.65 %, 9 % at 10^5, 27 % at 10^6)
GIANT_FRACTION = 1e-2


def float32_error(sphere: Sphere, origin: Vec3) -> float:
    """The integrator's error bound of a float32 hit on ``sphere`` written in the frame whose
    origin is the world point ``origin``."""
    center = max(abs(c - o) for c, o in zip(sphere.center, origin))
    return EPSILON32 * (RADIUS_ULPS * sphere.radius + CENTER_ULPS * center)


def giant_spheres(scene: Scene, origin: Vec3, smallest: float | None = None) -> list[int]:
    """Indices of the giant spheres of ``scene`` (written in the frame of ``origin``).

    ``smallest`` is the smallest radius of spheres the scene holds elsewhere (the loader's
    ellipsoids: whitted/sealed.py), if any.
    """
    if not scene.spheres:
        return []
    detail = min(sphere.radius for sphere in scene.spheres)
    if smallest is not None:
        detail = min(detail, smallest)
    return [k for k, sphere in enumerate(scene.spheres)
            if float32_error(sphere, origin) > GIANT_FRACTION * detail]


def exact_spheres(entries) -> str:
    """The ``exact_spheres`` property: ``id: x y z r`` per sphere, joined by ``"; "``, each
    number as the shortest text that reads back as the same float64."""
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
