"""``--budget``: the whole command's wall-clock time, and how renders are fitted in it.

Two decisions, kept apart from the sweep that acts on them: how much of the time
left a scene may use (an even share among the scenes still to do), and whether
a render fits in what the scene has left (predicted from what the same method
already cost there). A share is a duration, not a clock reading, so it means the
same in another process or on another machine.
"""

from __future__ import annotations

import math
import time

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

    def share(self, scenes_left: int) -> float:
        """Seconds the next scene may take: the time left over the scenes left
        (``math.inf`` without a budget, 0 when it is spent)."""
        if self.seconds is None:
            return math.inf
        remaining = max(0.0, self.start + self.seconds - time.monotonic())
        return remaining / max(1, scenes_left)

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
