"""Giant spheres intersected in float64, from the exact values the converter hands over.

Why. Mitsuba keeps a sphere's center and radius in float32 and, in the JIT
variants, intersects it in float32 in world space: a floor sphere of radius
10^6 is placed to ~0.1, one of 10^7 to ~1, while balls of radius 0.3 stand
on it. No ray offset can be right there: one that clears the floor's
uncertainty (8 ulps of the radius) lifts shadow and reflection rays over the
balls, so contact shadows and reflections break up (docs/numerics.md,
hazard 14). But such a sphere is known exactly in the scene file, and a
float64 test of the few giant ones costs a handful of operations per ray.

How. The converter lists the giant spheres (converter/giants.py) in the
integrator's ``exact_spheres`` property: each shape's id, its center (in the
scene's frame, subtracted in float64) and its radius, as float64 text.
:class:`GiantHits` traces every *other* shape through Mitsuba, on a scene of
those shapes alone (:meth:`~whitted.plugins.scene.tables.SceneTables.rest`: the same shape objects, so the same
instance IDs, BSDFs and tables), and intersects the giant spheres itself in
float64 (``Float64`` in the JIT variants, Python floats in the scalar ones)
with the stable discriminant r² − |f − (f·d)d|² (hazard 4b) and the
cancellation-free roots; the nearer of the two answers wins. The hit point
``o + t·d`` and the normal ``(p − C)/r`` are computed in float64 and rounded
to float32, so the point lies within an ulp of its own coordinates of the
exact surface, whatever the radius: its error bound (:func:`point_error`) is
relative to the point, not to the radius, and the ray offsets shrink from
ulps of 10^7 to ulps of the scene near the point.

A scene whose integrator lists no exact spheres never reaches this module.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.float32 import UNIT_ROUNDOFF

from ..scene.materials import bsdf_key
from . import off
from .hits import lat_long_uv, no_blocker, no_hits

#: the error bound of a point rounded from float64 to float32, in round-offs of its largest
#: coordinate (half an ulp per coordinate, with the margin the other bounds keep)
POINT_ULPS = 8
#: float64's unit round-off times the few operations of the float64 test: what it adds, in
#: units of the sphere's size (radius plus largest center coordinate)
FLOAT64_ERROR = 16 * 2.0 ** -53


def point_error(p, size):
    """How far a hit point computed in float64 and rounded to float32 may lie off its sphere
    (``size``: radius plus the center's largest coordinate; its float64 test's share)."""
    largest = dr.maximum(dr.maximum(dr.abs(p.x), dr.abs(p.y)), dr.abs(p.z))
    return (POINT_ULPS * UNIT_ROUNDOFF) * largest + FLOAT64_ERROR * size


def _roots(o, d, center, radius):
    """``(t, valid)``: the nearest root t > 0 of |o + t·d − C| = r, in float64 (``o``, ``d``,
    ``center`` float64 vectors; ``d`` need not be unit)."""
    f = o - center
    a = dr.squared_norm(d)
    b = dr.dot(f, d)
    h = radius * radius - dr.squared_norm(f - (b / a) * d)   # the discriminant over a
    root = dr.sqrt(dr.maximum(a * h, 0.0))
    q = -(b + dr.mulsign(root, b))
    distance = dr.norm(f)
    c = (distance - radius) * (distance + radius)            # |f|² − r², without cancellation
    t0, t1 = q / a, c / q
    near, far = dr.minimum(t0, t1), dr.maximum(t0, t1)
    t = dr.select(near > 0, near, far)
    return t, (h >= 0) & (t > 0) & (q != 0)


class _Giant:
    """One giant sphere: its exact center and radius, its shape's BSDF and texture frame."""

    def __init__(self, shape, center, radius, jit: bool):
        self.center_tuple, self.radius = center, radius
        self.size = radius + max(abs(c) for c in center)
        if jit:
            self.center = dr.opaque(mi.Point3d, center)
            self.radius64 = dr.opaque(mi.Float64, radius)
            self.bsdf = dr.opaque(mi.UInt32, bsdf_key(shape.bsdf()))
        else:
            self.center, self.radius64, self.bsdf = mi.Point3d(center), radius, shape.bsdf()
        self.frame = None
        if shape.bsdf().color.is_spatially_varying():   # a textured sphere: Mitsuba's UV frame
            matrix = np.array(mi.traverse(shape)["to_world"].matrix, np.float64).reshape(4, 4)
            axes = (matrix[:3, :3] / np.linalg.norm(matrix[:3, 0])).T
            self.frame = [mi.Vector3f(axis) for axis in axes]


class GiantHits:
    """Nearest hits, shadow tests and light surfaces for a scene with giant spheres: the
    ``inner`` finder's answer for the other shapes (None: there are none), the float64 test
    for the giant ones (see the module docstring). A :class:`.hits.HitFinder`."""

    def __init__(self, scene, inner, need_uv: bool, giants, primitives):
        """``giants``: ``(shape index, center, radius)`` of each giant sphere; ``primitives``:
        the scene's (:class:`~whitted.plugins.scene.primitives.Primitives`)."""
        self.jit = dr.is_jit_v(mi.Float)
        shapes = scene.shapes()
        self.giants = [_Giant(shapes[k], center, radius, self.jit) for k, center, radius in giants]
        self.inner = inner
        # the other shapes' surfaces: a giant's float32 bound (ulps of its radius) would put
        # lights metres above a floor of radius 10^7 on it
        self.others = primitives.without([k for k, _, _ in giants])
        self.need_uv = need_uv

    # -- lights on surfaces ----------------------------------------------------------------------

    def surface_at(self, point):
        """As :meth:`.hits.HitFinder.surface_at`; a giant sphere's bound is the point's, and
        only its exact surface counts."""
        p = np.asarray(point, np.float64).reshape(-1)
        for giant in self.giants:
            offset = p - np.asarray(giant.center_tuple)
            distance = float(np.linalg.norm(offset))
            error = POINT_ULPS * UNIT_ROUNDOFF * float(np.abs(p).max()) + FLOAT64_ERROR * giant.size
            if abs(distance - giant.radius) <= 2 * error:
                return error, tuple(offset / distance)
        return self.others.surface_at(point)

    # -- shadow segments -------------------------------------------------------------------------

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (:meth:`.hits.HitFinder.blocked`)."""
        shadowed = self.inner.blocked(ray, active) if self.inner is not None else no_blocker()
        if not self.jit and (shadowed or not active):
            return shadowed
        o, d, maxt = mi.Point3d(ray.o), mi.Vector3d(ray.d), mi.Float64(ray.maxt) if self.jit else float(ray.maxt)
        for giant in self.giants:
            t, valid = _roots(o, d, giant.center, giant.radius64)
            shadowed = shadowed | (valid & (t < maxt))
        return shadowed & active

    # -- nearest hits ----------------------------------------------------------------------------

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` (:meth:`.hits.HitFinder.intersect`)."""
        hit, si, bsdf, error = self.inner.intersect(ray, coherent) if self.inner is not None else no_hits()
        o, d = mi.Point3d(ray.o), mi.Vector3d(ray.d)
        if not self.jit:
            return self._scalar(ray, o, d, hit, si, bsdf, error)
        best = dr.select(hit, mi.Float64(si.t), dr.inf)
        which = mi.Int32(-1)
        for k, giant in enumerate(self.giants):
            t, valid = _roots(o, d, giant.center, giant.radius64)
            nearer = valid & (t < best)
            best, which = dr.select(nearer, t, best), dr.select(nearer, k, which)
        giant_hit = which >= 0
        if off(giant_hit):
            return hit, si, bsdf, error
        center, radius = mi.Point3d(0.0), mi.Float64(1.0)
        size, bsdf_giant = mi.Float(0.0), mi.UInt32(0)
        for k, giant in enumerate(self.giants):
            this = which == k
            center = dr.select(this, giant.center, center)
            radius = dr.select(this, giant.radius64, radius)
            size = dr.select(this, giant.size, size)
            bsdf_giant = dr.select(this, giant.bsdf, bsdf_giant)
        p = dr.fma(d, best, o)
        si.p = dr.select(giant_hit, mi.Point3f(p), si.p)
        si.n = dr.select(giant_hit, mi.Vector3f((p - center) / radius), si.n)
        si.t = dr.select(giant_hit, mi.Float(best), si.t)
        if self.need_uv:
            for k, giant in enumerate(self.giants):
                if giant.frame is not None:
                    si.uv = dr.select(which == k, lat_long_uv(si.n, *giant.frame), si.uv)
        error = dr.select(giant_hit, point_error(si.p, size), error)
        return hit | giant_hit, si, dr.select(giant_hit, bsdf_giant, bsdf), error

    def _scalar(self, ray, o, d, hit, si, bsdf, error):
        best, nearest = (float(si.t) if hit else float("inf")), None
        for giant in self.giants:
            t, valid = _roots(o, d, giant.center, giant.radius64)
            if valid and t < best:
                best, nearest = t, giant
        if nearest is None:
            return hit, si, bsdf, error
        if not hit:
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.time, si.wavelengths = ray.time, ray.wavelengths
        p = o + d * best
        si.p, si.n, si.t = mi.Point3f(p), mi.Vector3f((p - nearest.center) / nearest.radius), best
        if self.need_uv and nearest.frame is not None:
            si.uv = lat_long_uv(si.n, *nearest.frame)
        return True, si, nearest.bsdf, point_error(si.p, nearest.size)
