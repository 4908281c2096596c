"""Images: a render's files, and what it looks like on screen. A render is linear radiance
(EXR keeps it); what a person sees (PNG, the compare page) goes through an exposure and a
view, ``clip`` or ``aces`` (docs/display.md), in bands of rows so that a 16384² render
costs no whole-image float temporary.
"""

from __future__ import annotations

import functools
import math
import os
from pathlib import Path

import numpy as np

from .defaults import IMAGE_FORMATS, VIEWS
from .errors import WhittedError, first_line

#: OpenColorIO's built-in config, pinned so an image looks the same whatever OCIO is installed
OCIO_CONFIG = "cg-config-v4.0.0_aces-v2.0_ocio-v2.5"
OCIO_SOURCE = "Linear Rec.709 (sRGB)"     #: the working space of Mitsuba's RGB variants
OCIO_DISPLAY = "sRGB - Display"
OCIO_VIEW = "ACES 2.0 - SDR 100 nits (Rec.709)"
#: What each view is, in words (CLI help, the compare page).
VIEW_NAMES = {"clip": "plain sRGB, clipped to [0, 1]",
              "aces": f"tone-mapped sRGB (OpenColorIO's “{OCIO_VIEW}” view)"}
#: Linear values are capped here before a view (infinity included): no view tells brighter apart.
BRIGHTEST = 1e6
#: The share of pixels a view may clip before :func:`fitting_view` tone-maps instead.
MOST_CLIPPED = 0.01
#: rows converted at a time: bounds the conversion's temporaries
BAND_ROWS = 256


def default_view(integrator: str = "whitted", lighting: str | None = None) -> str:
    """``clip`` for the article's model (its colors are display values), ``aces`` for
    physically lit images (the path tracer, or ``lighting="physical"``)."""
    return "aces" if integrator == "path" or lighting == "physical" else "clip"


def fitting_view(reference, exposure: float = 0.0) -> str:
    """``clip`` while it clips under :data:`MOST_CLIPPED` of ``reference``, else ``aces``."""
    return "clip" if clipped_fraction(to_srgb(reference, exposure, "clip")) < MOST_CLIPPED else "aces"


def view_text(view: str, exposure: float = 0.0, clipped: float = math.nan) -> str:
    """How images are shown, in words, and (given the share of a reference's pixels plain
    sRGB clips) why."""
    text = VIEW_NAMES[view] + (f", exposure {exposure:+g} EV" if exposure else "")
    if math.isfinite(clipped) and view == "aces" and clipped >= MOST_CLIPPED:
        text += f", as plain sRGB would clip {clipped:.0%} of the reference's pixels"
    elif math.isfinite(clipped) and view == "clip":
        text += ", as the reference fits in it" if clipped < MOST_CLIPPED else ""
    return text


def check_view(view) -> str:
    if view not in VIEWS:
        raise WhittedError(f"unknown view '{view}'; choose one of {', '.join(VIEWS)}")
    return view


def check_exposure(exposure) -> float:
    try:
        value = float(exposure)
    except (TypeError, ValueError):
        raise WhittedError(f"exposure must be a number of stops, got {exposure!r}") from None
    if not (math.isfinite(value) and abs(value) <= 64):
        raise WhittedError(f"exposure must be a number of stops in [-64, 64], got {exposure}")
    return value


@functools.lru_cache(maxsize=None)
def _aces_processor():
    import PyOpenColorIO as ocio

    config = ocio.Config.CreateFromBuiltinConfig(OCIO_CONFIG)
    transform = ocio.DisplayViewTransform(src=OCIO_SOURCE, display=OCIO_DISPLAY, view=OCIO_VIEW)
    return config.getProcessor(transform).getDefaultCPUProcessor()


def _exposed(band: np.ndarray, exposure: float) -> np.ndarray:
    """A band of linear RGB (in place) times 2^exposure, in [0, :data:`BRIGHTEST`] (NaN 0)."""
    np.nan_to_num(band, copy=False, nan=0.0)
    if exposure:
        band *= np.float32(2.0 ** exposure)
    return np.clip(band, 0.0, BRIGHTEST, out=band)


def _display_band(band: np.ndarray, exposure: float, view: str, kind: str) -> np.ndarray:
    """A band of linear RGB (in place) as sRGB-encoded display values, ``kind`` "Float32" (in
    [0, 1]) or "UInt8" (``clip``: Mitsuba's own 8-bit encoding, as PNGs were always written)."""
    if view == "clip":
        return _srgb_encoded(np.minimum(_exposed(band, exposure), 1.0, out=band), kind)
    _aces_processor().applyRGB(_exposed(band, exposure))
    band = np.clip(band, 0.0, 1.0, out=band)
    return band if kind == "Float32" else np.rint(band * 255.0)


def _srgb_encoded(band: np.ndarray, kind: str) -> np.ndarray:
    """Linear values in [0, 1] sRGB-encoded by Mitsuba's ``Bitmap`` as ``kind`` ("Float32", "UInt8")."""
    import mitsuba as mi

    bitmap = mi.Bitmap(band, pixel_format=mi.Bitmap.PixelFormat.RGB)
    return np.asarray(bitmap.convert(mi.Bitmap.PixelFormat.RGB, getattr(mi.Struct.Type, kind),
                                     srgb_gamma=True))


def _rgb_pixels(image, where: str = "") -> np.ndarray:
    """``image`` as float32 (a float32 one not copied); an error unless it is (H, W, 3)."""
    pixels = np.asarray(image, dtype=np.float32)
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise WhittedError(f"{where}expected an (H, W, 3) RGB image, got shape {pixels.shape}")
    return pixels


def _banded(image, exposure, view, kind, rows_done=None) -> np.ndarray:
    """:func:`_display_band` of each band of rows of a linear RGB image."""
    pixels, exposure, view = _rgb_pixels(image), check_exposure(exposure), check_view(view)
    out = np.empty(pixels.shape, np.float32 if kind == "Float32" else np.uint8)
    for start in range(0, pixels.shape[0], BAND_ROWS):
        band = np.array(pixels[start:start + BAND_ROWS], dtype=np.float32)
        out[start:start + BAND_ROWS] = _display_band(band, exposure, view, kind)
        if rows_done is not None:
            rows_done(band.shape[0])
    return out


def to_display(image, exposure: float = 0.0, view: str = "clip") -> np.ndarray:
    """A linear RGB image as sRGB-encoded float32 in [0, 1]: what FLIP scores, to_srgb rounds."""
    return _banded(image, exposure, view, "Float32")


def to_srgb(image, exposure: float = 0.0, view: str = "clip", rows_done=None) -> np.ndarray:
    """A linear RGB image as the 8-bit sRGB a PNG holds; ``rows_done(n)`` after each band."""
    return _banded(image, exposure, view, "UInt8", rows_done)


def clipped_fraction(srgb8: np.ndarray) -> float:
    """The share of pixels with a channel at full scale (255): what a view has clipped."""
    return float(np.mean(np.any(np.asarray(srgb8) >= 255, axis=-1)))


def image_format(path: str | os.PathLike) -> str:
    """The suffix of ``path`` (".exr" or ".png"), or a clear error."""
    suffix = Path(path).suffix.lower()
    if suffix[1:] not in IMAGE_FORMATS:
        raise WhittedError(f"{path}: unsupported image format '{suffix or '(none)'}'; "
                           "use .exr (linear) or .png (sRGB)")
    return suffix


def write_image(path: str | os.PathLike, image, progress: bool = False, exposure: float = 0.0,
                view: str = "clip", shown: np.ndarray | None = None) -> None:
    """Write a linear RGB image (H, W, 3) as EXR (linear, ``exposure`` and ``view`` ignored) or
    PNG (8-bit sRGB as displayed); ``progress`` shows the conversion and the writing on stderr;
    ``shown``: the image's :func:`to_display` when already made, whose bits an ``aces`` PNG
    takes without tone-mapping again (``clip`` is Mitsuba's own encoding, of ``image``)."""
    from .progress import progress_bar

    suffix = image_format(path)
    pixels = _rgb_pixels(image, f"{path}: ")
    name = Path(path).name
    if suffix == ".png" and shown is not None and view == "aces":
        data = np.rint(np.asarray(shown, np.float32) * np.float32(255.0)).astype(np.uint8)
    elif suffix == ".png":
        with progress_bar(progress, pixels.shape[0], f"encoding {name}", unit="row", unit_scale=False) as bar:
            data = to_srgb(pixels, exposure, view, rows_done=bar.update)
    else:
        data = np.ascontiguousarray(pixels)
    write_pixels(path, data, progress)


def write_pixels(path: str | os.PathLike, data: np.ndarray, progress: bool = False) -> None:
    """Write RGB pixels (H, W, 3) as they are, atomically: EXR of floats, PNG of 8-bit values."""
    import mitsuba as mi

    from .atomic import atomic_path
    from .progress import elapsed

    bitmap = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.RGB)
    del data
    with atomic_path(path) as tmp, elapsed(progress, f"writing {Path(path).name}"):
        try:
            bitmap.write(str(tmp))
        except RuntimeError as error:
            raise WhittedError(f"{path}: could not write the image: {first_line(error)}") from None


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read an EXR or PNG as a linear RGB float32 array (H, W, 3); 8-bit sRGB is decoded."""
    import mitsuba as mi

    image_format(path)
    if not Path(path).is_file():
        raise WhittedError(f"{path}: no such image")
    try:
        bitmap = mi.Bitmap(str(path))
    except RuntimeError as error:
        raise WhittedError(f"{path}: could not read the image: {first_line(error)}") from None
    bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bitmap, dtype=np.float32).reshape(bitmap.height(), bitmap.width(), 3)
