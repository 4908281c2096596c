"""The images kept of every render and shown of it: the render itself (linear EXR, sRGB PNG)
and FLIP's error map in :data:`COLORMAP`, as FLIP draws it (:func:`colorbar` gives the page
the same colors, so that map and scale cannot disagree); :func:`thumbnail`, kept with each
measurement instead of its image; and ``contact_sheet.png``, a thumbnail of every render
beside the reference with its error and time: one canvas of pixels, each thumbnail enlarged
by a whole factor (pixels stay square, colors exact) and its captions drawn above it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..images import to_srgb, write_image, write_pixels
from .analysis import modelled_path
from .plot import save_figure
from .results import WHITTED_LIGHTING, WHITTED_METHODS, Measurement, SceneResult, seconds_text

SHEET_NAME = "contact_sheet.png"
THUMBNAIL_WIDTH = 160
#: The sheet's resolution, and in its pixels: a cell's caption (three lines), the space
#: around cells and a scene's title line.
SHEET_DPI = 110
CAPTION_HEIGHT = 32
GAP = 6
TITLE_HEIGHT = 20
CAPTION_SIZE = 5.5
TITLE_SIZE = 8
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
    (out / stem).parent.mkdir(parents=True, exist_ok=True)
    files = {"image": f"{stem}.exr", "image_png": f"{stem}.png"}
    write_image(out / files["image"], image)
    write_image(out / files["image_png"], image, exposure=exposure, view=view, shown=shown)
    if error_map is not None:   # as FLIP draws it: display colors, no transfer curve
        import matplotlib

        files["error_map"] = f"{stem}-flip.png"
        values = np.clip(np.nan_to_num(np.asarray(error_map, dtype=np.float64)), 0.0, 1.0)
        colors = np.round(matplotlib.colormaps[COLORMAP](values)[..., :3] * 255.0).astype(np.uint8)
        write_pixels(out / files["error_map"], colors)
    return files


def thumbnail(image: np.ndarray, exposure: float = 0.0, view: str = "clip") -> np.ndarray:
    """A small sRGB uint8 copy of a linear image, box-averaged by an integer factor so that
    noise shows as it would at full size."""
    image = np.nan_to_num(np.asarray(image, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    factor = max(1, math.ceil(image.shape[1] / THUMBNAIL_WIDTH))
    if factor > 1:
        h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
        h, w = max(h, factor), max(w, factor)
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))
    return to_srgb(np.ascontiguousarray(image, dtype=np.float32), exposure, view)


def _cell(title: str, m: Measurement | None) -> tuple[str, np.ndarray | None, str]:
    """(title, thumbnail, caption) of a render; one read from the path tracer's fitted curve
    says so, with the error and time read there."""
    if m is None:
        return title, None, "not rendered"
    if m.modelled:
        return title, None, (f"fitted curve, not rendered\n"
                             f"rel {m.rel_mse:.3g} · {seconds_text(m.seconds)}")
    return title, m.thumbnail, (f"rel {m.rel_mse:.3g} · FLIP {m.flip:.3f}\n"
                                f"{seconds_text(m.seconds)}")


def _rows(entry: SceneResult) -> list[list[tuple[str, np.ndarray | None, str]]]:
    """The reference and the path tracer's ladder, then a row per Whitted depth: its spp
    ladder in article, then in physical lighting."""
    done = {(m.setting.method, m.setting.max_depth, m.setting.spp): m
            for m in entry.measurements + modelled_path(entry)}
    rows = [[(f"reference: path · {entry.reference_spp} spp", entry.reference_thumbnail,
              "cached" if entry.reference_cached else seconds_text(entry.reference_seconds))]
            + [_cell(f"path · {spp} spp", done.get(("path", entry.path_depth, spp)))
               for spp in entry.path_spp]]
    return rows + [[_cell(f"{WHITTED_LIGHTING[method]} d{depth} · {spp} spp",
                          done.get((method, depth, spp)))
                    for method in WHITTED_METHODS for spp in entry.whitted_spp]
                   for depth in entry.depths]


def _enlarged(image: np.ndarray) -> np.ndarray:
    """A thumbnail at most :data:`THUMBNAIL_WIDTH` wide, enlarged by a whole factor towards it."""
    factor = max(1, THUMBNAIL_WIDTH // image.shape[1])
    return np.repeat(np.repeat(image, factor, axis=0), factor, axis=1)[:, :THUMBNAIL_WIDTH]


def contact_sheet(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """One block per scene, a row of cells per line of :func:`_rows`; every thumbnail of a
    scene has its reference's size."""
    from matplotlib.figure import Figure

    if not entries:
        fig = Figure(figsize=(4, 1))
        fig.text(0.5, 0.5, "nothing rendered within the budget", ha="center", va="center")
        save_figure(fig, path, dpi=100)
        return
    blocks = [(entry, _rows(entry), _enlarged(entry.reference_thumbnail).shape[0])
              for entry in entries]
    columns = max(len(row) for _, rows, _ in blocks for row in rows)
    cell = THUMBNAIL_WIDTH + GAP
    width = GAP + columns * cell
    height = sum(TITLE_HEIGHT + len(rows) * (CAPTION_HEIGHT + tall + GAP)
                 for _, rows, tall in blocks)
    canvas = np.full((height, width, 3), 255, np.uint8)
    texts = []   # (x, y, text, size, color) in pixels from the top left
    top = 0
    for entry, rows, tall in blocks:
        texts.append((width / 2, top + 4, f"{entry.name} ({entry.width}×{entry.height}): relative "
                      f"MSE · FLIP against the reference, render time (median of its timed "
                      f"rounds)", TITLE_SIZE, "black"))
        top += TITLE_HEIGHT
        for row in rows:
            for k, (title, image, caption) in enumerate(row):
                left = GAP + k * cell
                texts.append((left + THUMBNAIL_WIDTH / 2, top, f"{title}\n{caption}", CAPTION_SIZE,
                              "0.5" if image is None else "black"))
                if image is not None:
                    shown = _enlarged(image)[:tall]
                    x = left + (THUMBNAIL_WIDTH - shown.shape[1]) // 2
                    y = top + CAPTION_HEIGHT
                    canvas[y:y + shown.shape[0], x:x + shown.shape[1]] = shown[..., :3]
            top += CAPTION_HEIGHT + tall + GAP
    fig = Figure(figsize=(width / SHEET_DPI, height / SHEET_DPI), dpi=SHEET_DPI)
    fig.figimage(canvas, 0, 0, origin="upper", resize=False)
    for x, y, text, size, color in texts:
        fig.text(x / width, 1 - y / height, text, ha="center", va="top", fontsize=size, color=color)
    save_figure(fig, path, dpi=SHEET_DPI)
