"""The ``whitted`` command. A user error prints one line per problem and exits with 2, a
Ctrl-C (SIGTERM) one line and 130 (143), no partial output either way. Only what parsing
needs is imported here: each command imports its own module when it runs.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import time

from .defaults import (DEFAULT_FPS, FIT_ITERATIONS, FIT_WIDTH, IMAGE_FORMATS, INTEGRATOR,
                       INTEGRATORS, LIGHTING_MODES, PATH_MIN_SPP, VARIANTS, VERSION, VIEWS)
from . import interrupt
from .errors import EXIT_USER_ERROR, WhittedError, report

#: Options a user may try from the scene format's keywords, and the option that does it.
SCENE_KEYWORD_OPTIONS = {"--samples": "--spp", "--depth": "--max-depth",
                         "--minweight": "--min-weight"}


def _command(sub, name: str, module: str, function: str, help: str, description: str,
             options: bool = False) -> argparse.ArgumentParser:
    """The subcommand ``name``'s parser (kept in the arguments: errors speak its terms), run by
    ``module.function(args)``, imported when it runs; ``options``: ``module.add_arguments``
    adds its options now."""
    def run(args: argparse.Namespace):
        return getattr(importlib.import_module(module, __package__), function)(args)
    command = sub.add_parser(name, help=help, description=description)
    command.set_defaults(run=run, parser=command)
    if options:
        importlib.import_module(module, __package__).add_arguments(command)
    return command


def path_argument(text: str) -> str:
    """A file or folder named on the command line (argparse type): an empty name is refused,
    where it would stand for the current folder (as ``-o`` of several scenes: the root)."""
    if not text:
        raise argparse.ArgumentTypeError("an empty path names no file or folder")
    return text


def _talk(command, verbose: str | None, quiet: str | None = "no progress bar") -> None:
    """A command's ``-v`` and ``-q`` options, with their help (None: none)."""
    if verbose:
        command.add_argument("-v", "--verbose", action="store_true", help=verbose)
    if quiet:
        command.add_argument("-q", "--quiet", action="store_true", help=quiet)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or, given ``command``, one whose other commands have no
    options yet (their help is the same; their code is not imported)."""
    parser = argparse.ArgumentParser(
        prog="whitted",
        description="""\
        The classic Whitted sphere ray tracer of 'Ray Tracing: Graphics for the Masses', inside
        Mitsuba 3: convert legacy .scn scenes to Mitsuba XML and render them with the article's
        model or Mitsuba's path tracer.""")
    parser.add_argument("--version", action="version", version=f"whitted {VERSION}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    convert = _command(
        sub, "convert", ".commands", "convert_command",
        help="convert legacy .scn scenes to Mitsuba 3 XML",
        description="""\
        Convert legacy .scn scenes to Mitsuba 3 XML (format 3.0.0): each X.scn becomes X.xml beside
        it, or in the folder given with -o. The XML loads in Mitsuba's Python once 'import whitted'
        has registered the project's plugins; with --portable, X.portable.xml names only Mitsuba's
        stock plugins and loads in any Mitsuba 3 (the mitsuba command too), as the path tracer
        renders it. A bad file is reported as FILE:LINE: message and nothing is written for it; the
        others are still converted, and the exit status is 2.""")
    convert.add_argument("scenes", nargs="+", metavar="SCENE", type=path_argument,
                         help="legacy scene files (.scn), or folders holding them")
    convert.add_argument("-o", "--output", metavar="OUT", type=path_argument,
                         help="the XML file (one input file), or the folder that receives every "
                              "X.xml (default: beside each input)")
    convert.add_argument("--portable", action="store_true",
                         help="write X.portable.xml in Mitsuba's stock plugins only (path integrator, "
                              "stock BSDFs): the scene read physically, for any Mitsuba 3 tool; a "
                              "comment at its top says what differs from the article's model")
    _talk(convert, "say what was written", None)

    render = _command(
        sub, "render", ".commands", "render_command",
        help="render .scn or .xml scenes to EXR or PNG (one, or folders of them)",
        description="""\
        Render a scene with the article's Whitted model (default) or Mitsuba's path tracer. EXR
        stores linear RGB as rendered; PNG stores what is displayed: 8-bit sRGB after --exposure and
        a view transform (--view; the article's model: clipped to [0, 1], physically lit and
        path-traced images: tone-mapped). Several scenes, or folders of them (their .scn files, else
        their .xml), render in one process into the folder -o OUT/ names, as convert names its
        outputs: OUT/X.png (or --format exr) per scene X, skipping scenes whose images are newer
        than the scene and its textures (--force renders them again). A bad scene is reported as
        FILE:LINE: message and the others go on; the exit status is then 2.""")
    render.add_argument("scenes", nargs="+", metavar="SCENE", type=path_argument,
                        help="the scene (.scn or converted .xml), or several, or folders of them")
    render.add_argument("-o", "--output", required=True, metavar="OUT", type=path_argument,
                        help="output image, .exr (linear) or .png (sRGB); for several scenes or a "
                             "folder, the folder that receives every image (created when missing)")
    render.add_argument("--format", action="append", choices=IMAGE_FORMATS, metavar="{png,exr}",
                        help="the images written into an output folder: png (default) or exr; "
                             "give it twice for both")
    render.add_argument("--force", action="store_true",
                        help="render every scene, even those whose images are up to date")
    render.add_argument("--video", metavar="OUT.mp4", type=path_argument,
                        help="also encode the images, in the scenes' order, as an H.264 video "
                             "(see whitted video)")
    render.add_argument("--fps", type=float, metavar="N",
                        help=f"the video's frames per second (default {DEFAULT_FPS:g})")
    where = render.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N",
                       help="render the scenes on a local Dask cluster of N worker processes")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="render the scenes on the Dask cluster of this scheduler, e.g. "
                            "tcp://host:8786 (a shared file system; see docs/cluster.md)")
    render.add_argument("--variant", choices=VARIANTS,
                        help="Mitsuba variant (default: llvm_ad_rgb when a libLLVM >= 16 exists, "
                             "else scalar_rgb; or $WHITTED_VARIANT)")
    render.add_argument("--integrator", choices=INTEGRATORS, default=INTEGRATOR,
                        help="the article's model (whitted, default) or Mitsuba's path tracer (path)")
    render.add_argument("--lighting", choices=LIGHTING_MODES, default=None,
                        help="how the whitted integrator lights the scene: the article's model "
                             "(default) or physically (inverse-square fall-off, albedo/pi, no ambient)")
    render.add_argument("--spp", type=int, metavar="N",
                        help="samples per pixel (default: the scene's; the path tracer takes at least "
                             f"{PATH_MIN_SPP})")
    render.add_argument("--max-depth", type=int, metavar="N",
                        help="maximum ray-tree depth; primary rays have depth 1 (default: the scene's)")
    render.add_argument("--ambient", type=float, metavar="A",
                        help="the article's ambient coefficient (default: the scene's)")
    render.add_argument("--without", action="append", metavar="EFFECT",
                        help="leave an effect out of the article's model, as if the scene lacked it: "
                             "shadows, reflection, refraction, textures, diffuse or ambient (repeat it, "
                             "or separate names by commas; whitted integrator only)")
    render.add_argument("--min-weight", type=float, metavar="W",
                        help="adaptive depth control (Hall and Greenberg): leave reflected and "
                             "refracted rays untraced as long as together they cannot change a pixel "
                             "by more than W; --stats reports the bound reached (default: the "
                             "scene's, 1/255 unless it says; 0 traces the exact tree)")
    render.add_argument("--exposure", type=float, default=0.0, metavar="EV",
                        help="a PNG's exposure in stops: the image times 2^EV before the view "
                             "(default 0; never applied to EXR)")
    render.add_argument("--view", choices=VIEWS, default=None,
                        help="a PNG's view transform: clip (sRGB clipped to [0, 1]; default for the "
                             "article's model) or aces (OpenColorIO's ACES 2.0 SDR view, highlights "
                             "rolled off; default for --lighting physical and --integrator path)")
    render.add_argument("--stats", metavar="FILE.json", type=path_argument,
                        help="write ray counts and timings as JSON (for several scenes: one file, "
                             "every scene's and the totals)")
    _talk(render, "print a one-line summary")

    video = _command(
        sub, "video", ".video", "video_command",
        help="encode PNG or EXR frames as an H.264 video",
        description="""\
        Encode frames (image files, or folders of them: their PNG files sorted by name, else their
        EXR files) as an H.264 video through FFmpeg (imageio-ffmpeg). EXR frames are encoded to sRGB
        as PNG output is.""")
    video.add_argument("frames", nargs="+", metavar="FRAME", type=path_argument,
                       help="frames (.png or .exr), or folders of them")
    video.add_argument("-o", "--output", required=True, metavar="OUT.mp4", type=path_argument,
                       help="the video (.mp4, .mkv or .mov)")
    video.add_argument("--fps", type=float, default=DEFAULT_FPS, metavar="N",
                       help=f"frames per second (default {DEFAULT_FPS:g})")
    _talk(video, "say what was written")

    fit = _command(
        sub, "fit", ".fitting", "fit_command",
        help="fit a scene's colors, ambient and light colors to an image",
        description="""\
        Fit the article's model of a legacy scene to a target image (a path-traced reference, a
        photograph of the same view) by gradient descent (Mitsuba's Adam on the relative MSE, at low
        resolution): every untextured material's color, the ambient and the lights' colors. Writes
        the fitted scene as a .scn file and prints the loss of each step.""")
    fit.add_argument("scene", metavar="SCENE.scn", type=path_argument, help="the legacy scene to fit")
    fit.add_argument("--to", required=True, metavar="IMAGE.exr", dest="target", type=path_argument,
                     help="the target image (EXR or PNG), of the scene's view (its aspect ratio)")
    fit.add_argument("-o", "--output", required=True, metavar="FITTED.scn", type=path_argument,
                     help="the fitted scene to write")
    fit.add_argument("--iterations", type=int, default=FIT_ITERATIONS, metavar="N",
                     help=f"gradient steps (default {FIT_ITERATIONS})")
    fit.add_argument("--width", type=int, default=FIT_WIDTH, metavar="W",
                     help=f"the widest image the fit renders (default {FIT_WIDTH})")
    _talk(fit, None, "no progress bar, no losses")

    _command(
        sub, "trace", ".trace.cli", "trace_command", options=command in (None, "trace"),
        help="the ray tree of a pixel, as the renderer computed it",
        description="""\
        Trace pixels' center rays as a render at one sample per pixel traces them (the whitted
        integrator's own code) and print each ray tree as indented text (or --json): every ray's
        kind, origin, direction and distance, the sphere it hits (its line in the scene file),
        the normal, the ambient term and each light's term with its shadow ray (and the sphere
        that blocks it), the reflection and refraction weights, the ray's contribution to the
        pixel and why its branch stops. The contributions add up to the pixel. Positions are in
        the scene file's coordinates. -o PAGE.html also writes a page to project: the image with
        the pixels marked, each tree as a table and a 3D view of the rays.""")

    _command(
        sub, "compare", ".compare.cli", "compare_command", options=command in (None, "compare"),
        help="what accuracy costs in time: sweep the methods against a path-traced reference",
        description="""\
        Render a converged path-traced reference (cached), then sweep the Whitted integrator (max
        depth x spp, article and physical lighting) and the path tracer (spp) and score each
        render's relative MSE and FLIP against it. Writes DIR/report.html (the comparison as a page:
        open it from disk), DIR/summary.txt (its conclusions in text), DIR/findings.json (the same
        for scripts), DIR/results.csv (one row per render), DIR/error_vs_time.png,
        DIR/contact_sheet.png and every render under DIR/renders/.""")
    return parser


def suggestion(parser: argparse.ArgumentParser, unknown: list[str]) -> str:
    """``(did you mean --spp?)`` for the first unknown option like one of ``parser``'s, else ''."""
    import difflib

    options = [o for action in parser._actions for o in action.option_strings if o.startswith("--")]
    for word in unknown:
        name = word.split("=", 1)[0]
        if not name.startswith("-"):
            continue
        if name.lower() in SCENE_KEYWORD_OPTIONS:
            return f" (did you mean {SCENE_KEYWORD_OPTIONS[name.lower()]}?)"
        close = difflib.get_close_matches(name, options, n=1, cutoff=0.6)
        if close:
            return f" (did you mean {close[0]}?)"
    return ""


def process_start() -> float:
    """When this process started, in ``time.monotonic`` (for ``compare --budget``; else now)."""
    try:
        with open("/proc/self/stat") as stat:
            ticks = int(stat.read().rsplit(")", 1)[1].split()[19])
        age = time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
        return time.monotonic() - min(max(0.0, age), 60.0)
    except (OSError, ValueError, AttributeError, IndexError):
        return time.monotonic()


def main(argv: list[str] | None = None) -> int:
    interrupt.install()
    words = sys.argv[1:] if argv is None else argv
    parser = build_parser(next((w for w in words if not w.startswith("-")), None))
    args, unknown = parser.parse_known_args(argv)
    args.started = process_start() if argv is None else time.monotonic()   # a test's: now
    if unknown:   # the command's own usage, not the top-level one
        args.parser.error(f"unrecognized arguments: {' '.join(unknown)}{suggestion(args.parser, unknown)}")
    return interrupt.run(lambda: _run(args))


def _run(args) -> int:
    """The command's status: 2 after a user error or a path the system refuses (one line per
    problem), 1 on a closed pipe."""
    try:
        from .variant import check_environment, check_user_libllvm, request
        check_user_libllvm(getattr(args, "variant", None) or check_environment())
        request(getattr(args, "variant", None))   # chosen once, when Mitsuba is imported
        return args.run(args) or 0
    except WhittedError as error:
        if interrupt.requested():   # the stop's one line says it
            raise
        report(error)
        return EXIT_USER_ERROR
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as error:   # a path the system refuses (a name too long, ...): named, one line
        if error.filename is None or interrupt.requested():
            raise
        report(WhittedError(f"{error.filename}: {error.strerror or error}"))
        return EXIT_USER_ERROR


if __name__ == "__main__":
    sys.exit(main())
