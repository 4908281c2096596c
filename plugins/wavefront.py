"""The ray tree walked level by level, a wavefront at a time (JIT variants).

A *wavefront* is a :class:`~.tracer.Branch` whose fields are Dr.Jit arrays:
rays of one level of the tree with their path weights and the camera sample
each belongs to (``owner``). The tracer keeps a stack of them. Shading a
wavefront adds its colours to their camera samples and pushes one wavefront
of children, holding only the lanes that are really traced (``dr.compress``):
one kernel shades a level, and a small one packs its children. Wavefronts
wider than ``lanes`` are split, so that trees which double at each level still
run in bounded memory. No Python runs per ray.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from .tracer import Branch, Tracer

#: default camera samples per pass (and widest wavefront): a level holds about
#: 100 bytes per lane, so a pass stays around 100 MiB
SAMPLES_PER_PASS = 1 << 20
#: the same when the tree has a single level: then one kernel traces, shades
#: and splats each sample, storing nothing per lane, and larger passes are free
SAMPLES_PER_FLAT_PASS = 1 << 24


class WavefrontTracer(Tracer):
    def __init__(self, shader, min_weight: float, tally, lanes: int):
        super().__init__(shader, min_weight, tally)
        self.lanes = lanes
        self.samples_per_pass = SAMPLES_PER_PASS if shader.depth > 1 else SAMPLES_PER_FLAT_PASS

    def samples(self, count: int):
        return [dr.arange(mi.UInt32, count)]   # the whole pass is one wavefront

    def finish_pass(self) -> None:
        dr.eval()          # the pass's kernels and side effects (the block's accumulation)
        dr.sync_thread()   # so that progress reports finished work

    def trace(self, ray):
        total, scattered = None, False
        stack = [Branch(ray, mi.Float(1), 1)]
        while stack:
            front = stack.pop()
            if front.owner is not None and dr.width(front.weight) > self.lanes:
                stack.extend(reversed(self._split(front)))
                continue
            colour, children = self.step(front)
            if total is None:   # the camera rays: lane i is sample i
                total = colour
            else:
                dr.scatter_reduce(dr.ReduceOp.Add, total, colour, front.owner)
                scattered = True
            if children:
                stack.extend(self._next_level(front, children, total))
        if scattered:
            dr.eval(total)   # finish the last scatter before anything reads the total
        return total

    def _next_level(self, front, children, total):
        """The wavefront of ``children``: only their traced lanes, siblings side by side."""
        # One kernel shades this level, adds its colour, and stores the children ...
        dr.eval(total, front.owner, [(c.branch.ray.o, c.branch.ray.d, c.branch.weight, c.traced)
                                     for c in children])
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
            return []
        parent, second = (lane, None) if len(children) == 1 else (lane >> 1, (lane & 1) == 1)

        def gather(tp, field):
            """``field`` of each traced child, from the child of its kind."""
            if second is None:
                return dr.gather(tp, field(children[0]), parent)
            return dr.select(second, dr.gather(tp, field(children[1]), parent, second),
                             dr.gather(tp, field(children[0]), parent, ~second))

        ray = mi.Ray3f(gather(mi.Point3f, lambda c: c.branch.ray.o), gather(mi.Vector3f, lambda c: c.branch.ray.d))
        weight = gather(mi.Float, lambda c: c.branch.weight)
        owner = parent if front.owner is None else dr.gather(mi.UInt32, front.owner, parent)
        return [Branch(ray, weight, front.level + 1, owner)]

    def _split(self, front):
        """``front`` cut into wavefronts of at most ``lanes`` lanes."""
        dr.eval(front.ray, front.weight, front.owner)
        n = dr.width(front.weight)
        pieces = []
        for start in range(0, n, self.lanes):
            lane = dr.arange(mi.UInt32, min(self.lanes, n - start)) + dr.opaque(mi.UInt32, start)
            pieces.append(Branch(
                mi.Ray3f(dr.gather(mi.Point3f, front.ray.o, lane), dr.gather(mi.Vector3f, front.ray.d, lane)),
                dr.gather(mi.Float, front.weight, lane), front.level, dr.gather(mi.UInt32, front.owner, lane)))
        return pieces
