"""How long Mitsuba takes to build a scene of many spheres, by each way of handing it over.

Why: rendering a legacy ``.scn`` file goes scene model -> Mitsuba scene, and at
tens of thousands of spheres building the Mitsuba scene costs more than the
render. This script times every exact way the project could hand a scene over
(XML text or file vs ``mi.load_dict``, Mitsuba's parallel vs serial loading,
spheres by ``center``/``radius`` vs a ``to_world`` matrix, materials shared by
reference vs one per sphere, Mitsuba's ``optimize`` pass on or off), from the
same scene model, and checks that each builds the same scene (a render equal to
the XML path's, bit for bit). whitted.loading uses the fastest; the numbers are
in benchmarks/RESULTS.md, "Scene building" (this script rewrites its marked section
``scene-building``; the choice drawn from it, ``scene-building-choice``, is written by hand).

The scenes are random non-overlapping spheres (one per cell of a cubic grid,
jittered inside its cell) in a few shared materials, under one light, written
directly as a scene model.

Usage::

    .venv/bin/python -m benchmarks.studies.scene_building [--counts 1000 10000 66000] [--rounds 3]
        [--variant llvm_ad_rgb] [--markdown benchmarks/RESULTS.md]

Each time is the median of ``--rounds`` interleaved rounds (every method once
per round, in reverse order every other round) of the whole hand-over, Python
included, from the scene model to a ``mi.Scene``, each in a fresh process: its
CPU time (all threads of the process), which another job on a shared machine
barely changes, and its wall-clock time, the only one in which Mitsuba's
parallel loading could gain.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mitsuba as mi
import numpy as np

import whitted
import whitted.rendering
from whitted.converter import Light, Scene
from whitted.converter.description import describe
from whitted.converter.xml_writer import description_to_xml
from whitted.loading import mitsuba_dict

from .. import scenes, sections

REPO = Path(__file__).resolve().parents[2]

SECTION = "## Scene building"
#: this script's marked section of RESULTS.md (benchmarks/sections.py; run.py keeps it)
SECTION_NAME = "scene-building"


def random_spheres(count: int) -> Scene:
    """``count`` non-overlapping spheres in 8 shared materials (:func:`benchmarks.scenes.random_spheres`)
    seen from above one corner of their cube."""
    return Scene(width=64, height=48, eye=(16.0, 11.0, 20.0), lookat=(0.0, 0.0, 0.0), fov=50.0, depth=2,
                 lights=[Light((30.0, 40.0, 10.0))],
                 spheres=scenes.random_spheres(count, materials=8, reflect=0.3))


# -- the methods: scene model -> mi.Scene -------------------------------------------------------------

def _to_world(scene_dict: dict) -> dict:
    """Every untextured sphere given by a ``to_world`` matrix instead of ``center``/``radius``."""
    for value in scene_dict.values():
        if isinstance(value, dict) and value.get("type") == "sphere" and "center" in value:
            c, r = value.pop("center"), value.pop("radius")
            value["to_world"] = mi.ScalarTransform4d([[r, 0, 0, c[0]], [0, r, 0, c[1]], [0, 0, r, c[2]],
                                                      [0, 0, 0, 1]])
    return scene_dict


def _inline_materials(scene_dict: dict) -> dict:
    """Each sphere with its own copy of its material instead of a reference to a shared one."""
    for value in scene_dict.values():
        if isinstance(value, dict) and value.get("type") == "sphere":
            value["bsdf"] = dict(scene_dict[value["bsdf"]["id"]])
    return {k: v for k, v in scene_dict.items() if not k.startswith("material_")}


def methods(folder: Path) -> dict:
    """name -> (prepare, build): ``prepare(model)`` is the Python side (model -> what Mitsuba
    is handed), ``build(prepared)`` Mitsuba's; a method's time is their sum."""
    def xml_string(parallel):
        return (lambda model: description_to_xml(describe(model, None)),
                lambda text: mi.load_string(text, parallel=parallel))

    def xml_file(parallel):
        # The file exists when `whitted render x.xml` runs (write_xml): nothing to prepare.
        return (lambda model: str(folder / "scene.xml"),
                lambda path: mi.load_file(path, parallel=parallel))

    def as_dict(parallel, change=lambda d: d, optimize=True):
        return (lambda model: change(mitsuba_dict(describe(model, None))),
                lambda scene_dict: mi.load_dict(scene_dict, parallel=parallel, optimize=optimize))

    return {
        "XML text, load_string, parallel": xml_string(True),
        "XML text, load_string, serial": xml_string(False),
        "XML file, load_file, parallel (file written beforehand)": xml_file(True),
        "XML file, load_file, serial (file written beforehand)": xml_file(False),
        "dict, load_dict, parallel": as_dict(True),
        "dict, load_dict, serial": as_dict(False),
        "dict, serial, optimize=False": as_dict(False, optimize=False),
        "dict, serial, spheres by to_world": as_dict(False, _to_world),
        "dict, serial, one material per sphere": as_dict(False, _inline_materials),
    }


def load(name: str, model: Scene, folder: Path):
    prepare, build = methods(folder)[name]
    return build(prepare(model))


def write_xml(model: Scene, folder: Path) -> None:
    """The converted XML the "XML file" methods load."""
    (folder / "scene.xml").write_text(description_to_xml(describe(model, folder)), encoding="utf-8")


def python_parts(model: Scene) -> dict:
    """Seconds of the pure-Python steps: model -> description -> XML text or load_dict form."""
    times = {}
    start = time.perf_counter()
    description = describe(model, None)
    times["describe"] = time.perf_counter() - start
    start = time.perf_counter()
    description_to_xml(description)
    times["XML text"] = time.perf_counter() - start
    start = time.perf_counter()
    mitsuba_dict(description)
    times["load_dict form"] = time.perf_counter() - start
    return times


def image(scene) -> np.ndarray:
    return whitted.render(scene).image


def run_one(name: str, count: int, folder: Path) -> tuple[float, float, float]:
    """(wall, CPU, CPU of Mitsuba's part) seconds of one method building one scene, in this
    (fresh) process."""
    prepare, build = methods(folder)[name]
    # Load Mitsuba's plugins (a one-time cost the same for every method) before timing.
    warm_up = random_spheres(8)
    write_xml(warm_up, folder)
    build(prepare(warm_up))
    model = random_spheres(count)
    write_xml(model, folder)
    gc.collect()
    start, start_cpu = time.perf_counter(), time.process_time()
    prepared = prepare(model)
    mitsuba_cpu = time.process_time()
    build(prepared)
    end_cpu = time.process_time()
    return time.perf_counter() - start, end_cpu - start_cpu, end_cpu - mitsuba_cpu


def measure(counts, rounds: int, variant: str, folder: Path) -> tuple[dict, dict, dict, dict, dict]:
    """Each build in a fresh process, as `whitted render x.scn` does it: a process that has
    built and freed scenes before builds the next one up to twice as slowly (Dr.Jit's
    allocator and variable tables stay large), which would favour whichever method ran first."""
    names = list(methods(folder))
    seconds = {name: {} for name in names}
    cpu = {name: {} for name in names}
    mitsuba_cpu = {name: {} for name in names}
    exact, parts = {}, {}
    small = min(counts)
    model = random_spheres(small)
    write_xml(model, folder)
    expected = image(load("XML text, load_string, serial", model, folder))
    for name in names:
        exact[name] = bool(np.array_equal(image(load(name, model, folder)), expected))
    for count in counts:
        parts[count] = python_parts(random_spheres(count))
        runs = {name: [] for name in names}
        for r in range(rounds):
            for name in (names if r % 2 == 0 else names[::-1]):
                out = subprocess.run([sys.executable, "-m", "benchmarks.studies.scene_building", "--one", name, str(count),
                                      "--variant", variant], cwd=REPO, capture_output=True, text=True,
                                     check=True).stdout.split()
                runs[name].append(tuple(float(x) for x in out[-3:]))
            print(f"{count} spheres, round {r + 1}/{rounds}, CPU s: " +
                  ", ".join(f"{runs[n][-1][1]:.2f}" for n in names), file=sys.stderr, flush=True)
        for name in names:
            seconds[name][count] = statistics.median(run[0] for run in runs[name])
            cpu[name][count] = statistics.median(run[1] for run in runs[name])
            mitsuba_cpu[name][count] = statistics.median(run[2] for run in runs[name])
    return seconds, cpu, mitsuba_cpu, exact, parts


def _table(seconds: dict, exact: dict, counts) -> list[str]:
    big = max(counts)
    lines = ["| method | " + " | ".join(f"{c} spheres" for c in counts) + " | µs/sphere | exact |",
             "|---|" + "---|" * (len(counts) + 2)]
    for name, row in seconds.items():
        lines.append(f"| {name} | " + " | ".join(f"{row[c]:.3f}" for c in counts) +
                     f" | {row[big] / big * 1e6:.0f} | {'yes' if exact[name] else 'NO'} |")
    return lines


def markdown(seconds: dict, cpu: dict, mitsuba_cpu: dict, exact: dict, parts: dict, counts, rounds: int, variant: str,
             load: tuple, wall: float) -> str:
    small = min(counts)
    lines = [
        SECTION, "",
        f"Measured on {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC by "
        f"`python -m benchmarks.studies.scene_building --counts {' '.join(map(str, counts))} --rounds {rounds} "
        f"--variant {variant}` ({wall:.0f} s): {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Mitsuba {mi.__version__}, {variant}. The machine was shared with "
        f"other engineers' jobs (load average {load[0]:.1f} before, {load[1]:.1f} after, on 2 "
        f"cores): wall-clock times were inflated and noisy (this process got a fraction of the "
        f"CPUs), so compare CPU times; each is the median of {rounds} interleaved rounds.", "",
        "Scene model to `mi.Scene` for random non-overlapping spheres in 8 shared materials; "
        "\"exact\": a render equal bit for bit to the XML-text path's "
        f"(checked at {small} spheres); µs/sphere from the largest count.", "",
        "CPU seconds (all threads of the process), Python included:", "",
        *_table(cpu, exact, counts), "",
        "Of which Mitsuba's part (`load_string`, `load_file`, `load_dict` alone), CPU seconds:", "",
        *_table(mitsuba_cpu, exact, counts), "",
        "Wall-clock seconds (on the shared machine):", "",
        *_table(seconds, exact, counts),
    ]
    lines += ["", "Of which pure Python (no Mitsuba), seconds:", "",
              "| step | " + " | ".join(f"{c} spheres" for c in counts) + " |",
              "|---|" + "---|" * len(counts)]
    for step in parts[small]:
        lines.append(f"| {step} | " + " | ".join(f"{parts[c][step]:.3f}" for c in counts) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[1000, 10_000, 66_000])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--markdown", metavar="FILE", help="write the section into this Markdown file")
    parser.add_argument("--one", nargs=2, metavar=("METHOD", "COUNT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    whitted.set_variant(args.variant)
    if args.one:
        with tempfile.TemporaryDirectory() as folder, whitted.rendering.quiet_mitsuba():
            print(*run_one(args.one[0], int(args.one[1]), Path(folder)))
        return
    counts = sorted(args.counts)
    start, load_before = time.perf_counter(), os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as folder, whitted.rendering.quiet_mitsuba():
        seconds, cpu, mitsuba_cpu, exact, parts = measure(counts, args.rounds, args.variant, Path(folder))
    text = markdown(seconds, cpu, mitsuba_cpu, exact, parts, counts, args.rounds, args.variant,
                    (load_before, os.getloadavg()[0]), time.perf_counter() - start)
    print(text)
    if args.markdown:
        sections.replace(args.markdown, SECTION_NAME, text)


if __name__ == "__main__":
    main()
