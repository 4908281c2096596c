"""The whole ``whitted compare`` run: check the options, read and plan every scene,
sweep them one after the other within the budget, write the outputs.

This is the one place that knows the order of the work and holds Mitsuba
objects across it. Every scene is read and loaded before the first render, so a
bad scene fails at once, not after minutes of rendering; each scene's
``mi.Scene`` is then handed to its sweep and let go once that scene is done. A
scene's sweep (:func:`whitted.compare.sweep.sweep_scene`) needs only plain data,
so another driver can hand the scenes to worker processes instead of this loop.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .. import interrupt
from ..atomic import check_folder_creatable
from ..errors import WhittedError
from ..progress import progress_bar
from . import report
from .budget import Budget
from .planning import plan_scene
from .results import MAX_DEPTH, Options, SceneResult
from .scenes import SceneFile, scene_files, scene_names
from .sweep import sweep_scene


def check_options(options: Options) -> None:
    """One clean error for options that cannot work, before anything is read or written."""
    out = Path(options.out)
    if out.exists() and not out.is_dir():
        raise WhittedError(f"{out}: exists and is not a folder")
    check_folder_creatable(out)
    if options.repeats < 1 or options.reference_spp < 1:
        raise WhittedError("--repeats and --reference-spp must be >= 1")
    if options.budget is not None and not options.budget > 0:
        raise WhittedError(f"--budget must be a positive number of seconds, got {options.budget}")
    if options.depths and max(options.depths) > MAX_DEPTH:
        raise WhittedError(f"--depths: the scene format allows depths up to {MAX_DEPTH}")
    if options.path_depth is not None and not 1 <= options.path_depth <= MAX_DEPTH:
        raise WhittedError(f"--path-depth must be in 1…{MAX_DEPTH}, got {options.path_depth}")
    cache_folder = options.cache_folder
    if cache_folder.exists() and not cache_folder.is_dir():
        raise WhittedError(f"{cache_folder}: the reference cache exists and is not a folder")
    check_folder_creatable(cache_folder)


def compare(scenes: list[str | os.PathLike], options: Options) -> list[SceneResult]:
    """Run the whole comparison and write its outputs under ``options.out``."""
    from ..variant import set_variant

    budget = Budget(options.budget)
    check_options(options)
    out = Path(options.out)
    variant = set_variant(options.variant)
    files = scene_files(scenes)

    # Read, load and plan every scene first: a bad scene fails now, not after minutes of rendering.
    read, loaded, entries, plans = [], [], [], []
    for path, name in zip(files, scene_names(files)):
        scene = SceneFile.read(path, name)
        mitsuba_scene = scene.load()
        entry, settings = plan_scene(scene, mitsuba_scene, options, variant)
        read.append(scene)
        loaded.append(mitsuba_scene)
        entries.append(entry)
        plans.append(settings)
    if max(options.path_spp) >= options.reference_spp and not options.quiet:
        print(f"whitted compare: warning: the path tracer's ladder reaches the reference's "
              f"{options.reference_spp} spp; its error will stop falling there", file=sys.stderr)

    out.mkdir(parents=True, exist_ok=True)
    bar = progress_bar(not options.quiet, sum(map(len, plans)), "compare", unit="render",
                       unit_scale=False)
    try:
        for index, (scene, entry, settings) in enumerate(zip(read, entries, plans)):
            sweep_scene(scene, entry, settings, options, budget.share(len(entries) - index),
                        loaded=loaded[index], progress=bar)
            report.write_csv(out / report.CSV_NAME, entries[:index + 1])
            loaded[index] = None  # free the scene's memory
    except BaseException as error:   # Ctrl-C may arrive wrapped (see whitted.interrupt)
        if not interrupt.requested(error):
            raise
        bar.close()
        if any(e.reference_thumbnail is not None for e in entries):
            report.write_all(out, _with_reference(entries))
            print(f"whitted compare: interrupted; the outputs in {out} hold what was done",
                  file=sys.stderr)
        raise
    bar.close()
    report.write_all(out, _with_reference(entries))
    return entries


def _with_reference(entries: list[SceneResult]) -> list[SceneResult]:
    """The scenes that got as far as their reference (the others have nothing to show)."""
    return [e for e in entries if e.reference_thumbnail is not None]
