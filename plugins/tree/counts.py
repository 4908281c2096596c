"""What a render counts: its rays by kind (``whitted render --stats``).

Counts are kept where rays are cast (the shading code, the tracers) by a
:class:`Tally`: in the JIT variants they are added up inside the kernels that
trace the rays and read back once, at the end of the render.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import drjit as dr
import mitsuba as mi


@dataclass
class RayCounts:
    """Rays traced by one render.

    A refracted share sent along the mirror direction by total internal
    reflection still counts as a refraction ray: it is the ray the refraction
    term spawns. When the surface also reflects, that ray and the reflected one
    are the same, and are traced once (see :mod:`..shading`): it counts as one
    of each kind, and ``merged`` counts such rays, so that the rays traced are
    ``camera + shadow + reflection + refraction - merged``.
    ``max_depth_reached`` is the deepest level that traced a ray.

    ``culled`` counts the reflected and refracted rays that the adaptive depth
    control left untraced (a ray that would have carried both shares counts
    twice), ``culled_weight`` sums their path weights, and ``sample_culled_weight``
    is the largest sum of them in one camera sample's tree (the error bound's
    factor: :mod:`.adaptive`).
    """
    camera: int = 0
    shadow: int = 0
    reflection: int = 0
    refraction: int = 0
    merged: int = 0
    max_depth_reached: int = 0
    culled: int = 0
    culled_weight: float = 0.0
    sample_culled_weight: float = 0.0

    def rays(self) -> dict:
        return {kind: getattr(self, kind) for kind in ("camera", "shadow", "reflection", "refraction")}


class Tally:
    """Running counts of one render, named as :class:`RayCounts`' fields.

    In the JIT variants each count is a one-element array that the kernels add
    to atomically (``dr.scatter_reduce``: deferred, so it runs inside the kernel
    that computes the mask, and nothing is read back before :meth:`read`). The
    scalar variants' counts are Python numbers, as their masks are (``dr.scatter_reduce``
    takes only Dr.Jit arrays): the one difference, kept here.
    """

    def __init__(self):
        self._jit = dr.is_jit_v(mi.Float)
        self._sums = {}

    def add(self, name: str, mask) -> None:
        """Count the set lanes of ``mask``."""
        self._add(name, mi.UInt32, 1, mask)

    def add_total(self, name: str, value, mask) -> None:
        """Add up ``value`` over the set lanes of ``mask`` (in double precision: millions of
        small terms are added one after the other)."""
        self._add(name, mi.Float64, mi.Float64(value), mask)

    def note_max(self, name: str, value) -> None:
        """Keep the largest of ``value``'s lanes (and of those noted before)."""
        self._add(name, mi.Float, value, True, dr.ReduceOp.Max)

    def _add(self, name, tp, value, mask, op=dr.ReduceOp.Add):
        if not self._jit:
            if mask:
                old = self._sums.get(name, 0)
                self._sums[name] = old + value if op == dr.ReduceOp.Add else max(old, value)
            return
        if name not in self._sums:
            self._sums[name] = dr.zeros(tp, 1)
            dr.make_opaque(self._sums[name])
        dr.scatter_reduce(op, self._sums[name], value, mi.UInt32(0), mask)

    def read(self, **known) -> RayCounts:
        """The counts as Python numbers, with ``known`` ones (e.g. ``camera``) added."""
        kinds = {f.name: f.type for f in fields(RayCounts)}
        values = {name: (float if kinds[name] == "float" else int)(value[0] if self._jit else value)
                  for name, value in self._sums.items()}
        return RayCounts(**{**values, **known})
