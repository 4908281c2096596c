"""Where a ray hits: the nearest surface's point, normal, UV and BSDF.

:func:`hit_finder` picks one of two ways to the same answer.

``MitsubaHits`` asks Mitsuba's ``scene.ray_intersect`` for a surface
interaction. It works for every shape, but in the JIT variants the
interaction is computed by a call on the hit shape, and Dr.Jit traces that
call once per shape *instance* for every kernel: about 25 µs per sphere per
level of the ray tree, a quarter of a second per level for 10 000 spheres.

``SphereHits`` serves scenes made only of spheres in the JIT variants. Embree
still finds the nearest hit (``ray_intersect_preliminary``: a distance and a
shape, no call), and the rest comes from a per-shape table, computed exactly
as Mitsuba's sphere computes it: the hit is re-projected onto the sphere
(``N = normalize(o + t·d - C)``, ``P = C + r·N``) and the UV is the direction's
longitude and colatitude in the sphere's own frame (``u = atan2(y, x)/2π``,
``v = acos(z)/π``), which the converter orients so that UV is the article's
mapping. Centre and radius come from the sphere's bounding box (exact to a
float32 ulp of |C| + r, the precision Mitsuba's own float32 hit has), and
textured spheres' frames from their ``to_world`` transform.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np


def hit_finder(scene, need_uv: bool):
    """The fastest exact way to intersect ``scene`` in the current variant."""
    if dr.is_jit_v(mi.Float) and SphereHits.applies(scene):
        return SphereHits(scene, need_uv)
    return MitsubaHits(scene, need_uv)


class MitsubaHits:
    """Surface interactions from Mitsuba's own ``ray_intersect`` (any shape)."""

    def __init__(self, scene, need_uv: bool):
        self.scene = scene
        self.flags = mi.RayFlags.Minimal | (mi.RayFlags.UV if need_uv else mi.RayFlags.Empty)
        self.vectorized = dr.is_jit_v(mi.Float)

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf)``; ``bsdf`` is the BSDF's instance ID (JIT) or the BSDF itself
        (scalar, only meaningful where ``hit``)."""
        si = self.scene.ray_intersect(ray, ray_flags=self.flags, coherent=coherent)
        hit = si.is_valid()
        if self.vectorized:
            return hit, si, dr.reinterpret_array(mi.UInt32, si.bsdf())
        return hit, si, si.bsdf() if hit else None


class SphereHits:
    """Nearest hits on an all-sphere scene without Mitsuba's per-shape call (JIT variants)."""

    @staticmethod
    def applies(scene) -> bool:
        shapes = scene.shapes()
        return bool(shapes) and all(s.class_name() == "Sphere" for s in shapes)

    def __init__(self, scene, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        shapes = scene.shapes()
        ids = np.array(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1)
        bsdf_ids = np.array(dr.reinterpret_array(mi.UInt32, scene.shapes_dr().bsdf()), np.uint32).reshape(-1)
        size = int(ids.max()) + 1
        centre = np.zeros((3, size))
        radius = np.ones(size)
        frame = np.zeros((3, 3, size))   # columns: the sphere's local x, y, z axes
        frame[0, 0] = frame[1, 1] = frame[2, 2] = 1.0
        bsdf = np.zeros(size, np.uint32)
        for row, shape, bsdf_id in zip(ids, shapes, bsdf_ids):
            box = shape.bbox()
            low, high = np.array(box.min, np.float64), np.array(box.max, np.float64)
            centre[:, row] = (low + high) / 2
            radius[row] = (high[0] - low[0]) / 2
            bsdf[row] = bsdf_id
            if need_uv and shape.bsdf().color.is_spatially_varying():
                matrix = np.array(mi.traverse(shape)["to_world"].matrix, np.float64).reshape(4, 4)
                centre[:, row] = matrix[:3, 3]
                radius[row] = np.linalg.norm(matrix[:3, 0])
                frame[:, :, row] = (matrix[:3, :3] / radius[row]).T
        self._centre = mi.Point3f(centre)
        self._radius = mi.Float(radius)
        self._bsdf = mi.UInt32(bsdf)
        self._frame = [mi.Vector3f(frame[axis]) for axis in range(3)]
        dr.make_opaque(self._centre, self._radius, self._bsdf, *self._frame)

    def intersect(self, ray, coherent: bool):
        pi = self.scene.ray_intersect_preliminary(ray, coherent=coherent)
        hit = pi.is_valid()
        row = dr.reinterpret_array(mi.UInt32, pi.shape)
        centre = dr.gather(mi.Point3f, self._centre, row, hit)
        radius = dr.gather(mi.Float, self._radius, row, hit)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.t = dr.select(hit, pi.t, dr.inf)
        si.n = dr.normalize(ray(pi.t) - centre)
        si.p = dr.fma(si.n, radius, centre)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            x, y, z = (dr.dot(si.n, dr.gather(mi.Vector3f, axis, row, hit)) for axis in self._frame)
            u = dr.atan2(y, x) * dr.inv_two_pi
            si.uv = mi.Point2f(dr.select(u < 0, u + 1, u), dr.safe_acos(z) * dr.inv_pi)
        return hit, si, dr.gather(mi.UInt32, self._bsdf, row, hit)
