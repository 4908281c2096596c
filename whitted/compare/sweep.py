"""One scene's share of the comparison: its reference, then each setting rendered,
timed and scored.

This is the unit of work that can move to another process: :func:`sweep_scene`
takes plain data (the :class:`~whitted.compare.scenes.SceneFile`, the settings,
the :class:`~whitted.compare.results.Options` and a time share in seconds),
loads its own ``mi.Scene`` when none is handed to it, reads and writes the
reference cache by its folder, and returns a
:class:`~whitted.compare.results.SceneResult` (images reduced to thumbnails). No
Mitsuba object goes in or out unless the caller shares its process.

Timing is honest: each render is repeated and the median of the render times is
kept (every repeat's time too, for the spread), kernel compilation excluded
(``result.seconds`` of the rendering API) and reported apart
(``compile_seconds``). Error is measured on linear images (:mod:`whitted.metrics`).

Every render is kept under the output folder (``renders/SCENE/``: its linear EXR,
an sRGB PNG and FLIP's error map, :mod:`.errormaps`), written by whoever renders
it: a worker process must share the output folder's file system.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np

from .. import imageio, metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from .budget import Budget
from .errormaps import write_render
from .reference import Chunk, ReferenceCache, reference_image
from .report import thumbnail
from .results import Measurement, Options, SceneResult, Setting
from .scenes import SceneFile

#: The seed of every render of the sweep (the reference has its own).
SWEEP_SEED = 0


def measure(loaded, setting: Setting, reference: np.ndarray, repeats: int,
            out: Path | None = None, folder: str = "") -> Measurement:
    """Render ``setting`` of ``loaded`` (an ``mi.Scene``) ``repeats`` times and score the
    image against ``reference``; the median render time is kept, and every repeat's.
    With ``out``, the image and its error map are kept under ``out / folder``."""
    seconds, compile_seconds, image = [], [], None
    for _ in range(repeats):
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
    return Measurement(setting, statistics.median(seconds), max(compile_seconds),
                       metrics.relative_mse(image, reference), flip, repeats, thumbnail(image),
                       times=tuple(seconds), **files)


def sweep_scene(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
                seconds: float = math.inf, *, loaded=None, progress=None,
                chunks: list[Chunk] | None = None) -> SceneResult:
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
    ``progress`` a tqdm bar to advance by one per setting, or None
    ``chunks``   the reference's chunks (:class:`~whitted.compare.reference.Chunk`)
                 when a cluster's workers rendered them; None: rendered here unless
                 cached
    ============ ======================================================================
    """
    deadline = time.monotonic() + seconds
    if loaded is None:
        loaded = scene.load(entry.variant)
    out = Path(options.out)
    cache = ReferenceCache(options.cache_folder)
    reference = reference_image(scene, loaded, entry, cache, options,
                                seconds=deadline - time.monotonic(), chunks=chunks)
    if reference is None:
        entry.skipped.extend(settings)
        if progress is not None:
            progress.update(len(settings))
        return entry
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
