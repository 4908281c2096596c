"""The bodies of ``whitted convert`` and ``whitted render`` (``whitted/cli.py`` parses
their arguments; ``compare`` has its own package).

Both check everything a user can get wrong — options, environment, the scene,
every output path — before any long work, and write outputs atomically, so
that a failure or an interruption leaves no partial file.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .errors import EXIT_USER_ERROR, WhittedError, report



def convert_command(args) -> int:
    """``whitted convert SCENE... [-o OUT] [--portable]``: every file converted that can be;
    2 if any failed."""
    from .atomic import check_folder, check_folder_creatable, writable_folder
    from .converter.batch import PORTABLE_SUFFIX, XML_SUFFIX, convert_file, plan

    portable = getattr(args, "portable", False)
    pairs = plan(args.scenes, args.output, PORTABLE_SUFFIX if portable else XML_SUFFIX)
    # One rule: an -o that names a folder (several inputs, or a trailing /) is created
    # when missing; the folder of an -o that names a file must exist. Every folder
    # is checked before the first file is converted; errors name the user's paths.
    named_folder = Path(args.output) if args.output else None
    folders = sorted({target.parent for _, target in pairs})
    for folder in folders:
        targets = [target for _, target in pairs if target.parent == folder]
        named = targets[0] if len(targets) == 1 else folder
        if folder == named_folder and not folder.exists():
            check_folder_creatable(folder)
        else:
            check_folder(folder, named)
    if named_folder in folders:
        writable_folder(named_folder)
    failed = 0
    for source, target in pairs:
        try:
            convert_file(source, target, portable)
        except WhittedError as error:
            report(error)
            failed += 1
        else:
            if args.verbose:
                print(f"wrote {target}", file=sys.stderr)
    if failed and len(pairs) > 1:
        print(f"whitted: {failed} of {len(pairs)} scene files not converted", file=sys.stderr)
    return EXIT_USER_ERROR if failed else 0




def _summary(args, result, sensor) -> str:
    import mitsuba as mi
    width, height = (int(c) for c in sensor.film().crop_size())
    spp = sensor.sampler().sample_count()
    s = result.stats
    rays = ", ".join(f"{v} {k}" for k, v in s["rays"].items())
    depth = f"depth reached {s['max_depth_reached']}; " if "max_depth_reached" in s else ""
    if s.get("min_weight"):
        depth += (f"{s['culled_rays']} rays culled, error at most {s['error_bound']:.2g} "
                  f"(min weight {s['min_weight']:.3g}); ")
    return (f"whitted: {width}x{height} at {spp} spp with {args.integrator} ({mi.variant()}): "
            f"{s['seconds']:.3f} s (+{s['compile_seconds']:.3f} s compiling); rays: {rays}; {depth}"
            f"effects: {' '.join(s['effects']) or 'none'}; "
            f"peak memory {s['peak_memory_bytes'] / 2**20:.1f} MiB (Dr.Jit), "
            f"{s['peak_resident_bytes'] / 2**20:.1f} MiB resident")


def _load_quietly(args):
    from .loading import load_scene
    from .rendering import quiet_mitsuba
    with quiet_mitsuba():
        return load_scene(args.scene, variant=args.variant, integrator=args.integrator, spp=args.spp,
                          max_depth=args.max_depth, ambient=args.ambient, lighting=args.lighting)


def render_command(args) -> None:
    """``whitted render SCENE -o OUT``: everything is checked before anything is written."""
    from .atomic import check_writable, write_text
    from .defaults import check_ambient
    from .interrupt import deferred
    from .memory import peak_resident_bytes
    with deferred():   # numpy's C extension is not cut mid-import by a Ctrl-C (see deferred)
        from .imageio import image_format, write_image
        from .rendering import check_settings, render_checked

    output = Path(args.output)
    # Before the scene is loaded (seconds for a large one); once: render_checked trusts them.
    check_settings(args.spp, args.max_depth, args.lighting, args.integrator, args.min_weight)
    if args.ambient is not None:
        check_ambient(args.ambient)
    if args.stats and Path(args.stats).resolve() == output.resolve():
        raise WhittedError(f"{args.stats}: the statistics would overwrite the image")
    check_writable(output, inputs=(args.scene,))   # what is wrong with the path first
    image_format(output)
    if args.stats:
        check_writable(args.stats, inputs=(args.scene,))

    loaded = _load_quietly(args)   # the mi.Scene
    try:   # render checks the scene (a sensor; the article's materials) before it starts
        result = render_checked(loaded, integrator=args.integrator, progress=not args.quiet,
                                min_weight=args.min_weight)
    except WhittedError as error:
        raise WhittedError(f"{args.scene}: {error}") from None
    write_image(output, result.image, progress=not args.quiet)
    result.stats["peak_resident_bytes"] = peak_resident_bytes()   # the writing included
    if args.stats:
        write_text(args.stats, json.dumps(result.stats, indent=2) + "\n")
    if args.verbose:
        print(_summary(args, result, loaded.sensors()[0]), file=sys.stderr)
