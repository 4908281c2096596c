"""Frames to an H.264 video in yuv420p (every player reads it) by imageio-ffmpeg's
``ffmpeg``: ``whitted video``, and ``whitted render ... --video``.
"""

from __future__ import annotations

import os
from pathlib import Path

from . import defaults as D
from .errors import WhittedError, first_line

#: the containers written (H.264 in each)
VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov")
#: imageio-ffmpeg's quality, 0 to 10 (its default 5 blurs small frames: 5 levels of 255 off on 40x26)
QUALITY = 8
#: the images a folder of frames stands for, in this order of preference
FRAME_SUFFIXES = (".png", ".exr")


def check_video_path(path: str | os.PathLike) -> Path:
    from .atomic import check_writable
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise WhittedError(f"{path}: unsupported video format '{path.suffix or '(none)'}'; "
                           f"use {', '.join(VIDEO_SUFFIXES)}")
    return check_writable(path)


def check_fps(fps: float) -> float:
    """A rate FFmpeg encodes: from a frame every 1000 s (below about 1e-6 it ends without a
    video, or with an empty file) to 1000 frames a second."""
    if not 1e-3 <= fps <= 1000:
        raise WhittedError(f"--fps must be a number of frames per second in [0.001, 1000], got {fps:g}")
    return float(fps)


def _check_frame(path: Path) -> None:
    if not path.exists() and path.suffix.lower() not in FRAME_SUFFIXES:
        raise WhittedError(f"{path}: no such frame or folder")
    if path.suffix.lower() not in FRAME_SUFFIXES:
        raise WhittedError(f"{path}: not a frame (.png or .exr)")
    if not path.is_file():
        raise WhittedError(f"{path}: no such frame")


def frame_pixels(path: Path):
    """A frame as 8-bit sRGB (H, W, 3): a PNG's own bytes, an EXR encoded as PNGs are."""
    import mitsuba as mi
    import numpy as np

    from .images import read_image, to_srgb
    if path.suffix.lower() == ".exr":
        return to_srgb(read_image(path))
    try:
        bitmap = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8,
                                              srgb_gamma=True)
    except RuntimeError as error:
        raise WhittedError(f"{path}: could not read the frame: {first_line(error)}") from None
    return np.array(bitmap, dtype=np.uint8).reshape(bitmap.height(), bitmap.width(), 3)


def _even(pixels):
    """Pad an odd width or height by one repeated column or row (yuv420p needs even sizes)."""
    import numpy as np
    height, width = pixels.shape[:2]
    return np.pad(pixels, ((0, height % 2), (0, width % 2), (0, 0)), mode="edge")


def write_video(path: str | os.PathLike, frames: list[Path], fps: float = D.DEFAULT_FPS,
                progress: bool = False) -> None:
    """Encode ``frames`` (image files, all of one size) as an H.264 video at ``fps``."""
    import imageio.v2 as iio

    from .atomic import atomic_path
    from .progress import progress_bar

    path = check_video_path(path)
    fps = check_fps(fps)
    size = None
    with atomic_path(path) as tmp, \
            progress_bar(progress, len(frames), f"encoding {path.name}", unit="frame", unit_scale=False) as bar:
        try:
            writer = iio.get_writer(str(tmp), format="FFMPEG", mode="I", fps=fps, codec="libx264",
                                    quality=QUALITY, pixelformat="yuv420p", macro_block_size=1,
                                    ffmpeg_log_level="error",
                                    output_params=["-movflags", "+faststart"]
                                    if path.suffix.lower() in (".mp4", ".mov") else None)
        except (OSError, RuntimeError) as error:
            raise WhittedError(f"{path}: cannot start FFmpeg: {error}") from None
        try:
            for frame in frames:
                pixels = frame_pixels(frame)
                if size is None:
                    size = pixels.shape
                elif pixels.shape != size:
                    raise WhittedError(f"{frame}: a {pixels.shape[1]}x{pixels.shape[0]} frame among "
                                       f"{size[1]}x{size[0]} ones; a video's frames share one size")
                writer.append_data(_even(pixels))
                bar.update(1)
        finally:
            writer.close()


def video_command(args) -> None:
    """``whitted video FRAMES... -o OUT.mp4 [--fps N]``: files as given, a folder's PNGs by
    name (else its EXRs)."""
    from .converter.batch import expand_folders
    check_video_path(args.output)
    check_fps(args.fps)
    frames = expand_folders(args.frames, FRAME_SUFFIXES, ".png or .exr frames", _check_frame)
    if not frames:
        raise WhittedError("no frames given: name .png or .exr files or folders")
    write_video(args.output, frames, args.fps, progress=not args.quiet)
    if args.verbose:
        import sys
        print(f"whitted: wrote {args.output}: {len(frames)} frames at {args.fps:g} fps",
              file=sys.stderr)
