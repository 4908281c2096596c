"""One program run as a user runs it: its wall time, its own peak memory, a time limit.

Linux's ``ru_maxrss`` would carry over the high-water mark of the process that forked it,
so a small ``python -I -S`` wrapper (about 9 MiB) forks the program, reaps it with
``os.wait4`` and reports its exit status, peak memory and wall time. A run past its time
limit is killed and reported as not finished, with the memory it had reached.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path


@dataclass
class ProcessRun:
    returncode: int          # negative: killed by that signal
    wall_seconds: float      # from start to exit, as the user waits for it
    peak_rss: int            # bytes: the process's own high-water mark of resident memory
    timed_out: bool          # killed after ``timeout`` seconds
    timeout: float | None
    stdout: str
    stderr: str

    @property
    def ok(self) -> bool:
        return self.returncode == 0 and not self.timed_out

    def failure(self) -> str:
        """Why the run failed, in a few words for a table ('' when it did not)."""
        if self.timed_out:
            return f"did not finish in {self.timeout:g} s"
        if self.returncode < 0:
            name = signal.Signals(-self.returncode).name if -self.returncode in signal.valid_signals() \
                else str(-self.returncode)
            return f"killed by {name}" + (" (out of memory?)" if name == "SIGKILL" else "")
        if self.returncode:
            return f"exit status {self.returncode}"
        return ""


class DidNotFinish(RuntimeError):
    """A program ran past its time limit and was killed."""

    def __init__(self, program: str, run: ProcessRun):
        super().__init__(f"{program} {run.failure()}")
        self.run = run


#: the wrapper: fork, exec the program, wait for it, write "status maxrss-KiB wall-seconds"
_WRAPPER = r"""
import os, signal, sys, time
report, argv, pid = sys.argv[1], sys.argv[2:], 0
def stop(*_):
    if pid > 0:
        os.kill(pid, signal.SIGKILL)
    else:
        os._exit(128 + signal.SIGTERM)
signal.signal(signal.SIGTERM, stop)
start = time.perf_counter()
pid = os.fork()
if pid == 0:
    try:
        os.execvp(argv[0], argv)
    except BaseException as error:
        os.write(2, f"cannot run {argv[0]}: {error}\n".encode())
    os._exit(127)
_, status, usage = os.wait4(pid, 0)
wall = time.perf_counter() - start
with open(report, "w") as f:
    f.write(f"{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss} {wall!r}\n")
"""

#: seconds a wrapper gets to report after its program is killed, before it is killed too
_GRACE = 30.0


def run(command: list, timeout: float | None = None, cwd=None, env=None) -> ProcessRun:
    """Run ``command`` to its end, or kill it after ``timeout`` seconds; its output is kept."""
    command = [str(c) for c in command]
    with tempfile.TemporaryDirectory() as folder, \
            open(Path(folder) / "out", "w+b") as out, open(Path(folder) / "err", "w+b") as err:
        report = Path(folder) / "report"
        start = time.perf_counter()
        wrapper = subprocess.Popen([sys.executable, "-I", "-S", "-c", _WRAPPER, str(report)] + command,
                                   stdin=subprocess.DEVNULL, stdout=out, stderr=err, cwd=cwd, env=env,
                                   start_new_session=True)
        timed_out = False
        try:
            try:
                wrapper.wait(timeout)
            except subprocess.TimeoutExpired:
                timed_out = True
                wrapper.terminate()     # the wrapper kills the program and reports
                wrapper.wait(_GRACE)
        except BaseException as error:  # no report in time, or Ctrl-C: leave nothing running
            os.killpg(wrapper.pid, signal.SIGKILL)
            wrapper.wait()
            if not isinstance(error, subprocess.TimeoutExpired):
                raise
        wall = time.perf_counter() - start
        returncode, peak_kib = wrapper.returncode, 0
        if report.exists():
            status, peak_kib, wall = report.read_text().split()
            returncode, peak_kib, wall = int(status), int(peak_kib), float(wall)
        output = [(Path(folder) / name).read_text(errors="replace") for name in ("out", "err")]
        return ProcessRun(returncode, wall, peak_kib * 1024, timed_out, timeout, *output)


def whitted(*args, timeout: float | None = None) -> ProcessRun:
    """``whitted ARGS``, this Python environment's, run by :func:`run`."""
    script = Path(sys.executable).parent / "whitted"
    command = [str(script)] if script.exists() else [sys.executable, "-m", "whitted"]
    return run(command + list(args), timeout)


def succeeded(result: ProcessRun, program: str, scene: str) -> ProcessRun:
    """``result``, or its failure raised: :class:`DidNotFinish` past its time limit, else RuntimeError."""
    if result.timed_out:
        raise DidNotFinish(program, result)
    if not result.ok:
        raise RuntimeError(f"{program} failed ({result.failure()}) on {scene}: {result.stderr.strip()[-300:]}")
    return result
