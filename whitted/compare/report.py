"""The outputs of ``whitted compare``: results CSV, error-against-time plot, contact
sheet and the summary table of which method reaches an error level fastest.

Every file is written atomically (whitted.atomic). Figures use matplotlib's
object API with the Agg canvas, never pyplot's global state.

How to read ``error_vs_time.png``: one row per scene, relative MSE on the left
and FLIP on the right, against the median render time (compilation excluded),
both axes logarithmic. Each method has one colour; its faint dots are every
setting that was rendered, and its line joins the settings that no faster
setting of the same method beats (its Pareto front): the best error that method
buys for a given time. A curve that flattens is a bias showing: more samples or
depth no longer bring the image closer to the reference.
"""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

import numpy as np

from ..atomic import atomic_path, write_text
from .results import METHODS, WHITTED_METHODS, Measurement, SceneResult

CSV_COLUMNS = ("scene", "method", "integrator", "lighting", "spp", "max_depth", "seconds",
               "compile_seconds", "rel_mse", "flip", "repeats", "width", "height", "variant",
               "reference_spp")
CSV_NAME = "results.csv"
PLOT_NAME = "error_vs_time.png"
SHEET_NAME = "contact_sheet.png"

COLOURS = {"whitted-article": "#1f77b4", "whitted-physical": "#ff7f0e", "path": "#2ca02c"}
MARKERS = {"whitted-article": "o", "whitted-physical": "s", "path": "^"}
THUMBNAIL_WIDTH = 160


# --------------------------------------------------------------------------- images


def thumbnail(image: np.ndarray, width: int = THUMBNAIL_WIDTH) -> np.ndarray:
    """A small sRGB uint8 copy of a linear image: box-averaged by an integer factor so
    that noise shows as it would at full size on average, then encoded by Mitsuba."""
    import mitsuba as mi

    image = np.nan_to_num(np.asarray(image, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    factor = max(1, math.ceil(image.shape[1] / width))
    if factor > 1:
        h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
        h, w = max(h, factor), max(w, factor)
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))
    bitmap = mi.Bitmap(np.ascontiguousarray(np.clip(image, 0.0, 1.0), dtype=np.float32))
    return np.array(bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True))


# --------------------------------------------------------------------------- CSV


def _row(entry: SceneResult, m: Measurement) -> dict:
    s = m.setting
    return {"scene": entry.name, "method": s.method, "integrator": s.integrator,
            "lighting": s.lighting, "spp": s.spp, "max_depth": s.max_depth,
            "seconds": f"{m.seconds:.6g}", "compile_seconds": f"{m.compile_seconds:.6g}",
            "rel_mse": f"{m.rel_mse:.6g}", "flip": f"{m.flip:.6g}", "repeats": m.repeats,
            "width": entry.width, "height": entry.height, "variant": entry.variant,
            "reference_spp": entry.reference_spp}


def write_csv(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """One row per render that was done (skipped ones are absent)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for entry in entries:
        for m in entry.measurements:
            writer.writerow(_row(entry, m))
    write_text(path, buffer.getvalue())


# --------------------------------------------------------------------------- plot


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The (time, error) points that no faster point beats, by increasing time."""
    front, best = [], math.inf
    for seconds, error in sorted(points):
        if error < best:
            front.append((seconds, error))
            best = error
    return front


def _crowded(point: tuple[float, float], labelled: list[tuple[float, float]]) -> bool:
    """Whether a label at ``point`` would overlap one already placed (log–log axes)."""
    x, y = math.log10(point[0]), math.log10(point[1])
    return any(abs(x - math.log10(a)) < 0.2 and abs(y - math.log10(b)) < 0.08 for a, b in labelled)


def _usable(value: float) -> bool:
    return math.isfinite(value) and value > 0


def plot_error_vs_time(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """Error against time, log–log; one row of two panels (rel. MSE, FLIP) per scene."""
    from matplotlib.figure import Figure

    rows = max(1, len(entries))
    fig = Figure(figsize=(9.0, 3.4 * rows), layout="constrained")
    axes = fig.subplots(rows, 2, squeeze=False)
    if not entries:
        fig.suptitle("nothing rendered within the budget")
    for entry, (ax_mse, ax_flip) in zip(entries, axes):
        for ax, metric, name in ((ax_mse, "rel_mse", "relative MSE"), (ax_flip, "flip", "FLIP")):
            labelled: list[tuple[float, float]] = []
            for method in METHODS:
                ms = [m for m in entry.measurements if m.setting.method == method
                      and _usable(m.seconds) and _usable(getattr(m, metric))]
                if not ms:
                    continue
                colour = COLOURS[method]
                ax.scatter([m.seconds for m in ms], [getattr(m, metric) for m in ms], s=12,
                           color=colour, alpha=0.3, marker=MARKERS[method], linewidths=0)
                front = pareto_front([(m.seconds, getattr(m, metric)) for m in ms])
                ax.plot(*zip(*front), color=colour, marker=MARKERS[method], markersize=4,
                        label=method)
                by_point = {(m.seconds, getattr(m, metric)): m.setting for m in ms}
                for point in front:
                    if _crowded(point, labelled):
                        continue
                    labelled.append(point)
                    setting = by_point[point]
                    text = (f"{setting.spp}" if setting.integrator == "path"
                            else f"d{setting.max_depth}" + (f"×{setting.spp}" if setting.spp > 1 else ""))
                    ax.annotate(text, point, textcoords="offset points", xytext=(3, 3),
                                fontsize=6, color=colour)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("render time (s, median, compilation excluded)")
            ax.set_ylabel(f"{name} vs reference")
            ax.grid(True, which="both", alpha=0.2)
        ax_mse.set_title(f"{entry.name} ({entry.width}×{entry.height}): relative MSE", fontsize=9)
        ax_flip.set_title(f"{entry.name}: FLIP (as displayed, [0, 1] sRGB)", fontsize=9)
        if entry.measurements:
            ax_mse.legend(loc="lower left", fontsize=7,
                          title=f"reference: path, {entry.reference_spp} spp",
                          title_fontsize=7)
        else:
            ax_mse.text(0.5, 0.5, "no render within the budget", transform=ax_mse.transAxes,
                        ha="center")
    _save(fig, path, dpi=100)


def _save(fig, path: str | os.PathLike, dpi: int) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)


# --------------------------------------------------------------------------- contact sheet


def _sheet_rows(entry: SceneResult) -> list[list[tuple[str, np.ndarray | None, str]]]:
    """The cells (title, thumbnail or None, caption) of one scene's block, row by row:
    the reference and the path tracer's ladder first, then one row per depth with the
    Whitted integrator's spp ladder in article lighting, then in physical lighting."""
    done = {(m.setting.method, m.setting.max_depth, m.setting.spp): m for m in entry.measurements}

    def cell(title: str, m: Measurement | None) -> tuple[str, np.ndarray | None, str]:
        if m is None:
            return title, None, "not rendered"
        return title, m.thumbnail, f"rel {m.rel_mse:.3g} · FLIP {m.flip:.3f}\n{_seconds(m.seconds)}"

    rows = [[(f"reference: path · {entry.reference_spp} spp", entry.reference_thumbnail,
              "cached" if entry.reference_cached else _seconds(entry.reference_seconds))]
            + [cell(f"path · {spp} spp", done.get(("path", entry.path_depth, spp)))
               for spp in entry.path_spp]]
    for depth in entry.depths:
        rows.append([cell(f"{method.split('-')[1]} d{depth} · {spp} spp",
                          done.get((method, depth, spp)))
                     for method in WHITTED_METHODS for spp in entry.whitted_spp])
    return rows


def contact_sheet(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """Thumbnails of every render beside the reference, each with its error and time.

    One block per scene: the reference and the path tracer's spp ladder on top,
    then a row per Whitted max depth: its spp ladder in article lighting, then in
    physical lighting.
    """
    from matplotlib.figure import Figure

    if not entries:
        fig = Figure(figsize=(4, 1))
        fig.text(0.5, 0.5, "nothing rendered within the budget", ha="center", va="center")
        _save(fig, path, dpi=100)
        return
    cell_w = 1.45
    blocks = []
    for entry in entries:
        rows = _sheet_rows(entry)
        aspect = entry.height / entry.width
        blocks.append((entry, rows, len(rows) * (cell_w * aspect + 0.5) + 0.3))
    columns = max(len(row) for _, rows, _ in blocks for row in rows)
    fig = Figure(figsize=(cell_w * columns, sum(b[2] for b in blocks)), layout="constrained")
    subfigs = fig.subfigures(len(blocks), 1, squeeze=False, height_ratios=[b[2] for b in blocks])
    for (entry, rows, _), subfig in zip(blocks, subfigs[:, 0]):
        subfig.suptitle(f"{entry.name} ({entry.width}×{entry.height}): relative MSE · FLIP against "
                        f"the reference, median render time", fontsize=8)
        axes = subfig.subplots(len(rows), columns, squeeze=False)
        for ax in axes.flat:
            ax.set_axis_off()
        for row, ax_row in zip(rows, axes):
            for (title, image, caption), ax in zip(row, ax_row):
                if image is not None:
                    ax.imshow(image, interpolation="nearest")
                ax.set_title(f"{title}\n{caption}", fontsize=5.5,
                             color="0.5" if image is None else "black")
    _save(fig, path, dpi=110)


def _seconds(value: float) -> str:
    if not math.isfinite(value):
        return "time unknown"
    return f"{value * 1000:.1f} ms" if value < 1 else f"{value:.2f} s"


# --------------------------------------------------------------------------- summary


def fastest_table(entries: list[SceneResult], levels: tuple[float, ...]) -> str:
    """For each scene and error level (relative MSE), each method's fastest render
    reaching it; the last column names the fastest method."""
    methods = list(METHODS)
    lines = ["Fastest render reaching each error level (relative MSE against the path-traced "
             "reference; median time, compilation excluded):"]
    for entry in entries:
        lines.append("")
        lines.append(f"{entry.name} ({entry.width}×{entry.height}, reference {entry.reference_spp} spp)")
        header = ["rel_mse ≤"] + methods + ["fastest"]
        table = [header]
        for level in levels:
            row, best = [f"{level:g}"], None
            for method in methods:
                hits = [m for m in entry.measurements
                        if m.setting.method == method and m.rel_mse <= level]
                if not hits:
                    row.append("—")
                    continue
                fastest = min(hits, key=lambda m: m.seconds)
                row.append(f"{_seconds(fastest.seconds)} ({fastest.setting.label})")
                if best is None or fastest.seconds < best.seconds:
                    best = fastest
            row.append(best.setting.method if best else "none")
            table.append(row)
        widths = [max(len(r[i]) for r in table) for i in range(len(header))]
        for r in table:
            lines.append("  " + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip())
        if entry.skipped:
            why = "budget" if entry.reference_file else "budget; no time was left for its reference"
            lines.append(f"  ({len(entry.skipped)} renders skipped: {why})")
    return "\n".join(lines)


# --------------------------------------------------------------------------- all


def write_all(out: str | os.PathLike, entries: list[SceneResult]) -> None:
    out = Path(out)
    write_csv(out / CSV_NAME, entries)
    plot_error_vs_time(out / PLOT_NAME, entries)
    contact_sheet(out / SHEET_NAME, entries)


def output_files(out: str | os.PathLike) -> str:
    out = Path(out)
    return ", ".join(str(out / name) for name in (CSV_NAME, PLOT_NAME, SHEET_NAME))
