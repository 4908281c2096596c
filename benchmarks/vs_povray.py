"""whitted against POV-Ray 3.7 on Eric Haines' sphereflake, levels 1 to 5 (``make bench``).

What is compared: the same scene (sphereflake.py: the SPD's spheres, lights
and view, 512×512, depth 5, one ray per pixel) rendered by two whole programs,
each started as a user starts it:

* ``whitted render flakeL.scn -o X.png --min-weight 0 --stats S.json``
  (the exact ray tree: adaptive depth control off);
* ``povray +IflakeL.pov ... +WT<cores>`` on the same model written by
  povray.py (``max_trace_level 5``, ``adc_bailout 0``: no adaptive depth
  control either; no anti-aliasing).

Two times for each: the whole process (wall clock of the subprocess: start-up,
reading the scene, building the acceleration structure, rendering, writing the
PNG), and the render alone as each program reports it: whitted's ``--stats``
``seconds`` (kernel compilation excluded, reported beside it) and POV-Ray's
"Trace Time". Ratios are whitted / POV-Ray (below 1: whitted is faster). That
both trace the same tree is checked, not assumed: the table shows both
programs' shadow and reflected ray counts and the mean difference of their
8-bit images.

Each number is the median of a few runs, the two programs alternating; one
untimed run of each first fills the disk caches (Dr.Jit's kernel cache, the
page cache). The cost curve (time against sphere count, log-log) is drawn with
matplotlib.

Usage::

    python benchmarks/vs_povray.py [--quick] [--markdown benchmarks/RESULTS.md] [--plot PNG]

Options of run.py that ``make bench BENCHFLAGS=...`` passes along are ignored.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import parse_speed  # noqa: E402
import povray  # noqa: E402
import sections  # noqa: E402
import sphereflake  # noqa: E402

FULL = {"levels": (1, 2, 3, 4, 5), "runs": {1: 5, 2: 5, 3: 5, 4: 3, 5: 2},
        "parse_rounds": 3, "parse_level": 5, "parse_distinct": True}
QUICK = {"levels": (1, 2, 3), "runs": {1: 1, 2: 1, 3: 1}, "parse_rounds": 1, "parse_level": 4,
         "parse_distinct": False}


def whitted_command() -> list[str]:
    """The ``whitted`` command of this Python environment."""
    script = Path(sys.executable).parent / "whitted"
    return [str(script)] if script.exists() else [sys.executable, "-m", "whitted"]


@dataclass
class Row:
    level: int
    spheres: int
    whitted_wall: list = field(default_factory=list)
    whitted_render: list = field(default_factory=list)
    whitted_compile: list = field(default_factory=list)
    whitted_rays: dict = field(default_factory=dict)
    pov_wall: list = field(default_factory=list)
    pov_trace: list = field(default_factory=list)
    pov_rays: tuple = (0, 0)
    image_difference: float | None = None   # mean |whitted - POV-Ray|, 8-bit levels
    pov_missing: str = ""


def _median(values) -> float | None:
    return statistics.median(values) if values else None


def run_whitted(scene: Path, image: Path, stats: Path) -> tuple[float, dict]:
    command = whitted_command() + ["render", str(scene), "-o", str(image), "--min-weight", "0",
                                   "--stats", str(stats), "-q"]
    start = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"whitted failed on {scene}: {result.stderr.strip()[-300:]}")
    return wall, json.loads(stats.read_text())


def image_difference(a: Path, b: Path) -> float:
    """Mean absolute difference of two 8-bit images, in 8-bit levels."""
    import matplotlib.image
    x, y = (matplotlib.image.imread(str(p))[..., :3].astype(float) for p in (a, b))
    return float(abs(x - y).mean() * 255)


def bench_level(level: int, runs: int, folder: Path, pov_exe: str | None, pov_missing: str,
                threads: int, out) -> Row:
    model = sphereflake.scene(level)
    scn = sphereflake.write(level, folder / f"flake{level}.scn")
    pov = folder / f"flake{level}.pov"
    pov.write_text(povray.scene_to_pov(model))
    row = Row(level, len(model.spheres), pov_missing=pov_missing)
    w_image, p_image, stats = folder / f"whitted{level}.png", folder / f"povray{level}.png", folder / "stats.json"
    for _ in range(runs):
        wall, s = run_whitted(scn, w_image, stats)
        row.whitted_wall.append(wall)
        row.whitted_render.append(s["seconds"])
        row.whitted_compile.append(s["compile_seconds"])
        row.whitted_rays = s["rays"]
        if pov_exe:
            p = povray.run(pov_exe, pov, p_image, model.width, model.height, threads)
            row.pov_wall.append(p.wall_seconds)
            row.pov_trace.append(p.trace_seconds)
            row.pov_rays = (p.shadow_rays, p.reflected_rays)
    if pov_exe:
        row.image_difference = image_difference(w_image, p_image)
    print(f"level {level}: {row.spheres} spheres, whitted {_median(row.whitted_wall):.2f} s "
          f"(render {_median(row.whitted_render):.3f} s)"
          + (f", POV-Ray {_median(row.pov_wall):.2f} s (trace {_median(row.pov_trace):.3f} s)"
             if pov_exe else f", POV-Ray: {pov_missing}"), file=out, flush=True)
    return row


def _s(x: float | None) -> str:
    return "—" if x is None else f"{x:.3f}" if x < 10 else f"{x:.1f}"


def _ratio(a: float | None, b: float | None) -> str:
    return "—" if a is None or b is None else f"{a / b:.2f}"


COLUMNS = ["level", "spheres", "runs", "whitted process s", "POV-Ray process s", "process whitted / POV",
           "whitted render s", "POV-Ray trace s", "render whitted / POV", "whitted compile s",
           "shadow rays whitted / POV", "reflected rays whitted / POV", "image Δ (8-bit levels)"]


def table_rows(rows: list[Row]) -> list[list[str]]:
    out = []
    for r in rows:
        ww, pw = _median(r.whitted_wall), _median(r.pov_wall)
        wr, pt = _median(r.whitted_render), _median(r.pov_trace)
        shadow = f"{r.whitted_rays.get('shadow', 0)} / {r.pov_rays[0]}" if r.pov_wall else "—"
        reflected = f"{r.whitted_rays.get('reflection', 0)} / {r.pov_rays[1]}" if r.pov_wall else "—"
        out.append([str(r.level), str(r.spheres), str(len(r.whitted_wall)), _s(ww), _s(pw), _ratio(ww, pw),
                    _s(wr), _s(pt), _ratio(wr, pt), _s(_median(r.whitted_compile)), shadow, reflected,
                    "—" if r.image_difference is None else f"{r.image_difference:.2f}"])
    return out


def text_table(rows: list[Row]) -> str:
    cells = [COLUMNS] + table_rows(rows)
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths)) for row in cells)


def markdown_table(rows: list[Row]) -> str:
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in table_rows(rows)])


def plot(rows: list[Row], path: Path, title: str) -> None:
    """Time against sphere count, log-log: both programs, whole process and render."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    counts = [r.spheres for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=110)
    series = [("whitted, whole process", [_median(r.whitted_wall) for r in rows], "C0", "-"),
              ("whitted, render", [_median(r.whitted_render) for r in rows], "C0", "--"),
              ("POV-Ray 3.7, whole process", [_median(r.pov_wall) for r in rows], "C1", "-"),
              ("POV-Ray 3.7, trace", [_median(r.pov_trace) for r in rows], "C1", "--")]
    for label, values, color, style in series:
        points = [(c, v) for c, v in zip(counts, values) if v is not None]
        if points:
            ax.plot(*zip(*points), style, marker="o", color=color, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("spheres (sphereflake levels 1…5 and the floor)")
    ax.set_ylabel("seconds (median)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def machine() -> str:
    cpu = "unknown CPU"
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                   if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {len(os.sched_getaffinity(0))} cores, Python {platform.python_version()}, {platform.platform()}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="levels 1-3, one run each")
    parser.add_argument("--markdown", metavar="FILE",
                        help="record the run in FILE's 'sphereflake' section (benchmarks/RESULTS.md) "
                             "and draw the cost curve beside it")
    parser.add_argument("--plot", metavar="PNG", help="where to draw the cost curve "
                        "(default: cost_curve.png beside --markdown, else out/bench/cost_curve.png)")
    # `make bench BENCHFLAGS=...` passes run.py's options here too: those are not this script's.
    args, _ = parser.parse_known_args(argv)
    settings = QUICK if args.quick else FULL
    threads = len(os.sched_getaffinity(0))
    pov_exe, pov_missing = povray.find()
    load = os.getloadavg()[0]
    started = datetime.datetime.now(datetime.timezone.utc)
    print(f"whitted vs POV-Ray 3.7 on the sphereflake ({'quick' if args.quick else 'full'}): {machine()}; "
          f"POV-Ray: {pov_exe or pov_missing}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, open(os.devnull, "w") as quiet:
        folder = Path(tmp)
        # Warm-up: Dr.Jit's kernel cache, the page cache, POV-Ray's first start.
        bench_level(1, 1, folder, pov_exe, pov_missing, threads, quiet)
        rows = [bench_level(level, settings["runs"][level], folder, pov_exe, pov_missing, threads, sys.stdout)
                for level in settings["levels"]]
    print("\n== whitted vs POV-Ray 3.7, sphereflake 512×512, depth 5, 1 ray per pixel, adaptive depth off")
    print(text_table(rows))
    if not pov_exe:
        print(f"POV-Ray rows missing: {pov_missing}")

    print(f"\n== parsing the level-{settings['parse_level']} sphereflake (CPU seconds)")
    parse_rows = parse_speed.table(settings["parse_rounds"], settings["parse_level"], settings["parse_distinct"])
    print(parse_speed.markdown(parse_rows))
    seconds = time.perf_counter() - start
    load = max(load, os.getloadavg()[0])
    print(f"total {seconds:.0f} s; load average up to {load:.1f} on {threads} cores")

    plot_path = Path(args.plot) if args.plot else \
        (Path(args.markdown).parent / "cost_curve.png" if args.markdown else Path("out/bench/cost_curve.png"))
    plot(rows, plot_path, f"sphereflake 512×512, depth 5: whitted vs POV-Ray 3.7 ({threads} threads each)")
    print(f"cost curve: {plot_path}")

    if args.markdown:
        note = ("" if pov_exe else f"\n\nPOV-Ray rows missing: {pov_missing}.")
        body = f"""## whitted vs POV-Ray 3.7 on the sphereflake (benchmarks/vs_povray.py)

Measured {started:%Y-%m-%d %H:%M UTC} on {machine()}, {'quick' if args.quick else 'full'} mode, \
{seconds:.0f} s in all; the one-minute load average reached {load:.1f} on {threads} cores: other \
engineers were using the CPUs, so absolute times are high and noisy (to be re-run on a quiet machine).
Both programs render Eric Haines' sphereflake (benchmarks/sphereflake.py: the SPD's view, three lights,
mirror spheres with reflection 0.5 and a floor sphere) at 512×512, depth 5, one ray per pixel, with no
adaptive depth control (whitted `--min-weight 0`; POV-Ray `max_trace_level 5`, `adc_bailout 0`), each
with {threads} threads (Dr.Jit's pool; POV-Ray `+WT{threads}`). "Process" is the wall time of the whole
command (`whitted render flakeL.scn -o X.png --min-weight 0`, `povray +IflakeL.pov ...`); "render" is
whitted's `--stats` seconds (kernel compilation excluded, shown beside it) and POV-Ray's own Trace Time.
Medians of the runs shown, the two programs alternating, after one untimed run of each. Ratios are
whitted / POV-Ray (below 1: whitted is faster). The ray counts and the mean difference of the two 8-bit
images (in levels of 255) show that both trace the same tree.{note}

POV-Ray counts as "reflected" also the rays its last level spawns and then leaves
untraced (whitted at `--max-depth 6` counts 115 779 reflected rays on level 2, POV-Ray at
`max_trace_level 5` 115 780): its counts are whitted's one level deeper.

{markdown_table(rows)}

![time against sphere count, log-log](cost_curve.png)

Parsing the level-{settings['parse_level']} sphereflake (CPU seconds, median of \
{settings['parse_rounds']}; see the parse-speed section for the method):

{parse_speed.markdown(parse_rows)}

Reproduce: `make bench` (prints this table; `BENCHFLAGS=--quick` for levels 1-3), or
`.venv/bin/python benchmarks/vs_povray.py --markdown benchmarks/RESULTS.md` to rewrite this section.
"""
        sections.replace(args.markdown, "sphereflake", body)
        print(f"recorded in {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
