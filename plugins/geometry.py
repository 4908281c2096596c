"""Where a ray hits: the nearest surface's point, normal, UV and BSDF.

:func:`hit_finder` picks one of two ways to the same answer.

``MitsubaHits`` asks Mitsuba's ``scene.ray_intersect`` for a surface
interaction. It works for every shape, but in the JIT variants the
interaction is computed by a call on the hit shape, and Dr.Jit traces that
call once per shape *instance* for every kernel: about 25 µs per sphere per
level of the ray tree, a quarter of a second per level for 10 000 spheres.

``SphereHits`` serves scenes made only of spheres in the JIT variants:
``sphere`` shapes, and ``ellipsoids`` shapes of spheres (the loader's fast
path for sealed spheres, whitted/sealed.py). Embree still finds the nearest
hit (``ray_intersect_preliminary``: a distance, a shape and a primitive, no
call), and the rest comes from a per-primitive table, computed exactly
as Mitsuba's sphere computes it: the hit is re-projected onto the sphere
(``N = normalize(o + t·d - C)``, ``P = C + r·N``) and the UV is the direction's
longitude and colatitude in the sphere's own frame (``u = atan2(y, x)/2π``,
``v = acos(z)/π``), which the converter orients so that UV is the article's
mapping. Center and radius come from the sphere's bounding box (exact to a
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

from whitted.float32 import UNIT_ROUNDOFF, hit_error  # noqa: F401  (re-exported)

from .scene_state import memo
from .surfaces import shape_materials


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
    """Per primitive of ``scene.shapes()``: bounding sphere and error bound.

    Primitives are listed shape by shape, in that order. A ``sphere`` shape is
    one primitive; an ``ellipsoids`` shape is one primitive per ellipsoid,
    which is a sphere when its three scales are equal and it is not rotated
    (the loader writes sealed spheres that way: whitted/sealed.py).

    Center and radius come from the bounding boxes (exact to a float32 ulp of
    |C| + r for a sphere: within the error bound), and an ellipsoid's from its
    own center and largest scale (its box: the center ± that radius); a frame
    (rows: the local x, y and z axes) is the ``to_world`` rotation of a sphere
    whose color varies over it, which also gives that sphere's center and radius.
    """
    low: np.ndarray          # 3×P, bounding box
    high: np.ndarray         # 3×P
    center: np.ndarray       # 3×P
    radius: np.ndarray       # P
    error: np.ndarray        # P, :func:`hit_error`
    sphere: np.ndarray       # P, whether the primitive is a sphere
    frames: dict             # {primitive index: 3×3 frame}
    first: np.ndarray        # N, each shape's first primitive
    rows: np.ndarray | None  # N, each shape's instance ID (JIT variants)
    bsdf: np.ndarray | None  # N, the instance ID of each shape's BSDF (JIT variants)

    @property
    def counts(self) -> np.ndarray:
        """Each shape's number of primitives here (1 but for ellipsoids shapes)."""
        return np.diff(np.append(self.first, len(self.radius)))

    def slots(self):
        """``(slot, base, size)``: where the JIT tables keep each primitive. A shape of one
        primitive here (a sphere, a mesh...) has its instance ID as its slot, whatever
        primitive of it a ray hits; the primitives of ellipsoids shapes follow all of those,
        and ``base`` (per instance ID, None when there are none) says where they start, so
        that a hit's slot is ``base[row] + prim_index`` for them (:func:`_slot`)."""
        rows = self.rows if self.rows is not None else np.zeros(0, np.int64)
        size = int(rows.max(initial=0)) + 1
        counts = self.counts
        many = np.flatnonzero(counts != 1)
        if not len(many):
            return rows, None, size
        base = np.arange(size, dtype=np.int64)
        base[rows[many]] = size + np.concatenate([[0], np.cumsum(counts[many])[:-1]])
        slot = np.repeat(base[rows], counts) + (np.arange(len(self.radius)) - np.repeat(self.first, counts))
        expanded = np.zeros(size, bool)
        expanded[rows[many]] = True
        return slot, (base, expanded), size + int(counts[many].sum())


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


def ellipsoid_numbers(shape):
    """``(center, radius, sphere)`` of an ``ellipsoids`` shape's primitives: 3×M centers, M
    radii (the largest scale times the extent) and whether each is a sphere (equal scales,
    no rotation, no per-ellipsoid extent)."""
    params = mi.traverse(shape)
    data = np.asarray(params["data"], np.float64).reshape(-1, 10)
    scales = data[:, 3:6] * float(params["extent"])
    sphere = (scales[:, 0] == scales[:, 1]) & (scales[:, 1] == scales[:, 2]) & (data[:, 6:9] == 0).all(axis=1)
    if params["extent_adaptive_clamping"]:
        sphere[:] = False
    return data[:, :3].T.copy(), scales.max(axis=1), sphere


def _shape_numbers(scene, need_uv: bool) -> ShapeNumbers:
    # Mitsuba hands over the shapes' types and instance IDs as arrays; a bounding box
    # takes a call per shape (a vectorized call on the shapes would trace each of them,
    # several µs apiece), read into numpy without converting each box on its own.
    shapes = scene.shapes()
    corners = np.fromiter(itertools.chain.from_iterable((*box.min, *box.max) for box in
                                                        (shape.bbox() for shape in shapes)),
                          np.float64, 6 * len(shapes)).reshape(-1, 2, 3)
    low, high = corners[:, 0].T, corners[:, 1].T
    center, radius = (low + high) / 2, (high - low).max(axis=0, initial=0.0) / 2
    types = _shape_types(scene)
    sphere = types == int(mi.ShapeType.Sphere)
    materials = shape_materials(scene)
    rows = bsdf = None
    if dr.is_jit_v(mi.Float) and shapes:
        rows = np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1)
        bsdf = materials.key
    frames = {}
    if need_uv:
        for index in np.flatnonzero(materials.textured & sphere).tolist():
            matrix = np.array(mi.traverse(shapes[index])["to_world"].matrix, np.float64).reshape(4, 4)
            center[:, index], radius[index] = matrix[:3, 3], np.linalg.norm(matrix[:3, 0])
            frames[index] = (matrix[:3, :3] / radius[index]).T
    first = np.arange(len(shapes))
    groups = np.flatnonzero(types == int(mi.ShapeType.Ellipsoids))
    if len(groups):   # each ellipsoid shape's one entry becomes one per primitive
        parts, counts, start = [], np.ones(len(shapes), np.int64), 0
        for k in groups.tolist():
            c, r, s = ellipsoid_numbers(shapes[k])
            parts += [(low[:, start:k], high[:, start:k], center[:, start:k], radius[start:k], sphere[start:k]),
                      (c - r, c + r, c, r, s)]
            counts[k], start = len(r), k + 1
        parts.append((low[:, start:], high[:, start:], center[:, start:], radius[start:], sphere[start:]))
        low, high, center, radius, sphere = (np.concatenate(column, axis=-1) for column in zip(*parts))
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        frames = {int(first[k]): frame for k, frame in frames.items()}
    error = hit_error(radius, np.abs(center).max(axis=0, initial=0.0))
    return ShapeNumbers(low, high, center, radius, error, sphere, frames, first, rows, bsdf)


class _SurfacesNear:
    """Which sphere passes through a point, to within its error bound."""

    def __init__(self, center, radius, error, sphere):
        self.center, self.radius, self.error = center[:, sphere], radius[sphere], error[sphere]
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
        offset = point - self.center
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
    first moves the origin to the plane through the sphere's center and stays
    exact, so shadow rays use it. The scalar variants solve in float64 already.
    """
    if dr.is_jit_v(mi.Float):
        return scene.ray_intersect_preliminary(ray, coherent=False, active=active).is_valid()
    return scene.ray_test(ray, active)


def _frame_table(slots, frames, size: int):
    """``(mapped, axes)``: per slot (:meth:`ShapeNumbers.slots`), whether the primitive has
    a texture frame, and the frame's x, y and z axes as three opaque ``Vector3f`` tables
    (the identity where it has none)."""
    mapped, frame = np.zeros(size, bool), np.zeros((3, 3, size))
    frame[0, 0] = frame[1, 1] = frame[2, 2] = 1.0
    for k, prim_frame in frames.items():
        mapped[slots[k]], frame[:, :, slots[k]] = True, prim_frame
    axes = [mi.Vector3f(frame[axis]) for axis in range(3)]
    mapped = mi.Bool(mapped)
    dr.make_opaque(mapped, *axes)
    return mapped, axes


def _base_table(base):
    """The opaque tables of :meth:`ShapeNumbers.slots`' ``base``: where each instance ID's
    primitives start, and whether they are listed one by one (None when no shape's are)."""
    if base is None:
        return None
    start, expanded = mi.UInt32(base[0].astype(np.uint32)), mi.Bool(base[1])
    dr.make_opaque(start, expanded)
    return start, expanded


def _slot(base, row, prim_index, active):
    """A hit's slot in the primitive tables: its shape's instance ID ``row`` when every shape
    is one primitive there, else where its shape's primitives start, plus ``prim_index``
    where they are listed one by one."""
    if base is None:
        return row
    start, expanded = base
    return dr.gather(mi.UInt32, start, row, active) + \
        dr.select(dr.gather(mi.Bool, expanded, row, active), prim_index, 0)


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
            self._error, self._mapped, self._frame, self._base = \
                tables["error"], tables["mapped"], tables["frame"], tables["base"]
        else:
            self._shapes, self._errors = tables["shapes"], tables["errors"]

    def _tables(self, scene, need_uv):
        numbers = shape_numbers(scene, need_uv)
        tables = {"surface_at": _SurfacesNear(numbers.center, numbers.radius, numbers.error,
                                              numbers.sphere).surface_at}
        if not self.vectorized:   # the scalar variant hands out the same shape objects each time
            frames, first, many = numbers.frames, numbers.first.tolist(), (numbers.counts != 1).tolist()
            tables["errors"] = numbers.error.tolist()
            tables["shapes"] = {id(shape): (first[k], many[k], [mi.Vector3f(axis) for axis in frames[first[k]]]
                                            if first[k] in frames else None)
                                for k, shape in enumerate(scene.shapes())}
            return tables
        slots, base, size = numbers.slots()
        error = np.zeros(size)
        error[slots] = numbers.error
        tables["error"] = mi.Float(error)
        dr.make_opaque(tables["error"])
        tables["mapped"], tables["frame"] = _frame_table(slots, numbers.frames, size)
        tables["base"] = _base_table(base)
        return tables

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (:func:`blocked`)."""
        return blocked(self.scene, ray, active)

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)``; ``bsdf`` is the BSDF's instance ID (JIT) or the BSDF
        itself (scalar, only meaningful where ``hit``); ``error`` bounds how far ``si.p``
        lies off the surface (:func:`hit_error`)."""
        si = self.scene.ray_intersect(ray, ray_flags=self.flags, coherent=coherent)
        hit = si.is_valid()
        if not self.vectorized:
            if not hit:
                return hit, si, None, 0.0
            first, many, frame = self._shapes[id(si.shape)]
            if frame is not None:
                si.uv = lat_long_uv(si.n, *frame)
            return hit, si, si.bsdf(), self._errors[first + int(si.prim_index) if many else first]
        slot = _slot(self._base, dr.reinterpret_array(mi.UInt32, si.shape), si.prim_index, hit)
        if self.need_uv:
            mapped = dr.gather(mi.Bool, self._mapped, slot, hit)
            frame = [dr.gather(mi.Vector3f, axis, slot, mapped) for axis in self._frame]
            si.uv = dr.select(mapped, lat_long_uv(si.n, *frame), si.uv)
        return hit, si, dr.reinterpret_array(mi.UInt32, si.bsdf()), dr.gather(mi.Float, self._error, slot, hit)


class SphereHits:
    """Nearest hits on a scene of spheres without Mitsuba's per-shape call (JIT variants):
    ``sphere`` shapes, and ``ellipsoids`` shapes whose every primitive is a sphere."""

    @staticmethod
    def applies(scene) -> bool:
        types = _shape_types(scene)
        if not len(types):
            return False
        ellipsoids = types == int(mi.ShapeType.Ellipsoids)
        if not ((types == int(mi.ShapeType.Sphere)) | ellipsoids).all():
            return False
        shapes = scene.shapes()
        return memo(scene, "ellipsoids are spheres", lambda: all(
            ellipsoid_numbers(shapes[k])[2].all() for k in np.flatnonzero(ellipsoids).tolist()))

    def __init__(self, scene, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        tables = memo(scene, ("sphere tables", need_uv), lambda: self._tables(scene, need_uv))
        self.surface_at = tables["surface_at"]
        self._center, self._radius, self._error, self._bsdf, self._frame, self._base = tables["spheres"]

    @staticmethod
    def _tables(scene, need_uv):
        numbers = shape_numbers(scene, need_uv)
        slots, base, size = numbers.slots()
        counts = numbers.counts
        center, radius, error = np.zeros((3, size)), np.ones(size), np.zeros(size)
        bsdf = np.zeros(size, np.uint32)
        center[:, slots], radius[slots], error[slots], bsdf[slots] = \
            numbers.center, numbers.radius, numbers.error, np.repeat(numbers.bsdf, counts)
        table = (mi.Point3f(center), mi.Float(radius), mi.Float(error), mi.UInt32(bsdf))
        dr.make_opaque(*table)
        _, frame = _frame_table(slots, numbers.frames, size)
        return {"surface_at": _SurfacesNear(numbers.center, numbers.radius, numbers.error,
                                            numbers.sphere).surface_at,
                "spheres": (*table, frame, _base_table(base))}

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (:func:`blocked`)."""
        return blocked(self.scene, ray, active)

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` as :meth:`MitsubaHits.intersect`, ``bsdf`` an instance ID."""
        pi = self.scene.ray_intersect_preliminary(ray, coherent=coherent)
        hit = pi.is_valid()
        slot = _slot(self._base, dr.reinterpret_array(mi.UInt32, pi.shape), pi.prim_index, hit)
        center = dr.gather(mi.Point3f, self._center, slot, hit)
        radius = dr.gather(mi.Float, self._radius, slot, hit)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.t = dr.select(hit, pi.t, dr.inf)
        si.n = dr.normalize(ray(pi.t) - center)
        si.p = dr.fma(si.n, radius, center)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            si.uv = lat_long_uv(si.n, *(dr.gather(mi.Vector3f, axis, slot, hit) for axis in self._frame))
        return hit, si, dr.gather(mi.UInt32, self._bsdf, slot, hit), dr.gather(mi.Float, self._error, slot, hit)
