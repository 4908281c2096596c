"""The POV-Ray 3.7 scene writer of the benchmarks (benchmarks/povray.py), and what the
side-by-side benchmark measures (benchmarks/process.py, benchmarks/vs_povray.py).

The writer must make POV-Ray trace and shade what whitted does, or the
side-by-side benchmark compares different work. Where POV-Ray is installed,
the two programs render the same small scene and their images must agree;
elsewhere the written scene is checked against the mapping it promises.
A program's peak memory must be its own (not the benchmark's), a run past its
time limit must be killed and said, and the table must say so.
"""

from __future__ import annotations

import re
import shutil
import sys
from dataclasses import replace

import numpy as np
import pytest

from benchmarks import povray, process, sphereflake, vs_povray
from benchmarks.vs_povray import Runs
from whitted.converter.scene import Light, Material, Scene, Sphere
from whitted.converter.scn_writer import scene_to_scn




def test_finish_carries_the_articles_weights():
    scene = Scene(ambient=0.25, depth=7, lights=[Light((1, 2, 3), (0.5, 0.5, 0.5))],
                  spheres=[Sphere((0, 0, 0), 1, Material((1, 0.5, 0), reflect=0.4))])
    pov = povray.scene_to_pov(scene)
    # local = (1 - KR) (A + (1 - A) ...): ambient 0.6 * 0.25, diffuse 0.6 * 0.75; KR untinted
    finish = re.search(r"finish \{ ambient ([\d.]+) diffuse ([\d.]+) reflection \{ ([\d.]+) \}", pov)
    assert [float(x) for x in finish.groups()] == pytest.approx([0.15, 0.45, 0.4])
    assert "max_trace_level 7" in pov and "adc_bailout 0" in pov and "ambient_light rgb 1" in pov
    assert "light_source { <1.0, 2.0, 3.0> color rgb <0.5, 0.5, 0.5> }" in pov
    assert "fade" not in pov and "area_light" not in pov  # no fall-off, hard shadows
    assert "right -x*640/400" in pov and "angle 45.0" in pov


@pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is not installed")
def test_povray_renders_the_image_whitted_renders(tmp_path):
    import mitsuba as mi
    import whitted
    whitted.set_variant("llvm_ad_rgb")
    exe, why = povray.find()
    assert exe, why
    model = replace(sphereflake.scene(1), width=64, height=48)
    scn = tmp_path / "flake.scn"
    scn.write_text(scene_to_scn(model, "."))
    (tmp_path / "flake.pov").write_text(povray.scene_to_pov(model))
    run = povray.run(exe, tmp_path / "flake.pov", tmp_path / "pov.png", 64, 48, threads=1)
    assert run.trace_seconds >= 0 and run.wall_seconds > 0 and run.reflected_rays > 0

    result = whitted.render(whitted.load_scene(scn), min_weight=0)
    whitted.write_image(tmp_path / "whitted.png", result.image)
    ours = np.array(mi.Bitmap(str(tmp_path / "whitted.png")), dtype=float)[..., :3]
    theirs = np.array(mi.Bitmap(str(tmp_path / "pov.png")), dtype=float)[..., :3]
    assert ours.shape == theirs.shape == (48, 64, 3)
    difference = np.abs(ours - theirs)
    assert difference.mean() < 1.0                       # levels of 255
    assert (difference.max(axis=-1) <= 2).mean() > 0.97  # all but a few edge pixels
    assert run.shadow_rays == result.stats["rays"]["shadow"]




def test_a_programs_peak_memory_is_its_own_not_the_benchmarks():
    # this process holds 300 MiB more than the program it starts: the program must not inherit it
    ballast = np.ones(300 * 2 ** 20 // 8)
    small = process.run([sys.executable, "-I", "-S", "-c", "print('small')"])
    big = process.run([sys.executable, "-I", "-S", "-c",
                       "x = bytearray(200 * 2 ** 20); x[::4096] = b'1' * len(x[::4096])"])
    del ballast
    assert small.ok and small.stdout == "small\n" and small.wall_seconds > 0
    assert small.peak_rss < 60 * 2 ** 20
    assert 200 * 2 ** 20 < big.peak_rss < 260 * 2 ** 20


def test_a_run_past_its_time_limit_is_killed_and_said():
    run = process.run(["sleep", "30"], timeout=0.5)
    assert run.timed_out and not run.ok and run.wall_seconds < 10
    assert run.failure() == "did not finish in 0.5 s"
    assert process.run(["sh", "-c", "exit 3"]).failure() == "exit status 3"


@pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is not installed")
def test_povray_reports_parse_time_and_memory_and_keeps_to_its_limit(tmp_path):
    exe, why = povray.find()
    assert exe, why
    model = replace(sphereflake.scene(2, floor_radius=1e4), width=32, height=32)
    (tmp_path / "flake.pov").write_text(povray.scene_to_pov(model))
    run = povray.run(exe, tmp_path / "flake.pov", tmp_path / "pov.png", 32, 32, threads=1)
    assert run.parse_seconds >= 0 and run.bounding_seconds >= 0 and 5 * 2 ** 20 < run.peak_rss < 2 ** 30
    with pytest.raises(process.DidNotFinish, match="did not finish in 0.01 s"):
        povray.run(exe, tmp_path / "flake.pov", tmp_path / "pov.png", 32, 32, threads=1, timeout=0.01)


def test_benchmark_table_has_both_floors_memory_and_says_what_did_not_finish():
    pov = Runs([8.0], [1.8], [610 * 2 ** 20])
    done = vs_povray.Row(6, 1e3, 597872, whitted=Runs([90.0], [2.0], [11 * 2 ** 30]),
                         whitted_compile=[0.0], whitted_rays={"shadow": 10, "reflection": 4}, pov=pov,
                         pov_parse=[2.5], pov_bounding=[2.5], pov_rays=(10, 5), image_difference=0.3)
    late = vs_povray.Row(6, 1e4, 597872, pov=pov,
                         whitted=Runs(failure="did not finish in 600 s", failed_rss=9 * 2 ** 30))
    table = vs_povray.render_table([done, late])
    cells = [dict(zip(table.columns, row)) for row in table.rows]
    assert [c["floor radius"] for c in cells] == ["10^3", "10^4"]
    assert cells[0]["whitted peak RSS MiB"] == "11264" and cells[0]["POV-Ray peak RSS MiB"] == "610"
    assert cells[0]["process whitted / POV"] == "11.25" and cells[0]["image Δ (8-bit levels)"] == "0.30"
    assert cells[1]["whitted process s"] == "did not finish in 600 s"
    assert cells[1]["whitted peak RSS MiB"] == "≥ 9216" and cells[1]["process whitted / POV"] == "—"
    assert vs_povray.failures([done, late], []) == ["level 6, floor 10^4: whitted: did not finish in 600 s"]

    read = vs_povray.ReadRow(6, 597872, 69.7, convert=Runs([2.0], rss=[400 * 2 ** 20]),
                             parse_cpu=1.5, pov=done)
    table = vs_povray.read_table([read])
    cell = dict(zip(table.columns, table.rows[0]))
    assert cell["whitted convert process s"] == "2.000" and cell["POV-Ray Parse Time s"] == "2.500"
    assert cell["convert / POV-Ray parse"] == "0.80" and cell["convert peak RSS MiB"] == "400"


def test_path_tracer_rows_stand_beside_the_whitted_render():
    whitted = Runs([5.0], rss=[500 * 2 ** 20])
    done = vs_povray.Row(6, 1e3, 597872, whitted=whitted, path=Runs([12.5], [6.0], [600 * 2 ** 20]))
    late = vs_povray.Row(6, 1e4, 597872, whitted=whitted,
                         path=Runs(failure="did not finish in 600 s", failed_rss=3 * 2 ** 30))
    left_out = vs_povray.Row(5, 1e3, 66431, whitted=Runs([3.0]), path=Runs(failure="not run"))
    table = vs_povray.path_table([done, late, left_out])
    cells = [dict(zip(table.columns, row)) for row in table.rows]
    assert len(cells) == 2
    assert cells[0]["process path / whitted"] == "2.50" and cells[0]["RSS path / whitted"] == "1.20"
    assert cells[0]["path render s"] == "6.000" and cells[0]["path peak RSS MiB"] == "600"
    assert cells[1]["path process s"] == "did not finish in 600 s" and cells[1]["path peak RSS MiB"] == "≥ 3072"
    assert cells[1]["process path / whitted"] == "—"
    assert vs_povray.failures([done, late], []) == ["level 6, floor 10^4: path: did not finish in 600 s"]


def test_level_zero_is_a_level_the_command_runs(tmp_path, capsys, monkeypatch):
    """``--levels`` offers level 0 (one sphere on the floor); its runs are level 1's. POV-Ray,
    not asked for, is "not run", not failed, whether it is installed or not."""
    monkeypatch.setattr(povray, "find", lambda: (None, "POV-Ray is not installed"))
    assert vs_povray.main(["--levels", "0", "--programs", "convert",
                           "--plot", str(tmp_path / "new" / "curve.png")]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines()]
    assert [row[:3] for row in rows if row[:1] == ["0"]] == [["0", "10^3", "2"], ["0", "10^4", "2"]]
    assert "failed" not in out and "POV-Ray rows missing" not in out
    assert (tmp_path / "new" / "curve.png").is_file()   # (its folder made)


@pytest.mark.parametrize("options, message", [
    (["--runs", "0"], "--runs must be >= 1, got 0"), (["--runs=-2"], "--runs must be >= 1, got -2"),
    (["--floors", "1000", "0"], "--floors: a radius must be positive and at most 1e12 - 0.5, got 0"),
    (["--floors", "nan"], "got nan"), (["--floors", "1e300"], "got 1e+300")])
def test_a_bad_run_count_or_floor_is_a_usage_error(options, message, tmp_path, capsys):
    """--runs 0 ran the default counts and a negative count no run; a floor radius of 0 or NaN
    was a ValueError traceback, and one the scene format cannot hold made a failed conversion."""
    with pytest.raises(SystemExit) as stop:
        vs_povray.main(["--levels", "1", "--programs", "convert", *options,
                        "--plot", str(tmp_path / "curve.png")])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(message)
    assert not (tmp_path / "curve.png").exists()


@pytest.mark.parametrize("options, message", [
    (["--markdown", "{tmp}/missing/RESULTS.md"], "output folder {tmp}/missing does not exist"),
    (["--markdown", "{tmp}/binary.md"], "{tmp}/binary.md: is not a text file (not UTF-8)"),
    (["--markdown", "/proc/RESULTS.md"], "/proc/RESULTS.md: cannot write in /proc: it accepts no new files"),
    (["--plot", "{tmp}/file/curve.png"], "{tmp}/file/curve.png: output folder {tmp}/file is not a folder"),
    (["--plot", "{tmp}/file/more/curve.png"], "cannot create a folder under the file {tmp}/file"),
    (["--plot", "/proc/curve.png"], "/proc/curve.png: cannot write in /proc: it accepts no new files"),
    (["--plot", "{tmp}/curve.txt"], "cannot draw the cost curve as .txt; give a file name ending in .png, .svg "
                                    "or .pdf"),
    (["--plot", "{tmp}"], "cannot draw the cost curve as a file with no suffix; give a file name ending in "
                          ".png, .svg or .pdf")])
def test_a_bad_markdown_or_plot_path_is_a_usage_error_before_the_run(options, message, tmp_path, monkeypatch,
                                                                       capsys):
    """A --markdown or --plot path that could not be written (or, for --markdown, read) ended the
    whole run in a traceback, or its folder was made by the plot: a usage error naming it, before
    any work. A missing folder for --plot is made, as for its default, out/bench/."""
    (tmp_path / "file").write_text("a file\n")
    (tmp_path / "binary.md").write_bytes(b"\x89PNG\r\n\x1a\n\xff")

    def started(*args, **kwargs):
        raise AssertionError("the run started")
    monkeypatch.setattr(vs_povray, "bench_level", started)
    monkeypatch.setattr(vs_povray.povray, "find", started)
    with pytest.raises(SystemExit) as stop:
        vs_povray.main(["--levels", "1", "--programs", "convert",
                        *(option.format(tmp=tmp_path) for option in options)])
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(message.format(tmp=tmp_path))
    assert not (tmp_path / "missing").exists()
