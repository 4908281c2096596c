"""One scene's share of the comparison: its reference, then each setting rendered,
timed and scored.

This is the unit of work that can move to another process: :func:`sweep_scene`
takes plain data (the :class:`~whitted.compare.scenes.SceneFile`, the settings,
the :class:`~whitted.compare.results.Options` and a time share in seconds),
loads its own ``mi.Scene`` when none is handed to it, reads and writes the
reference cache by its folder, and returns a
:class:`~whitted.compare.results.SceneResult` (images reduced to thumbnails). No
Mitsuba object goes in or out unless the caller shares its process.

Timing is honest on a busy machine: each render is repeated and its fastest repeat is
kept (other processes only ever add time, so the fastest is the best estimate of the
render's own cost; every repeat's time is kept too, for the spread); while the two
fastest repeats differ by more than :data:`~whitted.defaults.COMPARE_SPREAD_LIMIT`, the
fastest is not trusted yet and the render is timed again, a bounded number of times.
Kernel compilation is excluded (``result.seconds`` of the rendering API) and reported
apart (``compile_seconds``). Error is measured on linear images (:mod:`whitted.metrics`).

After its renders, each Whitted method's limit is rendered (:mod:`.limits`) and every
render of the method scored against it too.

Every render is kept under the output folder (``renders/SCENE/``: its linear EXR,
an sRGB PNG and FLIP's error map, :mod:`.errormaps`), written by whoever renders
it: a worker process must share the output folder's file system.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import imageio, metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from ..defaults import COMPARE_MAX_EXTRA_REPEATS, COMPARE_SPREAD_LIMIT
from .budget import Budget
from .errormaps import write_render
from .limits import render_limit
from .planning import limit_methods
from .reference import Chunk, ReferenceCache, ReferencePlan, reference_image
from .results import Measurement, Options, SceneResult, Setting
from .scenes import SceneFile
from .sheet import thumbnail

#: The seed of every render of the sweep (the reference has its own).
SWEEP_SEED = 0


def spread(times: list[float]) -> float:
    """How far the second fastest of ``times`` lies above the fastest, as a fraction of
    it (0 for fewer than two): small when the fastest can be trusted."""
    if len(times) < 2:
        return 0.0
    fastest, second = sorted(times)[:2]
    return second / fastest - 1.0 if fastest > 0 else math.inf


def measure(loaded, setting: Setting, reference: np.ndarray, repeats: int,
            out: Path | None = None, folder: str = "") -> Measurement:
    """Render ``setting`` of ``loaded`` (an ``mi.Scene``) ``repeats`` times, and up to
    :data:`~whitted.defaults.COMPARE_MAX_EXTRA_REPEATS` more while the two fastest differ
    by more than :data:`~whitted.defaults.COMPARE_SPREAD_LIMIT`, and score the image
    against ``reference``; the fastest render time is kept, and every repeat's. With
    ``out``, the image and its error map are kept under ``out / folder``."""
    seconds, compile_seconds, image = [], [], None
    while (len(seconds) < repeats or (spread(seconds) > COMPARE_SPREAD_LIMIT
                                      and len(seconds) < repeats + COMPARE_MAX_EXTRA_REPEATS)):
        result = rendering.render(loaded, integrator=setting.integrator, spp=setting.spp,
                                  max_depth=setting.max_depth,
                                  lighting=setting.lighting if setting.integrator == "whitted" else None,
                                  seed=SWEEP_SEED, progress=False)
        seconds.append(float(result.seconds))
        compile_seconds.append(float(result.compile_seconds))
        if image is None:  # same seed, same image: score the first
            image = np.asarray(result.image, dtype=np.float32)
    error_map, flip = metrics.flip_map(image, reference)
    files = write_render(out, f"{folder}/{setting.slug}", image, error_map) if out is not None else {}
    return Measurement(setting, min(seconds), max(compile_seconds),
                       metrics.relative_mse(image, reference), flip, len(seconds), thumbnail(image),
                       times=tuple(seconds), **files)


def sweep_scene(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
                seconds: float = math.inf, *, loaded=None, progress=None,
                plan: ReferencePlan | None = None, chunks: list[Chunk] | None = None) -> SceneResult:
    """Render and score one scene's ``settings`` (in order) within ``seconds``.

    ============ ======================================================================
    ``scene``    the scene, as read once
    ``entry``    its result so far (from :func:`~whitted.compare.planning.plan_scene`);
                 filled in place as renders finish, so an interruption keeps them,
                 and returned
    ``settings`` what to render, cheapest first
    ``options``  the command's options (repeats, reference spp, cache folder, quiet)
    ``seconds``  the time this scene may take (``math.inf``: no budget); a reference
                 that is not cached is probed and scaled down to fit (or refused: the
                 scene is skipped), a render predicted to overrun is skipped, and
                 ``entry.notes`` says why
    ``loaded``   the scene's ``mi.Scene`` when the caller has it (else loaded here,
                 in ``entry.variant``)
    ``progress`` a tqdm bar to advance by one per setting and per Whitted method's
                 limit, or None
    ``plan``     the reference's plan (:func:`~whitted.compare.reference.plan_reference`)
                 when it was made elsewhere; None: made here
    ``chunks``   the rest of the reference after the plan's probes
                 (:class:`~whitted.compare.reference.Chunk`) when a cluster's workers
                 rendered them; None: rendered here unless cached
    ============ ======================================================================
    """
    deadline = time.monotonic() + seconds
    if loaded is None:
        loaded = scene.load(entry.variant)
    out = Path(options.out)
    cache = ReferenceCache(options.cache_folder)
    reference = reference_image(scene, loaded, entry, cache, options,
                                seconds=deadline - time.monotonic(), plan=plan, chunks=chunks)
    if reference is None:
        entry.skipped.extend(settings)
        if progress is not None:
            progress.update(len(settings) + len(limit_methods(settings)))
        return entry
    if progress is not None:  # the estimate of the time left: from the renders' own rate
        progress.unpause()
    entry.reference_thumbnail = thumbnail(reference)
    entry.reference_png = f"{entry.folder}/reference.png"  # its EXR is the cache's
    (out / entry.folder).mkdir(parents=True, exist_ok=True)
    imageio.write_image(out / entry.reference_png, reference)
    settings = _below_the_reference(entry, settings, progress)
    done: list[tuple[Setting, float, float]] = []
    overran = 0
    for setting in settings:
        if progress is not None:
            progress.set_postfix_str(f"{entry.name}: {setting.method} {setting.label}", refresh=False)
        predicted = Budget.predict(setting, done, options.repeats)
        if time.monotonic() + predicted > deadline:
            entry.skipped.append(setting)
            overran += 1
        else:
            start = time.monotonic()
            measurement = measure(loaded, setting, reference, options.repeats, out, entry.folder)
            entry.measurements.append(measurement)
            done.append((setting, measurement.seconds, time.monotonic() - start))
        if progress is not None:
            progress.update(1)
    _limits(loaded, entry, settings, reference, out, deadline, progress)
    if settings and not entry.measurements:
        took = ("was read from the cache" if entry.reference_cached
                else f"took {entry.reference_seconds:.1f} s")
        entry.notes.append(f"no render fitted in the time left of the scene's "
                           f"{seconds:.1f} s share after its reference ({took})")
    elif overran:
        entry.notes.append(f"{overran} of {len(settings)} renders skipped: each would have overrun "
                           f"the scene's {seconds:.1f} s share of --budget")
    return entry


def _below_the_reference(entry: SceneResult, settings: list[Setting], progress) -> list[Setting]:
    """The settings worth rendering against a reference the budget scaled down: the path
    tracer's renders of as many spp as the reference or more would only measure the
    reference's noise, so they are skipped (and a note says so)."""
    if entry.reference_spp >= entry.reference_requested:
        return settings
    kept = [s for s in settings if s.integrator != "path" or s.spp < entry.reference_spp]
    dropped = [s for s in settings if s not in kept]
    if dropped:
        entry.skipped.extend(dropped)
        entry.notes.append(f"the path tracer's renders of {min(s.spp for s in dropped)} spp and more "
                           f"skipped: not below the scaled-down reference's {entry.reference_spp} spp")
        if progress is not None:
            progress.update(len(dropped))
    return kept


def _limits(loaded, entry: SceneResult, settings: list[Setting], reference: np.ndarray, out: Path,
            deadline: float, progress) -> None:
    """Each Whitted method's limit (:func:`~whitted.compare.limits.render_limit`), its
    renders read back from their kept EXRs and scored against it."""
    for method in limit_methods(settings):
        if progress is not None:
            progress.set_postfix_str(f"{entry.name}: {method} limit", refresh=False)
        measured = [(m, imageio.read_image(out / m.image)) for m in entry.measurements
                    if m.setting.method == method and m.image]
        limit = render_limit(loaded, entry, method, measured, reference, out, deadline)
        if limit is not None:
            entry.limits[method] = limit
        elif measured:
            entry.notes.append(f"{method}: its limit was not rendered: it would have overrun the "
                               f"scene's share of --budget")
        if progress is not None:
            progress.update(1)
