"""Timing and memory for the benchmarks: medians of interleaved runs after warm-up.

Each contender does one whole render and waits for it. All are warmed up first, then the
rounds run as ``whitted compare``'s do (:mod:`whitted.compare.timing`: interleaved, a
ratio the median of per-round ratios), with a checked run confirming that no compilation
is left in what is timed.
"""

from __future__ import annotations

import gc
import math
import statistics
import time
from dataclasses import dataclass
from typing import Callable

import drjit as dr
import mitsuba as mi

from whitted.compare.timing import interleaved, median
from whitted.rendering import Clock


#: an interquartile range above this fraction of the median (and above the jitter of a
#: millisecond render, ``JITTER`` seconds) means the machine was busy
NOISY = 0.10
JITTER = 0.5e-3


@dataclass
class Timing:
    median: float            # seconds
    q1: float
    q3: float
    compile_seconds: float   # compilation left in a run after warm-up (should be 0)
    times: list              # seconds, one per round

    def spread(self) -> str:
        """The interquartile range relative to the median, e.g. '±3%'."""
        return f"±{50 * (self.q3 - self.q1) / self.median:.0f}%" if self.median else "-"

    def noisy(self) -> bool:
        return self.q3 - self.q1 > max(NOISY * self.median, JITTER)

    def over(self, other: "Timing") -> float:
        """This contender's time over ``other``'s: the median of their per-round ratios."""
        return median(a / b for a, b in zip(self.times, other.times))


def _wait():
    if dr.is_jit_v(mi.Float):
        dr.sync_thread()


def _done(run: Callable[[], object]) -> None:
    run()
    _wait()


def _clocked(run: Callable[[], object], fresh_memory: bool = True) -> Clock:
    with Clock(fresh_memory=fresh_memory) as clock:
        _done(run)
    return clock


def measure(contenders: dict[str, Callable[[], object]], rounds: int, warmup: int = 2,
            min_seconds: float = 0.5, max_rounds: int = 200) -> dict[str, Timing]:
    """Median wall time of each contender over at least ``rounds`` interleaved runs, more (up to
    ``max_rounds``) until they take about ``min_seconds``: a millisecond render timed five
    times says little on a shared machine."""
    for run in contenders.values():
        for _ in range(warmup):
            _done(run)
    compiled = {name: _clocked(run, fresh_memory=False).compile for name, run in contenders.items()}
    start = time.perf_counter()
    for run in contenders.values():
        _done(run)
    one_round = time.perf_counter() - start
    rounds = max(rounds, min(max_rounds, math.ceil(min_seconds / max(one_round, 1e-6))))
    times = {name: [] for name in contenders}
    names = list(contenders)
    gc.collect()
    gc.disable()
    try:
        for r in range(rounds):
            for name in interleaved(names, r):
                _wait()
                start = time.perf_counter()
                contenders[name]()
                _wait()
                times[name].append(time.perf_counter() - start)
    finally:
        gc.enable()
    result = {}
    for name, values in times.items():
        q = statistics.quantiles(values, n=4) if len(values) > 1 else [values[0]] * 3
        result[name] = Timing(statistics.median(values), q[0], q[2], compiled[name], values)
    return result


def cpu_seconds(run: Callable[[], object]) -> float:
    """CPU seconds of this process during ``run()``."""
    start = time.process_time()
    run()
    return time.process_time() - start


def peak_memory(run: Callable[[], object]) -> int:
    """Dr.Jit's high-water mark of allocated bytes during ``run()`` (0 in scalar variants): every
    array it holds, not Embree's acceleration structure or Python's heap."""
    return _clocked(run).peak_memory if dr.is_jit_v(mi.Float) else 0
