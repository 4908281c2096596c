"""``contact_sheet.png``: a thumbnail of every render beside the reference, with its error
and time; and :func:`thumbnail`, kept with each measurement instead of its image.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .plot import save_figure
from .results import WHITTED_LIGHTING, WHITTED_METHODS, Measurement, SceneResult, seconds_text

SHEET_NAME = "contact_sheet.png"
THUMBNAIL_WIDTH = 160


def thumbnail(image: np.ndarray, width: int = THUMBNAIL_WIDTH, exposure: float = 0.0,
              view: str = "clip") -> np.ndarray:
    """A small sRGB uint8 copy of a linear image, box-averaged by an integer factor so that
    noise shows as it would at full size."""
    from ..images import to_srgb

    image = np.nan_to_num(np.asarray(image, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    factor = max(1, math.ceil(image.shape[1] / width))
    if factor > 1:
        h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
        h, w = max(h, factor), max(w, factor)
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))
    return to_srgb(np.ascontiguousarray(image, dtype=np.float32), exposure, view)


def contact_sheet(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """One block per scene: the reference and the path tracer's ladder on top, then a row per
    Whitted depth: its spp ladder in article, then in physical lighting."""
    from matplotlib.figure import Figure

    if not entries:
        fig = Figure(figsize=(4, 1))
        fig.text(0.5, 0.5, "nothing rendered within the budget", ha="center", va="center")
        save_figure(fig, path, dpi=100)
        return

    def cell(title: str, m: Measurement | None) -> tuple[str, np.ndarray | None, str]:
        if m is None:
            return title, None, "not rendered"
        return title, m.thumbnail, f"rel {m.rel_mse:.3g} · FLIP {m.flip:.3f}\n{seconds_text(m.seconds)}"

    cell_w = 1.45
    blocks = []
    for entry in entries:
        done = {(m.setting.method, m.setting.max_depth, m.setting.spp): m
                for m in entry.measurements}
        rows = [[(f"reference: path · {entry.reference_spp} spp", entry.reference_thumbnail,
                  "cached" if entry.reference_cached else seconds_text(entry.reference_seconds))]
                + [cell(f"path · {spp} spp", done.get(("path", entry.path_depth, spp)))
                   for spp in entry.path_spp]]
        rows += [[cell(f"{WHITTED_LIGHTING[method]} d{depth} · {spp} spp",
                       done.get((method, depth, spp)))
                  for method in WHITTED_METHODS for spp in entry.whitted_spp]
                 for depth in entry.depths]
        blocks.append((entry, rows, len(rows) * (cell_w * entry.height / entry.width + 0.5) + 0.3))
    columns = max(len(row) for _, rows, _ in blocks for row in rows)
    fig = Figure(figsize=(cell_w * columns, sum(b[2] for b in blocks)), layout="constrained")
    subfigs = fig.subfigures(len(blocks), 1, squeeze=False, height_ratios=[b[2] for b in blocks])
    for (entry, rows, _), subfig in zip(blocks, subfigs[:, 0]):
        subfig.suptitle(f"{entry.name} ({entry.width}×{entry.height}): relative MSE · FLIP against "
                        f"the reference, render time (median of its timed rounds)", fontsize=8)
        axes = subfig.subplots(len(rows), columns, squeeze=False)
        for ax in axes.flat:
            ax.set_axis_off()
        for row, ax_row in zip(rows, axes):
            for (title, image, caption), ax in zip(row, ax_row):
                if image is not None:
                    ax.imshow(image, interpolation="nearest")
                ax.set_title(f"{title}\n{caption}", fontsize=5.5,
                             color="0.5" if image is None else "black")
    save_figure(fig, path, dpi=110)
