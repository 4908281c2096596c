"""``--budget``: the whole command's wall-clock time, and how renders are fitted in it.

Three decisions, kept apart from the sweep that acts on them: how much of the time left
a scene may use (an even share among the scenes still to do), how many samples its
reference can afford (from probe renders: a cost per render call and per sample,
:func:`fit_cost`, :func:`render_cost`), and whether a render fits in what the scene has
left (predicted from what the same method already cost there): docs/compare.md,
"Budget". A share is a duration, not a clock reading, so it means the same in another
process or on another machine.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from ..defaults import (COMPARE_MIN_REFERENCE_SPP, COMPARE_REFERENCE_SHARE,
                        COMPARE_REPORT_SECONDS)
from .results import Setting


class Budget:
    """Wall-clock time for the whole command, shared fairly among the scenes still to do.

    Before each render the sweep predicts its cost from what the same method has
    already cost on this scene (time grows with spp and depth) and skips it when it
    would overrun; a render that has begun is not interrupted.

    ============ ==================================================================
    ``seconds``  the whole command's time (None: unbounded)
    ``start``    when its clock started (a ``time.monotonic`` reading; None: now)
    ============ ==================================================================
    """

    def __init__(self, seconds: float | None, start: float | None = None):
        self.seconds = seconds
        self.start = time.monotonic() if start is None else start

    def reserve(self, scenes_left: int) -> float:
        """Seconds kept back for writing the outputs of ``scenes_left`` scenes (plots,
        contact sheet, page): :data:`COMPARE_REPORT_SECONDS` each, at most a quarter of
        the budget."""
        if self.seconds is None:
            return 0.0
        return min(COMPARE_REPORT_SECONDS * max(1, scenes_left), 0.25 * self.seconds)

    def share(self, scenes_left: int) -> float:
        """Seconds the next scene may take: the time left, less the outputs' reserve,
        over the scenes left (``math.inf`` without a budget, 0 when it is spent)."""
        if self.seconds is None:
            return math.inf
        remaining = self.start + self.seconds - self.reserve(scenes_left) - time.monotonic()
        return max(0.0, remaining) / max(1, scenes_left)

    @staticmethod
    def reference_spp(requested: int, cost: Callable[[int], float], seconds: float,
                      spent: float = 0.0) -> int | None:
        """The reference's spp within a scene's share of ``seconds``, of which it may take
        :data:`COMPARE_REFERENCE_SHARE`, less ``spent`` (the probe): ``requested`` when
        its ``cost(spp)`` (seconds) fits, else the largest power of two below it that
        fits; None when not even :data:`COMPARE_MIN_REFERENCE_SPP` fit."""
        if not math.isfinite(seconds):
            return requested
        allowed = COMPARE_REFERENCE_SHARE * seconds - spent
        candidates = [requested] + [1 << k for k in range(requested.bit_length() - 1, -1, -1)
                                    if 1 << k < requested]
        for spp in candidates:
            if spp < COMPARE_MIN_REFERENCE_SPP:
                break
            if cost(spp) <= allowed:
                return spp
        return None

    @staticmethod
    def predict(setting: Setting, done: list[tuple[Setting, float, float]]) -> tuple[float, float]:
        """Seconds the setting's render will take, and its scoring and compilation on top,
        from ``done`` = [(setting, seconds of its scored render, wall time of it with
        scoring)]; (0, 0) when this method has not run yet (its first render is always
        tried)."""
        estimates = [(0.0, 0.0)]
        for other, seconds, wall in done:
            if other.method == setting.method:
                scale = setting.spp / other.spp * max(1.0, setting.max_depth / other.max_depth)
                estimates.append((seconds * scale, max(0.0, wall - seconds)))
        return max(estimates, key=sum)


def fit_cost(points: list[tuple[int, float]]) -> tuple[float, float]:
    """A render's cost as t(n) = a + b·n seconds for n spp, from probe renders [(n, t)]:
    a (the cost of a render call: kernel launch, scene setup) and b (per spp) from the
    line through the last two points; with one point, or two that do not rise (timing
    noise), a = 0 and b = t / n of the last, which overestimates larger renders a little
    (it counts a in every sample) but never underestimates them."""
    n1, t1 = points[-1]
    if len(points) >= 2:
        n0, t0 = points[-2]
        if n1 > n0 and t1 > t0:
            per_spp = (t1 - t0) / (n1 - n0)
            return max(0.0, t1 - per_spp * n1), per_spp
    return 0.0, t1 / n1


def render_cost(spp: int, passes: int, overhead: float, per_spp: float) -> float:
    """Seconds to render ``spp`` samples per pixel in ``passes`` render passes (the rendering
    API's :func:`~whitted.rendering.path_passes`), at ``overhead`` a pass and ``per_spp``."""
    if spp <= 0:
        return 0.0
    return passes * overhead + spp * per_spp
