"""How fast the converter reads a big scene: the level-5 sphereflake (66 431 spheres).

The parser reads the spheres of plain lines a batch at a time and every other statement
on its own; ``careful=True`` reads every statement on its own, as the parser did before
batches (converter/parser.py). This times both on the same text, interleaved, in CPU
seconds (RESULTS.md, "Parsing a big scene"). ``--convert``
also times the whole ``whitted convert`` process, wall time and peak memory, as
vs_povray.py does beside POV-Ray's Parse Time.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

from whitted.converter import Light, Scene, parse_text

from . import process, scenes, sphereflake
from .timing import cpu_seconds


def measure(text: str, rounds: int) -> dict:
    """Median CPU seconds of ``parse_text`` with and without ``careful``, and their ratio."""
    fast, careful = [], []
    for _ in range(rounds):
        fast.append(fast_seconds(text))
        careful.append(cpu_seconds(lambda: parse_text(text, "bench.scn", careful=True)))
    lines = text.count("\n")
    f, c = statistics.median(fast), statistics.median(careful)
    return {"lines": lines, "fast_s": f, "careful_s": c, "speedup": c / f,
            "fast_us_per_line": 1e6 * f / lines, "careful_us_per_line": 1e6 * c / lines}


def fast_seconds(text: str) -> float:
    """CPU seconds of :func:`whitted.converter.parse_text` on ``text`` (spheres in batches)."""
    return cpu_seconds(lambda: parse_text(text, "bench.scn"))


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


def table(rounds: int = 5, level: int = 5) -> list[tuple[str, dict]]:
    """The sphereflake at ``level``, and 66 000 spheres with no two attribute lists alike."""
    flake = scenes.to_scn(sphereflake.scene(level))
    distinct = scenes.to_scn(Scene(width=64, height=64, lights=[Light((1.0, 2.0, 3.0))],
                                   spheres=scenes.random_spheres(66_000, reflect=0.5)))
    return [(f"sphereflake level {level} ({sphereflake.count(level) + 1} spheres)", measure(flake, rounds)),
            ("66 000 spheres, each with its own attributes", measure(distinct, rounds))]


def markdown(rows) -> str:
    lines = ["| file | lines | before (careful path) s | after (fast path) s | speed-up | µs/line before | µs/line after |",
             "|---|---|---|---|---|---|---|"]
    for name, r in rows:
        lines.append(f"| {name} | {r['lines']} | {r['careful_s']:.2f} | {r['fast_s']:.3f} | "
                     f"{r['speedup']:.1f}× | {r['careful_us_per_line']:.1f} | {r['fast_us_per_line']:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--level", type=int, default=5, choices=list(sphereflake.LEVELS))
    parser.add_argument("--convert", action="store_true",
                        help="also time the whole `whitted convert` process on the level's scene")
    args = parser.parse_args(argv)
    print(markdown(table(args.rounds, args.level)))
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
