"""The ray tree walked depth first, one ray at a time (scalar variants).

This is the article's recursion as written: shade a ray, then trace each of
its children that is traced and add up their colors. In the scalar variants
Mitsuba's values are plain numbers, one ray's, so there is no array to gather
a level's rays into; the recursion needs none, and is at most 64 calls deep.
"""

from __future__ import annotations

from .tracer import Tracer


class DepthFirstTracer(Tracer):
    #: a pass only paces the progress reports here: the tracer holds one ray's tree at a time
    samples_per_pass = 1 << 10

    def samples(self, count: int):
        return range(count)   # one camera sample at a time

    def trace(self, ray, progress=None):
        color, culled = self._trace(self.camera_branch(ray))
        if culled is not None:
            self.tally.note_max("sample_culled_weight", culled)
        if progress is not None:
            progress(1)
        return color

    def _trace(self, branch):
        """The color of ``branch``'s tree and the weight culled from it (None: traced exactly)."""
        color, culled, children = self.step(branch)
        for child in children:
            if child.traced:
                child_color, child_culled = self._trace(child.branch)
                color = color + child_color
                if child_culled is not None:   # (None below a leaf, or everywhere when exact)
                    culled = culled + child_culled
        return color, culled
