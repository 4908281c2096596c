"""The article's Whitted recursion: one step (:meth:`Recursion.step`) and the walks that repeat it.

A color is linear in its children's, ``(1 - KR - KT)·point + KR·reflected + KT·refracted``, so
a camera ray's color is the sum over its tree of ``w·point``, ``w`` the product of the KR and
KT factors on the way down: :meth:`Recursion.step` adds one level of rays, which
:class:`Recursion` (scalar) walks depth first and :class:`Wavefronts` (JIT) level by level.
Adaptive depth control (Hall and Greenberg 1983; POV-Ray's ``adc_bailout``) shares out each
ray's *allowance*, the weight its subtree may leave untraced (:func:`split`;
docs/statistics.md, "Adaptive depth").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import drjit as dr
import mitsuba as mi

from .hits import (TINY, SurfaceLookup, cos_incidence, facing_normal, off, reflect, refract,
                   relative_ior, scene_hits, spawn_ray, spawn_ray_to, unit)

#: default camera samples per pass and widest wavefront (about 100 bytes a lane: 100 MiB)
SAMPLES_PER_PASS = 1 << 20
#: the same for a single-level tree: one kernel, which Ctrl-C cannot stop, kept well under a
#: second (benchmarks/RESULTS.md)
SAMPLES_PER_FLAT_PASS = 1 << 21
#: ε is this much smaller than ``min_weight / L``, so that the allowances' float32 round-off
#: over 64 levels cannot push the bound past ``min_weight``
ROUND_OFF_MARGIN = 1e-5


@dataclass
class Branch:
    """Rays of one level (a wavefront, or one ray in scalar variants)."""
    ray: object      # mi.Ray3f
    weight: object   # mi.Float, the path weight
    level: int       # primary rays have level 1
    allowance: object = None   # mi.Float, the weight each may leave untraced (None: exact)
    total: float = 0.0         # the sum of the weights (for progress)


@dataclass
class Child:
    """A branch one level down."""
    kind: str        # "reflection" or "refraction"
    branch: Branch
    traced: object   # mi.Bool
    merged: object = None   # mi.Bool, where a reflection carries the refracted share too (TIR)


class Recursion:
    """The article's model for one render of a scene by ``integrator``, walked depth first
    (scalar variants); ``attached``: the parameters' own Dr.Jit values (:mod:`.gradients`)."""

    #: camera samples per pass when the integrator's ``wavefront_size`` is 0 (automatic)
    samples_per_pass = 1 << 10

    def __init__(self, scene, analysis, integrator, attached=None):
        self.physical = integrator.lighting == "physical"
        self.hide_background = integrator.hide_emitters
        ambient = integrator.ambient if analysis.has("ambient") else 0.0
        # each camera ray's allowance ε: 0 (the exact tree) unless a bound L is known
        self.bright = brightest(analysis, integrator.lighting, ambient) \
            if integrator.min_weight > 0 else None
        self.epsilon = 0.0 if self.bright is None \
            else integrator.min_weight / max(self.bright, 1e-30) * (1 - ROUND_OFF_MARGIN)
        # per-render constants are opaque: kernels are reused across scenes
        self.ambient = dr.opaque(mi.Float, ambient) \
            if attached is None or not analysis.has("ambient") else attached.ambient
        self.hits = scene_hits(scene, analysis.tables, analysis.has("textures"),
                               integrator.exact_spheres)
        # (position, strength, (error bound, normal) of a sphere the light sits on): the
        # article's color, or the intensity in physical lighting
        self.lights = []
        for k, light in enumerate(analysis.lights):
            error, normal = self.hits.surface_at(light.position)
            position, strength = (dr.opaque(mi.Point3f, light.position),
                                  dr.opaque(mi.Color3f, light.intensity if self.physical
                                            else light.color)) \
                if attached is None else attached.lights[k]
            self.lights.append((position, strength, (dr.opaque(mi.Float, error),
                                dr.opaque(mi.Vector3f, normal)) if error else None))
        self.environment = analysis.tables.environment
        self.reflection = analysis.has("reflection")
        self.refraction = analysis.has("refraction")
        self.shadows = analysis.has("shadows")
        self.surfaces = SurfaceLookup(analysis.surfaces, analysis.material_table if attached is None
                                      else attached.material_table, need_ior=self.refraction)
        self.depth = analysis.depth
        self.tally = Tally()
        self.deepest = 0   # the deepest level that traced a ray
        self.keep_camera_hit = False   # whether camera_hit is wanted (an alpha channel)
        self.camera_hit = None   # mi.Bool: which camera rays of the last :meth:`trace` hit
        # a pixel's ray tree (whitted/trace/record.py): each level's terms, shown to recorder
        self.record = None
        self.recorder = None

    def step(self, branch: Branch):
        """The rays of ``branch``: their color (already weighted), the weight culled below each
        ray (None when the tree is traced exactly) and their children."""
        ray, weight, level = branch.ray, branch.weight, branch.level
        self.deepest = max(self.deepest, level)
        camera = level == 1
        record = self.record
        hit, si, bsdf, error = self.hits.intersect(ray, camera)   # (camera rays are coherent)
        if record is not None:
            record.clear()
            record.update(si=si, lights=[])
        if camera and self.keep_camera_hit:
            self.camera_hit = hit
            if dr.is_jit_v(mi.Float):
                dr.schedule(hit)   # evaluated by the level's own kernel

        # A ray that escapes sees the background.
        color = mi.Color3f(0)
        if self.environment is not None and not (camera and self.hide_background):
            si_out = dr.zeros(mi.SurfaceInteraction3f)
            si_out.wi = -ray.d
            color = dr.select(hit, color, weight * self.environment.eval(si_out))
        if off(hit):   # a single ray that missed: no shape to ask for a material
            if self.recorder is not None:
                self.recorder.level(branch, color, hit, [])
            return color, None, []

        # At a hit: B·(A + (1 - A)·Σ s·light) (article) or (B/π)·Σ I·max(0, N'·L)/r² (physical),
        # s = 0 where the segment to the light is blocked (every sphere blocks it, transparent
        # ones too), weighted 1 - KR - KT.
        v = ray.d
        n_facing, inside = facing_normal(v, si.n)
        surface = self.surfaces.lookup(si, bsdf, hit)
        direct = mi.Color3f(0)
        for position, strength, on_surface in self.lights:
            to_light = position - si.p
            dist2 = dr.squared_norm(to_light)
            cos = dr.dot(n_facing, to_light) * dr.rsqrt(dr.maximum(dist2, TINY))
            facing = hit & (dist2 > 0) & (cos > 0)
            terms = None
            if record is not None:
                terms = {"position": position, "strength": strength, "facing": facing, "cos": cos}
                record["lights"].append(terms)
            if off(facing):
                continue
            if self.physical:
                strength = strength * dr.rcp(dr.maximum(dist2, TINY))
            lit = dr.select(facing, cos * strength, 0)
            if self.shadows:
                self.tally.add("shadow", facing)
                # The shadow ray leaves the hit moved off its surface by its error bound and
                # ends off the surface the light sits on. (Visibility is not differentiated.)
                shadow_ray = spawn_ray_to(si, error, dr.detach(position), *(on_surface or ()))
                shadowed = self.hits.blocked(shadow_ray, facing)
                if terms is not None:
                    terms.update(ray=shadow_ray, shadowed=shadowed)
                lit = dr.select(shadowed, 0, lit)
            if terms is not None:
                terms.update(value=lit)
            direct += lit
        if self.physical:
            point = surface.base * dr.inv_pi * direct
        else:
            point = surface.base * (self.ambient + (1 - self.ambient) * direct)
        color = dr.select(hit, weight * (1 - surface.reflect - surface.refract) * point, color)
        if record is not None:
            record.update(n_facing=n_facing, inside=inside, surface=surface, point=point)

        # The reflected ray (weight w·KR) and the refracted one (w·KT), the mirror ray under
        # total internal reflection; one ray with both shares where they coincide.
        spawned = []
        if level < self.depth and (self.reflection or self.refraction):
            c1 = cos_incidence(v, n_facing)
            mirror = unit(reflect(v, n_facing, c1))
            kr, kt, merged = surface.reflect, surface.refract, None
            if self.refraction:
                t, tir = refract(v, n_facing, c1, relative_ior(surface.ior, inside))
                if record is not None:
                    record["tir"] = tir
                refracted = spawn_ray(si, error, dr.select(tir, mirror, unit(t)))
                if self.reflection:   # the mirror ray carries both shares
                    merged = tir & (kr > 0) & (kt > 0)
                    kr, kt = kr + dr.select(merged, kt, 0), dr.select(merged, 0, kt)
            if self.reflection:
                spawned.append(("reflection", spawn_ray(si, error, mirror),
                                dr.select(hit, weight * kr, 0), merged))
            if self.refraction:
                spawned.append(("refraction", refracted, dr.select(hit, weight * kt, 0), None))
        if not spawned:
            if self.recorder is not None:
                self.recorder.level(branch, color, hit, [])
            return color, None, []

        # Adaptive depth control: which children are traced, with what allowance.
        weights = [w for _, _, w, _ in spawned]
        if branch.allowance is None:
            traced, allowance, culled = [w > 0 for w in weights], None, None
        else:
            first, second, allowance, culled = split(weights[0], weights[1] if len(weights) > 1
                                                     else 0.0, branch.allowance)
            traced = [first, second][:len(weights)]
        children = [Child(kind, Branch(child_ray, w, level + 1, allowance), is_traced, merged)
                    for (kind, child_ray, w, merged), is_traced in zip(spawned, traced)]
        if self.recorder is not None:
            self.recorder.level(branch, color, hit, children)
        for child in children:
            self.tally.add(child.kind, child.traced)
            if child.merged is not None:   # one ray, counted as both kinds
                self.tally.add("refraction", child.traced & child.merged)
                self.tally.add("merged", child.traced & child.merged)
            if culled is not None:
                lost = dr.select(child.traced, False, child.branch.weight > 0)
                self.tally.add("culled", lost)
                if child.merged is not None:
                    self.tally.add("culled", lost & child.merged)
                self.tally.add_total("culled_weight", child.branch.weight, lost)
        return color, culled, children

    def trace(self, ray, progress=None):
        """The color of the camera rays ``ray``; ``progress(n)`` is told of finished samples."""
        # A wavefront's width is its ray's widest field: the rays of a sensor may share their
        # origin (a pinhole) or their direction (orthographic, distant), held as one value.
        count = dr.width(ray)
        allowance = dr.opaque(mi.Float, self.epsilon) if self.epsilon > 0 else None
        walk = _Progress(count, progress)
        color, culled = self._subtree(Branch(ray, mi.Float(1), 1, allowance, float(count)), walk)
        walk.finish()
        if culled is not None:
            self.tally.note_max("sample_culled_weight", culled)
        return color

    # -- the depth-first walk (scalar variants) ---------------------------------------------------

    def _subtree(self, branch, walk):
        """The color of ``branch``'s tree and the weight culled from it (None: traced exactly)."""
        color, culled, children = self.step(branch)
        for child in children:
            if child.traced:
                child_color, child_culled = self._subtree(child.branch, walk)
                color = color + child_color
                if child_culled is not None:   # (None below a leaf, or everywhere when exact)
                    culled = culled + child_culled
        return color, culled

    def samples(self, count: int):
        """The sample indices of a pass, as the walk takes them (here one at a time)."""
        return range(count)

    def finish_pass(self) -> None:
        """Finish a pass's work (its image block's accumulation) before the next one."""


# -- the wavefront walk (JIT variants) ------------------------------------------------------------

class Wavefronts(Recursion):
    """The tree walked level by level: a level's traced children are packed into one wavefront
    (``dr.compress``), and their colors added back to their parents in a fixed order (the same
    bits at any thread count); wavefronts wider than the integrator's ``wavefront_size`` are
    split (bounded memory)."""

    def __init__(self, scene, analysis, integrator, attached=None):
        super().__init__(scene, analysis, integrator, attached)
        self.lanes = integrator.wavefront_size or SAMPLES_PER_PASS
        self.samples_per_pass = SAMPLES_PER_PASS if self.depth > 1 else SAMPLES_PER_FLAT_PASS

    def samples(self, count: int):
        return [dr.arange(mi.UInt32, count)]   # the whole pass is one wavefront

    def finish_pass(self) -> None:
        dr.eval()          # the pass's kernels and side effects (the block's accumulation)
        dr.sync_thread()   # so that progress reports finished work

    def _subtree(self, front, walk):
        """The color of each lane's tree from ``front`` down and the weight culled from it
        (None: exact): its own, then its first child's tree, then its second's."""
        if front.level > 1 and dr.width(front.ray) > self.lanes:   # a pass's camera rays fit
            return self._pieces(front, walk)
        color, culled, children = self.step(front)
        below = self._next_level(front, children, (color, culled), walk.reports) \
            if children else None
        if below is None:   # (a single-level tree is left lazy: it may run in a loop)
            walk.shaded(front, [])
            return color, culled
        child, parent, second = below
        walk.shaded(front, [child])
        child_color, child_culled = self._subtree(child, walk)
        width = dr.width(front.ray)   # (a camera wavefront's weight is one literal 1)
        color = _plus_children(color, child_color, parent, second, mi.Color3f, width)
        if child_culled is not None:
            culled = _plus_children(culled, child_culled, parent, second, mi.Float, width)
        dr.eval(color, culled)
        return color, culled

    def _pieces(self, front, walk):
        """:meth:`_subtree` of a wavefront too wide for one, a piece of ``lanes`` at a time."""
        dr.eval(front.ray, front.weight, front.allowance)
        n = dr.width(front.weight)
        pieces = []
        for start in range(0, n, self.lanes):
            lane = dr.arange(mi.UInt32, min(self.lanes, n - start)) + dr.opaque(mi.UInt32, start)
            weight = dr.gather(mi.Float, front.weight, lane)
            pieces.append((lane, Branch(
                mi.Ray3f(dr.gather(mi.Point3f, front.ray.o, lane),
                         dr.gather(mi.Vector3f, front.ray.d, lane)),
                weight, front.level,
                None if front.allowance is None else dr.gather(mi.Float, front.allowance, lane),
                float(dr.sum(weight)[0]) if walk.reports else 0.0)))
        walk.shaded(front, [piece for _, piece in pieces])
        color, culled = dr.zeros(mi.Color3f, n), None
        for lane, piece in pieces:
            piece_color, piece_culled = self._subtree(piece, walk)
            dr.scatter(color, piece_color, lane)
            if piece_culled is not None:
                if culled is None:
                    culled = dr.zeros(mi.Float, n)
                dr.scatter(culled, piece_culled, lane)
            dr.eval(color, culled)
        return color, culled

    def _next_level(self, front, children, sums, with_total: bool):
        """``(child, parent, second)``: the traced lanes of ``children``, siblings side by side,
        each parent's lane and whether it is the second child; None when none is traced."""
        # One kernel shades this level, computes its color, and stores the children ...
        dr.eval(sums, [(c.branch.ray.o, c.branch.ray.d, c.branch.weight, c.branch.allowance,
                        c.traced) for c in children])
        # ... then the traced children of every kind are packed into one wavefront,
        # interleaved so that siblings stay next to each other.
        if len(children) == 1:
            lane = dr.compress(children[0].traced)
        else:
            slot = dr.arange(mi.UInt32, 2 * dr.width(children[0].traced))
            lane = dr.compress(dr.select((slot & 1) == 1,
                                         dr.gather(mi.Bool, children[1].traced, slot >> 1),
                                         dr.gather(mi.Bool, children[0].traced, slot >> 1)))
        if dr.width(lane) == 0:
            return None
        parent, second = (lane, None) if len(children) == 1 else (lane >> 1, (lane & 1) == 1)

        def gather(tp, field):
            """``field`` of each traced child, from the child of its kind."""
            if second is None:
                return dr.gather(tp, field(children[0]), parent)
            return dr.select(second, dr.gather(tp, field(children[1]), parent, second),
                             dr.gather(tp, field(children[0]), parent, ~second))

        ray = mi.Ray3f(gather(mi.Point3f, lambda c: c.branch.ray.o),
                       gather(mi.Vector3f, lambda c: c.branch.ray.d))
        weight = gather(mi.Float, lambda c: c.branch.weight)
        # the allowance is the same for both children of a ray (see split)
        allowance = None if front.allowance is None \
            else dr.gather(mi.Float, children[0].branch.allowance, parent)
        dr.eval(parent, second)
        child = Branch(ray, weight, front.level + 1, allowance,
                       float(dr.sum(weight)[0]) if with_total else 0.0)
        return child, parent, second


def _plus_children(total, value, parent, second, tp, width: int):
    """``total`` plus ``value`` of the first children, then of the second, at their parents' lanes."""
    for which in (False, True):
        out = dr.zeros(tp, width)
        if second is not None:
            dr.scatter(out, value, parent, second if which else ~second)
        elif not which:
            dr.scatter(out, value, parent)
        total = total + out
    return total


class _Progress:
    """A pass's progress, reported to ``progress`` as the path weight still to shade shrinks."""

    def __init__(self, count: int, progress):
        self.count, self.progress = count, progress
        self.reports = progress is not None
        self.pending, self.done = float(count), 0

    def shaded(self, front, handed_down) -> None:
        """``front`` is shaded, its weight handed down to the branches ``handed_down``."""
        if not self.reports:
            return
        self.pending -= front.total - sum(branch.total for branch in handed_down)
        finished = self.count - self.pending
        if finished > self.done:
            self.progress(finished - self.done)
            self.done = finished

    def finish(self) -> None:
        if self.reports and self.count > self.done:
            self.progress(self.count - self.done)


# -- adaptive depth control (docs/statistics.md) ---------------------------------------------------

def split(w1, w2, a):
    """The rule for children of weights ``w1`` and ``w2`` under allowance ``a``: ``(traced1,
    traced2, allowance, culled)``, ``allowance`` being that of either traced child and
    ``culled`` the weight left untraced."""
    first_is_lighter = w1 <= w2
    light, heavy = dr.minimum(w1, w2), dr.maximum(w1, w2)
    light_traced = light > a
    rest = dr.select(light_traced, 0.5 * a, a - light)
    heavy_traced = heavy > rest
    culled = dr.select(light_traced, 0, light) + dr.select(heavy_traced, 0, heavy)
    return (dr.select(first_is_lighter, light_traced, heavy_traced),
            dr.select(first_is_lighter, heavy_traced, light_traced), rest, culled)


def brightest(analysis, lighting: str, ambient: float):
    """L: a bound on every channel of every ray's color (docs/statistics.md), or None where
    a texture, an environment or a light on a surface leaves it unknown."""
    tables = analysis.tables
    base, gain = analysis.surfaces.largest_base(), analysis.surfaces.largest_gain()
    if base is None or tables.background is None:
        return None
    if lighting == "physical":
        lit = 0.0
        for light in analysis.lights:
            distance = tables.primitives.distance_to_surfaces(light.position)
            if distance <= 0:
                return None
            lit += max(light.intensity) / distance ** 2
        point = base * lit / math.pi
    else:
        lit = sum(max(light.color) for light in analysis.lights)
        point = base * (ambient + (1 - ambient) * lit)
    return max(point, tables.background) * max(1.0, gain) ** (analysis.depth - 1)


# -- what a render counts -------------------------------------------------------------------------

@dataclass
class RayCounts:
    """Rays traced by one render (``whitted render --stats``; docs/statistics.md);
    ``sample_culled_weight``: the most weight culled from one camera sample's tree."""
    camera: int = 0
    shadow: int = 0
    reflection: int = 0
    refraction: int = 0
    merged: int = 0
    max_depth_reached: int = 0
    culled: int = 0
    culled_weight: float = 0.0
    sample_culled_weight: float = 0.0

    def rays(self) -> dict:
        return {kind: getattr(self, kind)
                for kind in ("camera", "shadow", "reflection", "refraction")}


class Tally:
    """Running counts of one render (:class:`RayCounts`' fields): one-element arrays the
    kernels add to atomically (JIT), or Python numbers (scalar)."""

    def __init__(self):
        self._jit = dr.is_jit_v(mi.Float)
        self._sums = {}

    def add(self, name: str, mask) -> None:
        self._add(name, mi.UInt32, 1, mask)

    def add_total(self, name: str, value, mask) -> None:
        """Add up ``value`` over the set lanes of ``mask`` (in float64: millions of terms)."""
        self._add(name, mi.Float64, mi.Float64(value), mask)

    def note_max(self, name: str, value) -> None:
        """Keep the largest of ``value``'s lanes (and of those noted before)."""
        self._add(name, mi.Float, value, True, dr.ReduceOp.Max)

    def _add(self, name, tp, value, mask, op=dr.ReduceOp.Add):
        if not self._jit:
            if mask:
                old = self._sums.get(name, 0)
                self._sums[name] = old + value if op == dr.ReduceOp.Add else max(old, value)
            return
        if name not in self._sums:
            self._sums[name] = dr.zeros(tp, 1)
            dr.make_opaque(self._sums[name])
        dr.scatter_reduce(op, self._sums[name], value, mi.UInt32(0), mask)

    def read(self, **known) -> RayCounts:
        """The counts as Python numbers, with ``known`` ones (e.g. ``camera``) added."""
        kinds = {f.name: f.type for f in fields(RayCounts)}
        values = {name: (float if kinds[name] == "float" else int)(value[0] if self._jit else value)
                  for name, value in self._sums.items()}
        return RayCounts(**{**values, **known})
