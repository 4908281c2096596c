"""The article's shading model (docs/scene-format.md, "Shading"), for one level of the ray tree.

:meth:`Shader.shade` takes rays (one in the scalar variants, a wavefront in
the JIT variants) with their path weights ``w`` and returns

- the color they contribute: ``w·(1 - KR - KT)·point`` on a hit, ``w·background``
  on a miss;
- their children: the reflected ray with weight ``w·KR`` and the refracted ray
  (or, under total internal reflection, the mirror ray) with weight ``w·KT``.

Under total internal reflection both children would be the very same ray, and
inside a glass ball that traps light the tree would double at every bounce. So
the mirror ray is traced once, with weight ``w·(KR + KT)``: exact, since the
color is linear in the weights. It still counts as a reflection ray and as a
refraction ray (``Child.merged``), as the article's recursion traces both.

Summing the contributions of every level gives exactly the article's recursion
``color = (1 - KR - KT)·point + KR·reflected + KT·refracted`` (it is linear),
which lets the tracers (:mod:`.tracer`) walk the tree in any order. Code for an
effect the scene lacks (see :mod:`.effects`) is left out of the kernels.

The same code shades a single ray (scalar variants) and a wavefront (JIT
variants); :mod:`.masks` says what differs and where it is handled.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from . import optics
from .geometry import hit_finder
from .giants import GiantHits
from .masks import off
from .surfaces import SurfaceTable


@dataclass
class Child:
    """A secondary ray and its path weight; ``kind`` is "reflection" or "refraction"."""
    kind: str
    ray: object      # mi.Ray3f
    weight: object   # mi.Float, 0 on lanes that spawn no such ray
    merged: object = None   # mi.Bool: lanes where the ray also carries the refracted share


@dataclass
class Shaded:
    color: object   # mi.Color3f, already multiplied by the path weight
    children: list   # [Child], empty when the tree ends at this level


#: a floor for squared distances: keeps 1/r and 1/r^2 finite when a light sits on the surface
_TINY = 1e-30


def offset_origin(p, n, error, d):
    """``p`` moved by ``error`` along the normal ``n``, to the side that ``d`` leaves towards.

    ``error`` bounds how far the float32 hit point ``p`` lies off its surface
    (see :func:`whitted.float32.hit_error`): from the moved origin, neither the
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
    ray = mi.Ray3f(origin, d * dr.rsqrt(dr.maximum(distance2, _TINY)))  # no 0/0 at the target
    ray.maxt = distance
    return ray


class Shader:
    """The article's model for one scene (see the module docstring)."""

    def __init__(self, scene, analysis, ambient: float, lighting: str, tally, exact_spheres=()):
        self.scene = scene
        self.physical = lighting == "physical"
        # Per-render constants are opaque: kernels are reused across scenes (plain numbers in scalar).
        self.ambient = dr.opaque(mi.Float, ambient)
        # Article lighting uses the light's color; physical lighting its intensity (divided by r^2).
        # Giant spheres listed with their exact values are intersected in float64 (.giants).
        need_uv = analysis.has("textures")
        self.hits = GiantHits(scene, need_uv, exact_spheres) if exact_spheres else hit_finder(scene, need_uv)
        # (position, strength, (error bound, normal) of a sphere the light sits on)
        self.lights = []
        for light in analysis.lights:
            error, normal = self.hits.surface_at(light.position)
            self.lights.append((dr.opaque(mi.Point3f, light.position),
                                dr.opaque(mi.Color3f, light.intensity if self.physical else light.color),
                                (dr.opaque(mi.Float, error), dr.opaque(mi.Vector3f, normal)) if error else None))
        self.environment = analysis.environment
        self.reflection = analysis.has("reflection")
        self.refraction = analysis.has("refraction")
        self.surfaces = SurfaceTable(analysis.surfaces, need_ior=self.refraction)
        self.tally = tally   # counts the shadow rays (see .counts)
        self.depth = analysis.depth

    def background(self, ray):
        """The color of rays that escape: the environment emitter's."""
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = -ray.d
        return self.environment.eval(si)

    def shade(self, ray, weight, spawn: bool, coherent: bool = False) -> Shaded:
        """One level of the tree for ``ray``; ``spawn`` is False at the last level."""
        hit, si, bsdf, error = self.hits.intersect(ray, coherent)
        color = mi.Color3f(0)
        if self.environment is not None:
            color = dr.select(hit, color, weight * self.background(ray))
        if off(hit):
            return Shaded(color, [])   # a single ray that missed: no shape to ask for a material

        v = ray.d
        n_facing, inside = optics.facing_normal(v, si.n)
        surface = self.surfaces.lookup(si, bsdf, hit)
        point = self.point_color(si, error, n_facing, surface.base, hit)
        diffuse = 1 - surface.reflect - surface.refract
        color = dr.select(hit, weight * diffuse * point, color)

        children = []
        if spawn and (self.reflection or self.refraction):
            c1 = optics.cos_incidence(v, n_facing)
            mirror = optics.unit(optics.reflect(v, n_facing, c1))
            kr, kt, merged = surface.reflect, surface.refract, None
            if self.refraction:
                eta = optics.relative_ior(surface.ior, inside)
                t, tir = optics.refract(v, n_facing, c1, eta)
                refracted = spawn_ray(si, error, dr.select(tir, mirror, optics.unit(t)))
                if self.reflection:   # the mirror ray carries both shares
                    merged = tir & (kr > 0) & (kt > 0)
                    kr, kt = kr + dr.select(merged, kt, 0), dr.select(merged, 0, kt)
            if self.reflection:
                children.append(Child("reflection", spawn_ray(si, error, mirror),
                                      dr.select(hit, weight * kr, 0), merged))
            if self.refraction:
                children.append(Child("refraction", refracted, dr.select(hit, weight * kt, 0)))
        return Shaded(color, children)

    def point_color(self, si, error, n_facing, base, active):
        """``B·(A + (1 - A)·Σ s·light)`` (article) or ``(B/π)·Σ I·max(0, N'·L)/r²`` (physical)."""
        direct = mi.Color3f(0)
        for position, strength, on_surface in self.lights:
            direct += self.light(si, error, n_facing, position, strength, on_surface, active)
        if self.physical:
            return base * dr.inv_pi * direct
        return base * (self.ambient + (1 - self.ambient) * direct)

    def light(self, si, error, n_facing, position, strength, on_surface, active):
        """One light's ``s·light_color`` (article) or ``I·cos/r²`` (physical), 0 in shadow.

        Every sphere blocks the segment to the light, transparent ones too. The
        shadow ray leaves from a point moved off the surface by the hit's error
        bound (:func:`spawn_ray_to`), so it cannot hit the surface it leaves,
        and ends off the surface the light sits on (``on_surface``: that sphere's
        error bound and normal at the light, or None).
        """
        to_light = position - si.p
        dist2 = dr.squared_norm(to_light)
        cos = dr.dot(n_facing, to_light) * dr.rsqrt(dr.maximum(dist2, _TINY))
        facing = active & (dist2 > 0) & (cos > 0)
        if off(facing):
            return mi.Color3f(0)
        self.tally.add("shadow", facing)
        shadowed = self.hits.blocked(spawn_ray_to(si, error, position, *(on_surface or ())), facing)
        if self.physical:
            strength = strength * dr.rcp(dr.maximum(dist2, _TINY))
        return dr.select(shadowed, 0, dr.select(facing, cos * strength, 0))
