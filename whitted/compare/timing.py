"""Render times that compare on a busy machine: what is compared is timed in the same
moments, in rounds, and a ratio of times is the median of its per-round ratios with a
distribution-free confidence interval (docs/compare.md, "Timing").
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import Callable

from ..defaults import COMPARE_CONFIDENCE, COMPARE_RUN_SHARE, COMPARE_SETTLED_WIDTH


def interleaved(items: list, k: int):
    """Round ``k``'s order: forward, then backward, so a drift within a round falls on both ends."""
    return items if k % 2 == 0 else reversed(items)


def median(values) -> float:
    """The median of the finite ``values`` (NaN: none)."""
    finite = [v for v in values if math.isfinite(v)]
    return statistics.median(finite) if finite else math.nan


def _order_rank(n: int, confidence: float) -> int:
    """The rank k whose order statistics [x(k), x(n+1-k)] hold the median of n values with
    ``confidence``; 1 (the extremes) where n is too small for any."""
    tail = (1.0 - confidence) / 2.0
    k = 1
    while k + 1 <= (n + 1) // 2 and sum(math.comb(n, i) for i in range(k + 1)) / 2.0 ** n <= tail:
        k += 1
    return k


def coverage(n: int) -> float:
    """How surely the interval :meth:`Interval.of` gives for n values holds their median."""
    if n < 2:
        return 0.0
    k = _order_rank(n, COMPARE_CONFIDENCE)
    return 1.0 - 2.0 * sum(math.comb(n, i) for i in range(k)) / 2.0 ** n


@dataclass(frozen=True)
class Interval:
    """A ratio measured in paired rounds: the median of the per-round ratios, and its
    interval (:data:`COMPARE_CONFIDENCE` where the rounds allow it)."""
    value: float
    low: float
    high: float
    rounds: int
    spread: float = 0.0   #: the share it is widened by each way (:meth:`widened`)

    @classmethod
    def of(cls, values) -> "Interval":
        finite = sorted(v for v in values if math.isfinite(v))
        if not finite:
            return cls(math.nan, math.nan, math.nan, 0)
        k = _order_rank(len(finite), COMPARE_CONFIDENCE)
        return cls(statistics.median(finite), finite[k - 1], finite[-k], len(finite))

    @property
    def known(self) -> bool:
        return self.rounds > 0 and math.isfinite(self.value)

    @property
    def settled(self) -> bool:
        """Narrow enough to quote: high / low within 1 + COMPARE_SETTLED_WIDTH over two rounds
        or more (before :meth:`widened`: the rounds' own width)."""
        return (self.rounds >= 2 and self.low > 0 and self.high / self.low
                <= (1.0 + COMPARE_SETTLED_WIDTH) * (1.0 + self.spread) ** 2)

    def reciprocal(self) -> Interval:
        """The same ratio the other way round (b / a for a / b), as wide between runs."""
        return Interval(1 / self.value, 1 / self.high, 1 / self.low, self.rounds, self.spread)

    def widened(self, share: float) -> Interval:
        """Wider by ``share`` each way (a ratio's low end divided by 1 + share, its high end
        multiplied): what moves between runs, which one run's rounds cannot show."""
        return Interval(self.value, self.low / (1.0 + share), self.high * (1.0 + share),
                        self.rounds, share)

    @property
    def straddles_one(self) -> bool:
        """No measurable difference."""
        return self.known and self.low <= 1.0 <= self.high

    def range_text(self) -> str:
        if self.rounds < 2:
            return "1 round"
        return f"{bound_text(self.low)}–{bound_text(self.high)}× over {self.rounds} rounds"

    def as_dict(self) -> dict:
        return {"value": self.value, "low": self.low, "high": self.high, "rounds": self.rounds,
                "confidence": coverage(self.rounds), "settled": self.settled,
                "no_measurable_difference": self.straddles_one}


def bound_text(value: float) -> str:
    """An interval's end to three digits, or more where three would read as 1 and it is not
    (1.0007: ``1.001``): an interval that does not hold 1 never reads as holding it."""
    for digits in range(3, 7):
        text = f"{value:.{digits}g}"
        if text != "1" or value == 1.0:
            return text
    return text


def paired(rounds: int, ratio_in_round: Callable[[int], float]) -> Interval:
    """The :class:`Interval` of ``ratio_in_round(r)`` over rounds r = 0 … rounds - 1, widened
    by COMPARE_RUN_SHARE: the rounds of one run share its moment, another run has its own."""
    return Interval.of(ratio_in_round(r) for r in range(rounds)).widened(COMPARE_RUN_SHARE)
