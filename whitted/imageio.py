"""Reading and writing images with Mitsuba's ``Bitmap``.

Images in the program are ``float32`` arrays of shape (H, W, 3) holding linear
RGB. EXR files store those values as they are; PNG files store what is displayed
(8-bit sRGB): by default the values clipped to [0, 1] and sRGB-encoded, as the
scene format's "Output" section asks, or with an exposure and a view transform
(:mod:`whitted.display`). Writing is atomic (:mod:`whitted.atomic`): a failed
write leaves no file behind.

Memory. An image of 16384² pixels is 3 GiB of float32, so writing makes no
whole-image temporary it can avoid: EXR costs one copy (Mitsuba's bitmap),
PNG a quarter of one (the 8-bit image and its bitmap), converted band by band
(:data:`whitted.display.BAND_ROWS` rows at a time).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import WhittedError

FORMATS = (".exr", ".png")


def image_format(path: str | os.PathLike) -> str:
    """The suffix of ``path`` (".exr" or ".png"), or a clear error."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise WhittedError(f"{path}: unsupported image format '{suffix or '(none)'}'; "
                           "use .exr (linear) or .png (sRGB)")
    return suffix


def write_image(path: str | os.PathLike, image, progress: bool = False, exposure: float = 0.0,
                view: str = "clip") -> None:
    """Write a linear RGB image (H, W, 3) as EXR (linear float, as it is) or PNG (8-bit sRGB,
    as displayed: ``exposure`` in stops and ``view``, "clip" or "aces", see
    :mod:`whitted.display`; an EXR ignores both); ``progress`` shows the conversion's rows
    and the writing's time on stderr."""
    import mitsuba as mi

    from .atomic import atomic_path
    from .progress import elapsed, progress_bar

    suffix = image_format(path)
    pixels = np.asarray(image, dtype=np.float32)   # no copy of a float32 image
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise WhittedError(f"{path}: expected an (H, W, 3) RGB image, got shape {pixels.shape}")
    name = Path(path).name
    if suffix == ".png":
        with progress_bar(progress, pixels.shape[0], f"encoding {name}", unit="row", unit_scale=False) as bar:
            data = srgb8(pixels, bar.update, exposure=exposure, view=view)
    else:
        data = np.ascontiguousarray(pixels)
    bitmap = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.RGB)
    del data
    with atomic_path(path) as tmp, elapsed(progress, f"writing {name}"):
        try:
            bitmap.write(str(tmp))
        except RuntimeError as error:
            raise WhittedError(f"{path}: could not write the image: {_first_line(error)}") from None


def srgb8(pixels: np.ndarray, rows_done=None, exposure: float = 0.0, view: str = "clip") -> np.ndarray:
    """A linear RGB image as 8-bit sRGB (H, W, 3), as PNG files hold it
    (:func:`whitted.display.to_srgb`; ``rows_done(n)`` after each band of rows)."""
    from .display import to_srgb

    return to_srgb(pixels, exposure=exposure, view=view, rows_done=rows_done)


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read an EXR or PNG as a linear RGB float32 array (H, W, 3); 8-bit sRGB is decoded."""
    import mitsuba as mi

    image_format(path)
    if not Path(path).is_file():
        raise WhittedError(f"{path}: no such image")
    try:
        bitmap = mi.Bitmap(str(path))
    except RuntimeError as error:
        raise WhittedError(f"{path}: could not read the image: {_first_line(error)}") from None
    bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bitmap, dtype=np.float32).reshape(bitmap.height(), bitmap.width(), 3)


def _first_line(error: Exception) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__
