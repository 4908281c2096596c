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
refraction ray (``SecondaryRay.merged``), as the article's recursion traces both.

Summing the contributions of every level gives exactly the article's recursion
``color = (1 - KR - KT)·point + KR·reflected + KT·refracted`` (it is linear),
which lets the tracers (:mod:`whitted.plugins.tree`) walk the tree in any order. Code for an
effect the scene lacks (see :mod:`whitted.plugins.scene.effects`) is left out of the kernels.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from whitted.errors import WhittedError

from . import off, optics
from .giants import GiantHits
from .hits import TINY, hit_finder, spawn_ray, spawn_ray_to
from .layers import LayeredHits


@dataclass
class SecondaryRay:
    """A secondary ray and its path weight; ``kind`` is "reflection" or "refraction"."""
    kind: str
    ray: object      # mi.Ray3f
    weight: object   # mi.Float, 0 on lanes that spawn no such ray
    merged: object = None   # mi.Bool: lanes where the ray also carries the refracted share


@dataclass
class Shaded:
    color: object   # mi.Color3f, already multiplied by the path weight
    children: list   # [SecondaryRay], empty when the tree ends at this level
    hit: object = None   # mi.Bool: the rays that hit a surface


def scene_hits(scene, tables, need_uv: bool, exact_spheres=()):
    """How rays meet ``scene`` (whose :class:`..scene.tables.SceneTables` are ``tables``): Mitsuba's ray
    tracing (:func:`.hits.hit_finder`) for the shapes it intersects exactly, layers for
    spheres it intersects exactly only in frames of their own (:mod:`.layers`), and the
    float64 test for the giant spheres listed in ``exact_spheres`` (:mod:`.giants`)."""
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


class Shader:
    """The article's model for one scene (see the module docstring)."""

    def __init__(self, scene, analysis, ambient: float, lighting: str, tally, exact_spheres=(),
                 hide_background: bool = False, attached=None):
        self.scene = scene
        # Mitsuba's ``hide_emitters``: camera rays that escape see black, not the background
        self.hide_background = hide_background
        self.physical = lighting == "physical"
        # Per-render constants are opaque: kernels are reused across scenes (plain numbers in scalar).
        # A differentiable render reads the parameters' own values (``attached``:
        # :class:`whitted.plugins.gradients.Attached`), so that the AD graph reaches them.
        self.ambient = dr.opaque(mi.Float, analysis.ambient(ambient)) \
            if attached is None or not analysis.has("ambient") else attached.ambient
        # Article lighting uses the light's color; physical lighting its intensity (divided by r^2).
        # Giant spheres listed with their exact values are intersected in float64 (.giants).
        need_uv = analysis.has("textures")
        tables = analysis.tables
        self.hits = scene_hits(scene, tables, need_uv, exact_spheres)
        # (position, strength, (error bound, normal) of a sphere the light sits on)
        self.lights = []
        for k, light in enumerate(analysis.lights):
            error, normal = self.hits.surface_at(light.position)
            position, strength = (dr.opaque(mi.Point3f, light.position),
                                  dr.opaque(mi.Color3f, light.intensity if self.physical else light.color)) \
                if attached is None else attached.lights[k]
            self.lights.append((position, strength,
                                (dr.opaque(mi.Float, error), dr.opaque(mi.Vector3f, normal)) if error else None))
        self.environment = analysis.environment
        self.reflection = analysis.has("reflection")
        self.refraction = analysis.has("refraction")
        self.shadows = analysis.has("shadows")
        self.surfaces = SurfaceLookup(analysis.surfaces, analysis.material_table if attached is None
                                      else attached.material_table, need_ior=self.refraction)
        self.tally = tally   # counts the shadow rays (:class:`~whitted.plugins.tree.counts.Tally`)
        self.depth = analysis.depth
        #: a dict that :meth:`shade` fills with the terms of the level it shades (None in a
        #: render): the hit, the facing normal, the material, each light's term and shadow ray
        #: (the ray tree of a pixel: whitted/trace/record.py)
        self.record = None

    def background(self, ray):
        """The color of rays that escape: the environment emitter's."""
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = -ray.d
        return self.environment.eval(si)

    def shade(self, ray, weight, spawn: bool, coherent: bool = False, camera: bool = False) -> Shaded:
        """One level of the tree for ``ray``; ``spawn`` is False at the last level, ``camera``
        True at the first (camera rays)."""
        hit, si, bsdf, error = self.hits.intersect(ray, coherent)
        record = self.record
        if record is not None:
            record.clear()
            record.update(si=si, lights=[])
        color = mi.Color3f(0)
        if self.environment is not None and not (camera and self.hide_background):
            color = dr.select(hit, color, weight * self.background(ray))
        if off(hit):
            return Shaded(color, [], hit)   # a single ray that missed: no shape to ask for a material

        v = ray.d
        n_facing, inside = optics.facing_normal(v, si.n)
        surface = self.surfaces.lookup(si, bsdf, hit)
        point = self.point_color(si, error, n_facing, surface.base, hit)
        diffuse = 1 - surface.reflect - surface.refract
        color = dr.select(hit, weight * diffuse * point, color)
        if record is not None:
            record.update(n_facing=n_facing, inside=inside, surface=surface, point=point)

        children = []
        if spawn and (self.reflection or self.refraction):
            c1 = optics.cos_incidence(v, n_facing)
            mirror = optics.unit(optics.reflect(v, n_facing, c1))
            kr, kt, merged = surface.reflect, surface.refract, None
            if self.refraction:
                eta = optics.relative_ior(surface.ior, inside)
                t, tir = optics.refract(v, n_facing, c1, eta)
                if record is not None:
                    record["tir"] = tir
                refracted = spawn_ray(si, error, dr.select(tir, mirror, optics.unit(t)))
                if self.reflection:   # the mirror ray carries both shares
                    merged = tir & (kr > 0) & (kt > 0)
                    kr, kt = kr + dr.select(merged, kt, 0), dr.select(merged, 0, kt)
            if self.reflection:
                children.append(SecondaryRay("reflection", spawn_ray(si, error, mirror),
                                      dr.select(hit, weight * kr, 0), merged))
            if self.refraction:
                children.append(SecondaryRay("refraction", refracted, dr.select(hit, weight * kt, 0)))
        return Shaded(color, children, hit)

    def point_color(self, si, error, n_facing, base, active):
        """``B·(A + (1 - A)·Σ s·light)`` (article) or ``(B/π)·Σ I·max(0, N'·L)/r²`` (physical)."""
        direct = mi.Color3f(0)
        for position, strength, on_surface in self.lights:
            direct += self.light(si, error, n_facing, position, strength, on_surface, active)
        if self.physical:
            return base * dr.inv_pi * direct
        return base * (self.ambient + (1 - self.ambient) * direct)

    def light(self, si, error, n_facing, position, strength, on_surface, active):
        """One light's ``s·light_color`` (article) or ``I·cos/r²`` (physical), 0 in shadow
        (never, when the render leaves shadows out).

        Every sphere blocks the segment to the light, transparent ones too. The
        shadow ray leaves from a point moved off the surface by the hit's error
        bound (:func:`spawn_ray_to`), so it cannot hit the surface it leaves,
        and ends off the surface the light sits on (``on_surface``: that sphere's
        error bound and normal at the light, or None).
        """
        to_light = position - si.p
        dist2 = dr.squared_norm(to_light)
        cos = dr.dot(n_facing, to_light) * dr.rsqrt(dr.maximum(dist2, TINY))
        facing = active & (dist2 > 0) & (cos > 0)
        terms = None
        if self.record is not None:
            terms = {"position": position, "strength": strength, "facing": facing, "cos": cos}
            self.record["lights"].append(terms)
        if off(facing):
            return mi.Color3f(0)
        if self.physical:
            strength = strength * dr.rcp(dr.maximum(dist2, TINY))
        lit = dr.select(facing, cos * strength, 0)
        if not self.shadows:   # the render leaves shadows out: every light is seen
            if terms is not None:
                terms.update(value=lit)
            return lit
        self.tally.add("shadow", facing)
        # (visibility is not differentiated: the shadow ray is detached from the light's position)
        shadow_ray = spawn_ray_to(si, error, dr.detach(position), *(on_surface or ()))
        shadowed = self.hits.blocked(shadow_ray, facing)
        value = dr.select(shadowed, 0, lit)
        if terms is not None:
            terms.update(ray=shadow_ray, shadowed=shadowed, value=value)
        return value


@dataclass
class SurfaceSample:
    """The material at a hit point."""
    base: object      # mi.Color3f, B (texel or color)
    reflect: object   # mi.Float, KR
    refract: object   # mi.Float, KT
    ior: object       # mi.Float


class SurfaceLookup:
    """The material at a hit, from the scene's material table
    (:meth:`whitted.plugins.scene.materials.Materials.table`).

    ``need_ior`` leaves the IOR out of the kernels of scenes without refraction.
    """

    def __init__(self, materials, table, need_ior: bool):
        self.need_ior = need_ior
        # KR and KT that are 0 on every material are constants, not lookups
        self.reflective, self.refractive = materials.reflective, materials.refractive
        self.textured = list(materials.textures.values())   # slot k is textured[k - 1]
        row_of, columns = table
        if dr.is_jit_v(mi.Float):
            self._row = lambda bsdf: bsdf
            self._read = lambda tp, values, row, active: dr.gather(tp, values, row, active)
        else:
            self._row = lambda bsdf: row_of[id(bsdf)]
            self._read = lambda tp, values, row, active: tp(values[..., row].tolist())
        self._color, self._reflect, self._refract, self._ior, self._slot = columns

    def lookup(self, si, bsdf, active) -> SurfaceSample:
        """The material at ``si`` on the lanes ``active`` (hits only).

        ``bsdf`` is the hit BSDF's instance ID (JIT variants) or the BSDF itself (scalar).
        """
        row = self._row(bsdf)
        base = self._read(*self._color, row, active)
        if self.textured:
            slot = self._read(*self._slot, row, active)
            for k, texture in enumerate(self.textured, start=1):
                on_texture = active & (slot == k)
                if not off(on_texture):
                    base = dr.select(on_texture, mi.Color3f(texture.eval(si, on_texture)), base)
        ior = self._read(*self._ior, row, active) if self.need_ior else mi.Float(1)
        reflect = self._read(*self._reflect, row, active) if self.reflective else mi.Float(0)
        refract = self._read(*self._refract, row, active) if self.refractive else mi.Float(0)
        return SurfaceSample(base, reflect, refract, ior)
