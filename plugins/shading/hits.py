"""Where a ray hits, and how rays leave a hit: point, normal, UV, BSDF and error bound.

:func:`hit_finder` picks one of two ways to the same answer.

``MitsubaHits`` asks Mitsuba's ``scene.ray_intersect`` for a surface
interaction. It works for every shape, but in the JIT variants the
interaction is computed by a call on the hit shape, and Dr.Jit traces that
call once per shape *instance* for every kernel, which a scene of thousands
of spheres feels at every level of the ray tree.

``SphereHits`` serves scenes made only of spheres in the JIT variants:
``sphere`` shapes, and ``ellipsoids`` shapes of spheres (the loader's fast
path for sealed spheres, whitted/sealed.py). Embree still finds the nearest
hit (``ray_intersect_preliminary``: a distance, a shape and a primitive, no
call), and the rest comes from the scene's primitive tables
(:mod:`whitted.plugins.scene.primitives`), computed exactly as Mitsuba's
sphere computes it: the hit is re-projected onto the sphere
(``N = normalize(o + t·d - C)``, ``P = C + r·N``) and the UV is the direction's
longitude and colatitude in the sphere's own frame (:func:`lat_long_uv`).

Both return each hit's error bound (:func:`whitted.float32.hit_error`), by
which :func:`offset_origin` moves secondary and shadow rays off the surface,
and tell which sphere a light sits on (``surface_at``). docs/numerics.md
catalogues the hazards.

Every finder, these two and the ones that wrap them (:class:`.layers.LayeredHits`,
:class:`.giants.GiantHits`), implements :class:`HitFinder`: the shader asks nothing else.
"""

from __future__ import annotations

from typing import Protocol

import drjit as dr
import mitsuba as mi

from ..scene.primitives import slot_of

#: a floor for squared distances: keeps 1/r and 1/r^2 finite when a light sits on the surface
TINY = 1e-30


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


# -- leaving a hit ---------------------------------------------------------------------------------

def offset_origin(p, n, error, d):
    """``p`` moved by ``error`` along the normal ``n``, to the side that ``d`` leaves towards.

    ``error`` bounds how far the float32 hit point ``p`` lies off its surface
    (:func:`whitted.float32.hit_error`): from the moved origin, neither the
    surface's true position nor the float32 ray-surface test can put the
    surface in front of the ray again (no acne). Mitsuba's own ``spawn_ray``
    moves by ``(1 + max|p_i|)·RayEpsilon`` instead, which is too little for a
    huge sphere under the origin and far too much in a scene of size 10^-3 or
    at 10^4 (docs/numerics.md).
    """
    return dr.fma(dr.mulsign(error, dr.dot(n, d)), n, p)


def spawn_ray(si, error, d):
    """The ray leaving the hit ``si`` along ``d``."""
    return mi.Ray3f(offset_origin(si.p, si.n, error, d), d)


def spawn_ray_to(si, error, target, target_error=0.0, target_normal=None):
    """The segment from the hit ``si`` to ``target``, which ends short of ``target``.

    When ``target`` sits on a surface (a light on a sphere), the end is moved
    off that surface by the surface's error bound ``target_error`` along its
    normal ``target_normal``, to the hit's side, as :func:`offset_origin` moves
    the start: the surface the light sits on does not hide it, even from
    segments that meet it at a grazing angle. Nothing else shortens the
    segment; Mitsuba's ``spawn_ray_to`` stops a fixed fraction of the length
    short, which lets a light inside a small sphere far away out of it.
    """
    if target_normal is not None:
        target = offset_origin(target, target_normal, target_error, si.p - target)
    origin = offset_origin(si.p, si.n, error, target - si.p)
    d = target - origin
    distance2 = dr.squared_norm(d)
    distance = dr.sqrt(distance2)
    ray = mi.Ray3f(origin, d * dr.rsqrt(dr.maximum(distance2, TINY)))  # no 0/0 at the target
    ray.maxt = distance
    return ray


def blocked(scene, ray, active, spheres: bool = True):
    """Whether a surface crosses the segment ``ray`` (from its origin to ``ray.maxt``);
    ``spheres``: whether ``scene`` holds ``sphere`` shapes.

    In the JIT variants Mitsuba's ``ray_test`` on a sphere shape solves the
    textbook quadratic in float32, whose discriminant ``B² - 4AC`` loses every
    digit when the ray starts a few thousand radii from the sphere (a small ball
    near a distant light casts a shadow of noise). Its ``ray_intersect_preliminary``
    first moves the origin to the plane through the sphere's center and stays
    exact, so shadow rays use it where there are sphere shapes. Elsewhere
    ``ray_test`` answers as the nearest hit would (an ``ellipsoids`` shape runs
    the same routine for both; triangles are watertight), and may stop at the
    first blocker. The scalar variants solve spheres in float64 already.
    """
    if spheres and dr.is_jit_v(mi.Float):
        return scene.ray_intersect_preliminary(ray, coherent=False, active=active).is_valid()
    return scene.ray_test(ray, coherent=False, active=active)


# -- finding hits ----------------------------------------------------------------------------------

class HitFinder(Protocol):
    """What the shader (:class:`.shader.Shader`) asks of a hit finder.

    One finder serves both kinds of variant. In the JIT variants a ray is a wavefront
    (``mi.Ray3f`` of Dr.Jit arrays) and masks are ``mi.Bool`` arrays; in the scalar ones a
    ray is one ray and masks are Python bools, and a finder must not touch a ray's
    shape where it missed (:func:`whitted.plugins.shading.off`).
    """

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)``: the nearest hit along ``ray`` (up to ``ray.maxt``).

        ``hit``: whether there is one (a mask). ``si``: an ``mi.SurfaceInteraction3f`` with
        ``t`` (inf where nothing was hit), ``p``, ``n`` (the geometric normal, unit), and
        ``uv`` when the finder was made with ``need_uv``. ``bsdf``: the hit shape's BSDF as
        its instance ID (JIT: ``mi.UInt32``) or the BSDF itself (scalar; None or anything
        where nothing was hit). ``error``: how far ``si.p`` may lie off the true surface
        (``mi.Float``, or a float), by which rays leave it (:func:`offset_origin`).
        ``coherent``: Mitsuba's hint that the rays are coherent (camera rays).
        """
        ...

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` from its origin to ``ray.maxt``
        (a shadow test), on the lanes of ``active``: a mask like ``active`` (``False``
        wherever ``active`` is; a scalar finder may return as soon as it knows)."""
        ...

    def surface_at(self, point) -> tuple[float, tuple[float, float, float]]:
        """``(error, normal)`` of the sphere that the scene point ``point`` (three floats, a
        light's position) lies on, within twice its error bound, ``(0.0, (0, 0, 0))`` if
        none: where a light sits on a surface, its shadow segments end off that surface
        (:func:`spawn_ray_to`). Plain Python, called once per light and render."""
        ...


def no_hits():
    """``(hit, si, bsdf, error)`` of rays that hit nothing (where a finder has no shapes)."""
    jit = dr.is_jit_v(mi.Float)
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.t = dr.inf
    return (mi.Bool(False) if jit else False), si, (mi.UInt32(0) if jit else None), 0.0


def no_blocker():
    """What :func:`blocked` says where a finder has no shapes."""
    return mi.Bool(False) if dr.is_jit_v(mi.Float) else False


def hit_finder(scene, tables, need_uv: bool, sphere_table: bool = True):
    """The fastest exact way to intersect ``scene`` (whose :class:`..scene.tables.SceneTables` are ``tables``)
    in the current variant; ``sphere_table=False`` keeps to Mitsuba's surface interactions."""
    if sphere_table and dr.is_jit_v(mi.Float) and tables.spheres_only:
        return SphereHits(scene, tables, need_uv)
    return MitsubaHits(scene, tables, need_uv)


class _SceneHits:
    """What :class:`MitsubaHits` and :class:`SphereHits` share: the scene they intersect,
    its tables, its shadow test (:func:`blocked`) and its lights' surfaces."""

    def __init__(self, scene, tables, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        self.primitives = tables.primitives
        self.spheres = tables.sphere_shapes
        self.tables = tables.hit_tables

    def surface_at(self, point):
        """As :meth:`HitFinder.surface_at` (:meth:`~whitted.plugins.scene.primitives.Primitives.surface_at`)."""
        return self.primitives.surface_at(point)

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (:func:`blocked`)."""
        return blocked(self.scene, ray, active, self.spheres)


class MitsubaHits(_SceneHits):
    """Surface interactions from Mitsuba's own ``ray_intersect`` (any shape).

    Textured spheres get their UV from :func:`lat_long_uv` rather than from
    Mitsuba, whose UV goes through the inverse of ``to_world`` and so misses the
    poles and the seam by a rounding error. A :class:`HitFinder`.
    """

    def __init__(self, scene, tables, need_uv: bool):
        super().__init__(scene, tables, need_uv)
        self.flags = mi.RayFlags.Minimal | (mi.RayFlags.UV if need_uv else mi.RayFlags.Empty)
        self.vectorized = dr.is_jit_v(mi.Float)
        self._errors = None if self.vectorized else tables.primitives.error.tolist()

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` (:meth:`HitFinder.intersect`)."""
        si = self.scene.ray_intersect(ray, ray_flags=self.flags, coherent=coherent)
        hit = si.is_valid()
        if not self.vectorized:
            if not hit:
                return hit, si, None, 0.0
            first, many, frame = self.tables[id(si.shape)]
            if frame is not None:
                si.uv = lat_long_uv(si.n, *frame)
            return hit, si, si.bsdf(), self._errors[first + int(si.prim_index) if many else first]
        tables = self.tables
        slot = slot_of(tables.base, dr.reinterpret_array(mi.UInt32, si.shape), si.prim_index, hit)
        if self.need_uv:
            mapped = dr.gather(mi.Bool, tables.mapped, slot, hit)
            frame = [dr.gather(mi.Vector3f, axis, slot, mapped) for axis in tables.frame]
            si.uv = dr.select(mapped, lat_long_uv(si.n, *frame), si.uv)
        return hit, si, dr.reinterpret_array(mi.UInt32, si.bsdf()), dr.gather(mi.Float, tables.error, slot, hit)


class SphereHits(_SceneHits):
    """Nearest hits on a scene of spheres without Mitsuba's per-shape call (JIT variants):
    ``sphere`` shapes, and ``ellipsoids`` shapes whose every primitive is a sphere. A
    :class:`HitFinder`."""

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` (:meth:`HitFinder.intersect`), ``bsdf`` an instance ID."""
        tables = self.tables
        pi = self.scene.ray_intersect_preliminary(ray, coherent=coherent)
        hit = pi.is_valid()
        slot = slot_of(tables.base, dr.reinterpret_array(mi.UInt32, pi.shape), pi.prim_index, hit)
        center = dr.gather(mi.Point3f, tables.center, slot, hit)
        radius = dr.gather(mi.Float, tables.radius, slot, hit)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.t = dr.select(hit, pi.t, dr.inf)
        si.n = dr.normalize(ray(pi.t) - center)
        si.p = dr.fma(si.n, radius, center)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            si.uv = lat_long_uv(si.n, *(dr.gather(mi.Vector3f, axis, slot, hit) for axis in tables.frame))
        return hit, si, dr.gather(mi.UInt32, tables.bsdf, slot, hit), dr.gather(mi.Float, tables.error, slot, hit)
