"""``--budget``: the whole command's wall-clock time, and how renders are fitted in it.

Three decisions, kept apart from the sweep that acts on them: how much of the time
left a scene may use (an even share among the scenes still to do, after a few
seconds kept back for writing the outputs), how many samples its reference can
afford (from a probe render's cost per sample), and whether a render fits in
what the scene has left (predicted from what the same method already cost
there). A share is a duration, not a clock reading, so it means the same in
another process or on another machine.

The reference comes first and is the costliest render of a scene, so it is the
one that used to sink a budget (a 20-second budget met a reference of three
hours). Its cost is now measured on a short probe before it is started, and it
may take at most :data:`~whitted.defaults.COMPARE_REFERENCE_SHARE` of the
scene's share: when the requested spp does not fit, the largest power of two
that does is used, and below
:data:`~whitted.defaults.COMPARE_MIN_REFERENCE_SPP` the scene is refused.
"""

from __future__ import annotations

import math
import time

from ..defaults import (COMPARE_MIN_REFERENCE_SPP, COMPARE_REFERENCE_SHARE,
                        COMPARE_REPORT_SECONDS)
from .results import Setting


class Budget:
    """Wall-clock time for the whole command, shared fairly among the scenes still to do.

    Before each render the sweep predicts its cost from what the same method has
    already cost on this scene (time grows with spp and depth) and skips it when it
    would overrun; a render that has begun is not interrupted.

    ============ ==================================================================
    ``seconds``  the whole command's time (None: unbounded); the clock starts when
                 the budget is made
    ============ ==================================================================
    """

    def __init__(self, seconds: float | None):
        self.seconds = seconds
        self.start = time.monotonic()
        #: kept back for writing the outputs: a tenth of the budget, at most a few seconds
        self.reserve = 0.0 if seconds is None else min(COMPARE_REPORT_SECONDS, 0.1 * seconds)

    def share(self, scenes_left: int) -> float:
        """Seconds the next scene may take: the time left, less the outputs' reserve,
        over the scenes left (``math.inf`` without a budget, 0 when it is spent)."""
        if self.seconds is None:
            return math.inf
        remaining = max(0.0, self.start + self.seconds - self.reserve - time.monotonic())
        return remaining / max(1, scenes_left)

    #: the fewest spp :meth:`reference_spp` scales a reference down to
    minimum_reference_spp = COMPARE_MIN_REFERENCE_SPP

    @staticmethod
    def reference_spp(requested: int, seconds_per_spp: float, seconds: float,
                      spent: float = 0.0) -> int | None:
        """The reference's spp within a scene's share of ``seconds``: it may take
        :data:`COMPARE_REFERENCE_SHARE` of them, less ``spent`` (the probe). That is
        ``requested`` when it fits at ``seconds_per_spp``, else the largest power of two
        that fits; None when not even :data:`COMPARE_MIN_REFERENCE_SPP` fit."""
        if not math.isfinite(seconds):
            return requested
        allowed = max(0.0, COMPARE_REFERENCE_SHARE * seconds - spent)
        affordable = math.floor(allowed / seconds_per_spp) if seconds_per_spp > 0 else requested
        if requested <= affordable:
            return requested
        if affordable < COMPARE_MIN_REFERENCE_SPP:
            return None
        return 1 << (affordable.bit_length() - 1)

    @staticmethod
    def predict(setting: Setting, done: list[tuple[Setting, float, float]], repeats: int) -> float:
        """Seconds the setting will take, from ``done`` = [(setting, median seconds, wall)];
        0 when this method has not run yet (its first render is always tried)."""
        estimates = []
        for other, seconds, wall in done:
            if other.method != setting.method:
                continue
            scale = setting.spp / other.spp * max(1.0, setting.max_depth / other.max_depth)
            overhead = max(0.0, wall - repeats * seconds)  # compilation, scoring
            estimates.append(repeats * seconds * scale + overhead)
        return max(estimates, default=0.0)
