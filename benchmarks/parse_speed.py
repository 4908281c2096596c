"""How fast the converter reads a big scene: the level-5 sphereflake (66 431 spheres).

The parser reads plain light and sphere lines on a fast path and everything
else on the careful path (converter/parser.py). This times both on the same
text, interleaved (a burst of load from another process hits both alike):
"careful" is the parser as it was before the fast path existed, statement by
statement, and "fast" is :func:`whitted.converter.parse_text`. A second file
of 66 000 spheres, each with its own random color and reflection coefficient,
shows the fast path where no two spheres share their attributes. Times are
CPU seconds of this process (``time.process_time``), medians of ``rounds``.

Usage::

    python benchmarks/parse_speed.py [--rounds 5] [--level 5]
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import sphereflake  # noqa: E402
from whitted.converter.parser import _parse  # noqa: E402


def random_spheres(count: int, seed: int = 1) -> str:
    """``count`` spheres, each with its own color and reflection (no two attribute lists alike)."""
    rng = random.Random(seed)
    lines = ["size 64 64", "light 1 2 3"]
    for _ in range(count):
        x, y, z = (rng.uniform(-5, 5) for _ in range(3))
        r, g, b = (rng.random() for _ in range(3))
        lines.append(f"sphere {x!r} {y!r} {z!r} {rng.uniform(0.01, 1)!r} color {r!r} {g!r} {b!r} "
                     f"reflect {rng.random() * 0.5!r}")
    return "\n".join(lines) + "\n"


def _cpu(run) -> float:
    start = time.process_time()
    run()
    return time.process_time() - start


def measure(text: str, rounds: int) -> dict:
    """Median CPU seconds of the careful and the fast path on ``text``, and their ratio."""
    fast, careful = [], []
    for _ in range(rounds):
        fast.append(_cpu(lambda: _parse(text, "bench.scn", fast=True)))
        careful.append(_cpu(lambda: _parse(text, "bench.scn", fast=False)))
    lines = text.count("\n")
    f, c = statistics.median(fast), statistics.median(careful)
    return {"lines": lines, "fast_s": f, "careful_s": c, "speedup": c / f,
            "fast_us_per_line": 1e6 * f / lines, "careful_us_per_line": 1e6 * c / lines}


def table(rounds: int = 5, level: int = 5, distinct: bool = True) -> list[tuple[str, dict]]:
    """The sphereflake at ``level``, and (``distinct``) 66 000 spheres of distinct attributes."""
    flake = sphereflake.to_scn(sphereflake.scene(level))
    rows = [(f"sphereflake level {level} ({sphereflake.count(level) + 1} spheres)", measure(flake, rounds))]
    if distinct:
        rows.append(("66 000 spheres, each with its own attributes", measure(random_spheres(66_000), rounds)))
    return rows


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
    args = parser.parse_args(argv)
    print(markdown(table(args.rounds, args.level)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
