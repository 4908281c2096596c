"""How the ray tree is walked, behind one interface.

The article's ``trace`` is recursive, but its result is linear in the
children's colours, so the colour of a camera ray is a sum over its tree's
rays of ``w·contribution``, ``w`` being the product of the KR and KT factors
on the way down (see :mod:`.shading`). Which rays make up the tree, how they
are shaded and counted, is the same however the tree is walked, and is written
once, here (:meth:`Tracer.step`). The walk itself differs with the variant,
and the integrator picks one when it starts a render:

* :class:`~.wavefront.WavefrontTracer` (JIT variants) walks the tree level by
  level: a *wavefront* holds the rays of one level for a whole pass of camera
  samples, and no Python runs per ray;
* :class:`~.depth_first.DepthFirstTracer` (scalar variants) is the article's
  recursion, one ray at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi


@dataclass
class Branch:
    """Rays of one level of the tree, with their path weights: a wavefront (JIT variants)
    or a single ray (scalar). ``owner`` is each lane's camera sample within its pass (the
    wavefront tracer's business; None for camera rays, lane i being sample i)."""
    ray: object      # mi.Ray3f
    weight: object   # mi.Float
    level: int       # primary rays have level 1
    owner: object = None


@dataclass
class Child:
    """A branch one level down, and on which lanes it is traced."""
    kind: str        # "reflection" or "refraction"
    branch: Branch
    traced: object   # mi.Bool


class Tracer:
    """Walks the trees of camera rays through one scene's :class:`~.shading.Shader`.

    ``min_weight`` is Hall and Greenberg's adaptive depth control (see
    :meth:`traced`); ``tally`` receives the ray counts (:class:`~.counts.Tally`).
    Subclasses say how a pass's camera samples are taken (:meth:`samples`) and
    how a tree is walked (:meth:`trace`).
    """

    #: camera samples per pass when the integrator's ``wavefront_size`` is 0 (automatic)
    samples_per_pass = 1

    def __init__(self, shader, min_weight: float, tally):
        self.shader = shader
        self.min_weight = min_weight
        self.tally = tally
        self.deepest = 0   # the deepest level that traced a ray

    def passes(self, total: int, wavefront_size: int):
        """``(first, count)`` of each pass over ``total`` camera samples."""
        per_pass = wavefront_size or self.samples_per_pass
        return [(first, min(per_pass, total - first)) for first in range(0, total, per_pass)]

    def samples(self, count: int):
        """The sample indices 0 … count - 1 of a pass, as the tracer takes them."""
        raise NotImplementedError

    def trace(self, ray):
        """The colour of the camera rays ``ray``: the sum of ``w·contribution`` over their trees."""
        raise NotImplementedError

    def finish_pass(self) -> None:
        """Make a pass's work (its image block's accumulation) done before its progress is told."""

    # -- one level, for both walks ------------------------------------------------------------------

    def step(self, branch: Branch):
        """Shade ``branch``; return its colour (already weighted) and its children."""
        self.deepest = max(self.deepest, branch.level)
        shaded = self.shader.shade(branch.ray, branch.weight, spawn=branch.level < self.shader.depth,
                                   coherent=branch.level == 1)
        children = []
        for child in shaded.children:
            traced = self.traced(child.weight)
            self.tally.add(child.kind, traced)
            if child.merged is not None:   # one ray, counted as both kinds (see .shading)
                self.tally.add("refraction", traced & child.merged)
                self.tally.add("merged", traced & child.merged)
            if self.min_weight > 0:
                culled = dr.select(traced, False, child.weight > 0)
                self.tally.add("culled", culled)
                self.tally.add_total("culled_weight", child.weight, culled)
            children.append(Child(child.kind, Branch(child.ray, child.weight, branch.level + 1), traced))
        return shaded.colour, children

    def traced(self, weight):
        """Whether a child ray is traced: any ray that can still add colour, or,
        with ``min_weight`` > 0, enough of it.

        This is Hall and Greenberg's adaptive depth control (1983): a ray's
        colour reaches the pixel multiplied by its path weight, the product of
        the KR and KT factors above it, so a subtree below weight W can change
        the pixel by at most W times the brightest colour in the scene, and is
        not worth tracing when W is below what the image can show.
        """
        if self.min_weight > 0:
            return weight >= dr.opaque(mi.Float, self.min_weight)
        return weight > 0

