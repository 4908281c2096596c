"""The formulas of the report, written once and unit-tested on hand-computed values: a
method's error-against-time curve read at a time or an error, its error floor, the
equal-quality levels, the best ambient and the reference's noise (docs/compare.md,
"Equal time, equal quality, error floor", "What the error is made of", "The reference's noise").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Generic, TypeVar

import numpy as np

from .. import metrics

T = TypeVar("T")


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The (time, error) points that no faster point beats, by increasing time."""
    return [(seconds, error) for seconds, error, _ in _front([(x, y, None) for x, y in points])]


def loglog_between(x: float, p0: tuple[float, float], p1: tuple[float, float]) -> float:
    """y at ``x`` on the straight line through ``p0`` and ``p1`` on log–log axes."""
    (x0, y0), (x1, y1) = p0, p1
    if x1 == x0:
        return min(y0, y1)
    slope = math.log(y1 / y0) / math.log(x1 / x0)
    return y0 * (x / x0) ** slope


@dataclass(frozen=True)
class Reading(Generic[T]):
    """A curve read at one point: ``how`` is ``"interpolated"``, ``"rendered"`` or ``"nearest"``
    (outside the rendered range: the nearest render's value); ``between``: the renders read."""
    value: float
    how: str
    between: tuple[T, ...]


def _front(curve: list[tuple[float, float, T]]) -> list[tuple[float, float, T]]:
    front, best = [], math.inf
    for seconds, error, payload in sorted(curve, key=lambda p: (p[0], p[1])):
        if 0 < seconds < math.inf and 0 < error < best:
            front.append((seconds, error, payload))
            best = error
    return front


def error_at_time(curve: list[tuple[float, float, T]], seconds: float) -> Reading[T] | None:
    """A method's error if given ``seconds``, read on its Pareto front; None for an empty curve."""
    front = _front(curve)
    if not front:
        return None
    if seconds <= front[0][0] or seconds >= front[-1][0]:   # at or past an end: that render
        end = front[0] if seconds <= front[0][0] else front[-1]
        return Reading(end[1], "rendered" if seconds == end[0] else "nearest", (end[2],))
    for (x0, y0, a), (x1, y1, b) in zip(front, front[1:]):
        if x0 <= seconds <= x1:
            return Reading(loglog_between(seconds, (x0, y0), (x1, y1)), "interpolated", (a, b))
    raise AssertionError("unreachable: the front covers the interval")


def time_to_reach(curve: list[tuple[float, float, T]], error: float) -> Reading[T] | None:
    """The time a method needs to reach ``error`` on its Pareto front; None when none does."""
    front = _front(curve)
    for index, (x1, y1, b) in enumerate(front):
        if y1 <= error:
            if index == 0 or y1 == error:
                return Reading(x1, "rendered" if y1 == error else "nearest", (b,))
            x0, y0, a = front[index - 1]
            slope = math.log(y1 / y0) / math.log(x1 / x0)
            return Reading(x0 * (error / y0) ** (1.0 / slope), "interpolated", (a, b))
    return None


@dataclass(frozen=True)
class Floor(Generic[T]):
    """Where more depth and samples stop paying for a Whitted method (``settled`` False: its
    floor is its costliest render, so the error may fall further)."""
    render: T
    seconds: float
    error: float
    best: float
    settled: bool


def error_floor(curve: list[tuple[float, float, T]], tolerance: float,
                work: Callable[[T], float] | None = None) -> Floor[T] | None:
    """The cheapest render within ``tolerance`` of the best error; cheapest by ``work`` when
    given, so that timing noise cannot choose. None when no error is finite."""
    usable = [p for p in curve if math.isfinite(p[1]) and math.isfinite(p[0])]
    if not usable:
        return None
    best = min(e for _, e, _ in usable)

    def cost(p):
        return (work(p[2]), p[0], p[1]) if work is not None else (p[0], p[1])
    chosen = min((p for p in usable if p[1] <= best * (1.0 + tolerance)), key=cost)
    seconds, error, render = chosen
    costlier = any(cost(p) > cost(chosen) for p in usable)
    return Floor(render, seconds, error, best, costlier)


def error_levels(floors: list[float], lowest: float, highest: float, count: int,
                 tolerance: float) -> tuple[float, ...]:
    """Equal-quality levels: each of ``floors`` times (1 + ``tolerance``) and ``count`` levels
    log-spaced between ``lowest`` and ``highest``, rounded up to two digits, largest first."""
    candidates = [f * (1.0 + tolerance) for f in floors if math.isfinite(f) and f > 0]
    if 0 < lowest < highest < math.inf:
        ratio = highest / lowest
        candidates += [lowest * ratio ** (k / (count + 1)) for k in range(1, count + 1)]
    levels: list[float] = []
    for value in sorted((_two_digits_up(v) for v in candidates), reverse=True):
        if not levels or value < 0.9 * levels[-1]:
            levels.append(value)
    return tuple(levels)


def _two_digits_up(value: float) -> float:
    exponent = math.floor(math.log10(value)) - 1
    digits = math.ceil(value / 10.0 ** exponent - 1e-9)
    return float(f"{digits}e{exponent}")


def best_ambient(dark: np.ndarray, lit: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """The article's ambient in [0, 1] closest to ``reference`` in relative MSE, and that
    error, from renders at A = 0 and A = 1 (NaN: no pixel depends on A)."""
    i0 = np.asarray(dark, dtype=np.float64)
    d = np.asarray(lit, dtype=np.float64) - i0
    r = np.asarray(reference, dtype=np.float64)
    w = 1.0 / (r * r + metrics.EPSILON)
    curvature = float(np.mean(w * d * d))
    if not curvature > 0:
        return math.nan, metrics.relative_mse(i0, r)
    ambient = min(1.0, max(0.0, float(np.mean(w * d * (r - i0))) / curvature))
    return ambient, metrics.relative_mse(i0 + ambient * d, r)


def reference_noise(half_a: np.ndarray, half_b: np.ndarray, count_a: int, count_b: int) -> float:
    """The relative MSE of a reference against the converged image, from its two halves."""
    a = np.asarray(half_a, dtype=np.float64)
    b = np.asarray(half_b, dtype=np.float64)
    total = count_a + count_b
    combined = (count_a * a + count_b * b) / total
    # relative_mse(R + (A − B), R) = mean((A − B)² / (R² + ε))
    return metrics.relative_mse(combined + (a - b), combined) * count_a * count_b / total ** 2


@dataclass(frozen=True)
class PathModel:
    """The path tracer's error as a function of spp, err(n) = c + v/n (v: the variance of
    one sample; c: the reference's noise and any bias), fitted to its renders of ``fitted``
    spp and checked by its render of ``checked`` spp, whose error it predicted within
    ``deviation`` (a fraction)."""
    c: float
    v: float
    fitted: tuple[int, ...]
    checked: int
    deviation: float

    def error(self, spp: float) -> float:
        return self.c + self.v / spp

    def spp_to_reach(self, error: float) -> float:
        """The spp at which the error falls to ``error`` (inf: never, at or below c)."""
        return self.v / (error - self.c) if error > self.c else math.inf


def fit_inverse(spp: list[float], errors: list[float], c: float) -> float:
    """v of err = c + v/n, c given (the reference's noise: the path tracer has no bias of its
    own), by least squares on residuals relative to each error, so that the small ones count."""
    x, e = 1.0 / np.asarray(spp, dtype=np.float64), np.asarray(errors, dtype=np.float64)
    w = 1.0 / e
    return float(np.sum(w * w * x * (e - c)) / np.sum(w * w * x * x))
