"""Looking up a hit's material: base colour B, KR, KT and IOR.

In the JIT variants a per-instance method call for every material would make
Dr.Jit trace one Python function per BSDF, which does not scale to scenes of
thousands of spheres. Instead the materials' numbers sit in a table indexed by
the BSDF's instance ID (a ``BSDFPtr`` reinterpreted as an integer), so a lookup
is a handful of gathers whatever the number of materials. Textures are the
exception: each textured material evaluates its own texture, only on the lanes
that hit it. In the scalar variant a hit asks its BSDF directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np


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
            self._build_table(surfaces)
        else:
            self._by_bsdf = {id(s.bsdf): s for s in surfaces}

    def _build_table(self, surfaces):
        ptrs = mi.BSDFPtr([s.bsdf for s in surfaces])
        ids = np.array(dr.reinterpret_array(mi.UInt32, ptrs), dtype=np.int64).reshape(-1)
        size = int(ids.max()) + 1 if len(ids) else 1     # row 0: the null BSDF of a miss
        colour = np.zeros((3, size), np.float32)
        coefficients = np.zeros((3, size), np.float32)   # KR, KT, IOR
        coefficients[2] = 1.0
        texture_slot = np.zeros(size, np.uint32)         # 0: untextured, k: self.textured[k-1]
        slots = {id(s): k for k, s in enumerate(self.textured, start=1)}
        for row, s in zip(ids, surfaces):
            colour[:, row] = s.colour
            coefficients[:, row] = (s.reflect, s.refract, s.ior)
            texture_slot[row] = slots.get(id(s), 0)
        self._colour = mi.Color3f(colour)
        self._reflect = mi.Float(coefficients[0])
        self._refract = mi.Float(coefficients[1])
        self._ior = mi.Float(coefficients[2])
        self._slot = mi.UInt32(texture_slot)
        dr.make_opaque(self._colour, self._reflect, self._refract, self._ior, self._slot)

    def lookup(self, si, bsdf, active) -> SurfaceSample:
        """The material at ``si`` on the lanes ``active`` (hits only).

        ``bsdf`` is the hit BSDF's instance ID (JIT variants) or the BSDF itself (scalar).
        """
        if not dr.is_jit_v(mi.Float):
            return self._lookup_scalar(si, bsdf)
        row = bsdf   # the table is indexed by instance ID; row 0 (a miss) is never read
        base = dr.gather(mi.Color3f, self._colour, row, active)
        if self.textured:
            slot = dr.gather(mi.UInt32, self._slot, row, active)
            for k, s in enumerate(self.textured, start=1):
                on_texture = active & (slot == k)
                base = dr.select(on_texture, s.texture.eval(si, on_texture), base)
        ior = dr.gather(mi.Float, self._ior, row, active) if self.need_ior else mi.Float(1)
        return SurfaceSample(base,
                             dr.gather(mi.Float, self._reflect, row, active),
                             dr.gather(mi.Float, self._refract, row, active),
                             ior)

    def _lookup_scalar(self, si, bsdf) -> SurfaceSample:
        s = self._by_bsdf[id(bsdf)]
        base = s.texture.eval(si) if s.texture is not None else mi.Color3f(s.colour)
        return SurfaceSample(mi.Color3f(base), mi.Float(s.reflect), mi.Float(s.refract), mi.Float(s.ior))
