"""The ``whitted`` command: convert, render and compare legacy scenes.

User errors (bad scene files, missing files, bad options, bad environment
variables) print one line on stderr (one per problem) and exit with status 2;
no traceback, no output file. Ctrl-C and SIGTERM print one line and exit with
status 130 (143 for SIGTERM), leaving no partial output.

This module imports only what argument parsing needs: ``whitted convert``
never loads Mitsuba, Dr.Jit or numpy (each command imports its own module
when it runs).
"""

from __future__ import annotations

import argparse
import os
import sys

from .defaults import INTEGRATOR, INTEGRATORS, LIGHTING_MODES, VERSION
from .defaults import VARIANTS as SUPPORTED_VARIANTS
from . import interrupt
from .errors import EXIT_USER_ERROR, WhittedError, report



def _convert(args: argparse.Namespace) -> int:
    from .commands import convert_command
    return convert_command(args)


def _render(args: argparse.Namespace) -> None:
    from .commands import render_command
    render_command(args)


def _compare(args: argparse.Namespace) -> None:
    from .compare.cli import compare_command
    compare_command(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="whitted",
        description="The classic Whitted sphere ray tracer of 'Ray Tracing: Graphics for the "
                    "Masses', inside Mitsuba 3: convert legacy .scn scenes to Mitsuba XML and "
                    "render them with the article's model or Mitsuba's path tracer.")
    parser.add_argument("--version", action="version", version=f"whitted {VERSION}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    convert = sub.add_parser(
        "convert", help="convert legacy .scn scenes to Mitsuba 3 XML",
        description="Convert legacy .scn scenes to Mitsuba 3 XML (format 3.0.0): each X.scn "
                    "becomes X.xml beside it, or in the folder given with -o. The XML loads in "
                    "Mitsuba's Python once 'import whitted' has registered the project's plugins; "
                    "with --portable, X.portable.xml names only Mitsuba's stock plugins and loads "
                    "in any Mitsuba 3 (the mitsuba command too), as the path tracer renders it. "
                    "A bad file is reported as FILE:LINE: message and nothing is written for it; "
                    "the others are still converted, and the exit status is 2.")
    convert.add_argument("scenes", nargs="+", metavar="SCENE",
                         help="legacy scene files (.scn), or folders holding them")
    convert.add_argument("-o", "--output", metavar="OUT",
                         help="the XML file (one input file), or the folder that receives every "
                              "X.xml (default: beside each input)")
    convert.add_argument("--portable", action="store_true",
                         help="write X.portable.xml in Mitsuba's stock plugins only (path integrator, "
                              "stock BSDFs): the scene read physically, for any Mitsuba 3 tool; a "
                              "comment at its top says what differs from the article's model")
    convert.add_argument("-v", "--verbose", action="store_true", help="say what was written")
    convert.set_defaults(run=_convert, parser=convert)

    render = sub.add_parser(
        "render", help="render a .scn or .xml scene to EXR or PNG",
        description="Render a scene with the article's Whitted model (default) or Mitsuba's "
                    "path tracer. EXR stores linear RGB; PNG stores sRGB clipped to [0, 1].")
    render.add_argument("scene", help="the scene (.scn or converted .xml)")
    render.add_argument("-o", "--output", required=True, metavar="OUT",
                        help="output image, .exr (linear) or .png (sRGB)")
    render.add_argument("--variant", choices=SUPPORTED_VARIANTS,
                        help="Mitsuba variant (default: llvm_ad_rgb when a libLLVM >= 16 exists, "
                             "else scalar_rgb; or $WHITTED_VARIANT)")
    render.add_argument("--integrator", choices=INTEGRATORS, default=INTEGRATOR,
                        help="the article's model (whitted, default) or Mitsuba's path tracer (path)")
    render.add_argument("--lighting", choices=LIGHTING_MODES, default=None,
                        help="how the whitted integrator lights the scene: the article's model "
                             "(default) or physically (inverse-square fall-off, albedo/pi, no ambient)")
    render.add_argument("--spp", type=int, metavar="N", help="samples per pixel (default: the scene's)")
    render.add_argument("--max-depth", type=int, metavar="N",
                        help="maximum ray-tree depth; primary rays have depth 1 (default: the scene's)")
    render.add_argument("--ambient", type=float, metavar="A",
                        help="the article's ambient coefficient (default: the scene's)")
    render.add_argument("--min-weight", type=float, metavar="W",
                        help="adaptive depth control (Hall and Greenberg): leave reflected and "
                             "refracted rays untraced as long as together they cannot change a pixel "
                             "by more than W; --stats reports the bound reached (default: the "
                             "scene's, 1/255 unless it says; 0 traces the exact tree)")
    render.add_argument("--stats", metavar="FILE.json", help="write ray counts and timings as JSON")
    render.add_argument("-v", "--verbose", action="store_true", help="print a one-line summary")
    render.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    render.set_defaults(run=_render, parser=render)

    from .compare.cli import add_arguments as add_compare_arguments
    compare = sub.add_parser(
        "compare", help="what accuracy costs in time: sweep the methods against a path-traced reference",
        description="Render a converged path-traced reference (cached), then sweep the Whitted "
                    "integrator (max depth x spp, article and physical lighting) and the path "
                    "tracer (spp) and score each render's relative MSE and FLIP against it. Writes "
                    "DIR/report.html (the comparison as a page: open it from disk), DIR/summary.txt "
                    "(its conclusions in text), DIR/findings.json (the same for scripts), "
                    "DIR/results.csv (one row per render), DIR/error_vs_time.png, "
                    "DIR/contact_sheet.png and every render under DIR/renders/.")
    add_compare_arguments(compare)
    compare.set_defaults(run=_compare, parser=compare)
    return parser


def main(argv: list[str] | None = None) -> int:
    interrupt.install()
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:   # the command's own usage, not the top-level one
        args.parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    try:
        from .variant import check_environment, request
        check_environment()
        request(getattr(args, "variant", None))   # chosen once, when Mitsuba is imported
        status = args.run(args) or 0
    except WhittedError as error:
        if not interrupt.requested():
            report(error)
            return EXIT_USER_ERROR
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except BaseException as error:
        if not interrupt.requested(error):
            raise
    else:
        return status
    print(interrupt.message(), file=sys.stderr)
    return interrupt.exit_status()


if __name__ == "__main__":
    sys.exit(main())
