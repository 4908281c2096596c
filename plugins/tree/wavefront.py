"""The ray tree walked level by level, a wavefront at a time (JIT variants).

A *wavefront* is a :class:`~.tracer.Branch` whose fields are Dr.Jit arrays:
rays of one level of the tree with their path weights. Shading a wavefront
gives each lane's own color and one wavefront of children, holding only the
lanes that are really traced (``dr.compress``), each with the lane of its
parent: one kernel shades a level, and a small one packs its children. The
walk goes down a wavefront's children before adding their colors back up to
their parents, each parent's first child and then its second, in a fixed
order: the image is the same bits run after run and at any thread count.
Wavefronts wider than ``lanes`` are split, so that trees which double at each
level still run in bounded memory. No Python runs per ray.
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
        # A wavefront's width is its ray's widest field: the rays of a sensor may share their
        # origin (a pinhole) or their direction (orthographic, distant), held as one value.
        count = dr.width(ray)
        camera = self.camera_branch(ray)
        camera.total = float(count)
        walk = _Walk(count, progress)
        color, culled = self._subtree(camera, walk)
        walk.finish()
        if culled is not None:
            self.tally.note_max("sample_culled_weight", culled)
        return color

    def _subtree(self, front, walk):
        """The color of each lane's tree below and including ``front`` and the weight culled
        from it (None: traced exactly).

        A ray's color is its own plus its first child's tree plus its second child's, added in
        that order, as :class:`~.depth_first.DepthFirstTracer` adds them: each sum has a fixed
        order, so the image is the same bits however many threads trace it (an atomic add of
        every level into its camera sample would add in the order the threads finish)."""
        if front.level > 1 and dr.width(front.ray) > self.lanes:   # a pass's camera rays fit
            return self._pieces(front, walk)
        color, culled, children = self.step(front)
        below = self._next_level(front, children, (color, culled), walk.reports) if children else None
        walk.shaded(front, below)
        if below is not None:
            child, parent, second = below
            child_color, child_culled = self._subtree(child, walk)
            width = dr.width(front.ray)   # (a camera wavefront's weight is one literal 1)
            color = color + _to_parents(child_color, parent, second, False, mi.Color3f, width) \
                + _to_parents(child_color, parent, second, True, mi.Color3f, width)
            if child_culled is not None:
                culled = culled + _to_parents(child_culled, parent, second, False, mi.Float, width) \
                    + _to_parents(child_culled, parent, second, True, mi.Float, width)
            dr.eval(color, culled)   # (a single-level tree is left lazy: it may be traced in a loop)
        return color, culled

    def _pieces(self, front, walk):
        """:meth:`_subtree` of a wavefront too wide for one, a piece of ``lanes`` at a time."""
        pieces = self._split(front, walk.reports)
        walk.replaced(front, pieces)
        n = dr.width(front.ray)
        color, culled = dr.zeros(mi.Color3f, n), None
        for start, piece in pieces:
            lane = dr.arange(mi.UInt32, dr.width(piece.weight)) + dr.opaque(mi.UInt32, start)
            piece_color, piece_culled = self._subtree(piece, walk)
            dr.scatter(color, piece_color, lane)
            if piece_culled is not None:
                if culled is None:
                    culled = dr.zeros(mi.Float, n)
                dr.scatter(culled, piece_culled, lane)
            dr.eval(color, culled)
        return color, culled

    def _next_level(self, front, children, sums, with_total: bool):
        """The wavefront of ``children``: only their traced lanes, siblings side by side;
        with the lane of ``front`` each came from and whether it is the second child
        (None: there is one kind of child). None when no child is traced."""
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

        ray = mi.Ray3f(gather(mi.Point3f, lambda c: c.branch.ray.o), gather(mi.Vector3f, lambda c: c.branch.ray.d))
        weight = gather(mi.Float, lambda c: c.branch.weight)
        # the allowance is the same for both children of a ray (see .adaptive.split)
        allowance = None if front.allowance is None else dr.gather(mi.Float, children[0].branch.allowance, parent)
        dr.eval(parent, second)
        child = Branch(ray, weight, front.level + 1, allowance, float(dr.sum(weight)[0]) if with_total else 0.0)
        return child, parent, second

    def _split(self, front, with_total: bool):
        """``front`` cut into wavefronts of at most ``lanes`` lanes, each with its first lane."""
        dr.eval(front.ray, front.weight, front.allowance)
        n = dr.width(front.weight)
        pieces = []
        for start in range(0, n, self.lanes):
            lane = dr.arange(mi.UInt32, min(self.lanes, n - start)) + dr.opaque(mi.UInt32, start)
            weight = dr.gather(mi.Float, front.weight, lane)
            pieces.append((start, Branch(
                mi.Ray3f(dr.gather(mi.Point3f, front.ray.o, lane), dr.gather(mi.Vector3f, front.ray.d, lane)),
                weight, front.level,
                None if front.allowance is None else dr.gather(mi.Float, front.allowance, lane),
                float(dr.sum(weight)[0]) if with_total else 0.0)))
        return pieces


def _to_parents(value, parent, second, which: bool, tp, width: int):
    """``value`` of each child lane at its parent's lane (0 where that parent has no such
    child): the first children's (``which`` False) or the second children's. A parent has at
    most one child of each kind, so each is a plain scatter, with no order to depend on."""
    out = dr.zeros(tp, width)
    if second is None:
        if not which:
            dr.scatter(out, value, parent)
        return out
    dr.scatter(out, value, parent, second if which else ~second)
    return out


class _Walk:
    """Progress of one pass's trees, reported to ``progress`` (when given) as the camera
    samples' path weight still to be shaded shrinks: a wavefront shaded takes its weight off
    and adds its children's. Python has control between levels: Ctrl-C lands there."""

    def __init__(self, count: int, progress):
        self.count, self.progress = count, progress
        self.reports = progress is not None
        self.pending, self.done = float(count), 0.0

    def shaded(self, front, below) -> None:
        if self.reports:
            self.pending -= front.total - (below[0].total if below is not None else 0.0)
            self._report()

    def replaced(self, front, pieces) -> None:
        if self.reports:
            self.pending -= front.total - sum(piece.total for _, piece in pieces)
            self._report()

    def _report(self) -> None:
        finished = self.count - self.pending
        if finished > self.done:
            self.progress(finished - self.done)
            self.done = finished

    def finish(self) -> None:
        if self.reports and self.count > self.done:
            self.progress(self.count - self.done)
