"""The ``whitted`` command: convert, render (and later compare) legacy scenes.

User errors (bad scene files, missing files, bad options) print one line on
stderr and exit with status 2; no traceback, no output file.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .errors import WhittedError
from .loading import LIGHTING_MODES
from .render import INTEGRATORS
from .variant import SUPPORTED_VARIANTS

EXIT_USER_ERROR = 2


def _convert(args: argparse.Namespace) -> None:
    from .atomic import write_text
    from .converter import parse_file, scene_to_xml

    source = Path(args.scene)
    scene = parse_file(source)  # first: nothing is written for an invalid scene
    target = Path(args.output) if args.output else source.with_suffix(".xml")
    if target.resolve() == source.resolve():
        raise WhittedError(f"{source}: output would overwrite the input; choose another with -o")
    if target.is_dir():
        raise WhittedError(f"{target}: is a folder; give the output file's name")
    xml = scene_to_xml(scene, base_dir=target.parent)
    try:
        write_text(target, xml)
    except OSError as error:
        raise WhittedError(f"{target}: cannot write: {error.strerror or error}") from None
    if args.verbose:
        print(f"wrote {target}", file=sys.stderr)


def _render(args: argparse.Namespace) -> None:
    from .render import render_command
    render_command(args)


def _compare(args: argparse.Namespace) -> None:
    from .compare import compare_command
    compare_command(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="whitted",
        description="The classic Whitted sphere ray tracer of 'Ray Tracing: Graphics for the "
                    "Masses', inside Mitsuba 3: convert legacy .scn scenes to Mitsuba XML and "
                    "render them with the article's model or Mitsuba's path tracer.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    convert = sub.add_parser(
        "convert", help="convert a legacy .scn scene to Mitsuba 3 XML",
        description="Convert a legacy .scn scene to Mitsuba 3 XML (format 3.0.0). The XML "
                    "loads in stock Mitsuba once 'import whitted' has registered the project's "
                    "plugins. Nothing is written unless the whole scene is valid.")
    convert.add_argument("scene", help="the legacy scene file (.scn)")
    convert.add_argument("-o", "--output", metavar="OUT.xml",
                         help="where to write the XML (default: beside the input, with a .xml suffix)")
    convert.add_argument("-v", "--verbose", action="store_true", help="say what was written")
    convert.set_defaults(run=_convert)

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
    render.add_argument("--integrator", choices=INTEGRATORS, default="whitted",
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
                        help="adaptive depth control (Hall and Greenberg): leave untraced the "
                             "reflected and refracted rays whose path weight, the product of the "
                             "KR and KT factors above them, is below W (default: the scene's; 0, off)")
    render.add_argument("--stats", metavar="FILE.json", help="write ray counts and timings as JSON")
    render.add_argument("-v", "--verbose", action="store_true", help="print a one-line summary")
    render.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    render.set_defaults(run=_render)

    from .compare import add_arguments as add_compare_arguments
    compare = sub.add_parser(
        "compare", help="what accuracy costs in time: sweep the methods against a path-traced reference",
        description="Render a converged path-traced reference (cached), then sweep the Whitted "
                    "integrator (max depth x spp, article and physical lighting) and the path "
                    "tracer (spp) and score each render's relative MSE and FLIP against it. Writes "
                    "DIR/results.csv, DIR/error_vs_time.png and DIR/contact_sheet.png.")
    add_compare_arguments(compare)
    compare.set_defaults(run=_compare)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.run(args)
    except WhittedError as error:
        print(f"whitted: error: {error}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("whitted: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
