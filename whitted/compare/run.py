"""The whole ``whitted compare`` run, the one place that knows the order of the work and
holds Mitsuba objects across it: every scene is read and loaded before the first render,
so a bad scene fails at once; then each is swept, here or on a Dask cluster, and the
outputs written.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .. import interrupt
from ..atomic import check_folder_creatable
from ..cluster import check_where, connect
from ..defaults import check_depth
from ..errors import WhittedError
from ..images import check_exposure, check_view
from ..progress import progress_bar
from ..variant import set_variant
from .budget import Budget
from .report import CSV_NAME, findings, json_safe, write_all, write_csv
from .results import Comparison, Options
from .scenes import SceneFile, plan_scene, progress_units, scene_files, scene_names
from .sweep import sweep_scene


def check_options(options: Options) -> None:
    out = Path(options.out)
    if out.exists() and not out.is_dir():
        raise WhittedError(f"{out}: exists and is not a folder")
    check_folder_creatable(out)
    if options.rounds < 1 or options.reference_spp < 1:
        raise WhittedError("--rounds and --reference-spp must be >= 1")
    if options.budget is not None and not options.budget > 0:
        raise WhittedError(f"--budget must be a positive number of seconds, got {options.budget}")
    for depth in options.depths or ():
        check_depth(depth, "--depths")
    if options.path_depth is not None:
        check_depth(options.path_depth, "--path-depth")
    cache_folder = options.cache_folder
    if cache_folder.exists() and not cache_folder.is_dir():
        raise WhittedError(f"{cache_folder}: the reference cache exists and is not a folder")
    check_folder_creatable(cache_folder)
    if options.reference_chunk_spp < 1:
        raise WhittedError("--reference-chunk-spp must be >= 1")
    check_where(options.workers, options.scheduler)
    if options.view is not None:
        check_view(options.view)
    check_exposure(options.exposure)


def compare(scenes: list[str | os.PathLike], options: Options) -> Comparison:
    """Run the whole comparison and write its outputs under ``options.out``; returns the
    scenes' results with their analyses and findings."""
    budget = Budget(options.budget, options.started)
    check_options(options)
    out = Path(options.out)
    variant = set_variant(options.variant)
    files = scene_files(scenes)

    on_cluster = options.workers is not None or options.scheduler is not None

    read, loaded, entries, plans = [], [], [], []
    for path, name in zip(files, scene_names(files)):
        scene = SceneFile.read(path, name)
        mitsuba_scene = scene.load()
        entry, settings = plan_scene(scene, mitsuba_scene, options, variant)
        read.append(scene)
        loaded.append(None if on_cluster else mitsuba_scene)  # workers load their own
        entries.append(entry)
        plans.append(settings)
    if max(options.path_spp) >= options.reference_spp and not options.quiet:
        print(f"whitted compare: warning: the path tracer's ladder reaches the reference's "
              f"{options.reference_spp} spp; its error will stop falling there", file=sys.stderr)
    try:
        if on_cluster:
            from .cluster import sweep_on_cluster
            with connect(options.workers, options.scheduler) as client:
                out.mkdir(parents=True, exist_ok=True)
                sweep_on_cluster(client, read, entries, plans, options, budget)
        else:
            out.mkdir(parents=True, exist_ok=True)
            with progress_bar(not options.quiet, sum(map(progress_units, plans)), "compare",
                              unit="render", unit_scale=False) as bar:
                for index, (scene, entry, settings) in enumerate(zip(read, entries, plans)):
                    sweep_scene(scene, entry, settings, options, budget.share(len(entries) - index),
                                loaded=loaded[index], progress=bar)
                    write_csv(out / CSV_NAME, entries[:index + 1])
                    loaded[index] = None  # free the scene's memory
        # in the try: a stop while they are drawn writes them all again, marked as stopped
        analyses = write_all(out, entries, options.levels)
    except BaseException as error:   # Ctrl-C may arrive wrapped (see whitted.interrupt)
        if not interrupt.requested(error) or not out.is_dir():
            raise
        # the outputs of what was done, marked so at the top, or a page that says nothing was
        # measured (a cluster is stopped by now: its cores are free to write)
        done, planned = sum(len(e.measurements) for e in entries), sum(map(len, plans))
        write_all(out, entries, options.levels, interrupted=(done, planned))
        interrupt.tell(f"the outputs in {out} hold what was done ({done} of {planned} renders)"
                       if done else f"the outputs in {out} say nothing was measured")
        raise
    return Comparison(entries, analyses, json_safe(findings(analyses)))  # as findings.json holds it
