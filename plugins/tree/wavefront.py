"""The ray tree walked level by level, a wavefront at a time (JIT variants).

A *wavefront* is a :class:`~.tracer.Branch` whose fields are Dr.Jit arrays:
rays of one level of the tree with their path weights and the camera sample
each belongs to (``owner``). The tracer keeps a stack of them. Shading a
wavefront adds its colors to their camera samples and pushes one wavefront
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
#: and splats each sample, storing nothing per lane, so a larger pass costs no
#: memory; but it is one kernel, which Ctrl-C cannot stop, and 2^21 samples keep
#: it short (well under a second on 2 cores: benchmarks/RESULTS.md)
SAMPLES_PER_FLAT_PASS = 1 << 21


class WavefrontTracer(Tracer):
    def __init__(self, shader, epsilon: float, tally, lanes: int):
        super().__init__(shader, epsilon, tally)
        self.lanes = lanes
        self.samples_per_pass = SAMPLES_PER_PASS if shader.depth > 1 else SAMPLES_PER_FLAT_PASS

    def samples(self, count: int):
        return [dr.arange(mi.UInt32, count)]   # the whole pass is one wavefront

    def finish_pass(self) -> None:
        dr.eval()          # the pass's kernels and side effects (the block's accumulation)
        dr.sync_thread()   # so that progress reports finished work

    def trace(self, ray, progress=None):
        count = dr.width(ray.d)
        color = culled = None
        camera = self.camera_branch(ray)
        camera.total = float(count)
        stack, done, scattered = [camera], 0.0, False
        while stack:
            front = stack.pop()
            if front.owner is not None and dr.width(front.weight) > self.lanes:
                stack.extend(reversed(self._split(front, progress is not None)))
                continue
            front_color, front_culled, children = self.step(front)
            if front.owner is None:   # the camera rays: lane i is sample i
                color, culled = front_color, front_culled
            else:
                scattered = True
                dr.scatter_reduce(dr.ReduceOp.Add, color, front_color, front.owner)
                if front_culled is not None:
                    dr.scatter_reduce(dr.ReduceOp.Add, culled, front_culled, front.owner)
            if children:
                stack.extend(self._next_level(front, children, (color, culled), progress is not None))
            if progress is not None:
                # A level is done (packing its children waited for its kernels) and Python
                # has control: Ctrl-C lands here, between levels, and progress is told.
                finished = count - sum(branch.total for branch in stack)
                if finished > done:
                    progress(finished - done)
                    done = finished
        if progress is not None and count > done:
            progress(count - done)
        if scattered:
            dr.eval(color, culled)   # finish the last scatters before anything reads the sums
        if culled is not None:
            self.tally.note_max("sample_culled_weight", culled)
        return color

    def _next_level(self, front, children, sums, with_total: bool):
        """The wavefront of ``children``: only their traced lanes, siblings side by side."""
        # One kernel shades this level, adds its color, and stores the children ...
        dr.eval(sums, front.owner, [(c.branch.ray.o, c.branch.ray.d, c.branch.weight, c.branch.allowance,
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
        # the allowance is the same for both children of a ray (see .adaptive.split)
        allowance = None if front.allowance is None else dr.gather(mi.Float, children[0].branch.allowance, parent)
        owner = parent if front.owner is None else dr.gather(mi.UInt32, front.owner, parent)
        return [Branch(ray, weight, front.level + 1, allowance, owner,
                       float(dr.sum(weight)[0]) if with_total else 0.0)]

    def _split(self, front, with_total: bool):
        """``front`` cut into wavefronts of at most ``lanes`` lanes."""
        dr.eval(front.ray, front.weight, front.allowance, front.owner)
        n = dr.width(front.weight)
        pieces = []
        for start in range(0, n, self.lanes):
            lane = dr.arange(mi.UInt32, min(self.lanes, n - start)) + dr.opaque(mi.UInt32, start)
            weight = dr.gather(mi.Float, front.weight, lane)
            pieces.append(Branch(
                mi.Ray3f(dr.gather(mi.Point3f, front.ray.o, lane), dr.gather(mi.Vector3f, front.ray.d, lane)),
                weight, front.level,
                None if front.allowance is None else dr.gather(mi.Float, front.allowance, lane),
                dr.gather(mi.UInt32, front.owner, lane), float(dr.sum(weight)[0]) if with_total else 0.0))
        return pieces
