"""The ``exact_spheres`` property's text: the giant spheres' exact centers and radii.

Why a module of its own. The converter writes the list (converter/giants.py decides
which spheres are giant) and the ``whitted`` integrator reads it back
(plugins/hits.py intersects them in float64): the format is the one thing
both sides share, so it lives below both, and neither imports the other. Plain
Python: no Mitsuba, no numpy.

Format: ``id: x y z r`` per sphere, joined by ``"; "``, each number as the shortest
text that reads back as the same float64 (Python's ``repr``).
"""

from __future__ import annotations

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
