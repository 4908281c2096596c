"""One program run as a user runs it: its wall time, its own peak memory, a time limit.

Linux's ``ru_maxrss`` would carry over the high-water mark of the process that forked it,
so a small ``python -I -S`` wrapper (about 9 MiB) forks the program, kills it past its time
limit, reaps it with ``os.wait4`` and reports its exit status, peak memory and wall time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from whitted import interrupt


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


#: the wrapper: fork, exec the program, kill it after TIMEOUT seconds (0: never), wait for it,
#: write "status maxrss-KiB wall-seconds timed-out"
_WRAPPER = r"""
import os, signal, sys, time
report, timeout, argv, killed = sys.argv[1], float(sys.argv[2]), sys.argv[3:], []
start = time.perf_counter()
pid = os.fork()
if pid == 0:
    try:
        os.execvp(argv[0], argv)
    except BaseException as error:
        os.write(2, f"cannot run {argv[0]}: {error}\n".encode())
    os._exit(127)
signal.signal(signal.SIGALRM, lambda *_: killed.append(os.kill(pid, signal.SIGKILL)))
signal.setitimer(signal.ITIMER_REAL, timeout)
_, status, usage = os.wait4(pid, 0)
wall = time.perf_counter() - start
with open(report, "w") as f:
    f.write(f"{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss} {wall!r} {len(killed)}")
"""


def run(command: list, timeout: float | None = None, cwd=None, env=None) -> ProcessRun:
    """Run ``command`` to its end, or kill it after ``timeout`` seconds; its output is kept."""
    interrupt.check()   # a stop the handler could not raise (in a finalizer) ends the run here
    with tempfile.TemporaryDirectory() as folder:
        report = Path(folder) / "report"
        wrapper = subprocess.Popen([sys.executable, "-I", "-S", "-c", _WRAPPER, report, str(timeout or 0),
                                    *map(str, command)], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, cwd=cwd, env=env, start_new_session=True)
        try:
            out, err = wrapper.communicate()
        except BaseException:   # Ctrl-C: leave nothing running
            os.killpg(wrapper.pid, signal.SIGKILL)
            wrapper.wait()
            raise
        status, peak_kib, wall, killed = report.read_text().split()
    return ProcessRun(int(status), float(wall), int(peak_kib) * 1024, killed == "1", timeout,
                      out.decode(errors="replace"), err.decode(errors="replace"))


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
