"""Where a ray hits, how rays leave a hit, and what is there: the Whitted recursion's helpers.

A hit finder (:class:`HitFinder`; :func:`scene_hits` assembles those a scene needs) answers a
ray with its nearest hit and that hit's error bound, by which :func:`offset_origin` moves new
rays off the surface (docs/numerics.md). :func:`facing_normal`, :func:`reflect` and
:func:`refract` are the article's optics (docs/scene-format.md, "Shading").

One code serves one ray (scalar variants, Python ``bool`` masks) and a wavefront (JIT): a
single ray must not start work its mask switches off (:func:`off`), and since ``~True`` is
-2 the code selects rather than negates a mask.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError
from whitted.float32 import UNIT_ROUNDOFF

from .primitives import bsdf_key, read, slot_of

#: a floor for squared distances: keeps 1/r and 1/r^2 finite when a light sits on the surface
TINY = 1e-30


def off(mask) -> bool:
    """Whether ``mask`` is a single ray's ``False`` (scalar variants): skip the work it guards."""
    return mask is False


# -- the article's optics (directions are unit vectors, ``v`` points into the surface) ----------

def facing_normal(v, n):
    """``(N', inside)``: the normal on the side the ray arrives from (``-N`` from inside)."""
    inside = dr.dot(v, n) > 0
    return dr.select(inside, -n, n), inside


def cos_incidence(v, n_facing):
    """``c1 = -N'·V``, the cosine between the facing normal and the reversed ray (>= 0)."""
    return -dr.dot(n_facing, v)


def reflect(v, n_facing, c1):
    """Mirror direction ``R = V + 2·c1·N'``."""
    return dr.fma(2 * c1, n_facing, v)


def relative_ior(ior, inside):
    """``n = n1/n2``: 1/IOR entering, IOR leaving (each surface judged on its own)."""
    return dr.select(inside, ior, dr.rcp(ior))


def refract(v, n_facing, c1, eta):
    """``(T, tir)``: Snell's ``T = n·V + (n·c1 - sqrt(k))·N'``, ``k = 1 - n²(1 - c1²)``;
    ``tir`` where ``k < 0`` (total internal reflection: ``T`` is then finite but meaningless).
    ``1 - c1²`` is taken as ``|V × N'|²``, exact to ulps however small: n² multiplies it
    (docs/numerics.md, hazard 15)."""
    k = 1 - eta * eta * dr.squared_norm(dr.cross(v, n_facing))
    tir = k < 0
    t = dr.fma(eta, v, (eta * c1 - dr.safe_sqrt(k)) * n_facing)
    return t, tir


def unit(v):
    """``v`` normalized; float32 round-off would otherwise drift along deep mirror chains."""
    return dr.normalize(mi.Vector3f(v))


def lat_long_uv(n, x_axis, y_axis, z_axis):
    """The lat/long UV of the unit normal ``n`` in a sphere's frame, as Mitsuba's, with u = 0
    at a pole and 1 on the seam (docs/CONTRACTS.md)."""
    x, y, z = dr.dot(n, x_axis), dr.dot(n, y_axis), dr.dot(n, z_axis)
    angle = dr.atan2(y, x)   # (-π, π]
    u = dr.select(angle > 0, angle, angle + dr.two_pi) * dr.inv_two_pi
    pole = dr.abs(z) >= 1
    return mi.Point2f(dr.select(pole, 0.0, u), dr.safe_acos(z) * dr.inv_pi)


# -- leaving a hit ---------------------------------------------------------------------------------

def offset_origin(p, n, error, d):
    """``p`` moved by its error bound ``error`` along ``n``, to the side ``d`` leaves
    towards: no acne at any scene scale, unlike Mitsuba's fixed epsilon (docs/numerics.md)."""
    return dr.fma(dr.mulsign(error, dr.dot(n, d)), n, p)


def spawn_ray(si, error, d):
    return mi.Ray3f(offset_origin(si.p, si.n, error, d), d)


def spawn_ray_to(si, error, target, target_error=0.0, target_normal=None):
    """The segment from the hit ``si`` to ``target``; where ``target`` sits on a surface
    (``target_normal``), its end is moved off it as :func:`offset_origin` moves the start."""
    if target_normal is not None:
        target = offset_origin(target, target_normal, target_error, si.p - target)
    origin = offset_origin(si.p, si.n, error, target - si.p)
    d = target - origin
    distance2 = dr.squared_norm(d)
    ray = mi.Ray3f(origin, d * dr.rsqrt(dr.maximum(distance2, TINY)))  # no 0/0 at the target
    ray.maxt = dr.sqrt(distance2)
    return ray


def blocked(scene, ray, active, spheres: bool = True):
    """Whether a surface crosses the segment ``ray`` (to ``ray.maxt``). Where ``scene`` has
    ``sphere`` shapes (``spheres``), the JIT variants use ``ray_intersect_preliminary``: their
    ``ray_test`` loses every digit far from a sphere (docs/numerics.md)."""
    if spheres and dr.is_jit_v(mi.Float):
        return scene.ray_intersect_preliminary(ray, coherent=False, active=active).is_valid()
    return scene.ray_test(ray, coherent=False, active=active)


# -- finding hits ----------------------------------------------------------------------------------

class HitFinder(Protocol):
    """What :meth:`.recursion.Recursion.step` asks of a hit finder (a wavefront, or one ray)."""

    def intersect(self, ray, coherent: bool):
        """``(hit, si, bsdf, error)`` of the nearest hit up to ``ray.maxt``: ``si.t`` (inf on a
        miss), ``p``, unit ``n``, ``uv`` if ``need_uv``; ``bsdf`` its key
        (:func:`.primitives.bsdf_key`); ``error`` the bound on ``si.p``'s error."""

    def blocked(self, ray, active):
        """Whether a surface crosses the segment ``ray`` (a shadow test) on the lanes ``active``."""

    def surface_at(self, point) -> tuple[float, tuple[float, float, float]]:
        """``(error, normal)`` of the sphere a light at ``point`` sits on, else
        ``(0.0, (0, 0, 0))``."""


def no_hits():
    """``(hit, si, bsdf, error)`` of rays that hit nothing (where a finder has no shapes)."""
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.t = dr.inf
    return mi.Bool(False), si, mi.UInt32(0), 0.0


def hit_finder(scene, tables, need_uv: bool, sphere_table: bool = True):
    """The fastest exact way to intersect ``scene`` (its tables: ``tables``) in the current
    variant; ``sphere_table=False`` keeps to Mitsuba's surface interactions."""
    if sphere_table and dr.is_jit_v(mi.Float) and tables.spheres_only:
        return SphereHits(scene, tables, need_uv)
    return MitsubaHits(scene, tables, need_uv)


class MitsubaHits:
    """A :class:`HitFinder` by Mitsuba's own ``ray_intersect`` (any shape); a textured
    sphere's UV from :func:`lat_long_uv` (Mitsuba's misses the poles and seam by a rounding)."""

    def __init__(self, scene, tables, need_uv: bool):
        self.scene = scene
        self.need_uv = need_uv
        self.primitives = tables.primitives
        self.spheres = tables.sphere_shapes
        self.tables = tables.hit_tables
        self.flags = mi.RayFlags.Minimal | (mi.RayFlags.UV if need_uv else mi.RayFlags.Empty)

    def surface_at(self, point):
        return self.primitives.surface_at(point)

    def blocked(self, ray, active):
        return blocked(self.scene, ray, active, self.spheres)

    def intersect(self, ray, coherent: bool):
        si = self.scene.ray_intersect(ray, ray_flags=self.flags, coherent=coherent)
        hit = si.is_valid()
        if off(hit):
            return no_hits()
        tables = self.tables
        slot = slot_of(tables, si.shape, si.prim_index, hit)
        if self.need_uv:
            mapped = read(mi.Bool, tables.mapped, slot, hit)
            frame = [read(mi.Vector3f, axis, slot, mapped) for axis in tables.frame]
            si.uv = dr.select(mapped, lat_long_uv(si.n, *frame), si.uv)
        bsdf = dr.reinterpret_array(mi.UInt32, si.bsdf()) if dr.is_jit_v(mi.Float) else id(si.bsdf())
        return hit, si, bsdf, read(mi.Float, tables.error, slot, hit)


class SphereHits(MitsubaHits):
    """A :class:`HitFinder` for scenes of spheres (JIT variants): Embree's preliminary hit, the
    rest from the primitive tables, re-projected onto the sphere as Mitsuba's sphere does."""

    def intersect(self, ray, coherent: bool):
        tables = self.tables
        pi = self.scene.ray_intersect_preliminary(ray, coherent=coherent)
        hit = pi.is_valid()
        slot = slot_of(tables, pi.shape, pi.prim_index, hit)
        center = dr.gather(mi.Point3f, tables.center, slot, hit)
        radius = dr.gather(mi.Float, tables.radius, slot, hit)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.t = dr.select(hit, pi.t, dr.inf)
        si.n = dr.normalize(ray(pi.t) - center)
        si.p = dr.fma(si.n, radius, center)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            si.uv = lat_long_uv(si.n,
                                *(dr.gather(mi.Vector3f, axis, slot, hit) for axis in tables.frame))
        return hit, si, dr.gather(mi.UInt32, tables.bsdf, slot, hit), dr.gather(mi.Float, tables.error, slot, hit)


# -- spheres traced in frames of their own -------------------------------------------------------

#: the texture frame of a layer's spheres (they are untextured; UV as for a unit sphere)
_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


class LayeredHits:
    """A :class:`HitFinder` over the ``inner`` finder (None: no other shapes) and the layers
    of ``tables`` (:class:`~.primitives.Layer`: spheres scaled by s = 1/r, where Mitsuba's
    test is exact). A scene ray ``o + t·d`` is ``s·o + s·t·d`` in a layer; the layers are
    traced largest first, then the inner finder, each bounded by the nearest hit so far."""

    def __init__(self, inner, tables, need_uv: bool):
        self.jit = dr.is_jit_v(mi.Float)
        self.inner = inner
        self.layers = sorted(tables.layers, key=lambda layer: -layer.radius)
        self.need_uv = need_uv
        self.primitives = tables.primitives
        # per-render constants are opaque: one kernel serves every scale
        self.scales = [dr.opaque(mi.Float, 1.0 / layer.radius) for layer in self.layers]
        self.radii = [dr.opaque(mi.Float, layer.radius) for layer in self.layers]
        # OptiX traces one scene per kernel: a kernel that reaches a second scene's shader
        # binding table has its ray tracing switched off (with a warning only), so on CUDA
        # each layer's rays are traced in a kernel of their own
        self.own_kernels = mi.variant().startswith("cuda")

    def _traced(self, trace, *inputs):
        """``trace()``, one layer's query of its scene, in a kernel of its own on CUDA."""
        if not self.own_kernels:
            return trace()
        dr.eval(*inputs)
        result = trace()
        dr.eval(result)
        return result

    def _ray(self, k: int, ray, maxt):
        scaled = mi.Ray3f(ray.o * self.scales[k], ray.d)
        scaled.maxt = maxt * self.scales[k]
        return scaled

    surface_at = MitsubaHits.surface_at

    def blocked(self, ray, active):
        tests = [lambda mask, k=k, layer=layer: self._traced(
                     lambda: blocked(layer.scene, self._ray(k, ray, ray.maxt), mask, spheres=False),
                     ray, mask)
                 for k, layer in enumerate(self.layers)]
        if self.inner is not None:
            tests.append(lambda mask: self.inner.blocked(ray, mask))
        shadowed = mi.Bool(False)
        for test in tests:
            if self.jit:   # lanes already blocked are not traced again
                shadowed = shadowed | test(active & ~shadowed)
            elif shadowed or not active:
                break
            else:
                shadowed = test(active)
        return shadowed & active

    def intersect(self, ray, coherent: bool):
        best, which, slot = mi.Float(ray.maxt), mi.Int32(-1), mi.UInt32(0)
        for k, layer in enumerate(self.layers):
            pi = self._traced(lambda: layer.scene.ray_intersect_preliminary(
                self._ray(k, ray, best), coherent=coherent), ray, best)
            t = pi.t / self.scales[k]
            nearer = pi.is_valid() & (t < best)
            if off(nearer):
                continue
            layer_slot = slot_of(layer.tables, pi.shape, pi.prim_index, nearer)
            best, which, slot = dr.select(nearer, t, best), dr.select(nearer, k, which), dr.select(nearer, layer_slot, slot)
        if self.inner is not None:   # the other shapes, before the nearest layer hit
            bounded = mi.Ray3f(ray)
            bounded.maxt = best
            hit, si, bsdf, error = self.inner.intersect(bounded, coherent)
            which = dr.select(hit, -1, which)
        else:
            hit, si, bsdf, error = no_hits()
        layered = which >= 0
        if off(layered):
            return hit, si, bsdf, error
        center, radius, layer_bsdf, layer_error = mi.Point3f(0.0), mi.Float(1.0), mi.UInt32(0), mi.Float(0.0)
        for k, layer in enumerate(self.layers):
            this = which == k
            center = dr.select(this, read(mi.Point3f, layer.tables.center, slot, this), center)
            radius = dr.select(this, self.radii[k], radius)
            layer_bsdf = dr.select(this, read(mi.UInt32, layer.tables.bsdf, slot, this), layer_bsdf)
            layer_error = dr.select(this, read(mi.Float, layer.tables.error, slot, this), layer_error)
        n = dr.normalize(ray(best) - center)
        si.t = dr.select(layered, best, si.t)
        si.n = dr.select(layered, n, si.n)
        si.p = dr.select(layered, dr.fma(n, radius, center), si.p)
        si.time = ray.time
        si.wavelengths = ray.wavelengths
        if self.need_uv:
            si.uv = dr.select(layered, lat_long_uv(n, *(mi.Vector3f(a) for a in _AXES)), si.uv)
        return hit | layered, si, dr.select(layered, layer_bsdf, bsdf), dr.select(layered, layer_error, error)


# -- giant spheres, in float64 ---------------------------------------------------------------------

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
    """``(t, valid)``: the nearest root t > 0 of |o + t·d − C| = r, in float64 (any ``d``)."""
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
    """One giant sphere: its exact center and radius, its shape's BSDF key and texture frame."""

    def __init__(self, shape, center, radius, frame):
        self.center_tuple, self.radius = center, radius
        self.size = radius + max(abs(c) for c in center)
        self.center = dr.opaque(mi.Point3d, center)
        self.radius64 = dr.opaque(mi.Float64, radius)
        self.bsdf = dr.opaque(mi.UInt32, bsdf_key(shape.bsdf()))
        self.frame = None if frame is None else [mi.Vector3f(axis) for axis in frame]


class GiantHits:
    """A :class:`HitFinder` that tests the giant spheres of ``exact_spheres`` in float64 and
    the other shapes by the ``inner`` finder (None: there are none): Mitsuba's float32 sphere
    places a floor of radius 10^7 to ~1 (docs/numerics.md, hazard 14). ``giants``: ``(shape
    index, center, radius)`` each; the hit point's bound is :func:`point_error`."""

    def __init__(self, scene, inner, need_uv: bool, giants, primitives):
        self.jit = dr.is_jit_v(mi.Float)
        shapes, frames = scene.shapes(), primitives.frames   # (a textured sphere's UV frame)
        self.giants = [_Giant(shapes[k], center, radius, frames.get(int(primitives.first[k])))
                       for k, center, radius in giants]
        self.inner = inner
        # the other shapes' surfaces: a giant's float32 bound (ulps of its radius) would put
        # lights metres above a floor of radius 10^7 on it
        self.others = primitives.without([k for k, _, _ in giants])
        self.need_uv = need_uv

    def surface_at(self, point):   # a giant sphere's exact surface first
        p = np.asarray(point, np.float64).reshape(-1)
        for giant in self.giants:
            offset = p - np.asarray(giant.center_tuple)
            distance = float(np.linalg.norm(offset))
            error = point_error(mi.ScalarPoint3d(*p), giant.size)
            if abs(distance - giant.radius) <= 2 * error:
                return error, tuple(offset / distance)
        return self.others.surface_at(point)

    def blocked(self, ray, active):
        shadowed = self.inner.blocked(ray, active) if self.inner is not None else mi.Bool(False)
        if not self.jit and (shadowed or not active):
            return shadowed
        o, d, maxt = mi.Point3d(ray.o), mi.Vector3d(ray.d), mi.Float64(ray.maxt)
        for giant in self.giants:
            t, valid = _roots(o, d, giant.center, giant.radius64)
            shadowed = shadowed | (valid & (t < maxt))
        return shadowed & active

    def intersect(self, ray, coherent: bool):
        hit, si, bsdf, error = self.inner.intersect(ray, coherent) if self.inner is not None else no_hits()
        o, d = mi.Point3d(ray.o), mi.Vector3d(ray.d)
        best = dr.select(hit, mi.Float64(si.t), dr.inf)
        which, center, radius = mi.Int32(-1), mi.Point3d(0.0), mi.Float64(1.0)
        size, bsdf_giant = mi.Float(0.0), mi.UInt32(0)
        for k, giant in enumerate(self.giants):   # the nearest giant's numbers
            t, valid = _roots(o, d, giant.center, giant.radius64)
            nearer = valid & (t < best)
            best, which = dr.select(nearer, t, best), dr.select(nearer, k, which)
            center = dr.select(nearer, giant.center, center)
            radius = dr.select(nearer, giant.radius64, radius)
            size = dr.select(nearer, giant.size, size)
            bsdf_giant = dr.select(nearer, giant.bsdf, bsdf_giant)
        giant_hit = which >= 0
        if off(giant_hit):
            return hit, si, bsdf, error
        p = dr.fma(d, best, o) if self.jit else o + d * best   # (each variant's own rounding)
        si.p = dr.select(giant_hit, mi.Point3f(p), si.p)
        si.n = dr.select(giant_hit, mi.Vector3f((p - center) / radius), si.n)
        si.t = dr.select(giant_hit, mi.Float(best), si.t)
        if self.need_uv:
            for k, giant in enumerate(self.giants):
                if giant.frame is not None:
                    si.uv = dr.select(which == k, lat_long_uv(si.n, *giant.frame), si.uv)
        error = dr.select(giant_hit, point_error(si.p, size), error)
        return hit | giant_hit, si, dr.select(giant_hit, bsdf_giant, bsdf), error


def scene_hits(scene, tables, need_uv: bool, exact_spheres=()):
    """The :class:`HitFinder` of ``scene`` (its ``tables``), with the layers and the giant
    spheres of ``exact_spheres`` where there are any."""
    giants = []
    if exact_spheres:
        index = {shape.id(): k for k, shape in enumerate(scene.shapes())}
        missing = [key for key, _, _ in exact_spheres if key not in index]
        if missing:
            raise WhittedError(f"the whitted integrator's exact_spheres names shapes the scene lacks: "
                               f"{', '.join(missing)} (each must be a shape of that id)")
        giants = [(index[key], center, radius) for key, center, radius in exact_spheres]
    left_out = {k for k, _, _ in giants} | set(tables.layered)
    if not left_out:
        return hit_finder(scene, tables, need_uv)
    rest, rest_tables = tables.rest(scene, left_out)
    hits = None if rest is None else hit_finder(rest, rest_tables, need_uv)
    if tables.layers:
        hits = LayeredHits(hits, tables, need_uv)
    return GiantHits(scene, hits, need_uv, giants, tables.primitives) if giants else hits


# -- the material at a hit --------------------------------------------------------------------------

@dataclass
class SurfaceSample:
    base: object      # mi.Color3f, B (texel or color)
    reflect: object   # mi.Float, KR
    refract: object   # mi.Float, KT
    ior: object       # mi.Float


class SurfaceLookup:
    """The material at a hit, from :meth:`~.scene_tables.Materials.table` (``need_ior``:
    False leaves the IOR out of the kernels)."""

    def __init__(self, materials, table, need_ior: bool):
        self.need_ior = need_ior
        # KR and KT that are 0 on every material are constants, not lookups
        self.reflective, self.refractive = materials.reflective, materials.refractive
        self.textured = list(materials.textures.values())   # slot k is textured[k - 1]
        row_of, columns = table
        self._row_of = None if dr.is_jit_v(mi.Float) else row_of   # (JIT: the key is the row)
        self._color, self._reflect, self._refract, self._ior, self._slot = columns

    def lookup(self, si, bsdf, active) -> SurfaceSample:
        """The material at ``si`` (``bsdf``: its key, :func:`.primitives.bsdf_key`) on the lanes
        ``active``."""
        row = bsdf if self._row_of is None else self._row_of[bsdf]
        base = read(*self._color, row, active)
        if self.textured:
            slot = read(*self._slot, row, active)
            for k, texture in enumerate(self.textured, start=1):
                on_texture = active & (slot == k)
                if not off(on_texture):
                    base = dr.select(on_texture, mi.Color3f(texture.eval(si, on_texture)), base)
        ior = read(*self._ior, row, active) if self.need_ior else mi.Float(1)
        reflect = read(*self._reflect, row, active) if self.reflective else mi.Float(0)
        refract = read(*self._refract, row, active) if self.refractive else mi.Float(0)
        return SurfaceSample(base, reflect, refract, ior)
