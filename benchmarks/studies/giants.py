"""The cost of exact giant spheres (docs/numerics.md, hazard 14), measured by interleaved renders.

For each scene, one process renders the converted scene alternately with the
integrator's ``exact_spheres`` as the converter writes it and emptied (the
integrator then intersects every sphere through Mitsuba, as before giant
spheres were handled), pair by pair after two warm-up renders of each;
``result.seconds`` is the render alone (loading excluded). Scenes without
giant spheres have no ``exact_spheres``: their kernels are the ones the
integrator traced before (compare with another checkout's ``whitted render
--stats``, interleaved: ``--compare-with``).

    .venv/bin/python -m benchmarks.studies.giants [--rounds 7] [SCENE.scn ...]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mitsuba as mi

import whitted
from whitted.converter import parse_file
from whitted.converter.description import describe
from whitted.loading import mitsuba_dict

REPO = Path(__file__).resolve().parents[2]


def _scene(model, exact: bool):
    description = describe(model, base_dir=None)
    if not exact:
        description.scene["integrator"].pop("exact_spheres", None)
    return mi.load_dict(mitsuba_dict(description))


def exact_cost(path: Path, rounds: int) -> dict:
    """Median render seconds with and without exact giant spheres, and the median ratio."""
    model = parse_file(path)
    t = time.perf_counter()
    description = describe(model, base_dir=None)
    describe_s = time.perf_counter() - t
    if "exact_spheres" not in description.scene["integrator"]:
        return {"scene": path.name, "giants": 0}
    t = time.perf_counter()
    scenes = {True: _scene(model, True), False: _scene(model, False)}
    load_s = time.perf_counter() - t
    times = {True: [], False: []}
    for k in range(rounds + 2):
        for exact in (False, True):
            seconds = whitted.render(scenes[exact]).seconds
            if k >= 2:
                times[exact].append(seconds)
    ratios = [a / b for a, b in zip(times[True], times[False])]
    return {"scene": path.name, "giants": description.scene["integrator"]["exact_spheres"].count(":"),
            "before_s": statistics.median(times[False]), "exact_s": statistics.median(times[True]),
            "ratio": statistics.median(ratios), "describe_s": describe_s, "load_both_s": load_s}


def interleaved(scene: Path, other: Path, rounds: int) -> dict:
    """Median render seconds of ``whitted render --stats`` with this checkout's and
    ``other``'s whitted command, run alternately (separate processes)."""
    mine = Path(sys.executable).with_name("whitted")
    times = {"this": [], "other": []}
    with tempfile.TemporaryDirectory() as folder:
        for k in range(rounds + 1):
            for name, command in (("this", mine), ("other", other)):
                stats = Path(folder) / "stats.json"
                subprocess.run([str(command), "render", str(scene), "-o", str(Path(folder) / "out.exr"),
                                "-q", "--stats", str(stats)], check=True)
                if k >= 1:
                    times[name].append(json.loads(stats.read_text())["seconds"])
    ratios = [a / b for a, b in zip(times["this"], times["other"])]
    return {"scene": scene.name, "this_s": statistics.median(times["this"]),
            "other_s": statistics.median(times["other"]), "ratio": statistics.median(ratios)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", type=Path)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--compare-with", type=Path, help="another checkout's whitted command")
    args = parser.parse_args(argv)
    whitted.set_variant("llvm_ad_rgb")
    for path in args.scenes or sorted((REPO / "scenes").glob("*.scn")):
        if args.compare_with:
            print(json.dumps(interleaved(path, args.compare_with, args.rounds)), flush=True)
        else:
            print(json.dumps(exact_cost(path, args.rounds)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
