"""How fast the converter reads a big scene: the level-5 sphereflake (66 431 spheres), and as
many spheres each with attributes of its own, in CPU seconds of ``parse_text`` (median of
``--rounds``). vs_povray.py times the whole ``whitted convert`` process beside POV-Ray's
Parse Time.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from whitted.converter import Light, Scene, parse_text
from whitted.converter.scn_writer import scene_to_scn

from . import run_main, scenes, sphereflake


def cpu_seconds(text: str) -> float:
    """CPU seconds of :func:`whitted.converter.parse_text` on ``text``."""
    start = time.process_time()
    parse_text(text, "bench.scn")
    return time.process_time() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--level", type=int, default=5, choices=list(sphereflake.LEVELS))
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error(f"--rounds must be >= 1, got {args.rounds}")
    flake = scene_to_scn(sphereflake.scene(args.level), ".")
    distinct = scene_to_scn(Scene(width=64, height=64, lights=[Light((1.0, 2.0, 3.0))],
                                   spheres=scenes.random_spheres(66_000, reflect=0.5)), ".")
    print("| file | lines | parse_text CPU s | µs/line |\n|---|---|---|---|")
    for name, text in [(f"sphereflake level {args.level} ({sphereflake.count(args.level) + 1} spheres)", flake),
                       ("66 000 spheres, each with its own attributes", distinct)]:
        seconds = statistics.median(cpu_seconds(text) for _ in range(args.rounds))
        lines = text.count("\n")
        print(f"| {name} | {lines} | {seconds:.3f} | {1e6 * seconds / lines:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main))
