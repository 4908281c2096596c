"""The ray tree walked depth first, one ray at a time (scalar variants).

This is the article's recursion as written: shade a ray, then trace each of
its children that is traced and add up their colours. In the scalar variants
Mitsuba's values are plain numbers, one ray's, so there is no array to gather
a level's rays into; the recursion needs none, and is at most 64 calls deep.
"""

from __future__ import annotations

from .tracer import Branch, Tracer


class DepthFirstTracer(Tracer):
    #: a pass only paces the progress reports here: the tracer holds one ray's tree at a time
    samples_per_pass = 1 << 10

    def samples(self, count: int):
        return range(count)   # one camera sample at a time

    def trace(self, ray):
        return self._trace(Branch(ray, 1.0, 1))

    def _trace(self, branch):
        colour, children = self.step(branch)
        for child in children:
            if child.traced:
                colour = colour + self._trace(child.branch)
        return colour
