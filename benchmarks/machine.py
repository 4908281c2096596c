"""What the numbers were measured on: the machine, the software and the source.

A benchmark's numbers mean little without the processor, the number of cores
it could use and the commit it measured; every program of benchmarks/ prints
and records this one description.
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
from pathlib import Path


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def _git(*args) -> str:
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True,
                              cwd=Path(__file__).resolve().parent).stdout
    except (OSError, subprocess.CalledProcessError):
        return ""


def source() -> str:
    """The commit measured, with the files changed since it named."""
    described = _git("describe", "--always", "--dirty").strip() or "unknown"
    changed = [line[3:] for line in _git("status", "--porcelain", "--untracked-files=no").splitlines() if line]
    return described + (f" (uncommitted changes in {', '.join(changed)})" if changed else "")


def machine() -> dict:
    """The processor, cores, Python, OS, source and date; with Mitsuba and Dr.Jit's versions,
    variant and thread count where this process has imported Mitsuba (not imported here:
    programs that only time subprocesses stay small)."""
    now = datetime.datetime.now(datetime.timezone.utc)
    info = {"source": source(), "cpu": _cpu(), "cores": len(os.sched_getaffinity(0)),
            "python": platform.python_version(), "os": platform.platform(),
            "date": now.strftime("%Y-%m-%d %H:%M UTC")}
    if "mitsuba" in sys.modules:
        import drjit as dr
        import mitsuba as mi
        llvm = dr.detail.llvm_version() if dr.backend_v(mi.Float) == dr.JitBackend.LLVM else None
        info.update({"drjit_threads": dr.thread_count(), "variant": mi.variant(), "mitsuba": mi.__version__,
                     "drjit": dr.__version__, "llvm": ".".join(map(str, llvm)) if llvm else None})
    return info


def summary(info: dict) -> str:
    """The machine in one line: processor, cores, Python, OS."""
    return f"{info['cpu']}, {info['cores']} cores, Python {info['python']}, {info['os']}"
