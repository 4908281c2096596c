"""How fast the converter reads a big scene: the level-5 sphereflake (66 431 spheres), and as
many spheres each with attributes of its own, in CPU seconds of ``parse_text`` (median of
``--rounds``). ``--convert`` also times the whole ``whitted convert`` process, wall time and
peak memory, as vs_povray.py does beside POV-Ray's Parse Time.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from whitted.converter import Light, Scene, parse_text

from . import process, scenes, sphereflake


def cpu_seconds(text: str) -> float:
    """CPU seconds of :func:`whitted.converter.parse_text` on ``text``."""
    start = time.process_time()
    parse_text(text, "bench.scn")
    return time.process_time() - start


def convert(scn: Path, xml: Path, runs: int = 1, timeout: float | None = None) -> list[process.ProcessRun]:
    """``runs`` runs of the whole ``whitted convert scn -o xml`` process (wall time, peak memory);
    the first that fails or runs past ``timeout`` seconds ends the list."""
    done = []
    for _ in range(runs):
        run = process.whitted("convert", scn, "-o", xml, timeout=timeout)
        done.append(run)
        if not run.ok:
            break
    return done


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--level", type=int, default=5, choices=list(sphereflake.LEVELS))
    parser.add_argument("--convert", action="store_true",
                        help="also time the whole `whitted convert` process on the level's scene")
    args = parser.parse_args(argv)
    flake = scenes.to_scn(sphereflake.scene(args.level))
    distinct = scenes.to_scn(Scene(width=64, height=64, lights=[Light((1.0, 2.0, 3.0))],
                                   spheres=scenes.random_spheres(66_000, reflect=0.5)))
    print("| file | lines | parse_text CPU s | µs/line |\n|---|---|---|---|")
    for name, text in [(f"sphereflake level {args.level} ({sphereflake.count(args.level) + 1} spheres)", flake),
                       ("66 000 spheres, each with its own attributes", distinct)]:
        seconds = statistics.median(cpu_seconds(text) for _ in range(args.rounds))
        lines = text.count("\n")
        print(f"| {name} | {lines} | {seconds:.3f} | {1e6 * seconds / lines:.1f} |")
    if args.convert:
        with tempfile.TemporaryDirectory() as folder:
            scn = sphereflake.write(args.level, Path(folder) / f"flake{args.level}.scn")
            runs = convert(scn, Path(folder) / f"flake{args.level}.xml", args.rounds)
        good = [r for r in runs if r.ok]
        if good:
            print(f"\nwhitted convert flake{args.level}.scn: {statistics.median(r.wall_seconds for r in good):.2f} s "
                  f"wall, peak RSS {statistics.median(r.peak_rss for r in good) / 2**20:.0f} MiB "
                  f"(median of {len(good)})")
        if len(good) < len(runs):
            print(f"whitted convert flake{args.level}.scn: {runs[-1].failure()}: {runs[-1].stderr.strip()[-300:]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
