"""whitted against POV-Ray 3.7 on Eric Haines' sphereflake, levels 1 to 6 (``make bench``).

Both whole programs render the same scene (sphereflake.py; povray.py writes POV-Ray's), each
started as a user starts it, with no adaptive depth control, on floor spheres of radius 10³
and 10⁴; Mitsuba's path tracer, and ``whitted convert`` against POV-Ray's Parse Time, run
beside them. vs_povray.md, the section written in benchmarks/RESULTS.md, says what each
column measures. Options of run.py that ``make bench BENCHFLAGS=...`` passes along are ignored.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from whitted.atomic import atomic_path, check_folder_creatable, check_writable
from whitted.compare.timing import median
from whitted.converter.scn_writer import scene_to_scn
from whitted.defaults import MAX_MAGNITUDE
from whitted.errors import WhittedError

from . import parse_speed, povray, process, run_main, sphereflake
from .report import MIB, Table, check_markdown, machine, mib, ratio, replace_section, seconds, summary

FLOORS = (1000.0, 10000.0)
#: runs of each level and of reading it (``--quick``: levels 1-3, reading level 3, one run each);
#: level 0, asked for by --levels only, runs as level 1
RUNS = {1: 5, 2: 5, 3: 5, 4: 3, 5: 2, 6: 1}
READ_RUNS = {5: 3, 6: 2}
#: seconds after which a run is killed and reported as not finished
TIMEOUT = 600.0
PROGRAMS = ("whitted", "povray", "path", "convert")
#: the prose of the section written in RESULTS.md, around the tables
NOTES = Path(__file__).with_name("vs_povray.md")


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

    def said(self, name: str, render: str = "") -> str:
        """The runs in a few words for the progress line (``render``: what their render time is)."""
        if not self.wall:
            return f"{name} not run" if self.failure == "not run" else f"{name}: —"
        inside = f"{render} {median(self.render):.3f} s, " if render else ""
        return f"{name} {median(self.wall):.2f} s ({inside}{median(self.rss) / MIB:.0f} MiB)"

    def cells(self) -> tuple[str, str]:
        """The process cell and the peak-memory cell of a table."""
        if self.wall:
            return seconds(median(self.wall)), mib(median(self.rss), 0)
        short = "not run" if self.failure == "not run" else \
            self.failure if self.failure.startswith("did not finish") else "failed (see below)"
        return short, (f"≥ {self.failed_rss / MIB:.0f}" if self.failed_rss else "—")


@dataclass
class Row:
    level: int
    floor: float
    spheres: int
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


@dataclass
class ReadRow:
    """Reading one level's scene: ``whitted convert`` against POV-Ray's Parse Time."""
    level: int
    spheres: int
    megabytes: float
    convert: Runs = field(default_factory=Runs)
    parse_cpu: float | None = None      # whitted's parse_text alone, CPU s, in this process
    pov: Row | None = None              # the render row whose POV-Ray runs give Parse Time


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
    scn.write_text(scene_to_scn(model, ".", sphereflake.title(level, floor)))
    pov = folder / f"{name}.pov"
    pov.write_text(povray.scene_to_pov(model))
    width, height = model.width, model.height
    row = Row(level, floor, len(model.spheres), scn=scn,
              whitted=Runs(failure="" if "whitted" in programs else "not run"),
              path=Runs(failure="" if "path" in programs else "not run"),
              pov=Runs(failure="not run" if "povray" not in programs else "" if pov_exe else pov_missing))
    del model   # level 6: some 600 MB of Python objects
    w_image, p_image, stats = folder / f"whitted-{name}.png", folder / f"povray-{name}.png", folder / "stats.json"
    run_w = lambda: run_whitted(scn, w_image, stats, timeout)   # noqa: E731
    run_p = lambda: povray.run(pov_exe, pov, p_image, width, height, threads, timeout)   # noqa: E731
    path_image = folder / f"path-{name}.png"
    run_path = lambda: run_whitted(scn, path_image, stats, timeout, path=True)   # noqa: E731
    # Round 0 is an untimed run of each: the kernels a scene needs depend on its radii (one
    # layer each: plugins/hits.py), and Dr.Jit compiles them once, then reads its cache.
    for timed in range(runs + 1):
        done = _attempt(row, "whitted", run_w)
        if timed and done is not None:
            result, stats_read = done
            row.whitted.add(result.wall_seconds, stats_read["seconds"], result.peak_rss)
            row.whitted_compile.append(stats_read["compile_seconds"])
            row.whitted_rays = stats_read["rays"]
        p = _attempt(row, "pov", run_p)
        if timed and p is not None:
            row.pov.add(p.wall_seconds, p.trace_seconds, p.peak_rss)
            row.pov_parse.append(p.parse_seconds)
            row.pov_bounding.append(p.bounding_seconds)
            row.pov_rays = (p.shadow_rays, p.reflected_rays)
        done = _attempt(row, "path", run_path)
        if timed and done is not None:
            row.path.add(done[0].wall_seconds, done[1]["seconds"], done[0].peak_rss)
    if row.whitted.wall and row.pov.wall and not (row.whitted.failure or row.pov.failure):
        row.image_difference = image_difference(w_image, p_image)
    path_text = f", {row.path.said('path', 'render')}" if row.path.wall else ""
    print(f"level {level}, floor {_floor_name(floor)}: {row.spheres} spheres, "
          f"{row.whitted.said('whitted', 'render')}, {row.pov.said('POV-Ray', 'trace')}{path_text}",
          *failures([row], [], pov_missing), sep="; ", flush=True)
    return row


def bench_read(level: int, runs: int, rows: list[Row], folder: Path, timeout: float | None) -> ReadRow:
    """``whitted convert`` of the level's scene (floor 10³), beside POV-Ray's Parse Time of it."""
    render = next((r for r in rows if r.level == level and r.floor == sphereflake.FLOOR_RADIUS), None)
    scn = render.scn if render else sphereflake.write(level, folder / f"flake{level}-read.scn")
    text = scn.read_text()
    row = ReadRow(level, sphereflake.count(level) + 1, len(text.encode()) / 1e6, pov=render)
    for _ in range(runs):
        run = process.whitted("convert", scn, "-o", folder / f"flake{level}.xml", timeout=timeout)
        if not run.ok:
            row.convert.failure = run.failure() + (f": {run.stderr.strip()[-200:]}" if not run.timed_out else "")
            break
        row.convert.add(run.wall_seconds, math.nan, run.peak_rss)
    row.parse_cpu = parse_speed.cpu_seconds(text)
    del text
    pov = f", POV-Ray parse {median(render.pov_parse):.2f} s" if render and render.pov_parse else ""
    print(f"reading level {level}: {row.convert.said('whitted convert')}, parse_text {row.parse_cpu:.2f} s CPU"
          f"{pov}", flush=True)
    return row


def render_table(rows: list[Row]) -> Table:
    table = Table("whitted vs POV-Ray 3.7, sphereflake 512×512, depth 5, 1 ray per pixel, adaptive depth off",
                  ["level", "floor radius", "spheres", "runs", "whitted process s", "POV-Ray process s",
                   "process whitted / POV", "whitted render s", "POV-Ray trace s", "render whitted / POV",
                   "whitted peak RSS MiB", "POV-Ray peak RSS MiB", "RSS whitted / POV", "whitted compile s",
                   "shadow rays whitted / POV", "reflected rays whitted / POV", "image Δ (8-bit levels)"])
    for r in rows:
        ww, pw, wr, pt, wm, pm = (median(v) for v in (r.whitted.wall, r.pov.wall, r.whitted.render,
                                                       r.pov.render, r.whitted.rss, r.pov.rss))
        both = r.whitted.wall and r.pov.wall
        shadow = f"{r.whitted_rays.get('shadow', 0)} / {r.pov_rays[0]}" if both else "—"
        reflected = f"{r.whitted_rays.get('reflection', 0)} / {r.pov_rays[1]}" if both else "—"
        (w_process, w_rss), (p_process, p_rss) = r.whitted.cells(), r.pov.cells()
        runs = {len(r.whitted.wall), len(r.pov.wall)} - {0}
        table.add(str(r.level), _floor_name(r.floor), str(r.spheres), "/".join(map(str, sorted(runs))) or "0",
                  w_process, p_process, ratio(ww, pw), seconds(wr), seconds(pt), ratio(wr, pt), w_rss, p_rss,
                  ratio(wm, pm), seconds(median(r.whitted_compile)), shadow, reflected,
                  "—" if r.image_difference is None else f"{r.image_difference:.2f}")
    return table


def path_table(rows: list[Row]) -> Table:
    """The path tracer's runs (``--integrator path --spp 1``) beside the Whitted render's."""
    table = Table("Mitsuba's path tracer on the same scene: `whitted render --integrator path --spp 1` "
                  "beside the Whitted render (whole process, peak RSS)",
                  ["level", "floor radius", "spheres", "runs", "whitted process s", "path process s",
                   "process path / whitted", "path render s", "whitted peak RSS MiB", "path peak RSS MiB",
                   "RSS path / whitted"])
    for r in rows:
        if r.path.failure == "not run":
            continue
        ww, pw, wm, pm = (median(v) for v in (r.whitted.wall, r.path.wall, r.whitted.rss, r.path.rss))
        (w_process, w_rss), (p_process, p_rss) = r.whitted.cells(), r.path.cells()
        table.add(str(r.level), _floor_name(r.floor), str(r.spheres), str(len(r.path.wall)), w_process,
                  p_process, ratio(pw, ww), seconds(median(r.path.render)), w_rss, p_rss, ratio(pm, wm))
    return table


def read_table(rows: list[ReadRow]) -> Table:
    table = Table("Reading the scene: the whole `whitted convert` process vs POV-Ray's Parse Time "
                  "(floor 10^3)",
                  ["level", "spheres", ".scn MB", "runs", "whitted convert process s", "convert peak RSS MiB",
                   "POV-Ray Parse Time s", "convert / POV-Ray parse", "POV-Ray Bounding Time s",
                   "POV-Ray process s", "whitted parse_text alone CPU s"])
    for r in rows:
        parse = median(r.pov.pov_parse) if r.pov else math.nan
        table.add(str(r.level), str(r.spheres), f"{r.megabytes:.1f}", str(len(r.convert.wall)),
                  *r.convert.cells(), seconds(parse), ratio(median(r.convert.wall), parse),
                  seconds(median(r.pov.pov_bounding) if r.pov else math.nan),
                  seconds(median(r.pov.pov.wall) if r.pov else math.nan), seconds(r.parse_cpu))
    return table


def failures(rows: list[Row], reads: list[ReadRow], pov_missing: str = "") -> list[str]:
    """One line per program that failed or did not finish, with why (POV-Ray's absence is said apart)."""
    lines = [f"level {r.level}, floor {_floor_name(r.floor)}: {who}: {runs.failure}"
             for r in rows for who, runs in (("whitted", r.whitted), ("POV-Ray", r.pov), ("path", r.path))
             if runs.failure not in ("", "not run", pov_missing)]
    return lines + [f"level {r.level}: whitted convert: {r.convert.failure}" for r in reads if r.convert.failure]


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
        for label, runs, color, style in [("whitted, whole process", "whitted.wall", "C0", "-"),
                                          ("whitted, render", "whitted.render", "C0", "--"),
                                          ("POV-Ray 3.7, whole process", "pov.wall", "C1", "-"),
                                          ("POV-Ray 3.7, trace", "pov.render", "C1", "--")]:
            program, kind = runs.split(".")
            points = [(r.spheres, median(getattr(getattr(r, program), kind))) for r in these]
            points = [(c, v) for c, v in points if math.isfinite(v)]
            if points:
                ax.plot(*zip(*points), style, marker="o", color=color, label=label)
        levels = sorted({r.level for r in these})
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"spheres (levels {levels[0]}…{levels[-1]} and the floor)")
        name = _floor_name(floor)
        ax.set_title(f"floor sphere of radius {'$' + name.replace('^', '^{') + '}$' if '^' in name else name}",
                     fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    axes[0][0].set_ylabel("seconds (median)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:   # whole or not at all
        fig.savefig(tmp, format=path.suffix[1:].lower())
    plt.close(fig)


def check_plot(path: Path) -> None:
    """Fail now (:class:`WhittedError`, naming ``path``) if :func:`plot` could not draw there
    after the run: a format matplotlib draws, and a folder that accepts it or can be made."""
    from matplotlib.backend_bases import FigureCanvasBase
    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix[1:].lower() not in formats:
        raise WhittedError(f"{path}: cannot draw the cost curve as {path.suffix or 'a file with no suffix'}; "
                           f"give a file name ending in .png, .svg or .pdf")
    if path.parent.exists():
        check_writable(path)
    else:
        check_folder_creatable(path.parent)


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
    parser.add_argument("--floors", type=float, nargs="+", default=FLOORS, metavar="R",
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
    if args.runs is not None and args.runs < 1:   # 0 ran the default counts
        parser.error(f"--runs must be >= 1, got {args.runs}")
    for radius in args.floors:
        if not 0 < radius <= float(MAX_MAGNITUDE) + sphereflake.FLOOR_HEIGHT:
            parser.error(f"--floors: a radius must be positive and at most {MAX_MAGNITUDE} - 0.5, "
                         f"got {radius:g}")
    plot_path = Path(args.plot) if args.plot else \
        (Path(args.markdown).parent / "cost_curve.png" if args.markdown else Path("out/bench/cost_curve.png"))
    try:   # before the run, not after it
        if args.markdown:
            check_markdown(args.markdown)
        check_plot(plot_path)
    except WhittedError as error:
        parser.error(str(error))
    levels = sorted(set(args.levels or ((1, 2, 3) if args.quick else RUNS)))
    # by default, reading is timed where POV-Ray's runs give its Parse Time beside it
    read_levels = sorted(set(args.read_levels if args.read_levels is not None else
                             [level for level in ((3,) if args.quick else READ_RUNS) if level in levels]))
    if "convert" not in args.programs:
        read_levels = []
    runs = {level: args.runs or (1 if args.quick else RUNS.get(level, RUNS[1])) for level in levels}
    read_runs = {level: args.runs or (1 if args.quick else READ_RUNS.get(level, 3)) for level in read_levels}
    timeout = args.timeout if args.timeout > 0 else None
    threads = len(os.sched_getaffinity(0))
    pov_exe, pov_missing = povray.find()
    load = os.getloadavg()[0]
    started = datetime.datetime.now(datetime.timezone.utc)
    mode = "quick" if args.quick else "full"
    measured_on = summary(machine())
    print(f"whitted vs POV-Ray 3.7 on the sphereflake ({mode}): {measured_on}; "
          f"POV-Ray: {pov_exe or pov_missing}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = [bench_level(level, floor, runs[level], folder, pov_exe, pov_missing, threads, timeout,
                            args.programs)
                for level in levels for floor in args.floors]
        reads = [bench_read(level, read_runs[level], rows, folder, timeout) for level in read_levels]
    total = time.perf_counter() - start
    load = max(load, os.getloadavg()[0])
    failed = failures(rows, reads, pov_missing)

    tables = [table for table in (render_table(rows), path_table(rows), read_table(reads)) if table.rows]
    for table in tables:
        print(table.text())
    failed += [] if pov_exe or "povray" not in args.programs else [f"POV-Ray rows missing: {pov_missing}"]
    for line in failed:
        print(line)
    print(f"total {total:.0f} s; load average up to {load:.1f} on {threads} cores")

    plot(rows, plot_path, f"sphereflake 512×512, depth 5: whitted vs POV-Ray 3.7 ({threads} threads each)")
    print(f"cost curve: {plot_path}")

    if args.markdown:
        body = NOTES.read_text().format(
            started=f"{started:%Y-%m-%d %H:%M UTC}", machine=measured_on, mode=mode, total=total,
            load=load, threads=threads, first=levels[0], last=levels[-1],
            floors=" and ".join(_floor_name(f) for f in args.floors), timeout=f"{timeout or math.inf:g}",
            failed="".join(f"\n- {line}" for line in failed) or " none.",
            tables="\n\n".join(table.markdown() for table in tables))
        replace_section(args.markdown, "sphereflake", body)
        print(f"recorded in {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main))
