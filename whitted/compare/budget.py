"""``--budget``: the whole command's wall-clock time, and how renders are fitted in it: a
scene's share, its reference's spp and whether a render fits (docs/compare.md, "Budget").
A share is a duration, not a clock reading, so it means the same on another machine.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from ..defaults import (COMPARE_MIN_REFERENCE_SPP, COMPARE_REFERENCE_SHARE,
                        COMPARE_REPORT_SECONDS)
from .results import Setting


class Budget:
    """Wall-clock time for the whole command, shared fairly among the scenes still to do
    (``start``: a ``time.monotonic`` reading)."""

    def __init__(self, seconds: float | None, start: float | None = None):
        self.seconds = seconds
        self.start = time.monotonic() if start is None else start

    def reserve(self, scenes_left: int) -> float:
        """Seconds kept back for the outputs of ``scenes_left`` scenes, at most a quarter."""
        if self.seconds is None:
            return 0.0
        return min(COMPARE_REPORT_SECONDS * max(1, scenes_left), 0.25 * self.seconds)

    def share(self, scenes_left: int) -> float:
        """Seconds the next scene may take (``math.inf`` without a budget, 0 once spent)."""
        if self.seconds is None:
            return math.inf
        remaining = self.start + self.seconds - self.reserve(scenes_left) - time.monotonic()
        return max(0.0, remaining) / max(1, scenes_left)

    @staticmethod
    def reference_spp(requested: int, cost: Callable[[int], float], seconds: float,
                      spent: float = 0.0) -> int | None:
        """The reference's spp in its share of ``seconds`` less ``spent``: ``requested`` when it
    fits, else the largest power of two below that fits; None below the minimum. What costs
    nothing more (``cost`` 0: its probes rendered it) fits even when they overran the share."""
        if not math.isfinite(seconds):
            return requested
        allowed = max(0.0, COMPARE_REFERENCE_SHARE * seconds - spent)
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
        """The seconds a render will take, and its scoring on top, scaled from what the same
    method cost in ``done``; (0, 0) for its first render, which is always tried."""
        estimates = [(0.0, 0.0)]
        for other, seconds, wall in done:
            if other.method == setting.method:
                scale = setting.spp / other.spp * max(1.0, setting.max_depth / other.max_depth)
                estimates.append((seconds * scale, max(0.0, wall - seconds)))
        return max(estimates, key=sum)


def fit_cost(points: list[tuple[int, float]]) -> tuple[float, float]:
    """A render's cost as a + b·n seconds for n spp, from the last two probe renders [(n, t)];
    where they do not rise (noise), a = 0: an overestimate, never an underestimate."""
    n1, t1 = points[-1]
    if len(points) >= 2:
        n0, t0 = points[-2]
        if n1 > n0 and t1 > t0:
            per_spp = (t1 - t0) / (n1 - n0)
            return max(0.0, t1 - per_spp * n1), per_spp
    return 0.0, t1 / n1


def render_cost(spp: int, passes: int, overhead: float, per_spp: float) -> float:
    return passes * overhead + spp * per_spp if spp > 0 else 0.0
