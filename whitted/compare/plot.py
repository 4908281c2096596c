"""``error_vs_time.png``: error against render time, one row per scene (and each scene's
own plot, for the page); docs/compare.md, "How to read the plot". Figures use
matplotlib's object API on the Agg canvas, never pyplot's global state.
"""

from __future__ import annotations

import math
import os

from ..atomic import atomic_path
from .analysis import METHOD_NAMES
from .curves import pareto_front
from .results import METHODS, SceneResult, seconds_text

PLOT_NAME = "error_vs_time.png"
#: each scene's own plot, for the page, relative to the output folder
SCENE_PLOT = "{folder}/error_vs_time.png"

#: Each method's colour, here and on the page (``report.html``'s method swatches).
COLORS = {"whitted-article": "#1f77b4", "whitted-physical": "#ff7f0e", "path": "#2ca02c"}
MARKERS = {"whitted-article": "o", "whitted-physical": "s", "path": "^"}
#: Where a label may go around its point (offset in points, alignment), tried in order.
LABEL_PLACES = ((4, 3, "left", "bottom"), (4, -3, "left", "top"), (-4, 3, "right", "bottom"),
                (-4, -3, "right", "top"), (0, 7, "center", "bottom"), (0, -7, "center", "top"),
                (10, 0, "left", "center"), (-10, 0, "right", "center"))
#: Display pixels kept free around a label, so that two labels never read as one.
LABEL_GAP = 3
#: The plot's resolution: its labels are placed at it, so it is saved at it.
FIGURE_DPI = 100
#: Room left above and below the data on the log error axes, as a fraction of their span:
#: the Whitted methods' points sit at the top, and their labels need a place to go.
Y_MARGIN = 0.12


def _usable(value: float) -> bool:
    return math.isfinite(value) and value > 0


def line_boxes(ax, line: list[tuple[float, float]], step: float = 3.0) -> list:
    """Small display-space boxes along a polyline, so that labels keep off the lines drawn."""
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
    """Annotate ``labels`` [(x, y, text, color)] where each overlaps no label placed before
    nor anything in ``taken`` (extended in place), else leave it out; needs a drawn figure."""
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
    save_figure(error_vs_time_figure(entries), path, dpi=FIGURE_DPI)


def error_vs_time_figure(entries: list[SceneResult]):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox

    rows = max(1, len(entries))
    fig = Figure(figsize=(10.0, 4.4 * rows), layout="constrained", dpi=FIGURE_DPI)
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
                spread = [[m.seconds - m.seconds_min for m in ms],
                          [m.seconds_max - m.seconds for m in ms]]
                ax.errorbar(xs, ys, xerr=spread, fmt="none", ecolor=color, alpha=0.25,
                            linewidth=0.8)
                ax.scatter(xs, ys, s=12, color=color, alpha=0.3, marker=MARKERS[method],
                           linewidths=0)
                front = pareto_front(list(zip(xs, ys)))
                ax.plot(*zip(*front), color=color, marker=MARKERS[method], markersize=4,
                        label=METHOD_NAMES[method] + f" ({method})")
                by_point = {(m.seconds, getattr(m, metric)): m.setting for m in ms}
                labels += [(x, y, by_point[(x, y)].short_label, color) for x, y in front]
                points += list(zip(xs, ys))
                lines.append(front)
                # the timing bars too: a label over one would read as part of it
                lines += [[(m.seconds_min, y), (m.seconds_max, y)] for m, y in zip(ms, ys)
                          if m.seconds_max > m.seconds_min]
            if metric == "rel_mse" and _usable(entry.reference_noise):
                ax.axhline(entry.reference_noise, color="0.35", linestyle="--", linewidth=0.9,
                           label=f"reference noise ({entry.reference_spp} spp, est. from two halves)")
            ax.set(xscale="log", yscale="log")
            ax.margins(x=0.06, y=Y_MARGIN)
            _time_axis(ax, [x for x, _ in points])
            ax.set(xlabel="render time (median of rounds; bars: fastest to slowest)",
                   ylabel=f"{name} vs reference")
            ax.grid(True, which="both", alpha=0.2)
            pending.append((ax, labels, points, lines))
        ax_mse.set_title(f"{entry.name} ({entry.width}×{entry.height}): relative MSE", fontsize=9)
        ax_flip.set_title(f"{entry.name}: FLIP (as displayed: {entry.view} view)", fontsize=9)
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
    return fig


def _time_axis(ax, seconds: list[float]) -> None:
    """Label a log time axis in words; minor ticks only when the data span less than a
    decade (else their labels would collide)."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    def label(value, _position=None, minor=False):   # minor ticks: 2 and 5 of each decade
        leading = round(value / 10 ** math.floor(math.log10(value) + 1e-9)) if value > 0 else 0
        return seconds_text(value) if value > 0 and (not minor or leading in (2, 5)) else ""

    ax.xaxis.set_major_formatter(FuncFormatter(label))
    narrow = seconds and math.log10(max(seconds) / min(seconds)) < 1.0
    ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, p=None: label(v, minor=True))
                                 if narrow else NullFormatter())


def save_figure(fig, path: str | os.PathLike, dpi: int) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
