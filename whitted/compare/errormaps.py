"""The images kept of every render: the render itself (linear EXR, sRGB PNG) and FLIP's
per-pixel error map in :data:`COLORMAP`, as FLIP draws it; :func:`colorbar` gives the page
the same colors, so that map and scale cannot disagree.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

#: The error maps' colormap (matplotlib's name), as FLIP draws its maps.
COLORMAP = "magma"


def colorize(error_map: np.ndarray) -> np.ndarray:
    import matplotlib

    values = np.clip(np.nan_to_num(np.asarray(error_map, dtype=np.float64)), 0.0, 1.0)
    colors = matplotlib.colormaps[COLORMAP](values)[..., :3]
    return np.round(colors * 255.0).astype(np.uint8)


def colorbar(stops: int = 11) -> list[str]:
    """The colormap's colors at ``stops`` evenly spaced values 0…1, as CSS hex colors."""
    import matplotlib

    colormap = matplotlib.colormaps[COLORMAP]
    return [matplotlib.colors.to_hex(colormap(i / (stops - 1))) for i in range(stops)]


def write_display_png(path: str | os.PathLike, pixels: np.ndarray) -> None:
    """Write (H, W, 3) uint8 display colors as a PNG, atomically, with no transfer curve."""
    import mitsuba as mi

    from ..atomic import atomic_path

    bitmap = mi.Bitmap(np.ascontiguousarray(pixels, dtype=np.uint8),
                       pixel_format=mi.Bitmap.PixelFormat.RGB)
    with atomic_path(path) as tmp:
        bitmap.write(str(tmp))


def write_render(out: Path, stem: str, image: np.ndarray, error_map: np.ndarray | None,
                 exposure: float = 0.0, view: str = "clip") -> dict:
    """Keep one render: ``STEM.exr`` (linear), ``STEM.png`` (as displayed) and its
    ``STEM-flip.png``; returns their paths relative to ``out`` by kind."""
    from ..images import write_image

    (out / stem).parent.mkdir(parents=True, exist_ok=True)
    files = {"image": f"{stem}.exr", "image_png": f"{stem}.png"}
    write_image(out / files["image"], image)
    write_image(out / files["image_png"], image, exposure=exposure, view=view)
    if error_map is not None:
        files["error_map"] = f"{stem}-flip.png"
        write_display_png(out / files["error_map"], colorize(error_map))
    return files
