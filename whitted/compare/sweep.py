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
kept, kernel compilation excluded (``result.seconds`` of the rendering API) and
reported apart (``compile_seconds``). Error is measured on linear images
(:mod:`whitted.metrics`).
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from .. import metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from .budget import Budget
from .reference import ReferenceCache, reference_image
from .report import thumbnail
from .results import Measurement, Options, SceneResult, Setting
from .scenes import SceneFile

#: The seed of every render of the sweep (the reference has its own).
SWEEP_SEED = 0


def measure(loaded, setting: Setting, reference: np.ndarray, repeats: int) -> Measurement:
    """Render ``setting`` of ``loaded`` (an ``mi.Scene``) ``repeats`` times and score the
    image against ``reference``; the median render time is kept."""
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
    return Measurement(setting, statistics.median(seconds), max(compile_seconds),
                       metrics.relative_mse(image, reference), metrics.flip(image, reference),
                       repeats, thumbnail(image))


def sweep_scene(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
                seconds: float = math.inf, *, loaded=None, progress=None) -> SceneResult:
    """Render and score one scene's ``settings`` (in order) within ``seconds``.

    ============ ======================================================================
    ``scene``    the scene, as read once
    ``entry``    its result so far (from :func:`~whitted.compare.planning.plan_scene`);
                 filled in place as renders finish, so an interruption keeps them,
                 and returned
    ``settings`` what to render, cheapest first
    ``options``  the command's options (repeats, reference spp, cache folder, quiet)
    ``seconds``  the time this scene may take (``math.inf``: no budget); a render
                 predicted to overrun is skipped, and with no time left at all a
                 reference that is not cached is not rendered (the scene is skipped)
    ``loaded``   the scene's ``mi.Scene`` when the caller has it (else loaded here,
                 in ``entry.variant``)
    ``progress`` a tqdm bar to advance by one per setting, or None
    ============ ======================================================================
    """
    deadline = time.monotonic() + seconds
    if loaded is None:
        loaded = scene.load(entry.variant)
    cache = ReferenceCache(options.cache_folder)
    reference = reference_image(scene, loaded, entry, cache, options,
                                may_render=time.monotonic() < deadline)
    if reference is None:
        entry.skipped.extend(settings)
        if progress is not None:
            progress.update(len(settings))
        return entry
    entry.reference_thumbnail = thumbnail(reference)
    done: list[tuple[Setting, float, float]] = []
    for setting in settings:
        if progress is not None:
            progress.set_postfix_str(f"{entry.name}: {setting.method} {setting.label}", refresh=False)
        predicted = Budget.predict(setting, done, options.repeats)
        if time.monotonic() + predicted > deadline:
            entry.skipped.append(setting)
        else:
            start = time.monotonic()
            measurement = measure(loaded, setting, reference, options.repeats)
            entry.measurements.append(measurement)
            done.append((setting, measurement.seconds, time.monotonic() - start))
        if progress is not None:
            progress.update(1)
    return entry
