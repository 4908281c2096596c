"""Reading and writing images with Mitsuba's ``Bitmap``.

Images in the program are ``float32`` arrays of shape (H, W, 3) holding linear
RGB. EXR files store those values as they are; PNG files store them
sRGB-encoded and clipped to [0, 1] (8 bits per channel), as the scene format's
"Output" section asks. Writing is atomic (:mod:`whitted.atomic`): a failed
write leaves no file behind.
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


def write_image(path: str | os.PathLike, image) -> None:
    """Write a linear RGB image (H, W, 3) as EXR (linear float) or PNG (8-bit sRGB)."""
    import mitsuba as mi

    from .atomic import atomic_path

    suffix = image_format(path)
    pixels = np.ascontiguousarray(np.asarray(image, dtype=np.float32))
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise WhittedError(f"{path}: expected an (H, W, 3) RGB image, got shape {pixels.shape}")
    bitmap = mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB)
    if suffix == ".png":
        # Clip first: the 8-bit conversion must not wrap or round out-of-range values.
        bitmap = mi.Bitmap(np.clip(np.nan_to_num(pixels), 0.0, 1.0),
                           pixel_format=mi.Bitmap.PixelFormat.RGB)
        bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True)
    with atomic_path(path) as tmp:
        try:
            bitmap.write(str(tmp))
        except RuntimeError as error:
            raise WhittedError(f"{path}: could not write the image: {_first_line(error)}") from None


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
