"""``whitted trace SCENE --pixel X Y [...] [--json] [-o PAGE.html]``: the ray trees of pixels."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..errors import WhittedError


def add_arguments(command) -> None:
    from ..cli import path_argument
    from ..defaults import LIGHTING_MODES, VARIANTS
    command.add_argument("scene", metavar="SCENE", type=path_argument,
                         help="the scene (.scn, or a converted .xml)")
    command.add_argument("--pixel", nargs=2, type=pixel_coordinate, action="append", required=True,
                         metavar=("X", "Y"),
                         help="a pixel: X the column from the left, Y the row from the top, from 0, "
                              "or each as a percentage of the width or height (--pixel 50%% 45%%: "
                              "near the middle at any size); give it again for more pixels")
    command.add_argument("--json", action="store_true",
                         help="print the trees as JSON (for scripts) instead of indented text")
    command.add_argument("-o", "--output", metavar="PAGE.html", type=path_argument,
                         help="also write a page to project: the image with the pixels marked, each "
                              "tree as a table and a 3D view of the rays (self-contained, works offline)")
    command.add_argument("--variant", choices=VARIANTS,
                         help="Mitsuba variant (default: as whitted render chooses it)")
    command.add_argument("--max-depth", type=int, metavar="N",
                         help="maximum ray-tree depth, primary rays having depth 1 (default: the scene's)")
    command.add_argument("--ambient", type=float, metavar="A",
                         help="the article's ambient coefficient (default: the scene's)")
    command.add_argument("--lighting", choices=LIGHTING_MODES, default=None,
                         help="the article's model (default) or physical lighting, as whitted render")
    command.add_argument("--min-weight", type=float, metavar="W",
                         help="adaptive depth control, as whitted render's: branches that cannot change "
                              "the pixel by more than W together are not traced, and the tree says so "
                              "(default: the scene's; 0 traces the exact tree)")


def pixel_coordinate(text: str):
    """A ``--pixel`` coordinate: an integer, or a percentage (``"45%"``) kept as text."""
    import argparse
    try:
        if text.endswith("%"):
            float(text[:-1])
            return text
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither a whole number nor a percentage "
                                         "such as 45%") from None


def trace_command(args) -> None:
    """Trace the pixels, print their trees, write the page (everything checked first)."""
    from ..atomic import check_writable
    from ..converter.parser import check_scene_file

    scene = Path(args.scene)
    check_scene_file(scene)
    page = None
    if args.output:
        page = Path(args.output)
        if page.suffix.lower() not in (".html", ".htm"):
            raise WhittedError(f"{page}: the page must be an .html file")
        check_writable(page, inputs=(scene,))
    from .pixel import trace_pixels
    traces = trace_pixels(scene, [tuple(p) for p in args.pixel], variant=args.variant,
                          max_depth=args.max_depth, ambient=args.ambient, lighting=args.lighting,
                          min_weight=args.min_weight)
    if page is not None:
        from .page import write_page
        write_page(page, traces, scene)
    _print(json.dumps(traces.json(), indent=1) if args.json else str(traces))
    if page is not None:
        print(f"whitted: wrote {page}", file=sys.stderr)


def _print(text: str) -> None:
    """``text`` on standard output; a full disk or a failing device behind it is one error
    (a closed pipe is the CLI's own quiet status 1), and what is left unwritten is dropped so
    that Python's exit does not try it again."""
    import os
    try:
        print(text)
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as error:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise WhittedError(f"cannot write the trees to standard output: {error.strerror or error}") from None
