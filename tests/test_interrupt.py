"""Ctrl-C and SIGTERM in a real process: one line, the shell's exit status, no traceback,
no partial output, and a prompt stop (within a few seconds of the signal).

Each command is started in a subprocess on a scene big enough that it is still
working when the signal arrives; the test checks that it was (otherwise it
proves nothing) and then what the user sees.
"""

from __future__ import annotations

import os
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
#: how long after the signal the process may take to stop (generous: the machine may be busy)
PATIENCE = 8.0
#: compare also writes what finished (CSV, plot, contact sheet) before it stops
COMPARE_PATIENCE = 30.0


def start(args, cwd):
    env = dict(os.environ)
    return subprocess.Popen([sys.executable, "-m", "whitted", *args], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def interrupt_after(process, seconds: float, number: int):
    time.sleep(seconds)
    assert process.poll() is None, "the command finished before the signal: make the scene slower"
    process.send_signal(number)
    sent = time.monotonic()
    out, err = process.communicate(timeout=60)
    return process.returncode, out, err, time.monotonic() - sent


@pytest.fixture()
def slow_scene(tmp_path):
    path = tmp_path / "slow.scn"
    path.write_text(SLOW_SCENE)
    return path


@pytest.mark.parametrize("integrator, number, delay", [
    ("whitted", signal.SIGINT, 4.0),
    ("whitted", signal.SIGTERM, 4.0),
    ("path", signal.SIGINT, 4.0),
    ("whitted", signal.SIGINT, 1.0),      # while importing and loading the scene
])
def test_render_stops_cleanly(slow_scene, tmp_path, integrator, number, delay):
    args = ["render", str(slow_scene), "-o", "out.png", "--integrator", integrator]
    if integrator == "path":
        args += ["--spp", "1024"]
    status, out, err, took = interrupt_after(start(args, tmp_path), delay, number)
    assert status == 128 + number
    assert err.strip().splitlines()[-1] == "whitted: interrupted"
    assert "Traceback" not in err and "Error" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.scn"]   # no image, no temp file
    assert took < PATIENCE


def test_compare_keeps_what_finished(slow_scene, tmp_path):
    scene = tmp_path / "small.scn"
    scene.write_text(SLOW_SCENE.replace("size 4096 3072", "size 32 24").replace("samples 64", "samples 1"))
    out = tmp_path / "cmp"
    process = start(["compare", str(scene), "--out", str(out), "--reference-spp", "16",
                     "--repeats", "30", "--depths", "1-8", "--spp", "1,4,16", "--path-spp", "1"], tmp_path)
    deadline = time.monotonic() + 120
    while not (out / "references").is_dir() or not any((out / "references").glob("*.exr")):
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline
        time.sleep(0.2)
    status, _, err, took = interrupt_after(process, 4.0, signal.SIGINT)
    assert status == 130 and "Traceback" not in err
    # One line says it all: the stop, and what was kept (the progress bar aside).
    assert [line for line in err.splitlines() if "interrupted" in line] == \
        [f"whitted: interrupted; the outputs in {out} hold what was done"]
    rows = (out / "results.csv").read_text().strip().splitlines()
    assert len(rows) >= 2                      # the header and at least one finished render
    assert not [p for p in Path(out).rglob(".*") if p.is_file()]   # no temporary files left
    assert took < COMPARE_PATIENCE
