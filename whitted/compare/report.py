"""The outputs of ``whitted compare``: results CSV, error-against-time plots, contact
sheet, the text summary (floors, what the error is made of, equal quality, equal time),
``findings.json`` (the same conclusions for scripts) and, through :mod:`.page`, the HTML
report that shows them all. An interrupted run's summary, findings and page say so first.

Every file is written atomically (whitted.atomic). Figures use matplotlib's
object API with the Agg canvas, never pyplot's global state.

How to read ``error_vs_time.png``: one row per scene, relative MSE on the left
and FLIP on the right, against the render time (the fastest repeat, compilation
excluded; the bars reach to the slowest repeat), both axes logarithmic. Each method
has one color; its faint dots are every setting that was rendered, and its line
joins the settings that no faster setting of the same method beats (its Pareto
front): the best error that method buys for a given time. Only the front's points
are labelled (``d3·4``: depth 3 at 4 spp; ``64``: the path tracer at 64 spp), each
label placed where it overlaps no other label, point or line, and dropped when no place
is free. A curve
that flattens is a bias showing: more samples or depth no longer bring the image
closer to the reference. The dashed line is the reference's own noise (estimated
from its two independent halves, :func:`~whitted.compare.curves.reference_noise`):
no render can measurably score below it.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np

from ..atomic import atomic_path, write_text
from .analysis import (METHOD_NAMES, TIMING, Analysis, analyse, equal_time_how, reach_text,
                       speedup_text)
from .curves import pareto_front
from .results import METHODS, WHITTED_LIGHTING, WHITTED_METHODS, Measurement, SceneResult, seconds_text

#: The CSV's columns; new ones are added at the end, so that readers of the old keep working.
CSV_COLUMNS = ("scene", "method", "integrator", "lighting", "spp", "max_depth", "seconds",
               "compile_seconds", "rel_mse", "flip", "repeats", "width", "height", "variant",
               "reference_spp", "seconds_min", "seconds_max", "seconds_each", "image", "image_png",
               "error_map", "reference_noise", "worker", "rel_mse_limit")
CSV_NAME = "results.csv"
FINDINGS_NAME = "findings.json"
PLOT_NAME = "error_vs_time.png"
SHEET_NAME = "contact_sheet.png"
SUMMARY_NAME = "summary.txt"
PAGE_NAME = "report.html"
#: each scene's own plot, for the page, relative to the output folder
SCENE_PLOT = "{folder}/error_vs_time.png"

COLORS = {"whitted-article": "#1f77b4", "whitted-physical": "#ff7f0e", "path": "#2ca02c"}
MARKERS = {"whitted-article": "o", "whitted-physical": "s", "path": "^"}
THUMBNAIL_WIDTH = 160


# --------------------------------------------------------------------------- images


def thumbnail(image: np.ndarray, width: int = THUMBNAIL_WIDTH) -> np.ndarray:
    """A small sRGB uint8 copy of a linear image: box-averaged by an integer factor so
    that noise shows as it would at full size on average, then encoded by Mitsuba."""
    from ..imageio import srgb8

    image = np.nan_to_num(np.asarray(image, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    factor = max(1, math.ceil(image.shape[1] / width))
    if factor > 1:
        h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
        h, w = max(h, factor), max(w, factor)
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))
    return srgb8(np.ascontiguousarray(image, dtype=np.float32))


# --------------------------------------------------------------------------- CSV


def _row(entry: SceneResult, m: Measurement) -> dict:
    s = m.setting
    return {"scene": entry.name, "method": s.method, "integrator": s.integrator,
            "lighting": s.lighting, "spp": s.spp, "max_depth": s.max_depth,
            "seconds": f"{m.seconds:.6g}", "compile_seconds": f"{m.compile_seconds:.6g}",
            "rel_mse": f"{m.rel_mse:.6g}", "flip": f"{m.flip:.6g}", "repeats": m.repeats,
            "width": entry.width, "height": entry.height, "variant": entry.variant,
            "reference_spp": entry.reference_spp, "seconds_min": f"{m.seconds_min:.6g}",
            "seconds_max": f"{m.seconds_max:.6g}",
            "seconds_each": ";".join(f"{t:.6g}" for t in m.times),
            "image": m.image or "", "image_png": m.image_png or "", "error_map": m.error_map or "",
            "reference_noise": f"{entry.reference_noise:.6g}", "worker": entry.worker,
            "rel_mse_limit": f"{m.rel_mse_limit:.6g}" if math.isfinite(m.rel_mse_limit) else ""}


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


def _usable(value: float) -> bool:
    return math.isfinite(value) and value > 0


#: Where a label may go around its point (offset in points, alignment), tried in order.
LABEL_PLACES = ((4, 3, "left", "bottom"), (4, -3, "left", "top"), (-4, 3, "right", "bottom"),
                (-4, -3, "right", "top"), (0, 7, "center", "bottom"), (0, -7, "center", "top"),
                (10, 0, "left", "center"), (-10, 0, "right", "center"))


#: Display pixels kept free around a label, so that two labels never read as one.
LABEL_GAP = 3


def line_boxes(ax, line: list[tuple[float, float]], step: float = 3.0) -> list:
    """Small display-space boxes along a polyline of data points (one every ``step``
    pixels), so that labels keep off the lines drawn, not only off their points."""
    from matplotlib.transforms import Bbox

    points = [ax.transData.transform(p) for p in line]
    boxes = []
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        count = max(1, int(math.hypot(x1 - x0, y1 - y0) / step))
        for k in range(count + 1):
            x, y = x0 + (x1 - x0) * k / count, y0 + (y1 - y0) * k / count
            boxes.append(Bbox.from_extents(x - 1, y - 1, x + 1, y + 1))
    return boxes


def place_labels(fig, ax, labels: list[tuple[float, float, str, str]], taken: list) -> int:
    """Annotate ``labels`` = [(x, y, text, color)] in ``ax`` where each overlaps neither
    a label placed before, a data point nor anything in ``taken`` (display-space boxes,
    extended in place); a label with no free place is left out. Needs a drawn figure
    (its layout final). Returns how many were placed."""
    from matplotlib.transforms import Bbox

    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed = 0
    for x, y, text, color in labels:
        for dx, dy, ha, va in LABEL_PLACES:
            label = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points",
                                ha=ha, va=va, fontsize=6.5, color=color)
            label.set_in_layout(False)
            box = label.get_window_extent(renderer)
            box = Bbox.from_extents(box.x0 - LABEL_GAP, box.y0 - LABEL_GAP, box.x1 + LABEL_GAP,
                                    box.y1 + LABEL_GAP)
            inside = frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
            if inside and not any(box.overlaps(other) for other in taken):
                taken.append(box)
                placed += 1
                break
            label.remove()
    return placed


def plot_error_vs_time(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    """Error against time, log–log; one row of two panels (rel. MSE, FLIP) per scene."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox

    rows = max(1, len(entries))
    fig = Figure(figsize=(10.0, 4.4 * rows), layout="constrained")
    FigureCanvasAgg(fig)
    if not entries:
        fig.suptitle("nothing rendered within the budget")
    pending = []  # (axes, labels, points, lines): labels are placed once the layout is final
    for entry, subfig in zip(entries, fig.subfigures(rows, 1, squeeze=False)[:, 0]):
        ax_mse, ax_flip = subfig.subplots(1, 2)
        for ax, metric, name in ((ax_mse, "rel_mse", "relative MSE"), (ax_flip, "flip", "FLIP")):
            labels, points, lines = [], [], []
            for method in METHODS:
                ms = [m for m in entry.measurements if m.setting.method == method
                      and _usable(m.seconds) and _usable(getattr(m, metric))]
                if not ms:
                    continue
                color = COLORS[method]
                xs, ys = [m.seconds for m in ms], [getattr(m, metric) for m in ms]
                spread = [[m.seconds - m.seconds_min for m in ms], [m.seconds_max - m.seconds for m in ms]]
                ax.errorbar(xs, ys, xerr=spread, fmt="none", ecolor=color, alpha=0.25, linewidth=0.8)
                ax.scatter(xs, ys, s=12, color=color, alpha=0.3, marker=MARKERS[method], linewidths=0)
                front = pareto_front(list(zip(xs, ys)))
                ax.plot(*zip(*front), color=color, marker=MARKERS[method], markersize=4,
                        label=METHOD_NAMES[method] + f" ({method})")
                by_point = {(m.seconds, getattr(m, metric)): m.setting for m in ms}
                labels += [(x, y, by_point[(x, y)].short_label, color) for x, y in front]
                points += list(zip(xs, ys))
                lines.append(front)
            if metric == "rel_mse" and _usable(entry.reference_noise):
                ax.axhline(entry.reference_noise, color="0.35", linestyle="--", linewidth=0.9,
                           label=f"reference noise ({entry.reference_spp} spp, est. from two halves)")
            ax.set_xscale("log")
            ax.set_yscale("log")
            _time_axis(ax, [x for x, _ in points])
            ax.set_xlabel("render time (fastest repeat; bars: to the slowest)")
            ax.set_ylabel(f"{name} vs reference")
            ax.grid(True, which="both", alpha=0.2)
            pending.append((ax, labels, points, lines))
        ax_mse.set_title(f"{entry.name} ({entry.width}×{entry.height}): relative MSE", fontsize=9)
        ax_flip.set_title(f"{entry.name}: FLIP (as displayed, [0, 1] sRGB)", fontsize=9)
        if entry.measurements:
            subfig.legend(*ax_mse.get_legend_handles_labels(), loc="outside lower center", ncols=2,
                          fontsize=7, title="labels: dDEPTH·SPP (Whitted), SPP (path tracer); "
                          f"reference: path tracer, {entry.reference_spp} spp", title_fontsize=7)
        else:
            ax_mse.text(0.5, 0.5, "no render within the budget", transform=ax_mse.transAxes,
                        ha="center")
    fig.draw_without_rendering()  # the layout is final now: labels can be measured
    fig.set_layout_engine("none")  # and stays so (labels are not part of it): saving is faster
    for ax, labels, points, lines in pending:
        taken = [Bbox.from_extents(px - 3, py - 3, px + 3, py + 3)
                 for px, py in (ax.transData.transform(p) for p in points)]
        taken += [box for line in lines for box in line_boxes(ax, line)]
        place_labels(fig, ax, labels, taken)
    _save(fig, path, dpi=100)


def _time_axis(ax, seconds: list[float]) -> None:
    """Label a log time axis in words (``2 ms``, ``1.5 s``); minor ticks are labelled
    only when the data span less than a decade (else their labels would collide)."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    def label(value, _position=None):
        return seconds_text(value) if value > 0 else ""

    ax.xaxis.set_major_formatter(FuncFormatter(label))
    narrow = seconds and math.log10(max(seconds) / min(seconds)) < 1.0
    ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, p=None: label(v) if _leading(v) in (2, 5) else "")
                                 if narrow else NullFormatter())


def _leading(value: float) -> int:
    """The leading digit of a positive number (2 for 0.0021)."""
    return int(round(value / 10 ** math.floor(math.log10(value) + 1e-9)))


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
        return title, m.thumbnail, f"rel {m.rel_mse:.3g} · FLIP {m.flip:.3f}\n{seconds_text(m.seconds)}"

    rows = [[(f"reference: path · {entry.reference_spp} spp", entry.reference_thumbnail,
              "cached" if entry.reference_cached else seconds_text(entry.reference_seconds))]
            + [cell(f"path · {spp} spp", done.get(("path", entry.path_depth, spp)))
               for spp in entry.path_spp]]
    for depth in entry.depths:
        rows.append([cell(f"{WHITTED_LIGHTING[method]} d{depth} · {spp} spp",
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
                        f"the reference, render time (fastest repeat)", fontsize=8)
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


# --------------------------------------------------------------------------- summary


def _table(rows: list[list[str]], indent: str = "  ") -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return [indent + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]


def equal_quality_lines(analysis: Analysis) -> list[str]:
    methods = analysis.table_methods
    whitted = [m for m in WHITTED_METHODS if m in methods]
    header = (["rel_mse ≤"] + methods + ["fastest"]
              + [f"{WHITTED_LIGHTING[m]} vs path" for m in whitted])
    rows = [header]
    for row in analysis.equal_quality:
        rows.append([f"{row.level:g}"] + [reach_text(row.reach.get(m)) for m in methods]
                    + [row.fastest_method or "none"] + [speedup_text(row, m) for m in whitted])
    return _table(rows)


def equal_time_lines(analysis: Analysis) -> list[str]:
    rows = [["method", "setting", "time", "rel_mse", "path rel_mse then", "ratio", "flip",
             "path flip then", "path read"]]
    for row in analysis.equal_time:
        m = row.whitted
        compared = row.rel_mse is not None and row.outside is None
        rows.append([m.setting.method, m.setting.label, seconds_text(m.seconds), f"{m.rel_mse:.3g}",
                     f"{row.rel_mse.value:.3g}" if compared else "—",
                     f"{row.ratio:.3g}" if math.isfinite(row.ratio) else "—", f"{m.flip:.3g}",
                     f"{row.flip.value:.3g}" if compared and row.flip else "—", equal_time_how(row)])
    return _table(rows)


def interruption_text(done: int, planned: int) -> str:
    """What an interrupted run's outputs say first."""
    if done == 0:
        return "Interrupted before any render was done: nothing was measured."
    return f"Interrupted after {done} of {planned} renders; the conclusions are drawn from those."


def summary(analyses: list[Analysis], equal_time: bool = True,
            interrupted: tuple[int, int] | None = None) -> str:
    """The summary in text: per scene, what the budget did, the floors and what the error is
    made of in words, the equal-quality table and (with ``equal_time``) the equal-time
    table; an interrupted run (``interrupted`` = (renders done, planned)) says so first."""
    lines = [interruption_text(*interrupted), ""] if interrupted else []
    lines += [f"Relative MSE and FLIP against the path-traced reference; render times are {TIMING}."]
    for analysis in analyses:
        entry = analysis.entry
        noise = (f", its noise ≈ {entry.reference_noise:.3g}" if _usable(entry.reference_noise)
                 else "")
        lines += ["", f"{entry.name} ({entry.width}×{entry.height}; reference: path tracer, "
                      f"{entry.reference_spp} spp{noise})"]
        lines += [f"  note: {note}" for note in entry.notes]
        lines += [f"  {floor.text}" for floor in analysis.floors]
        lines += [f"  {decomposition.text}" for decomposition in analysis.decompositions]
        if analysis.equal_quality and entry.measurements:
            lines += ["", "  Equal quality: the cheapest render reaching each error level (a method "
                          "that never does shows its best):"]
            lines += equal_quality_lines(analysis)
        if equal_time and analysis.equal_time:
            lines += ["", "  Equal time: each Whitted render beside the path tracer given its time "
                          "(read on the path tracer's log–log curve, only within its rendered range):"]
            lines += equal_time_lines(analysis)
    return "\n".join(lines)


def findings(analyses: list[Analysis], interrupted: tuple[int, int] | None = None) -> dict:
    """The run's conclusions as plain JSON data: ``findings.json`` (docs/compare.md)."""
    return {"interrupted": ({"renders_done": interrupted[0], "renders_planned": interrupted[1],
                             "text": interruption_text(*interrupted)} if interrupted else None),
            "timing": f"seconds are {TIMING}",
            "scenes": {a.entry.name: a.findings() for a in analyses}}


# --------------------------------------------------------------------------- all


def write_all(out: str | os.PathLike, entries: list[SceneResult], levels: tuple[float, ...] | None,
              interrupted: tuple[int, int] | None = None) -> list[Analysis]:
    """Every output for ``entries``: the CSV, the plots, the contact sheet, ``summary.txt``,
    ``findings.json`` and ``report.html``, of the scenes that got a reference (the page
    also lists the others, with the reason); ``levels`` None: from each scene's data;
    ``interrupted``: (renders done, renders planned) of a run that was stopped, said at
    the top of the summary, the findings and the page. Returns the analyses."""
    from .page import write_page

    out = Path(out)
    left_out = [e for e in entries if e.reference_thumbnail is None]
    entries = [e for e in entries if e.reference_thumbnail is not None]
    analyses = [analyse(entry, levels) for entry in entries]
    write_csv(out / CSV_NAME, entries)
    plots = {}
    for entry in entries:
        plots[entry.name] = SCENE_PLOT.format(folder=entry.folder)
        (out / plots[entry.name]).parent.mkdir(parents=True, exist_ok=True)
        plot_error_vs_time(out / plots[entry.name], [entry])
    if len(entries) == 1:  # the whole run's plot is the scene's
        with atomic_path(out / PLOT_NAME) as tmp:
            shutil.copyfile(out / plots[entries[0].name], tmp)
    else:
        plot_error_vs_time(out / PLOT_NAME, entries)
    contact_sheet(out / SHEET_NAME, entries)
    write_text(out / SUMMARY_NAME, summary(analyses, interrupted=interrupted) + "\n")
    write_text(out / FINDINGS_NAME, json.dumps(_json_safe(findings(analyses, interrupted)), indent=2,
                                               allow_nan=False) + "\n")
    write_page(out / PAGE_NAME, analyses, plots, {"csv": CSV_NAME, "plot": PLOT_NAME,
                                                   "sheet": SHEET_NAME, "summary": SUMMARY_NAME,
                                                   "findings": FINDINGS_NAME},
               left_out, interruption_text(*interrupted) if interrupted else None)
    return analyses


def _json_safe(value):
    """``value`` with every non-finite number (NaN: not measured) as None: JSON has no NaN."""
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def output_files(out: str | os.PathLike) -> str:
    out = Path(out)
    return ", ".join(str(out / name) for name in (PAGE_NAME, SUMMARY_NAME, FINDINGS_NAME, CSV_NAME,
                                                  PLOT_NAME, SHEET_NAME))
