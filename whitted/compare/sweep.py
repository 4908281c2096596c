"""One scene's share of the comparison: its reference, each setting rendered and scored once,
timed together in rounds (docs/compare.md, "Timing"), then each Whitted method's limit.
It takes and returns plain data, so it can run in another process, which must share the
output folder's file system.
"""

from __future__ import annotations

import contextlib
import math
import time
from pathlib import Path

import numpy as np

from .. import metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from ..defaults import (COMPARE_CLOCK, COMPARE_HEADLINE_ROUNDS, COMPARE_KEPT_MEMORY,
                        COMPARE_LIMITS_SHARE, COMPARE_LONG_ROUNDS, COMPARE_LONG_SECONDS,
                        COMPARE_MAX_ROUNDS, COMPARE_PATH_CHECK, COMPARE_QUICK_LIMITS_SHARE,
                        COMPARE_PATH_FIT_COUNTS, COMPARE_ROUND_REPEATS,
                        COMPARE_ROUND_SECONDS, COMPARE_ROUNDS_SECONDS, COMPARE_ROUNDS_SHARE,
                        COMPARE_TIMING_THREADS)
from ..images import (clipped_fraction, fitting_view, to_display, to_srgb,
                      write_image)
from ..progress import progress_bar
from .analysis import analyse
from .budget import Budget
from .curves import PathModel, fit_inverse
from .sheet import thumbnail, write_render
from .limits import render_limits
from .reference import Chunk, ReferenceCache, ReferencePlan, reference_image
from .results import Measurement, Options, SceneResult, Setting
from .scenes import SceneFile, limit_methods
from .timing import interleaved, median

#: The seed of every render of the sweep (the reference has its own).
SWEEP_SEED = 0


def _render(loaded, setting: Setting):
    """One render with the sweep's seed. Dr.Jit's memory cache is kept between renders (and
    bounded by :func:`_bound_memory`): memory handed back to the system costs the next render
    its page faults, time that is the process's history, not the render's."""
    return rendering.render(loaded, integrator=setting.integrator, spp=setting.spp,
                            max_depth=setting.max_depth,
                            lighting=setting.lighting if setting.integrator == "whitted" else None,
                            seed=SWEEP_SEED, progress=False, fresh_memory=False)


def _seconds(result) -> float:
    """A timed render's time on the COMPARE_CLOCK (the wall clock on a GPU, where the CPU waits)."""
    import mitsuba as mi
    cpu = COMPARE_CLOCK == "cpu" and not mi.variant().startswith("cuda")
    return float(result.cpu_seconds if cpu else result.seconds)


@contextlib.contextmanager
def timing_threads():
    """Dr.Jit's LLVM backend on COMPARE_TIMING_THREADS threads while rounds are timed;
    yields how many times slower a parallel render may be on them. No image file is read or
    written meanwhile: on one thread, Mitsuba 3.9.1's EXR reading and writing wait forever."""
    import drjit as dr
    slower = _slower()
    if slower == 0:
        yield 1.0
        return
    before = dr.thread_count()
    dr.set_thread_count(COMPARE_TIMING_THREADS)
    try:
        yield slower
    finally:
        dr.set_thread_count(before)


def _slower() -> float:
    """That factor (0: no timing threads are set, or not on the LLVM backend)."""
    import drjit as dr
    import mitsuba as mi
    if COMPARE_TIMING_THREADS is None or not mi.variant().startswith("llvm"):
        return 0.0
    return max(1.0, dr.thread_count() / COMPARE_TIMING_THREADS)


def _work(result) -> int:
    """What a render did, whatever the clock says: the rays it traced."""
    rays = result.stats["rays"]
    return int(sum(rays.values()) - result.stats.get("merged_rays", 0))


def measure(loaded, setting: Setting, reference: np.ndarray, out: Path, folder: str,
            exposure: float, view: str, shown_reference: np.ndarray) -> Measurement:
    """Render ``setting`` once, score it against ``reference`` (``shown_reference``: its
    :func:`~whitted.images.to_display`, made once a scene) and keep the image and its error
    map; its time is that render's until :func:`time_rounds` times it."""
    result = _render(loaded, setting)
    _bound_memory()
    image = np.asarray(result.image, dtype=np.float32)
    shown = to_display(image, exposure, view)
    error_map, flip = metrics.displayed_flip_map(shown, shown_reference)
    files = write_render(out, f"{folder}/{setting.slug}", image, shown, error_map, exposure, view)
    return Measurement(setting, float(result.seconds), float(result.compile_seconds),
                       metrics.relative_mse(image, reference), flip, _work(result),
                       thumbnail(image, exposure=exposure, view=view), **files,
                       render_seconds=float(result.seconds))


def time_rounds(loaded, entry: SceneResult, rounds: int, deadline: float = math.inf,
                progress=None, levels: tuple[float, ...] | None = None) -> None:
    """Time every render of ``entry`` in a first round, the renders the verdict reads (at
    ``levels``) in ``rounds`` in all, then the headlines' renders alone while a headline is
    unsettled (docs/compare.md, "Timing"), never past ``deadline``."""
    measured = list(entry.measurements)
    if not measured:
        return
    if progress is None:
        progress = progress_bar(False, 0, "")   # silent
    times = {id(m): [] for m in measured}
    extra_until = math.inf
    with timing_threads() as slower:
        # the scored renders' times (all threads): a round on fewer threads takes longer
        predicted = _cost([m.seconds for m in measured], slower)
        for k in range(COMPARE_MAX_ROUNDS):
            started = time.monotonic()
            if k == 1 < rounds:
                # then only the renders the verdict reads: a time the verdict does not read
                # is known from one round to what one round can tell
                measured = _verdict_renders(entry, levels)
                predicted = _cost([m.seconds for m in measured])
            if k >= rounds:
                if k == rounds:
                    extra_until = started + COMPARE_ROUNDS_SECONDS
                    # the headlines' renders alone, back to back, the same ones in every round
                    measured = _headline_renders(entry)
                    predicted = _cost([m.seconds for m in measured])
                wanted = (k < rounds + COMPARE_HEADLINE_ROUNDS
                          or _headline_renders(entry, unsettled=True))
                if not measured or not wanted or started + predicted > extra_until:
                    break
            if started + predicted > deadline:
                if k < rounds:
                    entry.notes.append(_rounds_cut(k, rounds))
                break
            progress.set_postfix_str(f"{entry.name}: timing, round {k + 1}", refresh=True)
            for m in interleaved(measured, k):
                # a long render is known to a few percent from its first rounds
                long = COMPARE_LONG_ROUNDS <= k < rounds and m.seconds > COMPARE_LONG_SECONDS
                times[id(m)].append(math.nan if long else _time_in_a_round(loaded, m.setting))
                _bound_memory()
            for m in measured:
                m.times = tuple(times[id(m)])
                m.seconds = median(m.times)
            predicted = time.monotonic() - started


def _rounds_cut(done: int, asked: int) -> str:
    """The note of rounds the budget cut; with none, what the times then are (the scored
    renders', on another clock than the one the reports name)."""
    if done == 0:
        return (f"not timed in rounds ({asked} asked): the first would have overrun the scene's "
                f"share of --budget; its times are those of its scored renders (wall time, "
                f"every thread, once each), not of timed rounds")
    return (f"timed in {done} round{'s' if done > 1 else ''}, not {asked}: the next would have "
            f"overrun the scene's share of --budget")


def _cost(seconds: list[float], slower: float = 1.0) -> float:
    """One timing round of renders of these ``seconds`` (each repeated for at least
    COMPARE_ROUND_SECONDS), on threads ``slower`` times slower."""
    return sum(max(s * slower, COMPARE_ROUND_SECONDS) for s in seconds)


def _bound_memory() -> None:
    if (rendering.resident_bytes() or 0) > COMPARE_KEPT_MEMORY:
        import drjit as dr
        dr.flush_malloc_cache()


def _time_in_a_round(loaded, setting: Setting) -> float:
    """A setting's time in one round: the fastest of renders repeated back to back for
    COMPARE_ROUND_SECONDS, since another program only ever adds time. A render whose clock
    did not move (0 once its compilation is taken off: seen on Dask workers) measured
    nothing and is rendered again; NaN if none measured anything."""
    fastest, start = math.inf, time.monotonic()
    for _ in range(COMPARE_ROUND_REPEATS):
        seconds = _seconds(_render(loaded, setting))
        if seconds > 0:
            fastest = min(fastest, seconds)
        if time.monotonic() - start >= COMPARE_ROUND_SECONDS and fastest < math.inf:
            break
    return fastest if fastest < math.inf else math.nan


def _verdict_renders(entry: SceneResult, levels: tuple[float, ...] | None) -> list[Measurement]:
    """The renders whose times the verdict reads: the path tracer's (its time curve), each
    method's floor render and each method's cheapest render at each equal-quality level.
    Which they are follows from errors and work, not from times."""
    analysis = analyse(entry, levels)
    chosen = {id(m) for m in entry.measurements if m.setting.integrator == "path"}
    chosen.update(id(floor.render) for floor in analysis.floors)
    chosen.update(id(reach.fastest) for row in analysis.equal_quality
                  for reach in row.reach.values() if reach.fastest is not None)
    return [m for m in entry.measurements if id(m) in chosen]


def _headline_renders(entry: SceneResult, unsettled: bool = False) -> list[Measurement]:
    """Each floor render and the path renders its ratio is read between (``unsettled``:
    only those of headlines still too wide to quote)."""
    renders = {}
    for floor in analyse(entry).floors:
        if floor.interval is not None and floor.path is not None and \
                not (unsettled and floor.interval.settled):
            for m in (floor.render, *floor.path.between):
                renders[id(m)] = m
    return [m for m in entry.measurements if id(m) in renders]


def sweep_scene(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
                seconds: float = math.inf, *, loaded=None, progress=None,
                plan: ReferencePlan | None = None, chunks: list[Chunk] | None = None) -> SceneResult:
    """Render, score and time one scene's ``settings`` (cheapest first) within ``seconds``,
    filling ``entry`` in place so that an interruption keeps what was done; ``plan`` and
    ``chunks``: the reference's, when made elsewhere (a cluster)."""
    deadline = time.monotonic() + seconds
    if progress is None:
        progress = progress_bar(False, 0, "")   # silent
    if loaded is None:
        loaded = scene.load(entry.variant)
    out = Path(options.out)
    cache = ReferenceCache(options.cache_folder)
    reference = reference_image(scene, loaded, entry, cache, options,
                                seconds=deadline - time.monotonic(), plan=plan, chunks=chunks)
    if reference is None:
        entry.skipped.extend(settings)
        progress.update(len(settings) + len(limit_methods(settings)))
        return entry
    progress.unpause()  # the estimate of the time left: from the renders' own rate
    entry.exposure = options.exposure
    entry.reference_black = not np.any(reference)
    entry.reference_clipped = clipped_fraction(to_srgb(reference, entry.exposure, "clip"))
    entry.view = options.view or fitting_view(reference, entry.exposure)
    entry.reference_thumbnail = thumbnail(reference, exposure=entry.exposure, view=entry.view)
    entry.reference_png = f"{entry.folder}/reference.png"  # its EXR is the cache's
    (out / entry.folder).mkdir(parents=True, exist_ok=True)
    shown_reference = to_display(reference, entry.exposure, entry.view)
    write_image(out / entry.reference_png, reference, exposure=entry.exposure, view=entry.view,
                shown=shown_reference)
    if options.budget is not None:
        settings = _below_the_reference(entry, settings, progress)
    done: list[tuple[Setting, float, float]] = []
    overran = 0
    # what is left, shared: the renders, then their timing rounds, then the limits and fit
    # (under --quick, what the verdict leaves: they are not part of it)
    left, slower = (deadline - time.monotonic() if seconds < math.inf else 0.0), _slower()
    timed_until = deadline - (COMPARE_QUICK_LIMITS_SHARE if options.quick
                              else COMPARE_LIMITS_SHARE) * left
    renders_until = timed_until - COMPARE_ROUNDS_SHARE * left
    kept = 0.0   # under --quick, the rounds of the renders done: kept for them, not shared

    def rounds_of(setting: Setting, seconds: float) -> float:
        """Its timing rounds: the path tracer's, all (the verdict reads every one); a Whitted
        render's, the first (the few the verdict reads get theirs while the deadline allows)."""
        rounds = options.rounds if setting.integrator == "path" else 1
        return rounds * _cost([seconds], max(1.0, slower))
    for setting in settings:
        progress.set_postfix_str(f"{entry.name}: {setting.method} {setting.label}", refresh=False)
        if setting.integrator == "path" and entry.path_model is not None:
            progress.update(1)   # read from the fitted curve, which its last render checked
            continue
        render, scoring = Budget.predict(setting, done)   # then its rounds, on the timing threads
        until = timed_until - kept if options.quick else renders_until
        if time.monotonic() + render + scoring + rounds_of(setting, render) > until:
            entry.skipped.append(setting)
            overran += 1
        else:
            start = time.monotonic()
            measurement = measure(loaded, setting, reference, out, entry.folder, entry.exposure,
                                  entry.view, shown_reference)
            entry.measurements.append(measurement)
            done.append((setting, measurement.render_seconds, time.monotonic() - start))
            kept += rounds_of(setting, measurement.render_seconds)
            if setting.integrator == "path":
                entry.path_model = checked_path_model(entry.measurements, entry.reference_noise)
        progress.update(1)
    time_rounds(loaded, entry, options.rounds, timed_until, progress, options.levels)
    if entry.reference_black:   # nothing is compared there (analysis.analyse): no limit, no fit
        progress.update(len(limit_methods(settings)))
    else:
        render_limits(loaded, entry, settings, reference, out, deadline, progress, scene.model)
    if settings and not entry.measurements:
        took = ("was read from the cache" if entry.reference_cached
                else f"took {entry.reference_seconds:.1f} s")
        entry.notes.append(f"no render fitted in the time left of the scene's "
                           f"{seconds:.1f} s share after its reference ({took})")
    elif overran:
        entry.notes.append(f"{overran} of {len(settings)} renders skipped: each would have overrun "
                           f"the scene's {seconds:.1f} s share of --budget")
    return entry


def checked_path_model(measurements: list[Measurement], noise: float) -> PathModel | None:
    """The path tracer's err = c + v/n (c: the reference's ``noise``, 0 if unknown), fitted to
    its renders but the last and checked by the last: None until COMPARE_PATH_FIT_COUNTS
    renders predict the next within COMPARE_PATH_CHECK; then refitted to all of them."""
    path = [m for m in measurements if m.setting.integrator == "path"]
    if len(path) <= COMPARE_PATH_FIT_COUNTS or not all(m.rel_mse > 0 for m in path):
        return None
    *fitted, last = path
    c = noise if math.isfinite(noise) else 0.0
    v = fit_inverse([m.setting.spp for m in fitted], [m.rel_mse for m in fitted], c)
    deviation = abs((c + v / last.setting.spp) / last.rel_mse - 1.0)
    if deviation > COMPARE_PATH_CHECK:
        return None
    v = fit_inverse([m.setting.spp for m in path], [m.rel_mse for m in path], c)
    return PathModel(c, v, tuple(m.setting.spp for m in path), last.setting.spp, deviation)


def _below_the_reference(entry: SceneResult, settings: list[Setting], progress) -> list[Setting]:
    """Against a reference the budget scaled down, the path tracer's renders of as many spp
    or more would measure only its noise: skipped, with a note (not against one of as many spp
    as its noise needs, as without --budget)."""
    if entry.reference_enough or entry.reference_spp >= entry.reference_requested:
        return settings
    kept = [s for s in settings if s.integrator != "path" or s.spp < entry.reference_spp]
    dropped = [s for s in settings if s not in kept]
    if dropped:
        entry.skipped.extend(dropped)
        entry.notes.append(f"the path tracer's renders of {min(s.spp for s in dropped)} spp and more "
                           f"skipped: not below the scaled-down reference's {entry.reference_spp} spp")
        progress.update(len(dropped))
    return kept
