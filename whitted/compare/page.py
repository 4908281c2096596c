"""``report.html``: one static page that opens anywhere, where a render, the reference and
its error map flip in place, every image a file of the output folder by relative path.
The template (``templates/report.html.j2``) shows the rows that summary.txt shows too
(:func:`~whitted.compare.summary.scene_words`), and the images and captions made here.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

from ..atomic import write_text
from ..defaults import VERSION
from ..images import view_text
from ..templates import environment
from .analysis import METHOD_NAMES, TIMING, Analysis
from .curves import pareto_front
from .errormaps import colorbar
from .plot import COLORS
from .results import METHODS, Measurement, SceneResult, seconds_text
from .summary import number, render_cells, scene_words

PAGE_NAME = "report.html"
TEMPLATE = "report.html.j2"
#: The viewer enlarges small images by a whole factor (pixels stay square) to at least this width.
VIEWER_WIDTH = 640


def _render(m: Measurement, index: str, card: bool) -> dict:
    s, cells = m.setting, render_cells(m)
    limit = (f", {number(m.rel_mse_limit)} from its limit"
             if math.isfinite(m.rel_mse_limit) else "")
    return {**cells, "id": index, "method_name": METHOD_NAMES[s.method], "depth": s.max_depth,
            "spp": s.spp, "rounds": m.rounds, "png": m.image_png, "exr": m.image or "",
            "map": m.error_map or m.image_png, "title": f"{s.method} {s.label}", "card": card,
            "caption": f"{METHOD_NAMES[s.method]} ({s.method}), {s.label}: {cells['time']}, "
                       f"relative MSE {cells['rel_mse']}{limit}, FLIP {cells['flip']}"}


def _on_curves(measurements: list[Measurement]) -> set[int]:
    """The renders worth a card (by ``id``): those on their method's Pareto front."""
    chosen = set()
    for method in METHODS:
        ms = [m for m in measurements if m.setting.method == method]
        front = set(pareto_front([(m.seconds, m.rel_mse) for m in ms]))
        chosen |= {id(m) for m in ms if (m.seconds, m.rel_mse) in front}
    return chosen


def scene_context(analysis: Analysis, plot: str, out: Path) -> dict:
    entry = analysis.entry
    key = "".join(c if c.isalnum() else "-" for c in entry.name)   # an HTML id
    order = {m: i for i, m in enumerate(METHODS)}
    measurements = sorted(entry.measurements, key=lambda m: (order[m.setting.method],
                                                             m.setting.max_depth, m.setting.spp))
    cards = _on_curves(measurements) | {id(f.render) for f in analysis.floors}
    renders = [_render(m, f"{key}-{i}", id(m) in cards) for i, m in enumerate(measurements)]
    groups = [{"method": method, "name": METHOD_NAMES[method],
               "renders": [r for r in renders if r["method"] == method]}
              for method in METHODS if any(r["method"] == method for r in renders)]
    # the viewer opens on the article's model at its floor: where it stops improving
    floor_render = analysis.floors[0].render if analysis.floors else None
    first = next((r for r, m in zip(renders, measurements) if m is floor_render),
                 renders[0] if renders else None)
    reference_exr = (os.path.relpath(entry.reference_file, out) if entry.reference_file else None)
    # the first screen: the article's floor render beside the path tracer's nearest in time
    paths = [(r, m) for r, m in zip(renders, measurements)
             if m.setting.method == "path" and m.seconds > 0]
    near = (min(paths, key=lambda p: abs(math.log(p[1].seconds / floor_render.seconds)))[0]
            if paths and floor_render and floor_render.seconds > 0 else None)
    words = scene_words(analysis)
    return {
        **words, "headline": words["verdicts"][0] if words["verdicts"] else None,
        "more": " ".join(words["verdicts"][1:] + [words["scale"]]), "path_near": near, "key": key,
        "display_width": entry.width * max(1, math.ceil(VIEWER_WIDTH / entry.width)),
        "variant": entry.variant, "path_depth": entry.path_depth,
        "reference": {"png": entry.reference_png, "exr": reference_exr, "spp": entry.reference_spp,
                      "requested": entry.reference_requested,
                      "why": "were enough" if entry.reference_enough else "were affordable",
                      "noise": number(entry.reference_noise),
                      "how": ("read from the cache" if entry.reference_cached
                              else f"rendered in {seconds_text(entry.reference_seconds)}")},
        "plot": plot, "groups": groups, "renders": renders, "first": first,
        "cards": [r for r in renders if r["card"]], "skipped": len(entry.skipped),
        "view": view_text(entry.view, entry.exposure, entry.reference_clipped),
    }


def write_page(path: str | os.PathLike, analyses: list[Analysis], plots: dict[str, str],
               files: dict[str, str], left_out: list[SceneResult] = (),
               interrupted: str | None = None) -> None:
    """Write the report page (atomically); ``plots``, ``files``: the outputs relative to its
    folder; ``left_out``: the scenes without a reference."""
    path = Path(path)
    template = environment("whitted.compare").get_template(TEMPLATE)
    text = template.render(
        scenes=[scene_context(a, plots[a.entry.name], path.parent) for a in analyses],
        left_out=[{"name": e.name, "notes": list(e.notes) or ["no reference"]} for e in left_out],
        files=files, colorbar=colorbar(), colors=COLORS, version=VERSION, interrupted=interrupted, timing=TIMING,
        created=time.strftime("%Y-%m-%d %H:%M"))
    write_text(path, text)
