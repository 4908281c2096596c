"""benchmarks/ is a small library that its programs and the tests import as the package
``benchmarks``: no program changes ``sys.path`` or imports from tests/, and every program
(what ``make bench`` runs) starts as ``python -m benchmarks.NAME``."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import scenes

REPO = Path(__file__).resolve().parent.parent
SOURCES = sorted((REPO / "benchmarks").rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_path_hacks_and_nothing_from_tests(path):
    module = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(module):
        if isinstance(node, ast.Attribute) and node.attr == "path" and \
                isinstance(node.value, ast.Name) and node.value.id == "sys":
            pytest.fail(f"{path.name}:{node.lineno}: sys.path")
        if isinstance(node, ast.Import):
            modules = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            modules = [node.module or ""]
            if node.level == 0:   # nothing private of the package's (whitted's _parse and the like)
                assert not [a.name for a in node.names if a.name.startswith("_")], \
                    f"{path.name}:{node.lineno}: imports private names of {node.module}"
        else:
            continue
        assert not any(m.split(".")[0] in ("tests", "conftest", "reference") for m in modules), \
            f"{path.name}:{node.lineno}: imports {modules}"


@pytest.mark.parametrize("name", ["run", "vs_povray", "frames"])
def test_every_program_starts_as_a_module(name):
    done = subprocess.run([sys.executable, "-m", f"benchmarks.{name}", "--help"], cwd=REPO,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("usage:")


def test_random_spheres_do_not_overlap_and_stay_in_their_box():
    spheres = scenes.random_spheres(500, seed=3, low=(-5.0, 0.0, -6.0), high=(5.0, 5.0, 3.0))
    assert len(spheres) == 500
    for s in spheres:
        assert all(lo <= c - s.radius and c + s.radius <= hi
                   for c, lo, hi in zip(s.center, (-5.0, 0.0, -6.0), (5.0, 5.0, 3.0)))
    for a_index, a in enumerate(spheres):
        for b in spheres[a_index + 1:]:
            gap = sum((x - y) ** 2 for x, y in zip(a.center, b.center)) ** 0.5
            assert gap >= a.radius + b.radius
    shiny = scenes.random_spheres(200, reflect=0.3)
    assert len({s.material for s in shiny}) == 200
    assert all(0 <= s.material.reflect <= 0.3 for s in shiny) and max(s.material.reflect for s in shiny) > 0.2


@pytest.mark.parametrize("rounds", ["0", "-1"])
def test_parse_speed_refuses_no_rounds(rounds, capsys):
    """No rounds has no median: a usage error (it was a StatisticsError traceback)."""
    from benchmarks import parse_speed
    with pytest.raises(SystemExit) as stop:
        parse_speed.main(["--rounds", rounds, "--level", "0"])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(f"error: --rounds must be >= 1, got {rounds}")


@pytest.mark.parametrize("options, message", [
    (["--size", "0", "0"], "width must be in 1…16384 pixels, got 0"),
    (["--spp", "0"], "spp must be a positive integer up to 2^31, got 0"),
    (["--scene", "nope.scn"], "nope.scn: no such file"), (["--rounds", "0"], "--rounds must be >= 1, got 0")])
def test_gradients_says_what_is_wrong(options, message, capsys):
    """A size, spp or scene the render refuses was a traceback, no rounds a table of nothing
    measured: usage errors."""
    from benchmarks import gradients
    with pytest.raises(SystemExit) as stop:
        gradients.main(["--size", "8", "6", "--spp", "1", "--rounds", "1", *options])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(f"error: {message}")


@pytest.mark.parametrize("options, message", [
    (["--frames", "0"], "--frames must be >= 1, got 0"), (["--frames=-1"], "--frames must be >= 1, got -1"),
    (["--size", "0", "0"], "--size width must be in 1…16384 pixels, got 0"),
    (["--size", "160", "20000"], "--size height must be in 1…16384 pixels, got 20000"),
    (["--rounds", "0"], "--rounds must be >= 1, got 0")])
def test_frames_refuses_no_frames_rounds_or_pixels(options, message, monkeypatch, capsys):
    """--frames 0 ran 48 frames; --frames -1, --size 0 0 and --rounds 0 ended in a traceback
    after the run: usage errors, before any work."""
    from benchmarks import frames

    def started():
        raise AssertionError("the run started")
    monkeypatch.setattr(frames.povray, "find", started)
    with pytest.raises(SystemExit) as stop:
        frames.main(["--quick", *options])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(f"error: {message}")


def test_run_refuses_to_record_one_section(monkeypatch, capsys):
    """--markdown writes RESULTS.md whole, acceptance table first; with --only it was ignored
    after the section ran, with status 0: a usage error, before any work."""
    from benchmarks import run

    def started(*args):
        raise AssertionError("the run started")
    monkeypatch.setattr(run.whitted, "set_variant", started)
    with pytest.raises(SystemExit) as stop:
        run.main(["--quick", "--only", "effects", "--markdown", "RESULTS.md"])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(
        "error: --markdown records a whole run (the acceptance table and every section): not with --only")


@pytest.mark.parametrize("where, message", [
    ("missing/RESULTS.md", "output folder {tmp}/missing does not exist"),
    ("file/RESULTS.md", "output folder {tmp}/file is not a folder"), ("", "is a folder; give a file name"),
    ("/proc/RESULTS.md", "cannot write in /proc: it accepts no new files"),
    ("binary.md", "is not a text file (not UTF-8)")])
def test_run_checks_its_markdown_file_before_the_run(where, message, tmp_path, monkeypatch, capsys):
    """A --markdown file that could not be read or written ended the whole run in a traceback:
    a usage error naming it, before any work."""
    from benchmarks import run
    (tmp_path / "file").write_text("a file\n")
    (tmp_path / "binary.md").write_bytes(b"\x89PNG\r\n\x1a\n\xff")

    def started(*args):
        raise AssertionError("the run started")
    monkeypatch.setattr(run.whitted, "set_variant", started)
    with pytest.raises(SystemExit) as stop:
        run.main(["--quick", "--markdown", str(tmp_path / where)])
    assert stop.value.code == 2
    line = capsys.readouterr().err.splitlines()[-1]
    assert str(tmp_path / where) in line and line.endswith(message.format(tmp=tmp_path))


@pytest.mark.parametrize("name, options", [
    ("run", ["--quick"]), ("vs_povray", ["--quick", "--programs", "whitted"]),
    ("frames", ["--quick", "--frames", "24", "--rounds", "5"])])
def test_ctrl_c_ends_a_benchmark_in_one_line(name, options, tmp_path):
    """Ctrl-C printed a KeyboardInterrupt traceback: now one line and status 130, as whitted's
    own commands end (whitted/interrupt.py), and promptly: a stop the handler could not raise
    (in a finalizer) is raised before the next timed run. It is sent once the program has
    printed its first line, the run under way."""
    import select
    import signal
    command = [sys.executable, "-m", f"benchmarks.{name}", *options]
    if name == "vs_povray":
        command += ["--plot", str(tmp_path / "curve.png")]
    program = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert select.select([program.stdout], [], [], 300)[0], "no line in 300 s"
        assert program.stdout.readline()
        program.send_signal(signal.SIGINT)
        _, err = program.communicate(timeout=300)
    finally:
        if program.poll() is None:
            program.kill()
            program.wait()
    assert program.returncode == 130, err[-2000:]
    assert err.splitlines() == ["whitted: interrupted"]
    assert not (tmp_path / "curve.png").exists()
