"""The images kept of every render: the render itself (linear EXR, sRGB PNG) and FLIP's
per-pixel error map in :data:`COLORMAP`, as FLIP draws it; :func:`colorbar` gives the page
the same colors, so that map and scale cannot disagree.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The error maps' colormap (matplotlib's name), as FLIP draws its maps.
COLORMAP = "magma"


def colorbar(stops: int = 11) -> list[str]:
    """The colormap's colors at ``stops`` evenly spaced values 0…1, as CSS hex colors."""
    import matplotlib

    colormap = matplotlib.colormaps[COLORMAP]
    return [matplotlib.colors.to_hex(colormap(i / (stops - 1))) for i in range(stops)]


def write_render(out: Path, stem: str, image: np.ndarray, shown: np.ndarray,
                 error_map: np.ndarray | None, exposure: float = 0.0, view: str = "clip") -> dict:
    """Keep one render: ``STEM.exr`` (linear), ``STEM.png`` (as displayed: ``shown``, its
    :func:`~whitted.images.to_display`) and its ``STEM-flip.png``; returns their paths
    relative to ``out`` by kind."""
    from ..images import write_image

    (out / stem).parent.mkdir(parents=True, exist_ok=True)
    files = {"image": f"{stem}.exr", "image_png": f"{stem}.png"}
    write_image(out / files["image"], image)
    write_image(out / files["image_png"], image, exposure=exposure, view=view, shown=shown)
    if error_map is not None:   # as FLIP draws it: display colors, no transfer curve
        import matplotlib

        files["error_map"] = f"{stem}-flip.png"
        values = np.clip(np.nan_to_num(np.asarray(error_map, dtype=np.float64)), 0.0, 1.0)
        colors = np.round(matplotlib.colormaps[COLORMAP](values)[..., :3] * 255.0).astype(np.uint8)
        _write_png(out / files["error_map"], colors)
    return files


def _write_png(path: Path, pixels: np.ndarray) -> None:
    """8-bit RGB ``pixels`` as they are, atomically."""
    import mitsuba as mi

    from ..atomic import atomic_path

    bitmap = mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB)
    with atomic_path(path) as tmp:
        bitmap.write(str(tmp))
