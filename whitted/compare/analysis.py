"""What a scene's measurements say, as a rendering paper would put it: equal time, equal
quality, and where the article's model stops improving.

* **Equal time**: each Whitted setting beside the error the path tracer reaches in the
  same time (read on its curve, :func:`~whitted.compare.curves.error_at_time`). This
  answers "I have this many milliseconds: which method?"
* **Equal quality**: for each error level, the cheapest setting of each method that
  reaches it, and how many times faster the Whitted methods are than the path tracer
  there; a method that never reaches the level shows its floor (its best error).
* **Error floor**: a ray tree leaves light out (the article's ambient term stands for
  all the indirect light), so past some depth more depth stops helping, and its error
  stays at a floor that no spp removes (:func:`~whitted.compare.curves.error_floor`).
  The floor is stated in words, with the time the path tracer needs to reach it.

Everything is computed from :class:`~whitted.compare.results.SceneResult` alone (plain
data), in relative MSE, the measure whose trends are known (1/spp for an unbiased
method); FLIP is given alongside at equal time. Both reports, the text summary and the
HTML page, read these tables; neither computes anything of its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..defaults import COMPARE_FLOOR_TOLERANCE
from .curves import Floor, Reading, error_at_time, error_floor, time_to_reach
from .results import METHODS, WHITTED_METHODS, Measurement, SceneResult, seconds_text

#: How the prose names each method.
METHOD_NAMES = {"whitted-article": "the article's model",
                "whitted-physical": "the physically lit ray tree",
                "path": "the path tracer"}


@dataclass(frozen=True)
class EqualTime:
    """One Whitted render beside the path tracer given the same time.

    ============= ===================================================================
    ``whitted``   the Whitted render
    ``rel_mse``   the path tracer's relative MSE at ``whitted.seconds`` (None: no
                  path render was done)
    ``flip``      the same for FLIP
    ============= ===================================================================
    """
    whitted: Measurement
    rel_mse: Reading[Measurement] | None
    flip: Reading[Measurement] | None

    @property
    def ratio(self) -> float:
        """The Whitted render's relative MSE over the path tracer's (< 1: Whitted wins)."""
        if self.rel_mse is None or not self.rel_mse.value > 0:
            return math.nan
        return self.whitted.rel_mse / self.rel_mse.value


@dataclass(frozen=True)
class Reach:
    """One method at one error level.

    =========== =====================================================================
    ``method``  the method
    ``fastest`` its cheapest render at or below the level (None: none reaches it)
    ``best``    its most accurate render: its floor, shown when none reaches the level
    =========== =====================================================================
    """
    method: str
    fastest: Measurement | None
    best: Measurement | None


@dataclass(frozen=True)
class EqualQuality:
    """One error level: each method's cheapest render reaching it, and the speed-ups.

    ============ ====================================================================
    ``level``    the relative MSE level
    ``reach``    method -> :class:`Reach`, for every method that rendered anything
    ``speedups`` Whitted method -> the path tracer's time over its time at this level
                 (> 1: the Whitted method is faster); only where both reach it
    ============ ====================================================================
    """
    level: float
    reach: dict[str, Reach]
    speedups: dict[str, float] = field(default_factory=dict)

    @property
    def fastest_method(self) -> str | None:
        hits = [r for r in self.reach.values() if r.fastest is not None]
        return min(hits, key=lambda r: r.fastest.seconds).method if hits else None


@dataclass(frozen=True)
class FloorStatement:
    """A Whitted method's error floor and what it costs the path tracer to match it.

    ============= ====================================================================
    ``method``    the Whitted method
    ``floor``     its :class:`~whitted.compare.curves.Floor` (depth, error, settled)
    ``render``    its most accurate render at the floor's depth (whose error is the floor)
    ``path``      the path tracer's time to reach the floor (None: it never does)
    ``path_best`` the path tracer's most accurate render (None: no path render)
    ``text``      the statement in words
    ============= ====================================================================
    """
    method: str
    floor: Floor
    render: Measurement
    path: Reading[Measurement] | None
    path_best: Measurement | None
    text: str


@dataclass
class Analysis:
    """Everything the reports say about one scene."""
    entry: SceneResult
    equal_time: list[EqualTime]
    equal_quality: list[EqualQuality]
    floors: list[FloorStatement]

    @property
    def table_methods(self) -> list[str]:
        """The methods the equal-quality table has a column for, in :data:`METHODS` order."""
        return [m for m in METHODS if any(m in row.reach for row in self.equal_quality)]


def _curve(measurements: list[Measurement], metric: str) -> list[tuple[float, float, Measurement]]:
    return [(m.seconds, getattr(m, metric), m) for m in measurements]


def analyse(entry: SceneResult, levels: tuple[float, ...],
            tolerance: float = COMPARE_FLOOR_TOLERANCE) -> Analysis:
    """The equal-time and equal-quality tables and the floor statements of one scene."""
    by_method = {method: [m for m in entry.measurements if m.setting.method == method]
                 for method in METHODS}
    path = by_method["path"]
    path_mse, path_flip = _curve(path, "rel_mse"), _curve(path, "flip")

    equal_time = [EqualTime(m, error_at_time(path_mse, m.seconds), error_at_time(path_flip, m.seconds))
                  for method in WHITTED_METHODS
                  for m in sorted(by_method[method], key=lambda m: (m.setting.max_depth, m.setting.spp))]

    equal_quality = []
    for level in levels:
        reach = {}
        for method, ms in by_method.items():
            if not ms:
                continue
            hits = [m for m in ms if m.rel_mse <= level]
            reach[method] = Reach(method, min(hits, key=lambda m: m.seconds) if hits else None,
                                  min(ms, key=lambda m: m.rel_mse))
        speedups = {}
        path_reach = reach.get("path")
        for method in WHITTED_METHODS:
            own = reach.get(method)
            if own and own.fastest and path_reach and path_reach.fastest and own.fastest.seconds > 0:
                speedups[method] = path_reach.fastest.seconds / own.fastest.seconds
        equal_quality.append(EqualQuality(level, reach, speedups))

    floors = []
    path_best = min(path, key=lambda m: m.rel_mse) if path else None
    for method in WHITTED_METHODS:
        ms = by_method[method]
        best_by_depth: dict[int, float] = {}
        for m in ms:
            depth = m.setting.max_depth
            best_by_depth[depth] = min(best_by_depth.get(depth, math.inf), m.rel_mse)
        floor = error_floor(best_by_depth, tolerance)
        if floor is None:
            continue
        render = min((m for m in ms if m.setting.max_depth == floor.depth and m.rel_mse == floor.error),
                     key=lambda m: m.seconds)
        reading = time_to_reach(path_mse, floor.error) if path else None
        floors.append(FloorStatement(method, floor, render, reading, path_best,
                                     floor_text(method, floor, render, reading, path_best,
                                                entry.reference_noise, tolerance)))
    return Analysis(entry, equal_time, equal_quality, floors)


def floor_text(method: str, floor: Floor, render: Measurement, path: Reading | None,
               path_best: Measurement | None, reference_noise: float, tolerance: float) -> str:
    """The floor in words, e.g. "The article's model stops improving at depth 4: ..."."""
    name = METHOD_NAMES[method]
    error = f"{floor.error:.3g} (relative MSE, at {render.setting.label}, {seconds_text(render.seconds)})"
    if floor.settled:
        text = (f"{name[0].upper()}{name[1:]} stops improving at depth {floor.depth} (deeper trees "
                f"lower its error by less than {tolerance:.0%}); its error then is {error}")
    else:
        text = (f"{name[0].upper()}{name[1:]} is still improving at depth {floor.depth}, the deepest "
                f"rendered; its best error there is {error}")
    if path is None and path_best is None:
        text += "; the path tracer was not rendered."
    elif path is None:
        text += (f", which the path tracer does not reach: its best render ({path_best.setting.label}, "
                 f"{seconds_text(path_best.seconds)}) scores {path_best.rel_mse:.3g}.")
    elif path.how == "nearest":
        first = path.between[0]
        text += (f", which even the path tracer's fastest render ({first.setting.label}, "
                 f"{seconds_text(first.seconds)}) beats with {first.rel_mse:.3g}.")
    elif path.how == "rendered":
        text += (f", which the path tracer reaches in {seconds_text(path.value)} "
                 f"({path.between[0].setting.label}).")
    else:
        a, b = path.between
        text += (f", which the path tracer reaches in {seconds_text(path.value)} (interpolated "
                 f"between its {a.setting.label} and {b.setting.label} renders).")
    if math.isfinite(reference_noise) and floor.error < 2 * reference_noise:
        text += (f" Caution: that is within a factor 2 of the reference's own noise "
                 f"({reference_noise:.3g}).")
    return text


def spread_text(m: Measurement) -> str:
    """A render's median time and the spread of its repeats: ``12.3 ms (11.9–13.0)``."""
    if len(m.times) < 2:
        return seconds_text(m.seconds)
    low, high = m.seconds_min, m.seconds_max
    scale, unit = (1000.0, "ms") if m.seconds < 1 else (1.0, "s")
    return f"{seconds_text(m.seconds)} ({low * scale:.3g}–{high * scale:.3g} {unit})"


def reach_text(reach: Reach | None) -> str:
    """One cell of the equal-quality table: the cheapest render reaching the level, or
    the method's floor when none does."""
    if reach is None:
        return "not rendered"
    if reach.fastest is not None:
        return f"{seconds_text(reach.fastest.seconds)} ({reach.fastest.setting.label})"
    return f"floor {reach.best.rel_mse:.3g} ({reach.best.setting.label})"


def speedup_text(row: EqualQuality, method: str) -> str:
    """How many times faster ``method`` reaches the row's level than the path tracer."""
    if method in row.speedups:
        return f"{row.speedups[method]:.3g}×"
    own, path = row.reach.get(method), row.reach.get("path")
    own_hit = own is not None and own.fastest is not None
    path_hit = path is not None and path.fastest is not None
    return "only it" if own_hit else "only path" if path_hit else "neither"


def reading_how(reading: Reading[Measurement] | None) -> str:
    """How an equal-time value was read off the path tracer's curve."""
    if reading is None:
        return "no path render"
    if reading.how == "interpolated":
        a, b = reading.between
        return f"interpolated {a.setting.spp}–{b.setting.spp} spp"
    return f"{reading.how}: {reading.between[0].setting.spp} spp"
