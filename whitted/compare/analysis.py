"""What a scene's measurements say: what accuracy costs (floor, equal quality, equal time)
and what the Whitted model's error is made of (docs/compare.md, "Equal time, equal quality,
error floor" and "What the error is made of"), computed once from plain data, for every
report to read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..defaults import (COMPARE_CLOCK, COMPARE_CONFIDENCE, COMPARE_DATA_LEVELS, COMPARE_FLOOR_TOLERANCE,
                        COMPARE_RUN_SHARE, COMPARE_TIMING_THREADS)
from .limits import fitted_text
from .curves import (Floor, PathModel, Reading, error_at_time, error_floor, error_levels,
                     time_to_reach)
from .results import (METHODS, WHITTED_METHODS, Limit, Measurement, SceneResult, Setting,
                      seconds_text)
from .timing import Interval, bound_text, coverage, paired

#: How the prose names each method.
METHOD_NAMES = {"whitted-article": "the article's model",
                "whitted-physical": "the physically lit ray tree",
                "path": "the path tracer"}
POSSESSIVES = {"whitted-article": "the article model's",
               "whitted-physical": "the physically lit ray tree's"}
_THREADS = {None: "the process's threads", 1: "one thread"}.get(COMPARE_TIMING_THREADS,
                                                                f"{COMPARE_TIMING_THREADS} threads")
#: What the reports say the renders' times are.
TIMING = ("the median of timed rounds: a first in which every render of a scene is timed once, "
          "then rounds of the renders the verdict reads (so that what is compared is timed in "
          "the same moments), each render's "
          f"{'CPU' if COMPARE_CLOCK == 'cpu' else 'wall'} time on {_THREADS} (wall time on a GPU), "
          "kernel compilation excluded; a ratio of times is the median of its per-round ratios, "
          f"with its interval ({COMPARE_CONFIDENCE:.0%} confidence over 5 rounds or more; over "
          f"fewer, its extremes: {coverage(4):.0%} over 4, {coverage(3):.0%} over 3, "
          f"{coverage(2):.0%} over 2), widened by "
          f"{COMPARE_RUN_SHARE:.0%} each way: what a ratio moves between runs")


def faster_text(interval: Interval, name: str, other: str) -> str:
    """Which of two methods is faster, from the interval of ``other``'s time over ``name``'s."""
    if interval.straddles_one and interval.rounds >= 2:
        return (f"no measurable difference in time between {name} and {other} "
                f"({interval.value:.3g}×, {interval.range_text()})")
    if interval.value < 1:
        name, other = other, name
        interval = interval.reciprocal()
    flag = "" if interval.settled or interval.rounds < 2 else "; unsettled: the machine's load kept changing"
    return f"{name} gets there {interval.value:.3g}× faster ({interval.range_text()}{flag})"


def ratio_text(interval: Interval | None) -> str:
    """A table cell: ``2.1× (1.9–2.4)``, ``≈ 1 (...)`` holding 1, ``?`` unsettled, ``—``."""
    if interval is None or not interval.known:
        return "—"
    if interval.rounds < 2:
        return f"{interval.value:.3g}×"
    flag = "" if interval.settled else " ?"
    value = "≈ 1" if interval.straddles_one else f"{interval.value:.3g}×"
    return f"{value} ({bound_text(interval.low)}–{bound_text(interval.high)}){flag}"


@dataclass(frozen=True)
class EqualTime:
    """One Whitted render beside the path tracer given the same time (``outside``: the
    render is ``"faster"`` or ``"slower"`` than every path render, so nothing is compared)."""
    whitted: Measurement
    rel_mse: Reading[Measurement] | None
    flip: Reading[Measurement] | None
    outside: str | None = None
    interval: Interval | None = None

    @property
    def ratio(self) -> float:
        """The Whitted render's relative MSE over the path tracer's (< 1: Whitted wins)."""
        if self.rel_mse is None or self.outside or not self.rel_mse.value > 0:
            return math.nan
        return self.whitted.rel_mse / self.rel_mse.value


@dataclass(frozen=True)
class Reach:
    """One method at one error level: its cheapest render reaching it, and its best."""
    method: str
    fastest: Measurement | None
    best: Measurement | None


@dataclass(frozen=True)
class EqualQuality:
    """One error level: each method's cheapest render reaching it, and the path tracer's
    time over each Whitted method's there, per timed round."""
    level: float
    reach: dict[str, Reach]
    speedups: dict[str, Interval] = field(default_factory=dict)
    #: the methods there not measurably slower than the fastest (their interval holds 1)
    ties: tuple[str, ...] = ()

    def reached(self, method: str) -> bool:
        return method in self.reach and self.reach[method].fastest is not None

    @property
    def fastest_method(self) -> str | None:
        hits = [r for r in self.reach.values() if r.fastest is not None]
        return min(hits, key=lambda r: r.fastest.seconds).method if hits else None

    @property
    def fastest_group(self) -> list[str]:
        """The fastest method and those it is not measurably faster than, in :data:`METHODS`'
        order (a tie has no order for the clock to pick)."""
        group = {self.fastest_method, *self.ties} - {None}
        return [m for m in METHODS if m in group]

    @property
    def fastest_text(self) -> str:
        return " ≈ ".join(self.fastest_group) or "none"


@dataclass(frozen=True)
class FloorStatement:
    """A Whitted method's floor and what it costs the path tracer to match it
    (``interval``: the headline ratio of times, per timed round)."""
    method: str
    floor: Floor[Measurement]
    path: Reading[Measurement] | None
    path_best: Measurement | None
    interval: Interval | None
    text: str = ""
    #: the method's deepest, densest setting, when --budget skipped it (the floor: the best so far)
    skipped_best: Setting | None = None

    @property
    def render(self) -> Measurement:
        return self.floor.render


@dataclass(frozen=True)
class Decomposition:
    """What a Whitted method's error at its floor is made of (``gone``: its cheapest
    render within the tolerance's share of the bias from its limit)."""
    method: str
    floor: Floor[Measurement]
    limit: Limit
    gone: Measurement | None
    text: str = ""

    @property
    def sampling(self) -> float:
        """The floor's error less the model's bias (relative MSEs of independent parts add)."""
        return max(0.0, self.floor.error - self.limit.rel_mse)


@dataclass
class Analysis:
    """Everything the reports say about one scene."""
    entry: SceneResult
    levels: tuple[float, ...]
    equal_time: list[EqualTime]
    equal_quality: list[EqualQuality]
    floors: list[FloorStatement]
    decompositions: list[Decomposition] = field(default_factory=list)

    def findings(self) -> dict:
        """The scene's conclusions (``findings.json``, docs/compare.md; NaN: not measured)."""
        methods = {}
        decompositions = {d.method: d for d in self.decompositions}
        for statement in self.floors:
            render = statement.render
            found = {"floor": {"max_depth": render.setting.max_depth, "spp": render.setting.spp,
                               "seconds": render.seconds, "rel_mse": render.rel_mse,
                               "settled": statement.floor.settled},
                     "best_rel_mse": statement.floor.best,
                     "path_seconds_to_floor": statement.path.value if statement.path else None,
                     "path_seconds_how": statement.path.how if statement.path else None,
                     "path_time_over_floor_time": (statement.interval.as_dict()
                                                   if statement.interval else None),
                     "floor_text": statement.text}
            decomposition = decompositions.get(statement.method)
            if decomposition is not None:
                limit = decomposition.limit
                found["limit"] = {k: getattr(limit, k) for k in ("max_depth", "spp", "rel_mse",
                                                                 "noise", "converged", "seconds")}
                found["depth_and_sampling_rel_mse"] = decomposition.sampling
                if statement.method == "whitted-article":
                    found["scene_ambient"] = limit.ambient
                    found["best_ambient"] = limit.best_ambient
                    found["rel_mse_at_best_ambient"] = limit.rel_mse_at_best_ambient
                    if limit.fitted is not None:
                        fitted = limit.fitted
                        found["fitted"] = {"rel_mse": fitted.rel_mse, "ambient": fitted.ambient,
                                           "colors": {k: list(v) for k, v in fitted.colors.items()},
                                           "lights": [list(c) for c in fitted.lights],
                                           "fit_size": list(fitted.size), "fit_rel_mse": fitted.fit_rel_mse,
                                           "seconds": fitted.seconds,
                                           "stopped_after_steps": fitted.stopped or None}
                found["text"] = decomposition.text
            methods[statement.method] = found
        entry, model = self.entry, self.entry.path_model
        return {"levels": list(self.levels), "reference_spp": entry.reference_spp,
                "reference_black": entry.reference_black,
                "reference_noise": entry.reference_noise,
                "renders": len(entry.measurements), "skipped": len(entry.skipped),
                "timed_rounds": rounds_of(entry), "methods": methods, "notes": list(entry.notes),
                "path_model": None if model is None else {
                    "c": model.c, "v": model.v, "fitted_spp": list(model.fitted),
                    "checked_spp": model.checked, "deviation": model.deviation,
                    "read_spp": [m.setting.spp for m in modelled_path(entry)],
                    "text": model_text(entry)},
                "equal_quality": [{"rel_mse": row.level,
                                   "fastest": row.fastest_group,
                                   "path_time_over": {m: i.as_dict() for m, i in row.speedups.items()}}
                                  for row in self.equal_quality]}


def _costliest_two(entry: SceneResult) -> tuple[Measurement, ...]:
    """The path tracer's two costliest renders: its time line goes through them."""
    path = sorted((m for m in entry.measurements if m.setting.integrator == "path"),
                  key=lambda m: m.setting.spp)
    return tuple(path[-2:])


def path_seconds(pair: tuple[Measurement, ...], spp: float,
                 timed_round: int | None = None) -> float:
    """The path tracer's time at ``spp`` on the line time = a + b·n through ``pair`` (their
    median times, or those of one timed round; NaN where one is missing)."""
    times = [m.seconds_in(timed_round) for m in pair]
    if len(pair) < 2 or not all(math.isfinite(t) and t > 0 for t in times):
        return math.nan
    (n0, t0), (n1, t1) = zip([m.setting.spp for m in pair], times)
    return t0 + (t1 - t0) * (spp - n0) / (n1 - n0)


def modelled_path(entry: SceneResult) -> list[Measurement]:
    """The path tracer's ladder counts above its checked render, read from its fitted curve
    (:attr:`Measurement.modelled`): the error c + v/n, the time in each round on its line."""
    model, pair = entry.path_model, _costliest_two(entry)
    if model is None or len(pair) < 2:
        return []
    rounds = rounds_of(entry) if any(m.times for m in pair) else 0
    per_spp = pair[-1].work / pair[-1].setting.spp
    return [Measurement(Setting("path", "physical", n, entry.path_depth), path_seconds(pair, n),
                        0.0, model.error(n), math.nan, round(per_spp * n),
                        times=tuple(path_seconds(pair, n, r) for r in range(rounds)), modelled=True)
            for n in entry.path_spp if n > model.checked]


def model_text(entry: SceneResult) -> str:
    """What was rendered of the path tracer, and what read from its fitted curve."""
    model, (low, high) = entry.path_model, _costliest_two(entry)
    read = ", ".join(str(m.setting.spp) for m in modelled_path(entry))
    return (f"The path tracer was rendered at {', '.join(map(str, model.fitted))} spp"
            + (f"; its {read} spp are read from its fitted curve" if read else "")
            + f": {curve_text(model, str(low.setting.spp), high.setting.label)}, "
              "in each timed round.")


def curve_text(model: PathModel, low: str, high: str) -> str:
    """The path tracer's fitted curve, and its time line through its renders ``low``, ``high``."""
    return (f"error = {model.c:.3g} + {model.v:.3g}/n, fitted to {model.fitted[0]}–"
            f"{model.fitted[-1]} spp and checked at {model.checked} spp within "
            f"{model.deviation:.0%}; time = a + b·n through its {low} and {high} renders")


def _curve(measurements: list[Measurement], metric: str,
           timed_round: int | None = None) -> list[tuple[float, float, Measurement]]:
    """(time, error, render): their median times, or those of one timed round."""
    points = [(m.seconds_in(timed_round), getattr(m, metric), m) for m in measurements]
    return [p for p in points if not math.isnan(p[0])]


def rounds_of(entry: SceneResult) -> int:
    """The timed rounds of a scene (not every render need have been timed in each)."""
    return max([len(m.times) for m in entry.measurements] + [1])


def _cost(m: Measurement) -> tuple[float, int, int]:
    """What chooses a render among those good enough: its work, then (a deeper tree that finds
    nothing more to trace draws the same image with the same work) its samples and depth;
    never its time, which noise would choose."""
    work = m.work if m.work > 0 else m.setting.spp * m.setting.max_depth
    return work, m.setting.spp, m.setting.max_depth


def data_levels(entry: SceneResult, tolerance: float = COMPARE_FLOOR_TOLERANCE) -> tuple[float, ...]:
    """The equal-quality levels the data suggest: each method's floor, and levels between
    the best and worst errors measured, so that every method reaches at least one."""
    measured = entry.measurements + modelled_path(entry)
    errors = [m.rel_mse for m in measured if math.isfinite(m.rel_mse) and m.rel_mse > 0]
    if not errors:
        return ()
    floors = [_floor([m for m in measured if m.setting.method == method], tolerance)
              for method in METHODS]
    return error_levels([f.error for f in floors if f is not None], min(errors), max(errors),
                        COMPARE_DATA_LEVELS, tolerance)


def _floor(ms: list[Measurement], tolerance: float) -> Floor[Measurement] | None:
    return error_floor(_curve(ms, "rel_mse"), tolerance, _cost)


def analyse(entry: SceneResult, levels: tuple[float, ...] | None = None,
            tolerance: float = COMPARE_FLOOR_TOLERANCE) -> Analysis:
    """The tables, floors and decompositions of one scene (``levels`` None: from the data);
    none against a black reference, where an error measures only a render's brightness."""
    if entry.reference_black:
        return Analysis(entry, (), [], [], [])
    if levels is None:
        levels = data_levels(entry, tolerance)
    by_method = {method: [m for m in entry.measurements if m.setting.method == method]
                 for method in METHODS}
    rendered = by_method["path"]
    path = by_method["path"] = rendered + modelled_path(entry)
    path_mse, path_flip = _curve(path, "rel_mse"), _curve(path, "flip")

    rounds = rounds_of(entry)
    equal_time = []
    for method in WHITTED_METHODS:
        for m in sorted(by_method[method], key=lambda m: (m.setting.max_depth, m.setting.spp)):
            reading = error_at_time(path_mse, m.seconds)
            if reading is not None and any(p.modelled for p in reading.between):
                reading = replace(reading, how="fitted")   # it says so
            outside = None
            if reading is not None and reading.how == "nearest":
                outside = "faster" if m.seconds < reading.between[0].seconds else "slower"
            interval = None
            if reading is not None and outside is None:
                interval = paired(rounds, lambda r, m=m: _over(
                    m.rel_mse, _path_in_round(path, r, m.seconds_in(r))))
            equal_time.append(EqualTime(m, reading, error_at_time(path_flip, m.seconds), outside, interval))

    equal_quality = []
    for level in levels:
        reach = {}
        for method, ms in by_method.items():
            if not ms:
                continue
            cheapest = min((m for m in ms if m.rel_mse <= level), key=_cost, default=None)
            reach[method] = Reach(method, cheapest, min(ms, key=lambda m: m.rel_mse))
        row = EqualQuality(level, reach)
        for method in WHITTED_METHODS:
            if row.reached(method) and row.reached("path"):
                a, b = reach["path"].fastest, reach[method].fastest
                row.speedups[method] = paired(
                    rounds, lambda r, a=a, b=b: _over(a.seconds_in(r), b.seconds_in(r)))
        if row.fastest_method is not None:
            first = reach[row.fastest_method].fastest
            row = replace(row, ties=tuple(
                m for m in reach if m != row.fastest_method and row.reached(m) and paired(
                    rounds, lambda r, a=reach[m].fastest: _over(a.seconds_in(r), first.seconds_in(r))
                ).low <= 1.0))
        equal_quality.append(row)

    floors, decompositions = [], []
    path_best = min(rendered, key=lambda m: m.rel_mse) if rendered else None
    for method in WHITTED_METHODS:
        ms = by_method[method]
        floor = _floor(ms, tolerance)
        if floor is None:
            continue
        skipped_best = _skipped_best(entry, method)
        if skipped_best is not None:
            floor = replace(floor, settled=False)
        reading = time_to_reach(_curve(rendered, "rel_mse"), floor.error) if rendered else None
        own, spp = floor.render, math.nan
        if reading is None and entry.path_model is not None:
            spp = entry.path_model.spp_to_reach(floor.error)
            pair = _costliest_two(entry)
            reading = (Reading(path_seconds(pair, spp), "fitted", pair) if math.isfinite(spp)
                       else None)
        interval = None
        if reading is not None and reading.how == "fitted":
            interval = paired(rounds, lambda r: _over(path_seconds(reading.between, spp, r),
                                                      own.seconds_in(r)))
        elif reading is not None and reading.how != "nearest":
            interval = paired(rounds, lambda r: _over(
                _path_in_round(rendered, r, own.seconds_in(r), floor.error), own.seconds_in(r)))
        statement = FloorStatement(method, floor, reading, path_best, interval,
                                   skipped_best=skipped_best)
        floors.append(replace(statement, text=floor_text(statement, entry.reference_noise,
                                                         tolerance, entry.path_model, spp)))
        limit = entry.limits.get(method)
        if limit is not None:
            gone = min((m for m in ms if m.rel_mse_limit <= tolerance * limit.rel_mse), key=_cost,
                       default=None)
            decomposition = Decomposition(method, floor, limit, gone)
            decompositions.append(replace(decomposition, text=decomposition_text(
                decomposition, entry.reference_noise, tolerance)))
    return Analysis(entry, tuple(levels), equal_time, equal_quality, floors, decompositions)


def _skipped_best(entry: SceneResult, method: str) -> Setting | None:
    """The method's deepest, densest setting when --budget skipped it: that render has its best
    error, which its floor is read within the tolerance of, so without it the floor is only
    the best of the renders done (None: it was rendered)."""
    planned = [m.setting for m in entry.measurements if m.setting.method == method]
    skipped = [s for s in entry.skipped if s.method == method]
    if not skipped:
        return None
    planned += skipped
    deepest = max(s.max_depth for s in planned)
    densest = max(s.spp for s in planned)
    return next((s for s in skipped if (s.max_depth, s.spp) == (deepest, densest)), None)


def _over(a: float, b: float) -> float:
    return a / b if b > 0 and math.isfinite(a) and math.isfinite(b) else math.nan


def _path_in_round(path: list[Measurement], timed_round: int, own: float,
                   error: float | None = None) -> float:
    """In one timed round, the path tracer's error at ``own`` seconds or, given ``error``, its
    time to reach it (NaN: outside its rendered range)."""
    if not math.isfinite(own):
        return math.nan
    curve = _curve(path, "rel_mse", timed_round)
    reading = error_at_time(curve, own) if error is None else time_to_reach(curve, error)
    return math.nan if reading is None or reading.how == "nearest" else reading.value


def floor_text(statement: FloorStatement, reference_noise: float, tolerance: float,
               model: PathModel | None = None, spp: float = math.nan) -> str:
    """The floor in words; its cheapest render is the one of least work (rays traced), so
    that timing noise does not choose it."""
    floor, path, path_best, interval = (statement.floor, statement.path, statement.path_best,
                                        statement.interval)
    name, render = METHOD_NAMES[statement.method], floor.render
    cheapest = (f"{render.setting.label} ({seconds_text(render.seconds)}) at {floor.error:.3g}")
    if statement.skipped_best is not None:
        text = (f"{name.capitalize()} does best at {floor.best:.3g} (relative MSE) of the renders "
                f"done, but its deepest, densest render ({statement.skipped_best.label}) was "
                f"skipped by --budget and may do better: its cheapest render within "
                f"{tolerance:.0%} of that best is {cheapest}")
    elif floor.settled:
        text = (f"{name.capitalize()} stops improving at {floor.best:.3g} (relative MSE, its "
                f"best): its cheapest render within {tolerance:.0%} of that is {cheapest}")
    else:
        text = (f"{name.capitalize()} is still improving at its costliest render, {cheapest} "
                f"(relative MSE): no costlier render shows where it stops")
    if path is None and path_best is None:
        text += "; the path tracer was not rendered."
    elif path is None:
        text += (f". The path tracer never gets there: its best render ({path_best.setting.label}, "
                 f"{seconds_text(path_best.seconds)}) scores {path_best.rel_mse:.3g}.")
    elif path.how == "nearest":
        first = path.between[0]
        text += (f". Even the path tracer's fastest render ({first.setting.label}, "
                 f"{seconds_text(first.seconds)}) does better, at {first.rel_mse:.3g}.")
    else:
        names = [m.setting.label for m in path.between]
        how = (f"its {names[0]} render" if path.how == "rendered" else
               f"read from its fitted curve at {spp:.3g} spp: {curve_text(model, *names)}"
               if path.how == "fitted" else
               f"interpolated between its {names[0]} and {names[1]} renders")
        if interval is None or not interval.known:
            ratio = path.value / render.seconds if render.seconds > 0 else math.nan
            interval = Interval(ratio, ratio, ratio, 1)
        faster = faster_text(interval, name, "the path tracer")
        text += (f". The path tracer reaches that error in {seconds_text(path.value)} ({how}): "
                 f"{faster}.")
    if math.isfinite(reference_noise) and floor.error < 2 * reference_noise:
        text += (f" Caution: that is within a factor 2 of the reference's own noise "
                 f"({reference_noise:.3g}).")
    return text


def decomposition_text(d: Decomposition, reference_noise: float = math.nan,
                       tolerance: float = COMPARE_FLOOR_TOLERANCE) -> str:
    """What the floor's error is made of, in words."""
    floor, limit, gone = d.floor, d.limit, d.gone
    text = f"Of {POSSESSIVES[d.method]} {floor.error:.3g} (at {floor.render.setting.label}), "
    if d.sampling > 0:
        text += f"{d.sampling:.2g} is its depth and sampling"
        if gone is floor.render:
            text += f", under {tolerance:.0%} of its bias there"
        elif gone is not None:
            text += f" (gone at {gone.setting.label}, {seconds_text(gone.seconds)})"
    else:
        text += "nothing measurable is its depth and sampling"
    text += (f": its limit (d{limit.max_depth}, every ray of the tree, {limit.spp} spp) scores "
             f"{limit.rel_mse:.3g}")
    article, rest, best = d.method == "whitted-article", limit.rel_mse, ""
    if article and math.isfinite(limit.best_ambient):
        rest = limit.rel_mse_at_best_ambient
        best = f"the best ambient ({_ambient_change(limit.best_ambient, limit.ambient)}) " \
               f"brings it to {rest:.3g}; "
    fitted = limit.fitted if article else None
    if fitted is not None:
        rest = fitted.rel_mse
        cut = f", stopped by --budget after {fitted.stopped} steps" if fitted.stopped else ""
        text += (f"; {best}fitted{cut}, the article's model reaches {rest:.3g} "
                 f"({fitted_text(fitted)}); the remaining {rest:.2g}")
    elif best:
        text += f"; {best}the remaining {rest:.2g}"
    elif article:
        text += f"; no pixel depends on the ambient, so all {rest:.2g} of it"
    else:
        text += f"; that {rest:.2g}"
    if math.isfinite(reference_noise) and rest < 2 * reference_noise:
        text += (f" is within a factor 2 of the reference's own noise ({reference_noise:.2g}): "
                 f"no light the model leaves out shows.")
    else:
        text += (f" is light {'the model' if article else 'a ray tree'} does not transport "
                 f"(indirect light and sky light).")
    if not limit.converged:
        text += (f" (The limit's own noise, {limit.noise:.2g}, is not yet a tenth of the smallest "
                 f"difference it measures: these parts are rough.)")
    return text


def _ambient_change(best: float, ambient: float) -> str:
    """``0.63 instead of 0.3``; ``0.15, the scene's own`` where the two read the same (two
    digits), not a change that is none said as one."""
    if f"{best:.2g}" == f"{ambient:.2g}":
        return f"{ambient:.2g}, the scene's own"
    return f"{best:.2g} instead of {ambient:.2g}"


def spread_text(m: Measurement) -> str:
    """A render's median time and its rounds' range: ``11.9 ms (11.2–13.0 ms)``."""
    if m.rounds < 2:
        return seconds_text(m.seconds)
    low, high = m.seconds_min, m.seconds_max
    scale, unit = (1000.0, "ms") if m.seconds < 1 else (1.0, "s")
    return f"{seconds_text(m.seconds)} ({low * scale:.3g}–{high * scale:.3g} {unit})"


def reach_text(reach: Reach | None) -> str:
    """An equal-quality cell: the cheapest render reaching the level, else the best."""
    if reach is None:
        return "not rendered"
    m = reach.fastest or reach.best
    what = seconds_text(m.seconds) if reach.fastest else f"best {m.rel_mse:.3g}"
    return f"{what} ({m.setting.label}{', fitted' if m.modelled else ''})"


def speedup_text(row: EqualQuality, method: str) -> str:
    if method in row.speedups:
        return ratio_text(row.speedups[method])
    return "only it" if row.reached(method) else "only path" if row.reached("path") else "neither"


def equal_time_how(row: EqualTime) -> str:
    if row.outside is not None:
        first = row.rel_mse.between[0]
        which = "fastest" if row.outside == "faster" else "slowest"
        return (f"{row.outside} than the path tracer's {which} render ({first.setting.label}, "
                f"{seconds_text(first.seconds)})")
    if row.rel_mse is None:
        return "no path render"
    if row.rel_mse.how in ("interpolated", "fitted"):
        a, b = row.rel_mse.between
        how = "interpolated" if row.rel_mse.how == "interpolated" else "on the fitted curve"
        return f"{how} {a.setting.spp}–{b.setting.spp} spp"
    return f"{row.rel_mse.how}: {row.rel_mse.between[0].setting.spp} spp"
