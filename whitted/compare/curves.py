"""The formulas of the report, written once: a method's error-against-time curve, reading
it at a given time or error, a Whitted method's error floor, the equal-quality levels
drawn from the data, the ambient that fits the reference best, and the reference's noise.

Why these and not a fit: a method's curve is known only at the settings rendered, and
between two of them the honest guess is the straight line on log–log axes, since error
and time follow power laws (an unbiased renderer's relative MSE falls as 1/spp, its time
grows as spp). Outside the rendered range nothing is guessed: the nearest render is
used, and the caller says so. Everything here is plain Python on (time, error) pairs, so
each formula has a unit test against values computed by hand (tests/test_compare_curves.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Generic, TypeVar

import numpy as np

T = TypeVar("T")


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The (time, error) points that no faster point beats, by increasing time: the best
    error a method buys for a given time (points with a non-positive or infinite value,
    which log–log axes cannot show, are left out)."""
    return [(seconds, error) for seconds, error, _ in _front([(x, y, None) for x, y in points])]


def loglog_between(x: float, p0: tuple[float, float], p1: tuple[float, float]) -> float:
    """y at ``x`` on the straight line through ``p0`` and ``p1`` on log–log axes:
    y = y0 · (x / x0) ** s, with the slope s = ln(y1 / y0) / ln(x1 / x0)."""
    (x0, y0), (x1, y1) = p0, p1
    if x1 == x0:
        return min(y0, y1)
    slope = math.log(y1 / y0) / math.log(x1 / x0)
    return y0 * (x / x0) ** slope


@dataclass(frozen=True)
class Reading(Generic[T]):
    """A curve read at one point.

    ============ =====================================================================
    ``value``    the value read (an error at a time, or a time at an error)
    ``how``      ``"interpolated"`` (on the log–log line between two renders),
                 ``"rendered"`` (a render lies exactly there), or ``"nearest"`` (outside
                 the rendered range: the nearest render's value, not an extrapolation)
    ``between``  the payloads of the render(s) read: one, or the two interpolated
    ============ =====================================================================
    """
    value: float
    how: str
    between: tuple[T, ...]


def _front(curve: list[tuple[float, float, T]]) -> list[tuple[float, float, T]]:
    """The Pareto front of (time, error, payload) triples, payloads kept."""
    front, best = [], math.inf
    for seconds, error, payload in sorted(curve, key=lambda p: (p[0], p[1])):
        if 0 < seconds < math.inf and 0 < error < best:
            front.append((seconds, error, payload))
            best = error
    return front


def error_at_time(curve: list[tuple[float, float, T]], seconds: float) -> Reading[T] | None:
    """A method's error if given ``seconds``: its curve (time, error, payload), reduced to
    its Pareto front, read on the log–log line between the two renders around ``seconds``;
    outside them, the nearest render's error (``how="nearest"``). None for an empty curve."""
    front = _front(curve)
    if not front:
        return None
    if seconds <= front[0][0]:
        first = front[0]
        return Reading(first[1], "rendered" if seconds == first[0] else "nearest", (first[2],))
    if seconds >= front[-1][0]:
        last = front[-1]
        return Reading(last[1], "rendered" if seconds == last[0] else "nearest", (last[2],))
    for (x0, y0, a), (x1, y1, b) in zip(front, front[1:]):
        if x0 <= seconds <= x1:
            return Reading(loglog_between(seconds, (x0, y0), (x1, y1)), "interpolated", (a, b))
    raise AssertionError("unreachable: the front covers the interval")


def time_to_reach(curve: list[tuple[float, float, T]], error: float) -> Reading[T] | None:
    """The time a method needs to reach ``error``: on its Pareto front, the log–log line
    between the last render above ``error`` and the first at or below it, solved for time
    (x = x0 · (error / y0) ** (1 / s)). When its fastest render is already at or below
    ``error``, that render's time (``how="nearest"``: it may need less). None when no
    render reaches ``error``."""
    front = _front(curve)
    for index, (x1, y1, b) in enumerate(front):
        if y1 <= error:
            if index == 0:
                return Reading(x1, "rendered" if y1 == error else "nearest", (b,))
            if y1 == error:
                return Reading(x1, "rendered", (b,))
            x0, y0, a = front[index - 1]
            slope = math.log(y1 / y0) / math.log(x1 / x0)
            return Reading(x0 * (error / y0) ** (1.0 / slope), "interpolated", (a, b))
    return None


@dataclass(frozen=True)
class Floor(Generic[T]):
    """Where more depth and samples stop paying for a Whitted method.

    =========== =======================================================================
    ``render``  the payload of its cheapest render whose error is within the tolerance
                of its best: the render a reader would choose
    ``seconds`` that render's time
    ``error``   that render's error: the method's floor
    ``best``    the best error of any of its renders (at most ``error``)
    ``settled`` whether a costlier render was made and bought less than the tolerance
                (False: the floor is its costliest render, so the error may fall further)
    =========== =======================================================================
    """
    render: T
    seconds: float
    error: float
    best: float
    settled: bool


def error_floor(curve: list[tuple[float, float, T]], tolerance: float,
                work: Callable[[T], float] | None = None) -> Floor[T] | None:
    """The floor of a method's renders (time, error, payload): with e* the least error of
    them all, the cheapest render whose error is at most e* · (1 + ``tolerance``). With
    ``work`` (payload -> what the render does, e.g. its rays), the cheapest is the one of
    least work, whatever the clock said (ties: the faster, then the more accurate), so
    that timing noise cannot choose; without it, the fastest (the more accurate of two
    equally fast). None when no render has a finite error."""
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
    """Error levels for an equal-quality table, from the data: each of ``floors`` times
    (1 + ``tolerance``), so that each method reaches at least the level of its own
    floor, and ``count`` levels evenly spaced on log axes strictly between the
    ``lowest`` and ``highest`` error measured; each rounded *up* to two significant
    digits (reaching a level stays true), a level within 10% of a larger one left out
    (whoever reaches it reaches the larger), largest first."""
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
    """``value`` rounded up to two significant digits (0.1234 -> 0.13, 0.12 -> 0.12)."""
    exponent = math.floor(math.log10(value)) - 1
    digits = math.ceil(value / 10.0 ** exponent - 1e-9)
    return float(f"{digits}e{exponent}")


def best_ambient(dark: np.ndarray, lit: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """The article's ambient A in [0, 1] that brings its image closest to ``reference`` in
    relative MSE, and that error, from two renders of one tree at A = 0 (``dark``) and
    A = 1 (``lit``): the image is affine in A, so the error is a parabola in A, least at
    A* = mean(w·D·(R − I₀)) / mean(w·D²) clipped to [0, 1] (docs/compare.md, "What the
    error is made of"). When no pixel depends on A, A is NaN and the error that of ``dark``."""
    from .. import metrics

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
    """The relative MSE of a reference against the converged image, estimated from its two
    independent halves A and B, of ``count_a`` and ``count_b`` spp: mean((A − B)² / (R² + ε))
    · n_a·n_b / N² (docs/compare.md, "The reference's noise", derives it)."""
    from .. import metrics

    a = np.asarray(half_a, dtype=np.float64)
    b = np.asarray(half_b, dtype=np.float64)
    total = count_a + count_b
    combined = (count_a * a + count_b * b) / total
    # relative_mse(x, R) = mean((x − R)² / (R² + ε)); with x = R + (A − B) that is the mean above
    return metrics.relative_mse(combined + (a - b), combined) * count_a * count_b / total ** 2
