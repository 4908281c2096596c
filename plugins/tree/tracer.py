"""How the ray tree is walked, behind one interface.

The article's ``trace`` is recursive, but its result is linear in the
children's colors, so the color of a camera ray is a sum over its tree's
rays of ``w·contribution``, ``w`` being the product of the KR and KT factors
on the way down (see :mod:`..shading`). Which rays make up the tree, how they
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

from .adaptive import split


@dataclass
class Branch:
    """Rays of one level of the tree, with their path weights: a wavefront (JIT variants)
    or a single ray (scalar). ``allowance`` is the path weight that may still be left
    untraced below each ray (:mod:`.adaptive`; None when the tree is traced exactly).
    ``total`` is the sum of the weights, for progress reports (the wavefront tracer's
    business)."""
    ray: object      # mi.Ray3f
    weight: object   # mi.Float
    level: int       # primary rays have level 1
    allowance: object = None   # mi.Float
    total: float = 0.0


@dataclass
class Child:
    """A branch one level down, and on which lanes it is traced."""
    kind: str        # "reflection" or "refraction"
    branch: Branch
    traced: object   # mi.Bool


class Tracer:
    """Walks the trees of camera rays through one scene's :class:`~..shading.shader.Shader`.

    ``epsilon`` is each camera ray's allowance, the path weight that the
    adaptive depth control may leave untraced in its tree (:mod:`.adaptive`;
    0: the exact tree); ``tally`` receives the ray counts
    (:class:`~.counts.Tally`). Subclasses say how a pass's camera samples are
    taken (:meth:`samples`) and how a tree is walked (:meth:`trace`).
    """

    #: camera samples per pass when the integrator's ``wavefront_size`` is 0 (automatic)
    samples_per_pass = 1

    def __init__(self, shader, epsilon: float, tally):
        self.shader = shader
        self.epsilon = epsilon
        self.tally = tally
        self.deepest = 0   # the deepest level that traced a ray
        #: whether :attr:`camera_hit` is wanted (an alpha channel): then it is computed with
        #: the camera rays' level, not again afterwards
        self.keep_camera_hit = False
        self.camera_hit = None   # mi.Bool: which camera rays of the last :meth:`trace` hit
        #: shown every level :meth:`step` shades, with its lanes' shading terms (None in a
        #: render): ``recorder.level(branch, shaded, traced)``, ``traced`` a mask per child of
        #: ``shaded`` (the ray tree of a pixel: whitted/trace/record.py)
        self.recorder = None

    @staticmethod
    def passes(total: int, per_pass: int):
        """``(first, count)`` of each pass of ``per_pass`` samples over ``total`` camera samples."""
        return [(first, min(per_pass, total - first)) for first in range(0, total, per_pass)]

    def samples(self, count: int):
        """The sample indices 0 … count - 1 of a pass, as the tracer takes them."""
        raise NotImplementedError

    def trace(self, ray, progress=None):
        """The color of the camera rays ``ray``: the sum of ``w·contribution`` over their trees.

        ``progress``, when given, is called as the trees are traced with the number of camera
        samples finished since its last call: a sample counts as finished in the proportion
        of its path weight whose rays have been shaded or culled.
        """
        raise NotImplementedError

    def finish_pass(self) -> None:
        """Make a pass's work (its image block's accumulation) done before the next one."""

    def camera_branch(self, ray) -> Branch:
        return Branch(ray, mi.Float(1), 1, dr.opaque(mi.Float, self.epsilon) if self.epsilon > 0 else None)

    # -- one level, for both walks ------------------------------------------------------------------

    def step(self, branch: Branch):
        """Shade ``branch``: its color (already weighted), the weight culled below each ray
        (None when the tree is traced exactly) and its children."""
        self.deepest = max(self.deepest, branch.level)
        camera = branch.level == 1
        shaded = self.shader.shade(branch.ray, branch.weight, spawn=branch.level < self.shader.depth,
                                   coherent=camera, camera=camera)
        if camera and self.keep_camera_hit:
            self.camera_hit = shaded.hit
            if dr.is_jit_v(mi.Float):
                dr.schedule(self.camera_hit)   # evaluated by the level's own kernel
        if not shaded.children:
            if self.recorder is not None:
                self.recorder.level(branch, shaded, [])
            return shaded.color, None, []
        weights = [child.weight for child in shaded.children]
        if branch.allowance is None:
            traced, allowance, culled = [w > 0 for w in weights], None, None
        else:
            first, second, allowance, culled = split(weights[0], weights[1] if len(weights) > 1 else 0.0,
                                                     branch.allowance)
            traced = [first, second][:len(weights)]
        if self.recorder is not None:
            self.recorder.level(branch, shaded, traced)
        children = []
        for child, is_traced in zip(shaded.children, traced):
            self.tally.add(child.kind, is_traced)
            if child.merged is not None:   # one ray, counted as both kinds (see .shading)
                self.tally.add("refraction", is_traced & child.merged)
                self.tally.add("merged", is_traced & child.merged)
            if culled is not None:
                lost = dr.select(is_traced, False, child.weight > 0)
                self.tally.add("culled", lost)
                if child.merged is not None:
                    self.tally.add("culled", lost & child.merged)
                self.tally.add_total("culled_weight", child.weight, lost)
            children.append(Child(child.kind, Branch(child.ray, child.weight, branch.level + 1, allowance),
                                  is_traced))
        return shaded.color, culled, children
