"""``whitted compare --workers N`` and ``--scheduler ADDRESS``: the sweep on a Dask cluster.

Mitsuba renders on one machine: it has no network rendering of its own. Dask's
``distributed`` runs Python functions in worker processes, on this machine (a
``LocalCluster`` of ``--workers N`` processes, started and stopped here) or on
many (the workers of a running scheduler, ``--scheduler tcp://host:port``),
moves their arguments and results, and hands the tasks of a worker that dies to
the others. The same code runs in both cases.

What runs where
    This process (the client) reads, loads and plans every scene as a run in one
    process does (a bad scene fails at once), then submits three kinds of task on
    plain data only, since Mitsuba objects do not pickle: the
    :class:`~whitted.compare.scenes.SceneFile` (the scene's path, bytes and
    parsed model), the settings and the :class:`~whitted.compare.results.Options`.

    * under ``--budget``, a scene's *probe*: the plan of its reference
      (:func:`~whitted.compare.reference.plan_reference`: short probe renders that
      measure its cost, and the spp that fits); without a budget the client plans
      each reference itself, since that renders nothing;
    * a *chunk* of a reference (:meth:`~whitted.compare.reference.ReferencePlan.chunks`),
      for each reference not in the cache: one reference's chunks run on any
      workers at once, with or without a budget;
    * a scene's *sweep* (:func:`~whitted.compare.sweep.sweep_scene`): the reference
      averaged from its plan's probes and chunks and stored in the cache (by that
      worker, atomically), then every setting of the scene, one after the other on
      that one worker, so that a scene's times are measured under the same
      conditions and compare. Under ``--budget`` the scene's share counts from its
      probe.

    A worker process prepares itself on its first task: it selects the variant and
    registers the plugins (``whitted.set_variant``) and sizes Dr.Jit's thread pool
    (``dr.set_thread_count``), and FLIP's OpenMP threads, to its share of its
    machine's cores: the cores over the number of workers on that machine, but at
    least :data:`MIN_THREADS`. It renders one task at a time even when
    started with several threads (a lock): two renders at once would share one
    thread pool and slow each other down unevenly.

Same results
    Without ``--budget``, a cluster writes the results.csv of a run in one process,
    the time columns and ``worker`` aside: the reference's chunks follow from its plan
    alone (and without a budget the plan from the options alone), every render has a
    fixed seed, and a render's image depends on its seed alone
    (:func:`whitted.rendering.path_passes`), whatever the worker's thread count. Under
    ``--budget`` the plan depends on the probe's timings, but a plan makes the same
    reference wherever its chunks run.

Failures
    A worker that dies mid-task: the scheduler hands its tasks to the others (a
    task may lose ``distributed.scheduler.allowed-failures`` workers, 3 by default,
    before the run fails). A scene's result is the return value of one whole task,
    so nothing is lost or counted twice. A scheduler that does not answer within
    :data:`~whitted.defaults.COMPARE_CONNECT_TIMEOUT` seconds, or has no worker, is
    one line of error before any work. Ctrl-C cancels the tasks, ends the ones
    running (:func:`stop_rendering`, so that no worker has to be killed on the way
    out) and the caller writes what finished, in one line. A local cluster's own
    log messages are silenced (``silence_logs``): a worker's failure reaches the
    user as the one-line error of the task it ran, and shutting down mid-task would
    otherwise print the heartbeat tracebacks of workers outliving their scheduler.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import sys
import threading
import time
import uuid
from collections import Counter
from dataclasses import replace
from pathlib import Path

from ..defaults import COMPARE_CONNECT_TIMEOUT
from ..errors import WhittedError
from .budget import Budget
from .csvfile import CSV_NAME, write_csv
from .reference import Chunk, ReferenceCache, ReferencePlan, plan_reference, render_chunk
from .results import Options, SceneResult, Setting
from .scenes import SceneFile
from .sweep import sweep_scene

# --------------------------------------------------------------------------- on the workers

#: The fewest Dr.Jit threads a worker gets, even when its share of the cores is one:
#: with a pool of one thread, Mitsuba 3.9's EXR reading and writing (``mi.Bitmap``,
#: through OpenEXR's thread pool) never returns, and the reference cache is EXR.
MIN_THREADS = 2
#: One render at a time in a worker process (see the module docstring).
_RENDERING = threading.Lock()
#: The (variant, Dr.Jit threads) this worker process is prepared for.
_prepared: tuple[str, int] | None = None
#: The thread of the task rendering now in this worker process (None: none).
_rendering_thread: int | None = None


class Stopped(Exception):
    """Raised in a worker's rendering thread when the client stops the run (Ctrl-C)."""


#: Guards :data:`_rendering_thread` between a task's thread and :func:`stop_rendering`.
_STOP_LOCK = threading.Lock()
#: How long :func:`stop_rendering` keeps trying, and how often (seconds).
STOP_PATIENCE, STOP_INTERVAL = 10.0, 0.1


def _raise_in(thread: int, error: type[BaseException] | None) -> None:
    """Have ``thread`` raise ``error`` at its next Python step (None: forget a pending one)."""
    import ctypes
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread),
                                               None if error is None else ctypes.py_object(error))


@contextlib.contextmanager
def _rendering():
    """One render at a time, its thread known so that :func:`stop_rendering` can end it."""
    global _rendering_thread
    with _RENDERING:
        with _STOP_LOCK:
            _rendering_thread = threading.get_ident()
        try:
            yield
        finally:
            with _STOP_LOCK:
                _rendering_thread = None
                _raise_in(threading.get_ident(), None)   # a stop that came too late is dropped


def _ignore_stopped(unraisable) -> None:
    """``sys.unraisablehook`` of a worker: :class:`Stopped` landing where Python cannot raise
    it (a garbage collector's callback, a finalizer) is no news; it is sent again."""
    if not isinstance(unraisable.exc_value, Stopped):
        sys.__unraisablehook__(unraisable)


def cancel(client, tasks) -> None:
    """On an error or Ctrl-C: cancel ``tasks`` and end the renders under way on every worker."""
    if tasks:
        client.cancel(list(tasks), force=True)
        with contextlib.suppress(Exception):   # the tasks running now end too
            client.run(stop_rendering, wait=True)


async def stop_rendering() -> bool:
    """On a worker (through ``client.run``, on its event loop): end the task rendering there.

    A task cannot be cancelled once it runs, and a worker busy with one can only be
    killed on the way out, leaving the semaphores of its process to the resource
    tracker (which warns about them). Instead its thread gets :class:`Stopped` at its
    next Python step (between kernels, or between a pass's levels), the task ends with
    that error (its future is cancelled already) and the worker stops cleanly. Where
    Python had to drop it (raised inside a callback), it is sent again until the task
    has ended, for :data:`STOP_PATIENCE` seconds at most; whether it ended is returned.
    """
    import asyncio
    for _ in range(round(STOP_PATIENCE / STOP_INTERVAL)):
        with _STOP_LOCK:
            if _rendering_thread is None:
                return True
            _raise_in(_rendering_thread, Stopped)
        await asyncio.sleep(STOP_INTERVAL)
    return _rendering_thread is None


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, else the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _prepare(variant: str, threads: dict[str, int]) -> str:
    """Make this worker process ready to render in ``variant`` with its share of its
    machine's cores (``threads``: host -> Dr.Jit threads per worker there); returns the
    worker's address."""
    global _prepared
    import drjit as dr
    from distributed import get_worker
    from distributed.comm import get_address_host

    from ..variant import set_variant

    address = get_worker().address
    count = threads.get(get_address_host(address)) or max(MIN_THREADS, available_cores())
    if _prepared is None:
        sys.unraisablehook = _ignore_stopped
    if _prepared != (variant, count):
        set_variant(variant)  # registers the plugins too
        dr.set_thread_count(count)
        if "flip_evaluator" not in sys.modules:  # its OpenMP reads this when it loads
            os.environ["OMP_NUM_THREADS"] = str(count)
        _prepared = (variant, count)
    return address


def chunk_task(scene: SceneFile, variant: str, max_depth: int, spp: int, seed: int, half: int,
               threads: dict[str, int]) -> Chunk:
    """One chunk of a reference (:func:`~whitted.compare.reference.reference_chunks`)."""
    with _rendering():
        worker = _prepare(variant, threads)
        chunk = render_chunk(scene.load(variant), spp, seed, half, max_depth)
        chunk.worker = worker
        return chunk


def _seconds(seconds: float, end: float | None, began: float | None = None) -> float:
    """A scene's time left now: its share ``seconds`` less what passed since its work
    ``began``, and none past the budget's ``end`` (``time.time()`` readings)."""
    now = time.time()
    if began is not None:
        seconds -= max(0.0, now - began)
    return seconds if end is None else min(seconds, max(0.0, end - now))


def probe_task(scene: SceneFile, entry: SceneResult, options: Options, seconds: float,
               end: float | None, threads: dict[str, int]) -> ReferencePlan:
    """Under ``--budget``, the plan of a scene's reference
    (:func:`~whitted.compare.reference.plan_reference`: its probe renders, here)."""
    with _rendering():
        worker = _prepare(entry.variant, threads)
        plan = plan_reference(scene, scene.load(entry.variant), entry,
                              ReferenceCache(options.cache_folder), options, _seconds(seconds, end))
        for chunk in plan.probes:
            chunk.worker = worker
        return plan


def sweep_task(scene: SceneFile, entry: SceneResult, settings: list[Setting], options: Options,
               seconds: float, end: float | None, threads: dict[str, int],
               plan: ReferencePlan | None, chunks: list[Chunk] | None) -> SceneResult:
    """One scene's sweep on this worker: its result, with ``worker`` set. With ``plan``
    the scene's time counts from when its reference was planned."""
    with _rendering():
        worker = _prepare(entry.variant, threads)
        seconds = _seconds(seconds, end, plan.began if plan is not None else None)
        result = sweep_scene(scene, entry, settings, options, seconds, plan=plan, chunks=chunks)
        result.worker = worker
        return result


# --------------------------------------------------------------------------- on the client


@contextlib.contextmanager
def connect(options: Options):
    """A Dask client of a local cluster of ``options.workers`` processes (started here
    on 127.0.0.1 without a dashboard, and stopped on leaving, also on error or Ctrl-C),
    or of the scheduler at ``options.scheduler``."""
    import logging

    from distributed import Client, LocalCluster

    cluster = client = None
    try:
        if options.workers is not None:
            _check_start_method()
            # Everything on 127.0.0.1, on free ports: without a dashboard the scheduler still
            # serves health and metrics over HTTP, by default on port 8787.
            with _workers_ignore_ctrl_c():
                cluster = LocalCluster(n_workers=options.workers, threads_per_worker=1,
                                       processes=True, host="127.0.0.1", dashboard_address=None,
                                       scheduler_kwargs={"dashboard": False,
                                                         "dashboard_address": "127.0.0.1:0"},
                                       silence_logs=logging.CRITICAL)
            client = Client(cluster, set_as_default=False)
        else:
            client = _connect_scheduler(options.scheduler)
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


def _check_start_method() -> None:
    """CUDA cannot run in a process forked from one that has started it: the local
    cluster's worker processes must be spawned (Dask's default for its nannies)."""
    import dask
    import mitsuba as mi

    method = dask.config.get("distributed.worker.multiprocessing-method")
    if mi.variant().startswith("cuda") and method != "spawn":
        raise WhittedError(f"--workers with {mi.variant()} needs Dask's worker processes spawned, "
                           f"not '{method}': unset distributed.worker.multiprocessing-method")


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """Start processes that ignore SIGINT (an ignored signal stays ignored in a child,
    and Python then keeps it so). A Ctrl-C on a terminal reaches its whole process
    group, the local cluster's workers included; they should not each die with a
    traceback, since this process cancels the work and stops them. A Ctrl-C while
    the cluster starts is lost."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _connect_scheduler(address: str):
    """A client of the scheduler at ``address`` with at least one worker, or one clean error."""
    import logging

    from distributed import Client

    from distributed.comm import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:  # checked first: a Client made from a bad address hangs on its way out
        scheme, location = parse_address(address)
        get_backend(scheme)
        parse_host_port(location)
    except ValueError as error:
        raise WhittedError(f"{address}: not a Dask scheduler address like tcp://host:8786 "
                           f"({error})") from None
    timeout = COMPARE_CONNECT_TIMEOUT
    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)  # the error below says it in one line
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as error:
        why = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise WhittedError(f"{address}: cannot reach the Dask scheduler within {timeout:g} s ({why})") \
            from None
    finally:
        quiet.setLevel(level)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        client.close()
        raise WhittedError(f"{address}: the Dask scheduler has no worker (none joined within "
                           f"{timeout:g} s); start some with: dask worker {address} --nthreads 1") from None
    return client


def worker_threads(cores: dict[str, int]) -> dict[str, int]:
    """Dr.Jit threads per worker on each host, from ``cores`` (worker address -> the cores
    it may use): the host's cores shared evenly among its worker processes, but at least
    :data:`MIN_THREADS`."""
    from distributed.comm import get_address_host

    per_host = Counter(get_address_host(address) for address in cores)
    return {host: max(MIN_THREADS, min(c for a, c in cores.items() if get_address_host(a) == host) // n)
            for host, n in per_host.items()}


def sweep_on_cluster(client, scenes: list[SceneFile], entries: list[SceneResult],
                     plans: list[list[Setting]], options: Options, budget: Budget) -> None:
    """Sweep every scene on the cluster of ``client``.

    ``entries`` (the planned results, one per scene) are replaced by the workers'
    results as they come, and ``results.csv`` rewritten, so that an interruption
    keeps what finished. With a budget, each scene may take its even share of the
    time times the number of workers (that many scenes run at once), and none
    runs past the budget's end (the workers' clocks are taken to agree).
    """
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
    cache = ReferenceCache(sent.cache_folder)
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
        if budget.seconds is None:  # planned here: nothing to render for it, only the cache to read
            submit_sweep(index, plan_reference(scene, None, entry, cache, sent))
        else:  # planned by a worker: the probe renders, then what fits
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
                submitted = submit_sweep(index, _result(future, name))
                for task in submitted:
                    running.add(task)
                bar.total += len(submitted)
            elif kind == "sweep":
                entries[index] = result = _result(future, name)
                finished[index] = True
                chunks_of.pop(index, None)  # their images may go now
                write_csv(out / CSV_NAME, [e for e, f in zip(entries, finished) if f])
                bar.set_postfix_str(f"{sum(finished)}/{len(entries)} scenes", refresh=False)
                if not options.quiet:
                    bar.write(f"whitted compare: {name}: {len(result.measurements)} renders on "
                              f"{result.worker}", file=sys.stderr)
            elif future.status == "error":
                _result(future, name)  # raises the chunk's error
            bar.update(1)
    except BaseException:
        cancel(client, tasks)
        raise
    finally:
        bar.close()


def _result(future, name: str):
    """The task's result; a task that lost every worker it ran on is one clean error."""
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    try:
        return future.result()
    except KilledWorker:
        raise WhittedError(f"{name}: the Dask workers that ran it died, every time it was tried; "
                           "see the workers' logs (memory?)") from None
    except CancelledError:
        raise WhittedError(f"{name}: its task was cancelled: the connection to the Dask scheduler "
                           "was lost?") from None
