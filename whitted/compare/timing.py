"""Render times that compare on a busy machine: rounds, paired ratios, intervals.

On a shared machine a render's time moves 2–3× between moments minutes apart, but only
~1.2× within one moment; so what is compared is timed in the same moments, in rounds
(every setting once per round, :func:`interleaved`), a render's time the median of its
rounds, and a ratio of times the median of its per-round ratios with a distribution-free
confidence interval (:class:`Interval`): docs/compare.md, "Timing". The benchmarks time
their contenders so too (benchmarks/timing.py).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import Callable

from ..defaults import COMPARE_CONFIDENCE, COMPARE_SETTLED_WIDTH


def interleaved(items: list, k: int):
    """The order of round ``k``: forward, then backward, so that a drift within a round falls
    on both ends alike."""
    return items if k % 2 == 0 else reversed(items)


def median(values) -> float:
    """The median of the finite ``values`` (NaN: none)."""
    finite = [v for v in values if math.isfinite(v)]
    return statistics.median(finite) if finite else math.nan


def _order_rank(n: int, confidence: float) -> int:
    """The 1-based rank k of the order statistics that bound a two-sided ``confidence``
    interval for the median of n values: [x(k), x(n+1-k)] holds the median with
    probability 1 - 2·P(Binomial(n, ½) < k); the largest k whose tail is within
    (1 - confidence) / 2, and 1 (the extremes) where n is too small for any."""
    tail = (1.0 - confidence) / 2.0
    k = 1
    while k + 1 <= (n + 1) // 2 and sum(math.comb(n, i) for i in range(k + 1)) / 2.0 ** n <= tail:
        k += 1
    return k


def coverage(n: int) -> float:
    """How surely the interval :meth:`Interval.of` gives for n values holds their median:
    1 - 2·P(Binomial(n, ½) < k) for its rank k. :data:`COMPARE_CONFIDENCE` or more where n
    allows it (n ≥ 5 for 90%); less over fewer rounds, whose interval is their extremes
    (75% over 3 rounds, 50% over 2)."""
    if n < 2:
        return 0.0
    k = _order_rank(n, COMPARE_CONFIDENCE)
    return 1.0 - 2.0 * sum(math.comb(n, i) for i in range(k)) / 2.0 ** n


@dataclass(frozen=True)
class Interval:
    """A ratio measured in paired rounds.

    =========== =======================================================================
    ``value``   the median of the per-round ratios
    ``low``     the lower end of its confidence interval (:data:`COMPARE_CONFIDENCE`
                where the rounds allow it: :func:`coverage`)
    ``high``    the upper end
    ``rounds``  how many rounds gave a ratio
    =========== =======================================================================
    """
    value: float
    low: float
    high: float
    rounds: int

    @classmethod
    def of(cls, values) -> "Interval":
        """The median of ``values`` (the finite ones) and its interval."""
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
        """Whether the interval is narrow enough to be quoted: high / low at most
        1 + :data:`COMPARE_SETTLED_WIDTH`, over at least two rounds."""
        return (self.rounds >= 2 and self.low > 0
                and self.high / self.low <= 1.0 + COMPARE_SETTLED_WIDTH)

    @property
    def straddles_one(self) -> bool:
        """Whether the interval holds 1: no measurable difference."""
        return self.known and self.low <= 1.0 <= self.high

    def range_text(self) -> str:
        """``1.9–2.4× over 9 rounds`` (``1 round``: no interval)."""
        if self.rounds < 2:
            return "1 round"
        return f"{self.low:.3g}–{self.high:.3g}× over {self.rounds} rounds"

    def as_dict(self) -> dict:
        """For findings.json."""
        def number(v):
            return v if math.isfinite(v) else None
        return {"value": number(self.value), "low": number(self.low), "high": number(self.high),
                "rounds": self.rounds, "confidence": coverage(self.rounds), "settled": self.settled,
                "no_measurable_difference": self.straddles_one}


def paired(rounds: int, ratio_in_round: Callable[[int], float]) -> Interval:
    """The :class:`Interval` of ``ratio_in_round(r)`` over rounds r = 0 … rounds - 1."""
    return Interval.of(ratio_in_round(r) for r in range(rounds))
