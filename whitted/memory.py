"""The process's resident memory as the operating system counts it, and its peak.

Why: Dr.Jit's allocator high-water mark (``peak_memory_bytes`` in the render
statistics) counts Dr.Jit's arrays only, not numpy's copies, Mitsuba's
bitmaps, Embree, LLVM or Python, which can make a large render's real peak
several times larger (benchmarks/RESULTS.md, "Peak memory of a large
render"). Linux keeps the peak resident set size (``VmHWM`` in
``/proc/self/status``) and lets a process reset it (writing ``5`` to
``/proc/self/clear_refs``), so the peak of one stretch of work can be
measured. Elsewhere the peak is that of the process's whole life
(``getrusage``).

Beware: on Linux the reset also resets what ``getrusage``, a parent's ``wait4`` and
GNU ``time`` report as the process's peak (checked: 500 MB touched, then a reset, and
``time`` says 26 MB). Each render resets it, so a whole ``whitted render`` process's
reported peak is its render's peak, not its loading's when that is higher. For the
sphereflake the render's is the higher (level 6: VmRSS polled every 0.5 s peaked at
469 MB, ``time`` reported 482 MB), which the whole-process figures of
benchmarks/RESULTS.md rely on.
"""

from __future__ import annotations

import contextlib
import resource
import sys
from pathlib import Path

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


def _status(key: str) -> int | None:
    """A ``kB`` entry of /proc/self/status in bytes (None where there is none)."""
    with contextlib.suppress(OSError):
        for line in _STATUS.read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return None


def resident_bytes() -> int | None:
    """The process's resident set size now (Linux; None elsewhere)."""
    return _status("VmRSS")


def reset_peak() -> None:
    """Start measuring the peak resident size afresh (Linux; elsewhere nothing happens)."""
    with contextlib.suppress(OSError):
        _CLEAR_REFS.write_text("5")


def peak_resident_bytes() -> int:
    """The process's peak resident set size since :func:`reset_peak` (Linux), or over its
    whole life (elsewhere)."""
    peak = _status("VmHWM")
    if peak is not None:
        return peak
    maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(maxrss) if sys.platform == "darwin" else int(maxrss) * 1024
