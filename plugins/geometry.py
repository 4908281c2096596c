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

Both also return each hit's error bound (:func:`hit_error`), by which
:mod:`.shading` moves secondary and shadow rays off the surface, tell which
sphere a light sits on (``surface_at``), and take a textured sphere's UV from
:func:`lat_long_uv`, which follows the spec at the poles and on the seam.
docs/numerics.md catalogues the hazards.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from .scene_state import memo
from .surfaces import shape_materials


#: float32's unit round-off, 2^-24
UNIT_ROUNDOFF = 2.0 ** -24
#: the error bound of a hit point, in round-offs of its shape's radius and of its centre's
#: largest coordinate (docs/numerics.md, "The error bound behind the ray offsets")
RADIUS_ULPS = 8
CENTRE_ULPS = 4


def hit_error(radius, centre):
    """How far a float32 hit point on a shape may lie off its surface, and how far off
    a float32 ray-shape test near it may place the surface.

    ``radius`` is the shape's radius (half its bounding box's widest side) and
    ``centre`` its centre's largest coordinate magnitude. Both terms come from
    rounding: re-projecting the point (``C + r·N``), subtracting the centre,
    and Mitsuba's float32 quadratic, whose self-intersection root is off by
    up to about two ulps of r (head-on rays) and an ulp of |C|. A floor sphere of
    radius 10^4 under the origin gets 7e-3, a unit sphere at 10^4 2.4e-3, a
    unit sphere at the origin 5e-7.
    """
    return (RADIUS_ULPS * UNIT_ROUNDOFF) * radius + (CENTRE_ULPS * UNIT_ROUNDOFF) * centre


def lat_long_uv(n, x_axis, y_axis, z_axis):
    """The article's lat/long mapping of the unit normal ``n`` in a sphere's frame, as
    Mitsuba's sphere UV: ``u = atan2(y, x)/2π``, ``v = acos(z)/π`` (v = 0 at the north pole).

    The converter orients the frame so that this is the article's (u, 1 - v)
    (docs/CONTRACTS.md). atan2 needs no division by sin(phi), and its two
    singular sets follow the spec: at a pole (|z| = 1 in float32: sin(phi) = 0)
    u = 0, and on the seam (y = 0, x > 0: theta = 0 and (Vn × Ve)·Vp = 0, the
    "otherwise" case) u = 1. A camera on the axis sees a pole pixel, and one in
    the seam's plane a whole row of seam pixels.
    """
    x, y, z = dr.dot(n, x_axis), dr.dot(n, y_axis), dr.dot(n, z_axis)
    angle = dr.atan2(y, x)   # (-π, π]
    u = dr.select(angle > 0, angle, angle + dr.two_pi) * dr.inv_two_pi
    pole = dr.abs(z) >= 1
    return mi.Point2f(dr.select(pole, 0.0, u), dr.safe_acos(z) * dr.inv_pi)


@dataclass
class ShapeNumbers:
    """Per shape of ``scene.shapes()`` (in that order): bounding sphere and error bound.

    Centre and radius come from the bounding boxes (exact to a float32 ulp of
    |C| + r for a sphere: within the error bound); a frame (rows: the local x,
    y and z axes) is the ``to_world`` rotation of a sphere whose colour varies
    over it, which also gives that sphere's centre and radius.
    """
    centre: np.ndarray       # 3×N
    radius: np.ndarray       # N
    error: np.ndarray        # N, :func:`hit_error`
    sphere: np.ndarray       # N, whether the shape is a sphere
    frames: dict             # {shape index: 3×3 frame}
    rows: np.ndarray | None  # N, each shape's instance ID (JIT variants)
    bsdf: np.ndarray | None  # N, the instance ID of each shape's BSDF (JIT variants)


def _shape_types(scene) -> np.ndarray:
    """Each shape's ``mi.ShapeType`` as an integer (one gather in the JIT variants)."""
    def build():
        if dr.is_jit_v(mi.Float):
            return np.asarray(scene.shapes_dr().shape_type(), np.uint32).reshape(-1)
        return np.array([int(shape.shape_type()) for shape in scene.shapes()], np.uint32)
    return memo(scene, "shape types", build)


def shape_numbers(scene, need_uv: bool) -> ShapeNumbers:
    """The :class:`ShapeNumbers` of ``scene``, computed once per scene state."""
    return memo(scene, ("shape numbers", need_uv), lambda: _shape_numbers(scene, need_uv))


def _shape_numbers(scene, need_uv: bool) -> ShapeNumbers:
    # Mitsuba hands over the shapes' types and instance IDs as arrays; a bounding box
    # takes a call per shape (a vectorized call on the shapes would trace each of them,
    # several µs apiece), read into numpy without converting each box on its own.
    shapes = scene.shapes()
    corners = np.fromiter(itertools.chain.from_iterable((*box.min, *box.max) for box in
                                                        (shape.bbox() for shape in shapes)),
                          np.float64, 6 * len(shapes)).reshape(-1, 2, 3)
    low, high = corners[:, 0].T, corners[:, 1].T
    centre, radius = (low + high) / 2, (high - low).max(axis=0, initial=0.0) / 2
    sphere = _shape_types(scene) == int(mi.ShapeType.Sphere)
    materials = shape_materials(scene)
    rows = bsdf = None
    if dr.is_jit_v(mi.Float) and shapes:
        rows = np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1)
        bsdf = materials.key
    frames = {}
    if need_uv:
        for index in np.flatnonzero(materials.textured & sphere).tolist():
            matrix = np.array(mi.traverse(shapes[index])["to_world"].matrix, np.float64).reshape(4, 4)
            centre[:, index], radius[index] = matrix[:3, 3], np.linalg.norm(matrix[:3, 0])
            frames[index] = (matrix[:3, :3] / radius[index]).T
    error = hit_error(radius, np.abs(centre).max(axis=0, initial=0.0))
    return ShapeNumbers(centre, radius, error, sphere, frames, rows, bsdf)


class _SurfacesNear:
    """Which sphere passes through a point, to within its error bound."""

    def __init__(self, centre, radius, error, sphere):
        self.centre, self.radius, self.error = centre[:, sphere], radius[sphere], error[sphere]
        self._answers = {}   # a light's position -> its answer: the lights ask at every render

    def surface_at(self, point):
        """``(error, normal)`` of the sphere that ``point`` lies on (within twice its error
        bound; the one with the largest bound if several do), ``(0, 0)`` if none."""
        key = tuple(float(x) for x in np.asarray(point, np.float64).reshape(-1))
        if key not in self._answers:
            self._answers[key] = self._surface_at(key)
        return self._answers[key]

    def _surface_at(self, point):
        point = np.asarray(point, np.float64).reshape(3, 1)
        offset = point - self.centre
        distance = np.linalg.norm(offset, axis=0)
        near = np.flatnonzero(np.abs(distance - self.radius) <= 2 * self.error)
        if not len(near):
            return 0.0, (0.0, 0.0, 0.0)
        k = near[np.argmax(self.error[near])]
        return float(self.error[k]), tuple(offset[:, k] / distance[k])


def hit_finder(scene, need_uv: bool):
    """The fastest exact way to intersect ``scene`` in the current variant."""
    if dr.is_jit_v(mi.Float) and SphereHits.applies(scene):
        return SphereHits(scene, need_uv)
    return MitsubaHits(scene, need_uv)


def blocked(scene, ray, active):
    """Whether a surface crosses the segment ``ray`` (from its origin to ``ray.maxt``).

    In the JIT variants Mitsuba's ``ray_test`` on a sphere solves the textbook
    quadratic in float32, whose discriminant ``B² - 4AC`` loses every digit
    when the ray starts a few thousand radii from the sphere (a small ball
    near a distant light casts a shadow of noise). Its ``ray_intersect_preliminary``
    first moves the origin to the plane through the sphere's centre and stays
    exact, so shadow rays use it. The scalar variants solve in float64 already.
    """
    if dr.is_jit_v(mi.Float):
        return scene.ray_intersect_preliminary(ray, coherent=False, active=active).is_valid()
    return scene.ray_test(ray, active)


def _frame_table(rows, frames, size: int):
    """``(mapped, axes)``: per row, whether the shape has a texture frame, and the frame's
    x, y and z axes as three opaque ``Vector3f`` tables (the identity where it has none)."""
    mapped, frame = np.zeros(size, bool), np.zeros((3, 3, size))
    frame[0, 0] = frame[1, 1] = frame[2, 2] = 1.0
    for k, shape_frame in frames.items():
        mapped[rows[k]], frame[:, :, rows[k]] = True, shape_frame
    axes = [mi.Vector3f(frame[axis]) for axis in range(3)]
    mapped = mi.Bool(mapped)
    dr.make_opaque(mapped, *axes)
    return mapped, axes


class MitsubaHits:
    """Surface interactions from Mitsuba's own ``ray_intersect`` (any shape).

    Textured spheres get their UV from :func:`lat_long_uv` rather than from
    Mitsuba, whose UV goes through the inverse of ``to_world`` and so misses the
    poles and the seam by a rounding error.
    """

    def __init__(self, scene, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        self.flags = mi.RayFlags.Minimal | (mi.RayFlags.UV if need_uv else mi.RayFlags.Empty)
        self.vectorized = dr.is_jit_v(mi.Float)
        tables = memo(scene, ("interaction tables", need_uv), lambda: self._tables(scene, need_uv))
        self.surface_at = tables["surface_at"]
        if self.vectorized:
            self._error, self._mapped, self._frame = tables["error"], tables["mapped"], tables["frame"]
        else:
            self._shapes = tables["shapes"]

    def _tables(self, scene, need_uv):
        numbers = shape_numbers(scene, need_uv)
        tables = {"surface_at": _SurfacesNear(numbers.centre, numbers.radius, numbers.error,
                                              numbers.sphere).surface_at}
        if not self.vectorized:   # the scalar variant hands out the same shape objects each time
            frames = numbers.frames
            tables["shapes"] = {id(shape): (float(numbers.error[k]), [mi.Vector3f(axis) for axis in frames[k]]
                                            if k in frames else None)
                                for k, shape in enumerate(scene.shapes())}
            return tables
        rows = numbers.rows if numbers.rows is not None else np.zeros(0, np.int64)
        size = int(rows.max(initial=0)) + 1
        error = np.zeros(size)
        error[rows] = numbers.error
        tables["error"] = mi.Float(error)
        dr.make_opaque(tables["error"])
        tables["mapped"], tables["frame"] = _frame_table(rows, numbers.frames, size)
        return tables

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)``; ``bsdf`` is the BSDF's instance ID (JIT) or the BSDF
        itself (scalar, only meaningful where ``hit``); ``error`` bounds how far ``si.p``
        lies off the surface (:func:`hit_error`)."""
        si = self.scene.ray_intersect(ray, ray_flags=self.flags, coherent=coherent)
        hit = si.is_valid()
        if not self.vectorized:
            if not hit:
                return hit, si, None, 0.0
            error, frame = self._shapes[id(si.shape)]
            if frame is not None:
                si.uv = lat_long_uv(si.n, *frame)
            return hit, si, si.bsdf(), error
        row = dr.reinterpret_array(mi.UInt32, si.shape)
        if self.need_uv:
            mapped = dr.gather(mi.Bool, self._mapped, row, hit)
            frame = [dr.gather(mi.Vector3f, axis, row, mapped) for axis in self._frame]
            si.uv = dr.select(mapped, lat_long_uv(si.n, *frame), si.uv)
        return hit, si, dr.reinterpret_array(mi.UInt32, si.bsdf()), dr.gather(mi.Float, self._error, row, hit)


class SphereHits:
    """Nearest hits on an all-sphere scene without Mitsuba's per-shape call (JIT variants)."""

    @staticmethod
    def applies(scene) -> bool:
        types = _shape_types(scene)
        return bool(len(types)) and bool((types == int(mi.ShapeType.Sphere)).all())

    def __init__(self, scene, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        tables = memo(scene, ("sphere tables", need_uv), lambda: self._tables(scene, need_uv))
        self.surface_at = tables["surface_at"]
        self._centre, self._radius, self._error, self._bsdf, self._frame = tables["spheres"]

    @staticmethod
    def _tables(scene, need_uv):
        numbers = shape_numbers(scene, need_uv)
        rows = numbers.rows
        size = int(rows.max()) + 1
        centre, radius, error = np.zeros((3, size)), np.ones(size), np.zeros(size)
        bsdf = np.zeros(size, np.uint32)
        centre[:, rows], radius[rows], error[rows], bsdf[rows] = \
            numbers.centre, numbers.radius, numbers.error, numbers.bsdf
        table = (mi.Point3f(centre), mi.Float(radius), mi.Float(error), mi.UInt32(bsdf))
        dr.make_opaque(*table)
        _, frame = _frame_table(rows, numbers.frames, size)
        return {"surface_at": _SurfacesNear(numbers.centre, numbers.radius, numbers.error,
                                            numbers.sphere).surface_at,
                "spheres": (*table, frame)}

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` as :meth:`MitsubaHits.intersect`, ``bsdf`` an instance ID."""
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
            si.uv = lat_long_uv(si.n, *(dr.gather(mi.Vector3f, axis, row, hit) for axis in self._frame))
        return hit, si, dr.gather(mi.UInt32, self._bsdf, row, hit), dr.gather(mi.Float, self._error, row, hit)
