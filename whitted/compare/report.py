"""Every output of ``whitted compare``, written in one go, each file atomically: the words
each scene's :class:`~whitted.compare.analysis.Analysis` says, built once as rows that the
templates of ``summary.txt`` and ``report.html`` render; ``findings.json``; ``results.csv``,
rewritten after every scene so that an interrupted run keeps the scenes that finished.
``report.html`` is one static page that opens anywhere, where a render, the reference and
its error map flip in place, every image a file of the output folder by relative path.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import time
from pathlib import Path

from ..atomic import atomic_path, write_text
from ..defaults import VERSION
from ..images import view_text
from ..templates import environment
from .analysis import (METHOD_NAMES, TIMING, Analysis, analyse, equal_time_how, model_text,
                       ratio_text, reach_text, speedup_text, spread_text)
from .curves import pareto_front
from .plot import COLORS, PLOT_NAME, SCENE_PLOT, plot_error_vs_time
from .results import (METHODS, WHITTED_LIGHTING, WHITTED_METHODS, Measurement, SceneResult,
                      seconds_text)
from .sheet import SHEET_NAME, colorbar, contact_sheet

SUMMARY_NAME = "summary.txt"
FINDINGS_NAME = "findings.json"
PAGE_NAME = "report.html"
CSV_NAME = "results.csv"
#: Every output, by the name the page gives it, in the order the command lists them.
FILES = {"page": PAGE_NAME, "summary": SUMMARY_NAME, "findings": FINDINGS_NAME, "csv": CSV_NAME,
         "plot": PLOT_NAME, "sheet": SHEET_NAME}
#: The CSV's columns; new ones are added at the end, so that readers of the old keep working.
CSV_COLUMNS = ("scene", "method", "integrator", "lighting", "spp", "max_depth", "seconds",
               "compile_seconds", "rel_mse", "flip", "repeats", "width", "height", "variant",
               "reference_spp", "seconds_min", "seconds_max", "seconds_each", "image", "image_png",
               "error_map", "reference_noise", "worker", "rel_mse_limit", "work")
#: The viewer enlarges small images by a whole factor (pixels stay square) to at least this width.
VIEWER_WIDTH = 640


def table(rows: list[list[str]]) -> list[str]:
    """Rows of cells as text lines, each column as wide as its widest cell."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  " + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]


def template(name: str):
    """One of the command's templates, given what words.txt.j2 reads."""
    env = environment("whitted.compare")
    env.globals.update(seconds_text=seconds_text, method_names=METHOD_NAMES)
    return env.get_template(name)


def number(value: float) -> str:
    return f"{value:.3g}" if math.isfinite(value) else "—"


def render_cells(m: Measurement) -> dict:
    """A render's cells, as every table and caption shows them."""
    return {"method": m.setting.method, "label": m.setting.label, "seconds": seconds_text(m.seconds),
            "time": spread_text(m), "rel_mse": number(m.rel_mse), "flip": number(m.flip)}


def equal_time_row(row) -> dict:
    """An equal-time row: its cells, ``line`` those of summary.txt; ``winner``: the more
    accurate method ("" where the interval holds 1 or nothing was compared)."""
    compared, ratio = row.rel_mse is not None and row.outside is None, row.ratio
    straddles = row.interval is not None and row.interval.straddles_one
    winner = "" if straddles or not math.isfinite(ratio) else "whitted" if ratio < 1 else "path"
    cells = {**render_cells(row.whitted), "path_rel_mse": number(row.rel_mse.value) if compared else "—",
             "ratio": ratio_text(row.interval) if math.isfinite(ratio) else "—",
             "path_flip": number(row.flip.value) if compared and row.flip else "—",
             "how": equal_time_how(row)}
    keys = ("method", "label", "seconds", "rel_mse", "path_rel_mse", "ratio", "flip", "path_flip",
            "how")
    return {**cells, "winner": winner, "line": [cells[k] for k in keys]}


def equal_quality_row(row, methods: list[str], whitted: list[str]) -> dict:
    """An equal-quality row: a cell per method, ``line`` summary.txt's."""
    cells = [{"text": reach_text(row.reach.get(m)), "reached": row.reached(m)} for m in methods]
    fastest, speedups = row.fastest_text, [speedup_text(row, m) for m in whitted]
    return {"level": f"{row.level:g}", "cells": cells, "fastest": fastest, "speedups": speedups,
            "line": [f"{row.level:g}", *(c["text"] for c in cells), fastest, *speedups]}


def scene_words(analysis: Analysis) -> dict:
    """What summary.txt and the page say of one scene (both templates read this)."""
    entry = analysis.entry
    noise = entry.reference_noise
    methods = [m for m in METHODS if any(m in row.reach for row in analysis.equal_quality)]
    whitted = [m for m in WHITTED_METHODS if m in methods]
    return {
        "name": entry.name, "width": entry.width, "height": entry.height,
        "notes": list(entry.notes), "reference": {"spp": entry.reference_spp},
        "black": entry.reference_black,
        "statements": analysis.floors,
        "noise": noise if math.isfinite(noise) and noise > 0 else None,
        "floors": ([f.text for f in analysis.floors]
                   + ([model_text(entry)] if entry.path_model else [])),
        "decompositions": [d.text for d in analysis.decompositions],
        "methods": methods, "whitted": [WHITTED_LIGHTING[m] for m in whitted],
        "equal_quality_header": (["rel_mse ≤", *methods, "fastest"]
                                 + [f"{WHITTED_LIGHTING[m]} vs path" for m in whitted]),
        "equal_quality": [equal_quality_row(row, methods, whitted)
                          for row in analysis.equal_quality],
        "equal_time": [equal_time_row(row) for row in analysis.equal_time]}


def interruption_text(done: int, planned: int) -> str:
    if done == 0:
        return "Interrupted before any render was done: nothing was measured."
    return f"Interrupted after {done} of {planned} renders; the conclusions are drawn from those."


def summary(analyses: list[Analysis], equal_time: bool = True,
            interrupted: tuple[int, int] | None = None) -> str:
    """``summary.txt``; ``interrupted``: (renders done, planned) of a stopped run, said first."""
    return template("summary.txt.j2").render(
        scenes=[scene_words(a) for a in analyses], timing=TIMING, equal_time=equal_time,
        table=table,
        interrupted=interruption_text(*interrupted) if interrupted else None).rstrip("\n")


def findings(analyses: list[Analysis], interrupted: tuple[int, int] | None = None) -> dict:
    return {"interrupted": ({"renders_done": interrupted[0], "renders_planned": interrupted[1],
                             "text": interruption_text(*interrupted)} if interrupted else None),
            "timing": f"seconds are {TIMING}",
            "scenes": {a.entry.name: a.findings() for a in analyses}}


def json_safe(value):
    """``value`` with NaN (not measured) as None: JSON has no NaN."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return None if isinstance(value, float) and not math.isfinite(value) else value


def _render(m: Measurement, index: str, card: bool) -> dict:
    s = m.setting
    return {**render_cells(m), "id": index, "method_name": METHOD_NAMES[s.method],
            "depth": s.max_depth, "spp": s.spp, "rounds": m.rounds, "png": m.image_png,
            "exr": m.image or "", "map": m.error_map or m.image_png, "card": card,
            "title": f"{s.method} {s.label}",
            "limit": number(m.rel_mse_limit) if math.isfinite(m.rel_mse_limit) else ""}


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
    measurements = sorted(entry.measurements, key=lambda m: (METHODS.index(m.setting.method),
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
    return {
        **scene_words(analysis), "path_near": near, "key": key,
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
    text = template("report.html.j2").render(
        scenes=[scene_context(a, plots[a.entry.name], path.parent) for a in analyses],
        left_out=[{"name": e.name, "notes": list(e.notes) or ["no reference"]} for e in left_out],
        files=files, colorbar=colorbar(), colors=COLORS, version=VERSION, interrupted=interrupted, timing=TIMING,
        created=time.strftime("%Y-%m-%d %H:%M"))
    write_text(path, text)


def write_csv(path: str | os.PathLike, entries: list[SceneResult]) -> None:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for entry in entries:
        for m in entry.measurements:
            s = m.setting
            writer.writerow({
                "scene": entry.name, "method": s.method, "integrator": s.integrator,
                "lighting": s.lighting, "spp": s.spp, "max_depth": s.max_depth,
                "seconds": f"{m.seconds:.6g}", "compile_seconds": f"{m.compile_seconds:.6g}",
                "rel_mse": f"{m.rel_mse:.6g}", "flip": f"{m.flip:.6g}", "repeats": m.rounds,
                "width": entry.width, "height": entry.height, "variant": entry.variant,
                "reference_spp": entry.reference_spp, "seconds_min": f"{m.seconds_min:.6g}",
                "seconds_max": f"{m.seconds_max:.6g}",
                "seconds_each": ";".join(f"{t:.6g}" for t in m.times), "image": m.image or "",
                "image_png": m.image_png or "", "error_map": m.error_map or "",
                "reference_noise": f"{entry.reference_noise:.6g}", "worker": entry.worker,
                "rel_mse_limit": f"{m.rel_mse_limit:.6g}" if math.isfinite(m.rel_mse_limit) else "",
                "work": m.work})
    write_text(path, buffer.getvalue())


def write_all(out: str | os.PathLike, entries: list[SceneResult], levels: tuple[float, ...] | None,
              interrupted: tuple[int, int] | None = None) -> list[Analysis]:
    """Every output for ``entries``, of the scenes that got a reference (the page lists the
    others, with why); ``interrupted``: (renders done, planned), said at the top."""
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
    write_text(out / FINDINGS_NAME, json.dumps(json_safe(findings(analyses, interrupted)), indent=2,
                                               allow_nan=False) + "\n")
    write_page(out / PAGE_NAME, analyses, plots, FILES, left_out,
               interruption_text(*interrupted) if interrupted else None)
    return analyses


def output_files(out: str | os.PathLike) -> str:
    return ", ".join(str(Path(out) / name) for name in FILES.values())
