"""Dask clusters for ``--workers`` and ``--scheduler`` (Mitsuba has no network rendering of
its own): starting or reaching one, preparing its workers, stopping their renders. What
runs where, and what a failure does: docs/cluster.md.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
from collections import Counter

from .defaults import COMPARE_CONNECT_TIMEOUT
from .errors import WhittedError, first_line

#: a worker's fewest Dr.Jit threads: with one, Mitsuba 3.9 never returns from an EXR's I/O
MIN_THREADS = 2
#: one render at a time in a worker: two would share its thread pool unevenly
_RENDERING = threading.Lock()
_prepared: tuple[str, int] | None = None   # (variant, Dr.Jit threads) of this worker
_rendering_thread: int | None = None


class Stopped(Exception):
    """Raised in a worker's rendering thread when the client stops the run (Ctrl-C)."""


_STOP_LOCK = threading.Lock()   # guards _rendering_thread
STOP_PATIENCE, STOP_INTERVAL = 10.0, 0.1


def _raise_in(thread: int, error: type[BaseException] | None) -> None:
    """Have ``thread`` raise ``error`` at its next Python step (None: forget a pending one)."""
    import ctypes
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread),
                                               None if error is None else ctypes.py_object(error))


@contextlib.contextmanager
def worker_task(variant: str, threads: dict[str, int]):
    """A task on a worker, prepared (yields its address), its thread known to :func:`stop_rendering`."""
    global _rendering_thread
    with _RENDERING:
        with _STOP_LOCK:
            _rendering_thread = threading.get_ident()
        try:
            yield prepare(variant, threads)
        finally:
            with _STOP_LOCK:
                _rendering_thread = None
                _raise_in(threading.get_ident(), None)   # a stop that came too late is dropped


def on_worker(function, variant: str, threads: dict[str, int], *args):
    """``function(*args)`` in a :func:`worker_task`, its result's ``worker`` set."""
    with worker_task(variant, threads) as worker:
        result = function(*args)
        result.worker = worker
        return result


def _ignore_stopped(unraisable) -> None:
    """A worker's ``sys.unraisablehook``: a :class:`Stopped` dropped in a callback is sent again."""
    if not isinstance(unraisable.exc_value, Stopped):
        sys.__unraisablehook__(unraisable)


def cancel(client, tasks) -> None:
    """On an error or Ctrl-C: cancel ``tasks`` and end the renders under way on every worker."""
    if tasks:
        client.cancel(list(tasks), force=True)
        with contextlib.suppress(Exception):   # the tasks running now end too
            client.run(stop_rendering, wait=True)


async def stop_rendering() -> bool:
    """On a worker (``client.run``): end the task rendering there, which Dask cannot cancel,
    by raising :class:`Stopped` in its thread (again while dropped, up to
    :data:`STOP_PATIENCE` s), so that no worker is killed; whether it ended."""
    import asyncio
    for _ in range(round(STOP_PATIENCE / STOP_INTERVAL)):
        with _STOP_LOCK:
            if _rendering_thread is None:
                return True
            _raise_in(_rendering_thread, Stopped)
        await asyncio.sleep(STOP_INTERVAL)
    return _rendering_thread is None


def available_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def prepare(variant: str, threads: dict[str, int]) -> str:
    """This worker's address, ready for ``variant`` with its share (``threads`` by host)."""
    global _prepared
    import drjit as dr
    from distributed import get_worker
    from distributed.comm import get_address_host

    from .variant import set_variant

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


def check_where(workers: int | None, scheduler: str | None) -> None:
    """One clean error for ``--workers`` and ``--scheduler`` that cannot work."""
    if workers is not None and scheduler is not None:
        raise WhittedError("--workers starts a local cluster, --scheduler uses a running one: "
                           "give one of them")
    if workers is not None and workers < 1:
        raise WhittedError(f"--workers must be >= 1, got {workers}")


@contextlib.contextmanager
def connect(workers: int | None, scheduler: str | None):
    """A Dask client of a local cluster of ``workers`` processes, or of ``scheduler``'s."""
    from distributed import Client, LocalCluster

    cluster = client = None
    try:
        if workers is not None:
            import dask
            import mitsuba as mi

            method = dask.config.get("distributed.worker.multiprocessing-method")
            if mi.variant().startswith("cuda") and method != "spawn":   # CUDA cannot run forked
                raise WhittedError(f"--workers with {mi.variant()} needs Dask's worker processes "
                                   f"spawned, not '{method}': unset "
                                   "distributed.worker.multiprocessing-method")
            # Everything on 127.0.0.1, on free ports: without a dashboard the scheduler still
            # serves health and metrics over HTTP, by default on port 8787.
            with _workers_ignore_ctrl_c():
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                       processes=True, host="127.0.0.1", dashboard_address=None,
                                       scheduler_kwargs={"dashboard": False,
                                                         "dashboard_address": "127.0.0.1:0"},
                                       silence_logs=logging.CRITICAL)
            client = Client(cluster, set_as_default=False)
        else:
            client = _connect_scheduler(scheduler)
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """Start processes that ignore SIGINT: the terminal's Ctrl-C is this process's to handle."""
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
        raise WhittedError(f"{address}: cannot reach the Dask scheduler within {timeout:g} s "
                           f"({first_line(error)})") from None
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
    """Dr.Jit threads per worker by host: its cores shared among its workers, at least
    :data:`MIN_THREADS` (``cores``: worker address -> cores)."""
    from distributed.comm import get_address_host

    per_host = Counter(get_address_host(address) for address in cores)
    return {host: max(MIN_THREADS, min(c for a, c in cores.items() if get_address_host(a) == host) // n)
            for host, n in per_host.items()}


def task_result(future, name: str):
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
