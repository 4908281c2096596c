"""Reading and writing images with Mitsuba's ``Bitmap``.

Images in the program are ``float32`` arrays of shape (H, W, 3) holding linear
RGB. EXR files store those values as they are; PNG files store them
sRGB-encoded and clipped to [0, 1] (8 bits per channel), as the scene format's
"Output" section asks. Writing is atomic (:mod:`whitted.atomic`): a failed
write leaves no file behind.

Memory. An image of 16384² pixels is 3 GiB of float32, so writing makes no
whole-image temporary it can avoid: EXR costs one copy (Mitsuba's bitmap),
PNG a quarter of one (the 8-bit image and its bitmap), converted band by band
(:data:`PNG_BAND_ROWS` rows at a time, with Mitsuba's own sRGB conversion).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import WhittedError

FORMATS = (".exr", ".png")
#: rows of a PNG converted to 8-bit sRGB at a time: bounds the conversion's temporaries
PNG_BAND_ROWS = 256


def image_format(path: str | os.PathLike) -> str:
    """The suffix of ``path`` (".exr" or ".png"), or a clear error."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise WhittedError(f"{path}: unsupported image format '{suffix or '(none)'}'; "
                           "use .exr (linear) or .png (sRGB)")
    return suffix


def write_image(path: str | os.PathLike, image, progress: bool = False) -> None:
    """Write a linear RGB image (H, W, 3) as EXR (linear float) or PNG (8-bit sRGB);
    ``progress`` shows the conversion's rows and the writing's time on stderr."""
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
            data = srgb8(pixels, bar.update)
    else:
        data = np.ascontiguousarray(pixels)
    bitmap = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.RGB)
    del data
    with atomic_path(path) as tmp, elapsed(progress, f"writing {name}"):
        try:
            bitmap.write(str(tmp))
        except RuntimeError as error:
            raise WhittedError(f"{path}: could not write the image: {_first_line(error)}") from None


def srgb8(pixels: np.ndarray, rows_done=None) -> np.ndarray:
    """A linear RGB image as 8-bit sRGB (H, W, 3), as PNG files hold it: clipped to [0, 1]
    first (the 8-bit conversion must not wrap or round out-of-range values; NaN is 0),
    then Mitsuba's sRGB conversion, band by band (``rows_done(n)`` after each)."""
    import mitsuba as mi

    out = np.empty(pixels.shape, np.uint8)
    for start in range(0, pixels.shape[0], PNG_BAND_ROWS):
        band = np.nan_to_num(pixels[start:start + PNG_BAND_ROWS])
        np.clip(band, 0.0, 1.0, out=band)
        band = mi.Bitmap(band, pixel_format=mi.Bitmap.PixelFormat.RGB)
        out[start:start + PNG_BAND_ROWS] = np.asarray(
            band.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True))
        if rows_done is not None:
            rows_done(min(PNG_BAND_ROWS, pixels.shape[0] - start))
    return out


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
