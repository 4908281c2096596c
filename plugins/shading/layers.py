"""Nearest hits on spheres traced in frames of their own (:mod:`whitted.plugins.scene.layers`).

A layer holds spheres of radius r in the scene's frame scaled by s = 1/r
about the origin, where Mitsuba's ``ellipsoids`` test is exact. A ray
``o + t·d`` of the scene is the ray ``s·o + t'·d`` there, with the same unit
direction and ``t' = s·t``: so Embree finds the nearest sphere of each layer
(``ray_intersect_preliminary``), the nearest over the layers and the
``inner`` finder (the scene's other shapes) wins, and the hit point, normal,
BSDF and error bound come from the layer's tables in the scene's frame,
re-projected onto the sphere as :class:`.hits.SphereHits` does.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from ..scene.primitives import slot_of
from .hits import blocked, lat_long_uv, no_blocker, no_hits

#: the texture frame of a layer's spheres (they are untextured; UV as for a unit sphere)
_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


class LayeredHits:
    """The ``inner`` finder's hits (None: no other shapes) and the layers' of ``tables``.

    The layers are traced first, largest spheres first, each bounded by the nearest hit so
    far (``maxt``), and the inner finder last, bounded the same way: Embree skips what lies
    beyond. A shadow segment already blocked is not traced again. A :class:`.hits.HitFinder`.
    """

    def __init__(self, inner, tables, need_uv: bool):
        self.jit = dr.is_jit_v(mi.Float)
        self.inner = inner
        self.layers = sorted(tables.layers, key=lambda layer: -layer.radius)
        self.need_uv = need_uv
        self.primitives = tables.primitives
        # per-render constants are opaque: one kernel serves every scale
        self.scales = [dr.opaque(mi.Float, layer.scale) if self.jit else layer.scale for layer in self.layers]
        self.radii = [dr.opaque(mi.Float, layer.radius) if self.jit else layer.radius for layer in self.layers]

    def _ray(self, k: int, ray, maxt):
        """``ray`` in layer ``k``'s frame, up to ``maxt`` (in the scene's frame)."""
        scaled = mi.Ray3f(ray.o * self.scales[k], ray.d)
        scaled.maxt = maxt * self.scales[k]
        return scaled

    def surface_at(self, point):
        """As :meth:`.hits.HitFinder.surface_at`: the layers' spheres are the scene's primitives."""
        return self.primitives.surface_at(point)

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (:meth:`.hits.HitFinder.blocked`)."""
        tests = [lambda mask, k=k, layer=layer: blocked(layer.scene, self._ray(k, ray, ray.maxt), mask,
                                                        spheres=False)
                 for k, layer in enumerate(self.layers)]
        if self.inner is not None:
            tests.append(lambda mask: self.inner.blocked(ray, mask))
        shadowed = no_blocker()
        for test in tests:
            if self.jit:   # lanes already blocked are not traced again
                shadowed = shadowed | test(active & ~shadowed)
            elif shadowed or not active:
                break
            else:
                shadowed = test(active)
        return shadowed & active

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` (:meth:`.hits.HitFinder.intersect`)."""
        if not self.jit:
            return self._scalar(ray, coherent)
        best, which, slot = mi.Float(ray.maxt), mi.Int32(-1), mi.UInt32(0)
        for k, layer in enumerate(self.layers):
            pi = layer.scene.ray_intersect_preliminary(self._ray(k, ray, best), coherent=coherent)
            t = pi.t / self.scales[k]
            nearer = pi.is_valid() & (t < best)
            layer_slot = slot_of(layer.tables.base, dr.reinterpret_array(mi.UInt32, pi.shape), pi.prim_index, nearer)
            best, which, slot = dr.select(nearer, t, best), dr.select(nearer, k, which), dr.select(nearer, layer_slot, slot)
        if self.inner is not None:   # the other shapes, before the nearest layer hit
            bounded = mi.Ray3f(ray)
            bounded.maxt = best
            hit, si, bsdf, error = self.inner.intersect(bounded, coherent)
            which = dr.select(hit, -1, which)
        else:
            hit, si, bsdf, error = no_hits()
        layered = which >= 0
        center, radius, layer_bsdf, layer_error = mi.Point3f(0.0), mi.Float(1.0), mi.UInt32(0), mi.Float(0.0)
        for k, layer in enumerate(self.layers):
            this = which == k
            center = dr.select(this, dr.gather(mi.Point3f, layer.tables.center, slot, this), center)
            radius = dr.select(this, self.radii[k], radius)
            layer_bsdf = dr.select(this, dr.gather(mi.UInt32, layer.tables.bsdf, slot, this), layer_bsdf)
            layer_error = dr.select(this, dr.gather(mi.Float, layer.tables.error, slot, this), layer_error)
        n = dr.normalize(ray(best) - center)
        si.t = dr.select(layered, best, si.t)
        si.n = dr.select(layered, n, si.n)
        si.p = dr.select(layered, dr.fma(n, radius, center), si.p)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            si.uv = dr.select(layered, lat_long_uv(n, *(mi.Vector3f(a) for a in _AXES)), si.uv)
        return hit | layered, si, dr.select(layered, layer_bsdf, bsdf), dr.select(layered, layer_error, error)

    def _scalar(self, ray, coherent):
        best, nearest = float(ray.maxt), None
        for k, layer in enumerate(self.layers):
            pi = layer.scene.ray_intersect_preliminary(self._ray(k, ray, best), coherent=coherent)
            if pi.is_valid() and pi.t / layer.scale < best:
                best, nearest = pi.t / layer.scale, (layer, pi.shape, int(pi.prim_index))
        if self.inner is not None:
            bounded = mi.Ray3f(ray)
            bounded.maxt = best
            hit, si, bsdf, error = self.inner.intersect(bounded, coherent)
        else:
            hit, si, bsdf, error = no_hits()
        if hit or nearest is None:
            return hit, si, bsdf, error
        layer, shape, prim = nearest
        first, layer_bsdf = layer.tables[id(shape)]
        if not hit:
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.time, si.wavelengths = ray.time, ray.wavelengths
        center = layer.center[first + prim]
        si.n = dr.normalize(ray(best) - center)
        si.p, si.t = dr.fma(si.n, layer.radius, center), best
        if self.need_uv:
            si.uv = lat_long_uv(si.n, *(mi.Vector3f(a) for a in _AXES))
        return True, si, layer_bsdf, layer.error[first + prim]
