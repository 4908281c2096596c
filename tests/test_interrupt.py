"""Ctrl-C and SIGTERM in a real process: one line, the shell's exit status, no traceback,
no partial output, and a prompt stop (a few CPU seconds of work after the signal).

Each command is started in a subprocess on a scene big enough that it is still
working when the signal arrives; the test checks that it was (otherwise it
proves nothing) and then what the user sees.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

#: glass and mirrors at a size that takes minutes to render on 2 cores
SLOW_SCENE = """size 4096 3072
samples 64
depth 12
light 5 5 10
light -5 3 8 0.5 0.5 0.5
sphere 0 0 0 1 refract 0.9 1.5
sphere 1.5 0 -1 0.8 reflect 0.8
sphere -1.5 0.2 -1 0.8 reflect 0.5 refract 0.4 1.3
sphere 0 -101 0 100 color 0.8 0.8 0.8
"""
#: how much work the process may do after the signal before it stops, in CPU seconds (all its
#: threads): a busy machine stretches the wall time a stop takes, not the work it needs
PATIENCE = 8.0
#: compare also writes what finished (CSV, plot, contact sheet) before it stops
COMPARE_PATIENCE = 30.0


def start(args, cwd):
    """The command, once it handles signals itself (:func:`handles_signals`): a signal that
    lands while Python itself is still starting is Python's to report, whatever the program."""
    env = dict(os.environ, PYTHONFAULTHANDLER="1")   # a hung child shows where (see stop)
    process = subprocess.Popen([sys.executable, "-m", "whitted", *args], cwd=cwd, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while not handles_signals(process.pid) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    return process


def handles_signals(pid: int) -> bool:
    """Whether process ``pid`` catches SIGTERM, as whitted's CLI does from its first step
    (``interrupt.install``; Python alone catches only SIGINT): read from /proc on Linux,
    assumed elsewhere."""
    try:
        with open(f"/proc/{pid}/status") as status:
            caught = next(int(line.split()[1], 16) for line in status if line.startswith("SigCgt:"))
    except (OSError, StopIteration):
        return True
    return bool(caught & (1 << (signal.SIGTERM - 1)))


def cpu_seconds(pid: int) -> float:
    """The CPU time process ``pid`` has used so far (user + system, all threads), from /proc."""
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Work:
    """The CPU seconds a child process spends from now until it is reaped: what it used in
    total (the reaped children's usage) less what it had used when this was made."""

    def __init__(self, process):
        self.before = cpu_seconds(process.pid)
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.reaped = usage.ru_utime + usage.ru_stime

    def after_exit(self) -> float:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime - self.reaped - self.before


#: CPU seconds (all threads) after which a render of SLOW_SCENE is well into rendering: Python,
#: Mitsuba and the scene take under one; CPU time, unlike the wall clock, a busy machine does not
#: stretch
RENDERING = 3.0


def interrupt_after(process, delay: float | str, number: int):
    """Send signal ``number`` ``delay`` seconds after the start, or (``"rendering"``) once the
    process has worked :data:`RENDERING` CPU seconds; (status, stdout, stderr, CPU seconds the
    stop took)."""
    if delay == "rendering":
        while process.poll() is None and cpu_seconds(process.pid) < RENDERING:
            time.sleep(0.02)
    else:
        time.sleep(delay)
    assert process.poll() is None, "the command finished before the signal: make the scene slower"
    work = Work(process)
    process.send_signal(number)
    out, err = process.communicate(timeout=120)
    return process.returncode, out, err, work.after_exit()


@pytest.fixture()
def slow_scene(tmp_path):
    path = tmp_path / "slow.scn"
    path.write_text(SLOW_SCENE)
    return path


def shell_status(returncode: int) -> int:
    """The status a shell reports (``$?``): 128 + N for a process killed by signal N."""
    return 128 - returncode if returncode < 0 else returncode


@pytest.mark.parametrize("integrator, number, delay", [
    ("whitted", signal.SIGINT, "rendering"),
    ("whitted", signal.SIGTERM, "rendering"),
    ("path", signal.SIGINT, "rendering"),
    ("whitted", signal.SIGINT, 1.0),      # while importing and loading the scene
    # during start-up: importing numpy, Mitsuba and Dr.Jit, setting the variant (a Ctrl-C
    # there used to be swallowed, or to abort the interpreter on its way out)
    *[("whitted", signal.SIGINT, delay) for delay in (0.2, 0.35, 0.5, 0.65, 0.8)],
])
def test_render_stops_cleanly(slow_scene, tmp_path, integrator, number, delay):
    args = ["render", str(slow_scene), "-o", "out.png", "--integrator", integrator]
    if integrator == "path":
        args += ["--spp", "1024"]
    status, out, err, took = interrupt_after(start(args, tmp_path), delay, number)
    # Python ends a process whose KeyboardInterrupt reached it from C++ by re-raising the
    # signal: the shell sees 130 all the same.
    assert shell_status(status) == 128 + number, err
    assert err.strip().splitlines()[-1] == "whitted: interrupted"
    assert "Traceback" not in err and "Error" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.scn"]   # no image, no temp file
    assert took < PATIENCE


class Lines:
    """A process's stderr read by a thread as it comes, so a test can wait for a line."""

    def __init__(self, stream):
        import threading
        self.lines: list[str] = []
        self.thread = threading.Thread(target=lambda: self.lines.extend(stream), daemon=True)
        self.thread.start()

    def text(self) -> str:
        self.thread.join(timeout=60)
        return "".join(self.lines)


def wait_for(process, condition, what: str, seconds: float = 180.0) -> None:
    """Poll ``condition`` (no fixed sleep: the machine may be busy) while the process runs."""
    deadline = time.monotonic() + seconds
    while not condition():
        assert process.poll() is None, f"the command ended before {what}"
        assert time.monotonic() < deadline, f"no {what} within {seconds:.0f} s"
        time.sleep(0.05)


def stop(process, err: Lines, seconds: float = 120.0):
    work = Work(process)
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGABRT)   # the faulthandler prints every thread's stack
        process.wait(timeout=30)
        pytest.fail(f"still running {seconds:.0f} s after SIGINT; its stderr:\n{err.text()[-6000:]}")
    return process.returncode, err.text(), work.after_exit()


@pytest.fixture()
def small_scene(tmp_path):
    scene = tmp_path / "small.scn"
    scene.write_text(SLOW_SCENE.replace("size 4096 3072", "size 32 24").replace("samples 64", "samples 1"))
    return scene


def test_compare_keeps_what_finished_and_says_it_is_partial(small_scene, tmp_path):
    import json

    out = tmp_path / "cmp"
    process = start(["compare", str(small_scene), "--out", str(out), "--cache", str(out / "references"), "--reference-spp", "16",
                     "--rounds", "30", "--depths", "1-8", "--spp", "1,4,16", "--path-spp", "1"], tmp_path)
    err = Lines(process.stderr)
    renders = out / "renders" / "small"
    # a render's files are written before it is counted: a fourth render's files mean that
    # three renders are counted, whenever the signal lands
    wait_for(process, lambda: len(list(renders.glob("*-flip.png"))) >= 4, "four renders")
    status, text, took = stop(process, err)
    assert status == 130 and "Traceback" not in text
    rows = (out / "results.csv").read_text().strip().splitlines()[1:]
    planned = 2 * 8 * 3 + 1
    assert 3 <= len(rows) < planned
    # One line says it all: the stop, and what was kept (the progress bar aside; the test's
    # own folder may say "interrupted").
    said = text.replace(str(tmp_path), "TMP")
    assert [line for line in said.splitlines() if "interrupted" in line] == [
        f"whitted: interrupted; the outputs in TMP/cmp hold what was done ({len(rows)} of {planned} "
        f"renders)"]
    marker = f"Interrupted after {len(rows)} of {planned} renders"
    assert (out / "summary.txt").read_text(encoding="utf-8").startswith(marker)
    findings = json.loads((out / "findings.json").read_text(encoding="utf-8"))
    assert findings["interrupted"]["renders_done"] == len(rows)
    assert findings["interrupted"]["renders_planned"] == planned
    page = (out / "report.html").read_text(encoding="utf-8")
    assert marker in page and page.index(marker) < page.index('<section class="scene"')
    assert "What the error is made of is not known here" in page  # stopped before the limits
    assert not [p for p in Path(out).rglob(".*") if p.is_file()]   # no temporary files left
    assert took < COMPARE_PATIENCE


def test_compare_interrupted_during_the_reference_says_nothing_was_measured(small_scene, tmp_path):
    import json

    out = tmp_path / "cmp"
    # a reference of 4M spp in chunks of 1024: minutes of work, interrupted in its first chunks
    process = start(["compare", str(small_scene), "--out", str(out), "--cache", str(out / "references"), "--reference-spp", str(1 << 22),
                     "--depths", "1", "--spp", "1", "--path-spp", "1"], tmp_path)
    err = Lines(process.stderr)
    wait_for(process, lambda: any("rendering the reference" in line for line in err.lines),
             "reference")
    status, text, took = stop(process, err)
    assert status == 130 and "Traceback" not in text
    said = text.replace(str(tmp_path), "TMP")  # the test's own folder may say "interrupted"
    assert [line for line in said.splitlines() if "interrupted" in line] == [
        "whitted: interrupted; the outputs in TMP/cmp say nothing was measured"]
    nothing = "Interrupted before any render was done: nothing was measured."
    assert (out / "summary.txt").read_text(encoding="utf-8").startswith(nothing)
    assert json.loads((out / "findings.json").read_text(encoding="utf-8"))["interrupted"]["text"] == nothing
    page = (out / "report.html").read_text(encoding="utf-8")
    assert nothing in page and "nothing was measured" in page
    assert (out / "results.csv").read_text().strip().splitlines() == [
        (out / "results.csv").read_text().splitlines()[0]]   # the header only
    references = out / "references"
    assert not references.exists() or not list(references.glob("*.exr"))  # no reference cached
    assert not [p for p in Path(out).rglob(".*") if p.is_file()]
    assert took < COMPARE_PATIENCE


def test_a_stop_inside_deferred_waits_for_its_end():
    """What must not be cut in half (importing Mitsuba, setting a variant) runs inside
    ``deferred``: a signal there is remembered and raised when the block ends."""
    from whitted import interrupt
    previous = signal.getsignal(signal.SIGINT)
    interrupt.install()
    try:
        steps = []
        with pytest.raises(KeyboardInterrupt):
            with interrupt.deferred():
                os.kill(os.getpid(), signal.SIGINT)
                for _ in range(1000):   # the handler runs between these bytecodes, and waits
                    pass
                steps.append("finished")
        assert steps == ["finished"] and interrupt.requested()
        with interrupt.deferred():      # raised once: writing what was done may follow
            steps.append("after")
        assert steps == ["finished", "after"]
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        interrupt._received = None   # the stop is handled: this process renders on


def test_a_stop_that_mitsuba_wraps_while_loading_stays_a_stop(monkeypatch):
    """Ctrl-C in a Python plugin's constructor comes back from Mitsuba's loader as a
    RuntimeError ("failed to instantiate ... Traceback"): it is raised as a stop, not
    reported as a scene that could not load (which would exit 2 instead of 130)."""
    from whitted import interrupt
    from whitted.errors import WhittedError
    from whitted.loading import load_error
    wrapped = RuntimeError('[parser.cpp:1718] At dictionary node "integrator": failed to '
                           'instantiate unknown plugin of type "whitted": Traceback ...')
    monkeypatch.setattr(interrupt, "_received", None)   # an earlier test's stop forgotten
    assert isinstance(load_error("frame003.scn", wrapped), WhittedError)   # no stop asked
    monkeypatch.setattr(interrupt, "_received", signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        load_error("frame003.scn", wrapped)


def test_a_stop_swallowed_where_it_landed_ends_the_next_render(monkeypatch):
    """Python ignores an exception raised in a ``__del__`` (tqdm's, when SIGINT lands there):
    the stop is remembered, and the next render raises it instead of starting."""
    import whitted
    from whitted import interrupt
    monkeypatch.setattr(interrupt, "_received", None)   # an earlier test's stop forgotten
    scene = whitted.loads("size 8 6\nlight 0 5 5\nsphere 0 0 0 1 color 1 0 0\n")
    assert whitted.render(scene).image.shape == (6, 8, 3)   # no stop asked
    monkeypatch.setattr(interrupt, "_received", signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        whitted.render(scene)


class StoppedInFinalizer:
    """An object whose ``__del__`` is where a Ctrl-C lands: it runs the installed handler there,
    as a tqdm bar's finalizer did in a Ctrl-C'd compare."""

    def __del__(self):
        from whitted import interrupt
        interrupt._handler(signal.SIGINT, sys._getframe())


@pytest.mark.parametrize("how", ["file", "probe"])
def test_a_stop_while_a_temporary_file_is_made_leaves_none_behind(monkeypatch, tmp_path, how):
    """A stop can land in ``tempfile.mkstemp`` once the file exists but before its name is
    returned (a loaded machine's slow file creation made that window wide enough to hit: a
    ``.NAME.XXXXXXXX.exr`` was left in compare's renders/). The stop still ends the work,
    and the folder holds no file."""
    import tempfile

    from whitted import interrupt
    from whitted.atomic import atomic_path, check_folder
    made = tempfile.mkstemp

    def interrupted_mkstemp(*args, **kwargs):
        made_now = made(*args, **kwargs)
        interrupt._handler(signal.SIGINT, None)   # what the installed handler does there
        return made_now
    monkeypatch.setattr(interrupt, "_received", None)
    monkeypatch.setattr(tempfile, "mkstemp", interrupted_mkstemp)
    with pytest.raises(KeyboardInterrupt):
        if how == "file":
            with atomic_path(tmp_path / "image.exr") as tmp:
                tmp.write_bytes(b"not reached")
        else:
            check_folder(tmp_path, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_stop_that_lands_in_a_finalizer_prints_no_traceback(monkeypatch):
    """Python prints an exception raised in a ``__del__`` ("Exception ignored in: <function
    tqdm.__del__ ...>", a traceback on stderr) and goes on: seen once in a Ctrl-C'd compare.
    A stop that lands there is not raised there; it ends the next unit of work instead."""
    import gc

    from whitted import interrupt
    ignored = []
    monkeypatch.setattr("sys.unraisablehook", ignored.append)
    monkeypatch.setattr(interrupt, "_received", None)

    StoppedInFinalizer()
    gc.collect()
    assert ignored == [] and interrupt.requested()
    with pytest.raises(KeyboardInterrupt):
        interrupt.check()


def test_a_stop_that_lands_in_a_weakref_callback_prints_no_traceback(monkeypatch, capsys):
    """A weakref's callback is a finalizer the handler cannot tell from other code: a stop
    raised there (in ``WeakSet._remove``, seen once in a Ctrl-C'd compare) would be printed as
    an ignored exception, a traceback on stderr. Installed, the CLI keeps it for the next
    unit of work instead, and prints nothing; any other error there is printed as before."""
    import weakref

    from whitted import interrupt
    monkeypatch.setattr("sys.unraisablehook", sys.__unraisablehook__)   # Python's own printer
    for name in ("_received", "_outcome"):
        monkeypatch.setattr(interrupt, name, None)   # (and back to None after the test)
    previous = signal.getsignal(signal.SIGINT)
    try:
        interrupt.install()

        class Watched:
            pass

        def fails(ref):
            raise ValueError("a callback's own error")
        watched = Watched()
        watcher = weakref.ref(watched, fails)
        del watched
        assert "ValueError: a callback's own error" in capsys.readouterr().err   # still printed
        watched = Watched()
        watcher = weakref.ref(watched, lambda ref: interrupt._handler(signal.SIGINT, sys._getframe()))
        del watched
        assert watcher() is None
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    assert capsys.readouterr().err == ""
    assert interrupt.requested()
    with pytest.raises(KeyboardInterrupt):
        interrupt.check()


def test_a_stop_swallowed_by_the_last_finalizer_still_exits_130(monkeypatch, capsys):
    """A command that finishes after a stop no check() saw (it landed in a ``__del__`` after the
    last unit of work) does not exit 0 as if nobody had pressed Ctrl-C."""
    from whitted import commands, interrupt
    from whitted.cli import main

    def finishes_after_a_swallowed_stop(args):
        StoppedInFinalizer()
        return 0
    monkeypatch.setattr(commands, "convert_command", finishes_after_a_swallowed_stop)
    for name in ("_received", "_outcome"):
        monkeypatch.setattr(interrupt, name, None)   # (and back to None after the test)
    previous = signal.getsignal(signal.SIGINT)
    try:
        assert main(["convert", "x.scn"]) == 130
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    assert capsys.readouterr().err == "whitted: interrupted\n"
