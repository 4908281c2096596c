"""whitted against POV-Ray 3.7 on Eric Haines' sphereflake, levels 1 to 6 (``make bench``).

Both whole programs render the same scene (sphereflake.py; povray.py writes POV-Ray's), each
started as a user starts it, with no adaptive depth control, on floor spheres of radius 10³
and 10⁴; Mitsuba's path tracer, and ``whitted convert`` against POV-Ray's Parse Time, run
beside them. The section written in benchmarks/RESULTS.md says what each column measures.
Options of run.py that ``make bench BENCHFLAGS=...`` passes along are ignored.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import parse_speed, povray, process, sections, sphereflake
from .machine import machine, summary
from .tables import MIB, markdown_table, mib, ratio, seconds, text_table


def _mib(x: float | None) -> str:
    return mib(x, decimals=0)


FLOORS = (1000.0, 10000.0)
FULL = {"levels": (1, 2, 3, 4, 5, 6), "floors": FLOORS, "runs": {1: 5, 2: 5, 3: 5, 4: 3, 5: 2, 6: 1},
        "read_levels": (5, 6), "read_runs": {5: 3, 6: 2}}
QUICK = {"levels": (1, 2, 3), "floors": FLOORS, "runs": {1: 1, 2: 1, 3: 1},
         "read_levels": (3,), "read_runs": {3: 1}}
#: seconds after which a run is killed and reported as not finished
TIMEOUT = 600.0
PROGRAMS = ("whitted", "povray", "path", "convert")


@dataclass
class Runs:
    """One program's runs at one level and floor; ``failure``: why they stopped ('not run')."""
    wall: list = field(default_factory=list)
    render: list = field(default_factory=list)     # whitted's --stats seconds, POV-Ray's Trace Time
    rss: list = field(default_factory=list)
    failure: str = ""
    failed_rss: int = 0         # bytes reached by a run that did not finish

    def add(self, wall: float, render: float, rss: int) -> None:
        self.wall.append(wall)
        self.render.append(render)
        self.rss.append(rss)

    def said(self, name: str, render: str) -> str:
        """The runs in a few words for the progress line."""
        if self.wall:
            return (f"{name} {_median(self.wall):.2f} s ({render} {_median(self.render):.3f} s, "
                    f"{_median(self.rss) / MIB:.0f} MiB)")
        return f"{name} not run" if self.failure == "not run" else f"{name}: —"

    def cells(self) -> tuple[str, str]:
        """The process cell and the peak-memory cell of a table."""
        if self.wall:
            return seconds(_median(self.wall)), _mib(_median(self.rss))
        short = "not run" if self.failure == "not run" else \
            self.failure if self.failure.startswith("did not finish") else "failed (see below)"
        return short, (f"≥ {self.failed_rss / MIB:.0f}" if self.failed_rss else "—")


@dataclass
class Row:
    level: int
    floor: float
    spheres: int
    runs: int = 0
    whitted: Runs = field(default_factory=Runs)
    pov: Runs = field(default_factory=Runs)
    path: Runs = field(default_factory=Runs)        # whitted render --integrator path --spp 1
    whitted_compile: list = field(default_factory=list)
    whitted_rays: dict = field(default_factory=dict)
    pov_parse: list = field(default_factory=list)
    pov_bounding: list = field(default_factory=list)
    pov_rays: tuple = (0, 0)
    image_difference: float | None = None   # mean |whitted - POV-Ray|, 8-bit levels
    scn: Path | None = None

    def failures(self, but=("not run",)) -> list[tuple[str, str]]:
        """(program, why) of each program that failed, but for the reasons ``but``."""
        programs = (("whitted", self.whitted), ("POV-Ray", self.pov), ("path", self.path))
        return [(who, runs.failure) for who, runs in programs if runs.failure not in ("", *but)]


@dataclass
class ReadRow:
    """Reading one level's scene: ``whitted convert`` against POV-Ray's Parse Time."""
    level: int
    spheres: int
    lines: int
    megabytes: float
    convert: Runs = field(default_factory=Runs)
    parse_cpu: float | None = None      # whitted's parse_text alone, CPU s, in this process
    pov: Row | None = None              # the render row whose POV-Ray runs give Parse Time


def _median(values) -> float | None:
    values = [v for v in values if not (isinstance(v, float) and math.isnan(v))]
    return statistics.median(values) if values else None


def _floor_name(radius: float) -> str:
    exponent = math.log10(radius)
    return f"10^{exponent:.0f}" if exponent == int(exponent) else f"{radius:g}"


def run_whitted(scene: Path, image: Path, stats: Path, timeout: float | None,
                path: bool = False) -> tuple[process.ProcessRun, dict]:
    """``whitted render`` of ``scene``: the Whitted integrator's exact tree, or (``path``)
    Mitsuba's path tracer at one sample per pixel."""
    options = ["--integrator", "path", "--spp", "1"] if path else ["--min-weight", "0"]
    stats.unlink(missing_ok=True)
    result = process.whitted("render", scene, "-o", image, *options, "--stats", stats, "-q",
                             timeout=timeout)
    process.succeeded(result, "whitted (path)" if path else "whitted", scene.name)
    return result, json.loads(stats.read_text())


def image_difference(a: Path, b: Path) -> float:
    """Mean absolute difference of two 8-bit images, in 8-bit levels."""
    import matplotlib.image
    x, y = (matplotlib.image.imread(str(p))[..., :3].astype(float) for p in (a, b))
    return float(abs(x - y).mean() * 255)


def _attempt(row: Row, program: str, run):
    """``run()`` unless ``program`` ("whitted", "path" or "pov") failed already on ``row``; None
    when it fails now, the failure (a timeout with its memory) recorded on the row."""
    runs = getattr(row, program)
    if runs.failure:
        return None
    try:
        return run()
    except process.DidNotFinish as error:
        runs.failure = error.run.failure()
        runs.failed_rss = error.run.peak_rss
    except RuntimeError as error:
        runs.failure = str(error)
    return None


def bench_level(level: int, floor: float, runs: int, folder: Path, pov_exe: str | None, pov_missing: str,
                threads: int, timeout: float | None = TIMEOUT, programs=PROGRAMS) -> Row:
    name = f"flake{level}-{floor:g}"
    model = sphereflake.scene(level, floor)
    scn = folder / f"{name}.scn"
    scn.write_text(sphereflake.to_scn(model, sphereflake.title(level, floor)))
    pov = folder / f"{name}.pov"
    pov.write_text(povray.scene_to_pov(model))
    width, height = model.width, model.height
    row = Row(level, floor, len(model.spheres), runs, scn=scn,
              whitted=Runs(failure="" if "whitted" in programs else "not run"),
              path=Runs(failure="" if "path" in programs else "not run"),
              pov=Runs(failure=("" if "povray" in programs else "not run") if pov_exe else pov_missing))
    del model   # level 6: some 600 MB of Python objects
    w_image, p_image, stats = folder / f"whitted-{name}.png", folder / f"povray-{name}.png", folder / "stats.json"
    run_w = lambda: run_whitted(scn, w_image, stats, timeout)   # noqa: E731
    run_p = lambda: povray.run(pov_exe, pov, p_image, width, height, threads, timeout)   # noqa: E731
    path_image = folder / f"path-{name}.png"
    run_path = lambda: run_whitted(scn, path_image, stats, timeout, path=True)   # noqa: E731
    # One untimed run of each first: the kernels a scene needs depend on its radii (one layer
    # each: plugins/hits.py), and Dr.Jit compiles them once, then reads its cache.
    _attempt(row, "whitted", run_w)
    _attempt(row, "pov", run_p)
    _attempt(row, "path", run_path)
    for _ in range(runs):
        done = _attempt(row, "whitted", run_w)
        if done is not None:
            result, stats_read = done
            row.whitted.add(result.wall_seconds, stats_read["seconds"], result.peak_rss)
            row.whitted_compile.append(stats_read["compile_seconds"])
            row.whitted_rays = stats_read["rays"]
        p = _attempt(row, "pov", run_p)
        if p is not None:
            row.pov.add(p.wall_seconds, p.trace_seconds, p.peak_rss)
            row.pov_parse.append(p.parse_seconds)
            row.pov_bounding.append(p.bounding_seconds)
            row.pov_rays = (p.shadow_rays, p.reflected_rays)
        done = _attempt(row, "path", run_path)
        if done is not None:
            row.path.add(done[0].wall_seconds, done[1]["seconds"], done[0].peak_rss)
    if row.whitted.wall and row.pov.wall and not (row.whitted.failure or row.pov.failure):
        row.image_difference = image_difference(w_image, p_image)
    path_text = f", {row.path.said('path', 'render')}" if row.path.wall else ""
    failures = "".join(f"; {who}: {why}" for who, why in row.failures())
    print(f"level {level}, floor {_floor_name(floor)}: {row.spheres} spheres, "
          f"{row.whitted.said('whitted', 'render')}, {row.pov.said('POV-Ray', 'trace')}{path_text}"
          f"{failures}", flush=True)
    return row


def bench_read(level: int, runs: int, rows: list[Row], folder: Path, timeout: float | None) -> ReadRow:
    """``whitted convert`` of the level's scene (floor 10³), beside POV-Ray's Parse Time of it."""
    render = next((r for r in rows if r.level == level and r.floor == sphereflake.FLOOR_RADIUS), None)
    scn = render.scn if render else sphereflake.write(level, folder / f"flake{level}-read.scn")
    text = scn.read_text()
    row = ReadRow(level, sphereflake.count(level) + 1, text.count("\n"), len(text.encode()) / 1e6, pov=render)
    for run in parse_speed.convert(scn, folder / f"flake{level}.xml", runs, timeout):
        if run.ok:
            row.convert.add(run.wall_seconds, None, run.peak_rss)
        else:
            row.convert.failure = run.failure() + (f": {run.stderr.strip()[-200:]}" if not run.timed_out else "")
    row.parse_cpu = parse_speed.cpu_seconds(text)
    del text
    pov = f", POV-Ray parse {_median(render.pov_parse):.2f} s" if render and render.pov_parse else ""
    convert = (f"whitted convert {_median(row.convert.wall):.2f} s ({_median(row.convert.rss) / MIB:.0f} MiB)"
               if row.convert.wall else f"whitted convert: {row.convert.failure}")
    print(f"reading level {level}: {convert}, parse_text {row.parse_cpu:.2f} s CPU{pov}", flush=True)
    return row


COLUMNS = ["level", "floor radius", "spheres", "runs", "whitted process s", "POV-Ray process s",
           "process whitted / POV", "whitted render s", "POV-Ray trace s", "render whitted / POV",
           "whitted peak RSS MiB", "POV-Ray peak RSS MiB", "RSS whitted / POV", "whitted compile s",
           "shadow rays whitted / POV", "reflected rays whitted / POV", "image Δ (8-bit levels)"]


def table_rows(rows: list[Row]) -> list[list[str]]:
    out = []
    for r in rows:
        ww, pw, wr, pt, wm, pm = (_median(v) for v in (r.whitted.wall, r.pov.wall, r.whitted.render,
                                                        r.pov.render, r.whitted.rss, r.pov.rss))
        both = r.whitted.wall and r.pov.wall
        shadow = f"{r.whitted_rays.get('shadow', 0)} / {r.pov_rays[0]}" if both else "—"
        reflected = f"{r.whitted_rays.get('reflection', 0)} / {r.pov_rays[1]}" if both else "—"
        (w_process, w_rss), (p_process, p_rss) = r.whitted.cells(), r.pov.cells()
        runs = {len(r.whitted.wall), len(r.pov.wall)} - {0}
        out.append([str(r.level), _floor_name(r.floor), str(r.spheres),
                    "/".join(str(n) for n in sorted(runs)) or "0", w_process, p_process, ratio(ww, pw),
                    seconds(wr), seconds(pt), ratio(wr, pt), w_rss, p_rss, ratio(wm, pm),
                    seconds(_median(r.whitted_compile)), shadow, reflected,
                    "—" if r.image_difference is None else f"{r.image_difference:.2f}"])
    return out


PATH_COLUMNS = ["level", "floor radius", "spheres", "runs", "whitted process s", "path process s",
                "process path / whitted", "path render s", "whitted peak RSS MiB", "path peak RSS MiB",
                "RSS path / whitted"]


def path_rows(rows: list[Row]) -> list[list[str]]:
    """The path tracer's runs (``--integrator path --spp 1``) beside the Whitted render's."""
    out = []
    for r in rows:
        if r.path.failure == "not run":
            continue
        ww, pw, wm, pm = (_median(v) for v in (r.whitted.wall, r.path.wall, r.whitted.rss, r.path.rss))
        (w_process, w_rss), (p_process, p_rss) = r.whitted.cells(), r.path.cells()
        out.append([str(r.level), _floor_name(r.floor), str(r.spheres), str(len(r.path.wall)), w_process,
                    p_process, ratio(pw, ww), seconds(_median(r.path.render)), w_rss, p_rss, ratio(pm, wm)])
    return out


READ_COLUMNS = ["level", "spheres", ".scn MB", "runs", "whitted convert process s", "convert peak RSS MiB",
                "POV-Ray Parse Time s", "convert / POV-Ray parse", "POV-Ray Bounding Time s",
                "POV-Ray process s", "whitted parse_text alone CPU s"]


def read_rows(rows: list[ReadRow]) -> list[list[str]]:
    out = []
    for r in rows:
        cw = _median(r.convert.wall)
        parse = _median(r.pov.pov_parse) if r.pov else None
        out.append([str(r.level), str(r.spheres), f"{r.megabytes:.1f}", str(len(r.convert.wall)),
                    *r.convert.cells(), seconds(parse), ratio(cw, parse),
                    seconds(_median(r.pov.pov_bounding)) if r.pov else "—",
                    seconds(_median(r.pov.pov.wall)) if r.pov else "—", seconds(r.parse_cpu)])
    return out


def failures(rows: list[Row], reads: list[ReadRow], pov_missing: str = "") -> list[str]:
    """One line per program that failed or did not finish, with why (POV-Ray's absence is said apart)."""
    lines = []
    for r in rows:
        lines += [f"level {r.level}, floor {_floor_name(r.floor)}: {who}: {why}"
                  for who, why in r.failures(but=("not run", pov_missing))]
    for r in reads:
        if r.convert.failure:
            lines.append(f"level {r.level}: whitted convert: {r.convert.failure}")
    return lines


def plot(rows: list[Row], path: Path, title: str) -> None:
    """Time against sphere count, log-log, one panel per floor: both programs, whole process and render."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    floors = sorted({r.floor for r in rows})
    fig, axes = plt.subplots(1, len(floors), figsize=(5.5 * len(floors), 4.5), dpi=110, sharey=True,
                             squeeze=False)
    for ax, floor in zip(axes[0], floors):
        these = [r for r in rows if r.floor == floor]
        counts = [r.spheres for r in these]
        series = [("whitted, whole process", [_median(r.whitted.wall) for r in these], "C0", "-"),
                  ("whitted, render", [_median(r.whitted.render) for r in these], "C0", "--"),
                  ("POV-Ray 3.7, whole process", [_median(r.pov.wall) for r in these], "C1", "-"),
                  ("POV-Ray 3.7, trace", [_median(r.pov.render) for r in these], "C1", "--")]
        for label, values, color, style in series:
            points = [(c, v) for c, v in zip(counts, values) if v is not None]
            if points:
                ax.plot(*zip(*points), style, marker="o", color=color, label=label)
        levels = sorted({r.level for r in these})
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"spheres (levels {levels[0]}…{levels[-1]} and the floor)")
        ax.set_title(f"floor sphere of radius ${_floor_name(floor).replace('^', '^{')}}}$"
                     if "^" in _floor_name(floor) else f"floor sphere of radius {floor:g}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    axes[0][0].set_ylabel("seconds (median)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def _runs_note(runs: dict[int, int], why: str = "") -> str:
    """How many runs each level's medians are of, e.g. 'medians of 5 runs (levels 1-3), 2 (level 5), ...'."""
    by_count: dict[int, list[int]] = {}
    for level, n in sorted(runs.items()):
        by_count.setdefault(n, []).append(level)
    if len(by_count) == 1:
        (n, _), = by_count.items()
        return f"{'one run' if n == 1 else f'medians of {n} runs'} per level and floor" + (f" ({why})" if why else "")
    parts = []
    for n, levels in sorted(by_count.items(), reverse=True):
        named = f"level{'s' if len(levels) > 1 else ''} {', '.join(map(str, levels))}"
        parts.append(f"{'one run only' if n == 1 else f'{n} runs'} at {named}"
                     + (" (for its size: each run takes minutes)" if n == 1 and 6 in levels else ""))
    return "medians of " + "; ".join(parts) + " per floor"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="levels 1-3 on both floors, one run each")
    parser.add_argument("--markdown", metavar="FILE",
                        help="record the run in FILE's 'sphereflake' section (benchmarks/RESULTS.md) "
                             "and draw the cost curve beside it")
    parser.add_argument("--plot", metavar="PNG", help="where to draw the cost curve "
                        "(default: cost_curve.png beside --markdown, else out/bench/cost_curve.png)")
    parser.add_argument("--levels", type=int, nargs="+", choices=list(sphereflake.LEVELS), metavar="L",
                        help="the levels to render (default: 1-6, --quick 1-3)")
    parser.add_argument("--floors", type=float, nargs="+", metavar="R",
                        help="the floor sphere's radii (default: 1000 10000)")
    parser.add_argument("--runs", type=int, metavar="N", help="runs of each level (default: 5 for small "
                        "levels down to 1 for level 6)")
    parser.add_argument("--read-levels", type=int, nargs="*", choices=list(sphereflake.LEVELS), metavar="L",
                        help="the levels whose reading is timed (default: 5 and 6, --quick 3)")
    parser.add_argument("--timeout", type=float, default=TIMEOUT, metavar="S",
                        help=f"kill a run after S seconds and say so (default {TIMEOUT:g})")
    parser.add_argument("--programs", nargs="+", choices=PROGRAMS, default=list(PROGRAMS),
                        help="what to run: whitted render, POV-Ray, whitted convert (default: all)")
    args, _ = parser.parse_known_args(argv)
    settings = dict(QUICK if args.quick else FULL)
    if args.levels:
        settings["levels"] = tuple(sorted(set(args.levels)))
        # by default, reading is timed where POV-Ray's runs give its Parse Time beside it
        settings["read_levels"] = tuple(level for level in settings["read_levels"] if level in settings["levels"])
    if args.floors:
        settings["floors"] = tuple(args.floors)
    if args.read_levels is not None:
        settings["read_levels"] = tuple(sorted(set(args.read_levels)))
    runs = {level: args.runs or settings["runs"].get(level, FULL["runs"][level]) for level in settings["levels"]}
    read_runs = {level: args.runs or settings["read_runs"].get(level, FULL["read_runs"].get(level, 3))
                 for level in settings["read_levels"]}
    if "convert" not in args.programs:
        settings["read_levels"] = ()
    timeout = args.timeout if args.timeout > 0 else None
    threads = len(os.sched_getaffinity(0))
    pov_exe, pov_missing = povray.find()
    load = os.getloadavg()[0]
    started = datetime.datetime.now(datetime.timezone.utc)
    mode = "quick" if args.quick else "full"
    print(f"whitted vs POV-Ray 3.7 on the sphereflake ({mode}): {summary(machine())}; "
          f"POV-Ray: {pov_exe or pov_missing}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = [bench_level(level, floor, runs[level], folder, pov_exe, pov_missing, threads, timeout,
                            args.programs)
                for level in settings["levels"] for floor in settings["floors"]]
        reads = [bench_read(level, read_runs[level], rows, folder, timeout)
                 for level in settings["read_levels"]]
    total = time.perf_counter() - start
    load = max(load, os.getloadavg()[0])
    runs_note = _runs_note(runs, "--quick" if args.quick else "")
    failed = failures(rows, reads, pov_missing)

    print(f"\n== whitted vs POV-Ray 3.7, sphereflake 512×512, depth 5, 1 ray per pixel, adaptive depth off; "
          f"{runs_note}; a run is killed after {timeout or math.inf:g} s")
    print(text_table(COLUMNS, table_rows(rows)))
    paths = path_rows(rows)
    if paths:
        print("\n== Mitsuba's path tracer on the same scene: `whitted render --integrator path --spp 1` beside "
              "the Whitted render (whole process, peak RSS)")
        print(text_table(PATH_COLUMNS, paths))
    if reads:
        print("\n== reading the scene: the whole `whitted convert` process vs POV-Ray's Parse Time (floor 10^3)")
        print(text_table(READ_COLUMNS, read_rows(reads)))
    if not pov_exe:
        print(f"POV-Ray rows missing: {pov_missing}")
    for line in failed:
        print(line)
    print(f"total {total:.0f} s; load average up to {load:.1f} on {threads} cores")

    plot_path = Path(args.plot) if args.plot else \
        (Path(args.markdown).parent / "cost_curve.png" if args.markdown else Path("out/bench/cost_curve.png"))
    plot(rows, plot_path, f"sphereflake 512×512, depth 5: whitted vs POV-Ray 3.7 ({threads} threads each)")
    print(f"cost curve: {plot_path}")

    if args.markdown:
        note = ("" if pov_exe else f"\n\nPOV-Ray rows missing: {pov_missing}.")
        if failed:
            note += "\n\nRuns that failed or did not finish:\n\n" + "\n".join(f"- {line}" for line in failed)
        levels = settings["levels"]
        path_section = "" if not paths else f"""
Mitsuba's path tracer on the same scenes: the whole `whitted render flakeL.scn -o X.png --integrator path
--spp 1` process beside the Whitted render's above (same runs, alternating), and its peak resident memory.
Its rays cost more (one sample of a path of up to 6 segments with a light sample at each, against the
Whitted tree's); the scene it loads is as compact as the Whitted integrator's (whitted/sealed.py: the sealed
spheres of the commonest radius and of the larger radii in one `ellipsoids` shape per radius and material).

{markdown_table(PATH_COLUMNS, paths)}
"""
        reading = "" if not reads else f"""
Reading the scene, side by side: the whole `whitted convert flakeL.scn -o flakeL.xml` process (Python's
start-up, parsing, writing the XML; wall time and peak resident memory, medians of the runs shown) against
POV-Ray's own Parse Time of the same scene (floor 10³) in its render runs above, with its Bounding Time
(building its hierarchy) and its whole render process beside it. The last column is whitted's parser alone
(`parse_text`, CPU seconds in the benchmark's own process): how much of the process is parsing.

{markdown_table(READ_COLUMNS, read_rows(reads))}
"""
        body = f"""## whitted vs POV-Ray 3.7 on the sphereflake (benchmarks/vs_povray.py)

Measured {started:%Y-%m-%d %H:%M UTC} on {summary(machine())}, {mode} mode, \
{total:.0f} s in all; the one-minute load average reached {load:.1f} on {threads} cores.
Both programs render Eric Haines' sphereflake (benchmarks/sphereflake.py: the SPD's view, three lights,
mirror spheres with reflection 0.5), levels {levels[0]} to {levels[-1]}, each on a floor sphere of radius
{" and ".join(_floor_name(f) for f in settings["floors"])} (its top at the same height), at 512×512, depth 5,
one ray per pixel, with no adaptive depth control (whitted `--min-weight 0`; POV-Ray `max_trace_level 5`,
`adc_bailout 0`), each with {threads} threads (Dr.Jit's pool; POV-Ray `+WT{threads}`). "Process" is the
wall time of the whole command (`whitted render flakeL.scn -o X.png --min-weight 0`, `povray +IflakeL.pov
...`) and "peak RSS" its own peak resident memory (benchmarks/process.py); "render" is whitted's `--stats`
seconds (kernel compilation excluded, shown beside it) and POV-Ray's own Trace Time. {runs_note[0].upper()}\
{runs_note[1:]}, the two programs alternating, after one untimed run of each; a run is killed after \
{timeout or math.inf:g} s and its cell says so. Ratios are whitted / POV-Ray (below 1: whitted is faster or smaller).
The ray counts and the mean difference of the two 8-bit images (in levels of 255) show that both trace the
same tree.{note}

POV-Ray counts as "reflected" also the rays its last level spawns and then leaves
untraced (whitted at `--max-depth 6` counts 115 779 reflected rays on level 2, POV-Ray at
`max_trace_level 5` 115 780): its counts are whitted's one level deeper.

{markdown_table(COLUMNS, table_rows(rows))}

![time against sphere count, log-log, one panel per floor](cost_curve.png)
{path_section}{reading}
Reproduce: `make bench` (prints these tables; `BENCHFLAGS=--quick` for levels 1-3), or
`.venv/bin/python -m benchmarks.vs_povray --markdown benchmarks/RESULTS.md` to rewrite this section.
"""
        sections.replace(args.markdown, "sphereflake", body)
        print(f"recorded in {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
