"""Looking up a hit's material: base colour B, KR, KT and IOR.

In the JIT variants a per-instance method call for every material would make
Dr.Jit trace one Python function per BSDF, which does not scale to scenes of
thousands of spheres. Instead the materials' numbers sit in a table indexed by
the BSDF's instance ID (a ``BSDFPtr`` reinterpreted as an integer), so a lookup
is a handful of gathers whatever the number of materials. Textures are the
exception: each textured material evaluates its own texture, only on the lanes
that hit it. The scalar variant reads the same table, by the hit BSDF's row.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from .masks import off


@dataclass
class SurfaceSample:
    """The material at a hit point."""
    base: object      # mi.Color3f, B (texel or colour)
    reflect: object   # mi.Float, KR
    refract: object   # mi.Float, KT
    ior: object       # mi.Float


class SurfaceTable:
    """Material lookups for the surfaces of a :class:`~.effects.SceneAnalysis`.

    ``need_ior`` leaves the IOR out of the kernels of scenes without refraction.
    """

    def __init__(self, surfaces, need_ior: bool):
        self.need_ior = need_ior
        self.textured = [s for s in surfaces if s.texture is not None]
        if dr.is_jit_v(mi.Float):
            # A hit names its BSDF by instance ID: the tables are indexed by it, read by gathers.
            rows = np.array(dr.reinterpret_array(mi.UInt32, mi.BSDFPtr([s.bsdf for s in surfaces])),
                            dtype=np.int64).reshape(-1)
            self._row = lambda bsdf: bsdf
            self._read = lambda tp, table, row, active: dr.gather(tp, table, row, active)
            store = self._opaque
        else:
            # A hit hands over the BSDF itself; dr.gather takes no plain numbers: numpy indexing.
            rows = np.arange(1, len(surfaces) + 1)
            row_of = {id(s.bsdf): row for row, s in zip(rows, surfaces)}
            self._row = lambda bsdf: row_of[id(bsdf)]
            self._read = lambda tp, table, row, active: tp(table[..., row].tolist())
            store = lambda tp, values: values
        size = int(rows.max()) + 1 if len(rows) else 1   # row 0: no material (a miss)
        colour = np.zeros((3, size))
        coefficients = np.zeros((3, size))               # KR, KT, IOR
        coefficients[2] = 1.0
        texture_slot = np.zeros(size, np.uint32)         # 0: untextured, k: self.textured[k-1]
        slots = {id(s): k for k, s in enumerate(self.textured, start=1)}
        for row, s in zip(rows, surfaces):
            colour[:, row] = s.colour
            coefficients[:, row] = (s.reflect, s.refract, s.ior)
            texture_slot[row] = slots.get(id(s), 0)
        self._colour = (mi.Color3f, store(mi.Color3f, colour))
        self._reflect, self._refract, self._ior = ((mi.Float, store(mi.Float, c)) for c in coefficients)
        self._slot = (mi.UInt32, store(mi.UInt32, texture_slot))

    @staticmethod
    def _opaque(tp, values):
        table = tp(values)
        dr.make_opaque(table)
        return table

    def lookup(self, si, bsdf, active) -> SurfaceSample:
        """The material at ``si`` on the lanes ``active`` (hits only).

        ``bsdf`` is the hit BSDF's instance ID (JIT variants) or the BSDF itself (scalar).
        """
        row = self._row(bsdf)
        base = self._read(*self._colour, row, active)
        if self.textured:
            slot = self._read(*self._slot, row, active)
            for k, s in enumerate(self.textured, start=1):
                on_texture = active & (slot == k)
                if not off(on_texture):
                    base = dr.select(on_texture, mi.Color3f(s.texture.eval(si, on_texture)), base)
        ior = self._read(*self._ior, row, active) if self.need_ior else mi.Float(1)
        return SurfaceSample(base, self._read(*self._reflect, row, active),
                             self._read(*self._refract, row, active), ior)
