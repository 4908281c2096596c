"""The ``compare`` subcommand of the ``whitted`` CLI: its options, and what it prints (the
comparison itself is :func:`whitted.compare.compare`, which a script can call)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from ..defaults import (COMPARE_MAX_DEFAULT_DEPTH, COMPARE_PATH_SPP, COMPARE_QUICK,
                        COMPARE_REFERENCE_CHUNK_SPP, COMPARE_REFERENCE_SPP, COMPARE_ROUNDS,
                        COMPARE_WHITTED_SPP, VARIANTS, VIEWS)
from .results import Options


#: the most values a list option holds (each one a render of every scene)
MAX_LIST = 1000


def int_list(text: str) -> tuple[int, ...]:
    """'1,4,16' or '1-5' or '1-3,8' -> a sorted tuple of distinct positive integers (argparse type)."""
    values: set[int] = set()
    try:
        for item in map(str.strip, text.split(",")):
            low, high = map(int, item.split("-", 1) if "-" in item[1:] else (item, item))
            if high < low:
                raise ValueError
            if len(values) + high - low >= MAX_LIST:
                raise argparse.ArgumentTypeError(f"'{text}': a list holds at most {MAX_LIST} values")
            values.update(range(low, high + 1))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a list of integers like 1,4,16 or 1-5") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"'{text}': every value must be an integer >= 1")
    return tuple(sorted(values))


def float_list(text: str) -> tuple[float, ...]:
    """'0.1,0.03' -> a tuple of positive finite numbers, largest first (argparse type)."""
    try:
        values = {float(item) for item in text.split(",")}
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a list of numbers like 0.1,0.03,0.01") from None
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"'{text}': every value must be a positive number")
    return tuple(sorted(values, reverse=True))


#: The options --quick may set (its own are COMPARE_QUICK's), each one given beside it wins.
LADDERS = ("reference_spp", "depths", "spp", "path_spp", "rounds", "budget")


def quick_text() -> str:
    def value(v):
        return ",".join(map(str, v)) if isinstance(v, tuple) else f"{v:g}"
    return " ".join(f"--{name.replace('_', '-')} {value(v)}" for name, v in COMPARE_QUICK.items())


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..cli import path_argument
    parser.add_argument("scenes", nargs="+", metavar="SCENE", type=path_argument,
                        help="scenes (.scn or .xml), or folders of them")
    parser.add_argument("-o", "--out", required=True, metavar="DIR", type=path_argument,
                        help="output folder")
    parser.add_argument("--reference-spp", type=int, metavar="N",
                        help=f"the reference's samples per pixel, at most: fewer where its noise "
                             f"needs fewer (default {COMPARE_REFERENCE_SPP})")
    parser.add_argument("--depths", type=int_list, metavar="LIST",
                        help="Whitted max depths, e.g. 1-5 or 1,2,4 (default: 1 to the scene's depth, "
                             f"at most {COMPARE_MAX_DEFAULT_DEPTH})")
    for flag, whose, ladder in (("--spp", "the Whitted integrator's", COMPARE_WHITTED_SPP),
                                ("--path-spp", "the path tracer's", COMPARE_PATH_SPP)):
        parser.add_argument(flag, type=int_list, metavar="LIST",
                            help=f"{whose} spp ladder (default {','.join(map(str, ladder))})")
    parser.add_argument("--path-depth", type=int, metavar="N",
                        help="the path tracer's max depth, for the reference too (default: the scene's)")
    parser.add_argument("--rounds", type=int, metavar="N",
                        help="timed rounds of the renders the verdict reads, at least, each timed once "
                             "per round so that methods are timed in the same moments (the first "
                             "round times every render); then rounds of the headlines' renders "
                             f"alone (default {COMPARE_ROUNDS})")
    # --repeats: --rounds under the name scripts may still use
    parser.add_argument("--repeats", dest="rounds", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--budget", type=float, metavar="SECONDS",
                        help="bound the whole command's time: renders, timing rounds, limits and "
                             "the fit that would overrun are skipped or cut short")
    parser.add_argument("--quick", action="store_true",
                        help=f"a quick verdict (under 30 s a scene on 2 cores): {quick_text()}; "
                             "options given beside it win")
    parser.add_argument("--levels", type=float_list, metavar="LIST",
                        help="relative MSE levels of the equal-quality table, e.g. 0.1,0.03 "
                             "(default: from the data: each method's floor, and levels between "
                             "the best and worst errors measured)")
    parser.add_argument("--cache", metavar="DIR", type=path_argument, help="where references are cached (default: ~/.cache/whitted/references, or "
                             "$XDG_CACHE_HOME/whitted/references; shared by every run; safe to delete)")
    parser.add_argument("--variant", choices=VARIANTS,
                        help="Mitsuba variant (default as for render)")
    parser.add_argument("--reference-chunk-spp", type=int, default=COMPARE_REFERENCE_CHUNK_SPP,
                        metavar="N", help="render the reference in chunks of N spp, each with its "
                                          "own seed, averaged; a cluster spreads them over its "
                                          f"workers (default {COMPARE_REFERENCE_CHUNK_SPP})")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N",
                       help="sweep on a local Dask cluster of N worker processes (each scene's "
                            "settings on one worker; the cores shared among them)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="sweep on the Dask cluster of this scheduler, e.g. tcp://host:8786 "
                            "(workers started with whitted installed; see docs/cluster.md)")
    parser.add_argument("--view", choices=VIEWS,
                        help="how every image is displayed (PNGs, report page, contact sheet) and "
                             "FLIP scores it: clip (sRGB clipped to [0, 1]) or aces (OpenColorIO's "
                             "ACES 2.0 SDR view); default: per scene, clip unless that clips 1%% "
                             "or more of the reference's pixels. The relative MSE reads linear values")
    parser.add_argument("--exposure", type=float, default=0.0, metavar="EV",
                        help="the displayed images' exposure in stops (default 0); FLIP scores them so")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def compare_command(args: argparse.Namespace) -> None:
    from .report import output_files, summary
    from .run import compare

    chosen = dict(COMPARE_QUICK if args.quick else {})   # then what the command line gives
    chosen.update({name: getattr(args, name) for name in LADDERS
                   if getattr(args, name) is not None})
    if "spp" in chosen:
        chosen["whitted_spp"] = chosen.pop("spp")
    # the options that Options names as the command line does
    given = ("path_depth", "levels", "variant", "quiet", "reference_chunk_spp", "workers", "scheduler",
             "view", "exposure", "quick")
    options = Options(out=Path(args.out), **chosen, **{name: getattr(args, name) for name in given},
                      cache=Path(args.cache) if args.cache else None,
                      started=getattr(args, "started", None))
    start = time.monotonic()
    entries = compare(args.scenes, options)
    skipped = sum(len(e.skipped) for e in entries)
    done = sum(len(e.measurements) for e in entries)
    print(summary(entries.analyses, equal_time=False))
    if skipped:
        held = "the outputs hold the renders that were done" if done else "nothing was rendered"
        print(f"\nbudget of {options.budget:g} s: skipped {skipped} of {skipped + done} renders; {held}")
    for e in entries:
        for note in e.notes:  # what the budget did, and why (also in the report)
            print(f"{e.name}: {note}", file=sys.stderr)
        if e.reference_file is None:
            continue
        how = "read from the cache" if e.reference_cached else f"rendered in {e.reference_seconds:.1f} s"
        print(f"{e.name}: reference (path tracer, {e.reference_spp} spp) {how}: {e.reference_file}",
              file=sys.stderr)
    if done == 0:
        print("whitted compare: no render was done (see the lines above for why)", file=sys.stderr)
    # The progress bar counts every render, each Whitted method's limit too: so does this line.
    limits = sum(len(e.limits) for e in entries)
    counted = (f"{done + limits} renders ({done} timed and scored, {limits} limit{'s' if limits > 1 else ''})"
               if limits else f"{done} render{'' if done == 1 else 's'}")
    print(f"\n{counted} in {time.monotonic() - start:.1f} s; wrote {output_files(options.out)}",
          file=sys.stderr)
