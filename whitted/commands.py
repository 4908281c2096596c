"""The bodies of ``whitted convert`` and ``whitted render``: everything a user can get wrong
is checked before any long work."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .errors import EXIT_USER_ERROR, WhittedError, report


def convert_command(args) -> int:
    """``whitted convert``: every file converted that can be; 2 if any failed."""
    from .converter.batch import PORTABLE_SUFFIX, XML_SUFFIX, convert_file, plan, prepare_folders

    pairs = plan(args.scenes, args.output, PORTABLE_SUFFIX if args.portable else XML_SUFFIX)
    prepare_folders([target for _, target in pairs], args.output)
    failed = 0
    for source, target in pairs:
        try:
            convert_file(source, target, args.portable)
        except WhittedError as error:
            report(error)
            failed += 1
        else:
            if args.verbose:
                print(f"wrote {target}", file=sys.stderr)
    if failed and len(pairs) > 1:
        print(f"whitted: {failed} of {len(pairs)} scene files not converted", file=sys.stderr)
    return EXIT_USER_ERROR if failed else 0


def _summary(args, result) -> str:
    import mitsuba as mi

    from .defaults import check_without
    height, width = result.image.shape[:2]
    s = result.stats
    rays = ", ".join(f"{v} {k}" for k, v in s["rays"].items())
    depth = f"depth reached {s['max_depth_reached']}; " if "max_depth_reached" in s else ""
    if s.get("min_weight"):
        depth += (f"{s['culled_rays']} rays culled, error at most {s['error_bound']:.2g} "
                  f"(min weight {s['min_weight']:.3g}); ")
    return (f"whitted: {width}x{height} at {s['spp']} spp with {args.integrator} ({mi.variant()}): "
            f"{s['seconds']:.3f} s (+{s['compile_seconds']:.3f} s compiling); rays: {rays}; {depth}"
            f"effects: {' '.join(s['effects']) or 'none'}; "
            f"{'left out: ' + ' '.join(check_without(args.without)) + '; ' if args.without else ''}"
            f"peak memory {s['peak_memory_bytes'] / 2**20:.1f} MiB (Dr.Jit), "
            f"{s['peak_resident_bytes'] / 2**20:.1f} MiB resident")


def render_command(args) -> int | None:
    """``whitted render``, of one scene or into a folder."""
    from .atomic import names_folder
    if names_folder(args.scenes, args.output):
        return render_many_command(args)
    for given, option in ((args.format, "--format"), (args.video, "--video"), (args.workers, "--workers"),
                          (args.scheduler, "--scheduler")):
        if given is not None:
            raise WhittedError(f"{option} renders scenes into a folder: give -o OUT/ (with a trailing /)")
    _check_fps_has_video(args)
    render_single(args)


def _check_fps_has_video(args) -> None:
    if args.fps is not None and not args.video:
        raise WhittedError("--fps is the rate of a video: give --video OUT.mp4 too")


def _settings(args):
    """The render options of ``args`` as :class:`whitted.batch.Settings`."""
    from .batch import Settings
    from .defaults import check_without
    return Settings(integrator=args.integrator, spp=args.spp, max_depth=args.max_depth,
                    ambient=args.ambient, lighting=args.lighting, min_weight=args.min_weight,
                    without=check_without(args.without, "--without") if args.without else None,
                    variant=args.variant, exposure=args.exposure, view=args.view)


def render_single(args) -> None:
    """``whitted render SCENE -o OUT``: everything is checked before anything is written."""
    from .atomic import check_writable, write_text
    from .interrupt import deferred
    with deferred():   # numpy's C extension is not cut mid-import by a Ctrl-C (see deferred)
        from .batch import render_file
        from .images import image_format, write_image
        from .rendering import peak_resident_bytes

    output = Path(args.output)
    settings = _settings(args)
    settings.check()   # before the scene loads (seconds for a large one); render_checked trusts it
    if args.stats and Path(args.stats).resolve() == output.resolve():
        raise WhittedError(f"{args.stats}: the statistics would overwrite the image")
    check_writable(output, inputs=(args.scenes[0],))   # what is wrong with the path first
    image_format(output)
    if args.stats:
        check_writable(args.stats, inputs=(args.scenes[0],))

    result, view = render_file(args.scenes[0], settings, not args.quiet)
    write_image(output, result.image, progress=not args.quiet, exposure=settings.exposure,
                view=view)
    result.stats["peak_resident_bytes"] = peak_resident_bytes()   # the writing included
    if args.stats:
        write_text(args.stats, json.dumps(result.stats, indent=2) + "\n")
    if args.verbose:
        print(_summary(args, result), file=sys.stderr)


def render_many_command(args) -> int:
    """``whitted render SCENE|FOLDER... -o OUT/``: every scene rendered that can be; 2 if any failed."""
    from . import interrupt
    from .atomic import check_writable, write_text
    from .batch import Totals, plan_batch, render_planned
    from .defaults import DEFAULT_FPS, IN_PROCESS
    from .cluster import check_where
    from .progress import progress_bar

    settings = _settings(args)
    settings.check()
    check_where(args.workers, args.scheduler)
    _check_fps_has_video(args)
    if args.video:
        from .video import check_fps, check_video_path
        check_video_path(args.video)
        args.fps = check_fps(DEFAULT_FPS if args.fps is None else args.fps)
    formats = args.format or ["png"]
    planned, skipped, todo = plan_batch(args.scenes, args.output, formats, args.force)
    images = {Path(p).resolve() for _, outputs in planned for p in outputs}
    for extra in (args.stats, args.video):
        if extra and Path(extra).resolve() in images:
            raise WhittedError(f"{extra}: would overwrite an image of the render")
    if args.stats:
        check_writable(args.stats, inputs=tuple(scene for scene, _ in planned))

    tally = Totals(planned=len(planned), items=list(skipped))
    interrupted = True
    bar = progress_bar(not args.quiet, len(planned), "render", unit="scene", unit_scale=False,
                       initial=len(skipped))
    rendering = render_planned(todo, settings, workers=args.workers, scheduler=args.scheduler)
    try:
        for item in rendering:
            tally.items.append(item)
            if item.status == "failed":   # as the CLI prints a user error
                for line in item.error.splitlines():
                    bar.write(f"whitted: error: {line}", file=sys.stderr)
            elif args.verbose:
                where = f" on {item.worker}" if item.worker != IN_PROCESS else ""
                bar.write(f"whitted: wrote {', '.join(map(str, item.outputs))} "
                          f"({item.seconds:.2f} s{where})", file=sys.stderr)
            bar.update(1)
        interrupted = False
    finally:
        rendering.close()   # a cluster's tasks cancelled and the cluster stopped now, not later
        bar.close()
        if interrupted and interrupt.requested():
            # counted on disk: a worker may have written a scene whose result had not come back
            whole = sum(all(p.exists() for p in outputs) for _, outputs in planned)
            interrupt.tell(f"the images of {whole} of {len(planned)} scenes are in {args.output}; "
                           "run it again to render the rest")
            if args.stats:
                with interrupt.deferred():
                    write_text(args.stats,
                               json.dumps(tally.json(interrupted=True), indent=2) + "\n")
    failed = tally.count("failed")
    if args.stats:
        write_text(args.stats, json.dumps(tally.json(), indent=2) + "\n")
    print(tally.line(args.output), file=sys.stderr)
    if args.video:
        if failed:
            print(f"whitted: no video: {failed} scene{'s' if failed > 1 else ''} failed",
                  file=sys.stderr)
        else:
            from .video import write_video
            write_video(args.video, [outputs[0] for _, outputs in planned], args.fps,
                        progress=not args.quiet)
            print(f"whitted: wrote {args.video} ({len(planned)} frames at {args.fps:g} fps)",
                  file=sys.stderr)
    return EXIT_USER_ERROR if failed else 0
