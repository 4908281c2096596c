"""``whitted compare --workers N`` and ``--scheduler ADDRESS``: the sweep on a Dask cluster, as
tasks on plain data only (Mitsuba objects do not pickle): a reference's probe and chunks on
any worker, a scene's sweep on one (so that its times compare). docs/cluster.md says which
task does what and why a dead worker loses or counts nothing twice.
"""

from __future__ import annotations

import math
import sys
import time
import uuid
from dataclasses import replace
from pathlib import Path

from ..cluster import (available_cores, cancel, on_worker, task_result, worker_task,
                       worker_threads)
from .budget import Budget
from .report import CSV_NAME, write_csv
from .reference import Chunk, ReferenceCache, ReferencePlan, plan_reference, render_chunk
from .results import Options, SceneResult, Setting
from .scenes import SceneFile
from .sweep import sweep_scene


def chunk_task(scene: SceneFile, variant: str, max_depth: int, spp: int, seed: int, half: int,
               threads: dict[str, int]) -> Chunk:
    return on_worker(lambda: render_chunk(scene.load(variant), spp, seed, half, max_depth),
                     variant, threads)


def _seconds(seconds: float, end: float | None, plan: ReferencePlan | None = None) -> float:
    """A scene's time left now: its share less what passed since its ``plan``, none past ``end``."""
    now = time.time()
    if plan is not None:
        seconds -= max(0.0, now - plan.began)
    return seconds if end is None else min(seconds, max(0.0, end - now))


def probe_task(scene: SceneFile, entry: SceneResult, options: Options, seconds: float,
               end: float | None, threads: dict[str, int]) -> ReferencePlan:
    with worker_task(entry.variant, threads) as worker:
        plan = plan_reference(scene, scene.load(entry.variant), entry,
                              ReferenceCache(options.cache_folder), options, _seconds(seconds, end))
        for chunk in plan.probes:
            chunk.worker = worker
        return plan


def sweep_task(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
               seconds: float, end: float | None, threads: dict[str, int],
               plan: ReferencePlan | None, chunks: list[Chunk] | None) -> SceneResult:
    """One scene's sweep on this worker; with ``plan``, its time counts from the planning."""
    def sweep():
        return sweep_scene(scene, entry, settings, options, _seconds(seconds, end, plan), plan=plan,
                           chunks=chunks)
    return on_worker(sweep, entry.variant, threads)


def sweep_on_cluster(client, scenes: list[SceneFile], entries: list[SceneResult],
                     plans: list[list[Setting]], options: Options, budget: Budget) -> None:
    """Sweep every scene on the cluster of ``client``, ``entries`` replaced by the workers'
    results as they come and ``results.csv`` rewritten, so that an interruption keeps
    what finished; with a budget, each scene's share is multiplied by the scenes run at once."""
    from distributed import as_completed
    from tqdm import tqdm

    cores = client.run(available_cores)  # worker address -> its cores
    threads, workers = worker_threads(cores), len(cores)
    share, end = math.inf, None
    if budget.seconds is not None:
        remaining = budget.share(len(scenes)) * len(scenes)  # the outputs' time kept back
        share, end = remaining * min(workers, len(scenes)) / len(scenes), time.time() + remaining
    # The workers may start elsewhere: paths absolute; their messages stay in their logs.
    sent = replace(options, out=Path(options.out).resolve(), cache=options.cache_folder.resolve(),
                   quiet=True)
    run = uuid.uuid4().hex[:8]
    tasks = {}   # future -> (scene index, "probe", "chunk" or "sweep")
    chunks_of = {}

    def submit_sweep(index: int, plan: ReferencePlan) -> list:
        """The chunks left of the scene's reference and its sweep, as tasks."""
        scene, entry = scenes[index], entries[index]
        chunks = [client.submit(chunk_task, scene, entry.variant, entry.path_depth, *chunk, threads,
                                key=f"whitted-reference-{entry.name}-{k}-{run}")
                  for k, chunk in enumerate(plan.chunks(options.reference_chunk_spp))]
        chunks_of[index] = chunks
        sweep = client.submit(sweep_task, scene, entry, plans[index], sent, share, end, threads, plan,
                              chunks, key=f"whitted-sweep-{entry.name}-{run}")
        tasks.update((future, (index, "chunk")) for future in chunks)
        tasks[sweep] = (index, "sweep")
        return chunks + [sweep]

    for index, (scene, entry) in enumerate(zip(scenes, entries)):
        # planned by a worker: the probe renders, then what fits or is enough
        tasks[client.submit(probe_task, scene, entry, sent, share, end, threads,
                            key=f"whitted-probe-{entry.name}-{run}")] = (index, "probe")

    out = Path(options.out)
    finished = [False] * len(entries)
    bar = tqdm(total=len(tasks), desc="whitted compare", unit="task", disable=options.quiet,
               file=sys.stderr, dynamic_ncols=True)
    try:
        running = as_completed(list(tasks), loop=client.loop)
        for future in running:
            index, kind = tasks.pop(future)
            name = entries[index].name
            if kind == "probe":
                submitted = submit_sweep(index, task_result(future, name))
                running.update(submitted)
                bar.total += len(submitted)
            elif kind == "sweep":
                entries[index] = result = task_result(future, name)
                finished[index] = True
                chunks_of.pop(index, None)  # their images may go now
                write_csv(out / CSV_NAME, [e for e, f in zip(entries, finished) if f])
                bar.set_postfix_str(f"{sum(finished)}/{len(entries)} scenes", refresh=False)
                if not options.quiet:
                    bar.write(f"whitted compare: {name}: {len(result.measurements)} renders on "
                              f"{result.worker}", file=sys.stderr)
            elif future.status == "error":
                task_result(future, name)  # raises the chunk's error
            bar.update(1)
    except BaseException:
        cancel(client, tasks)
        raise
    finally:
        bar.close()
