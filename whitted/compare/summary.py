"""What the reports say of each scene, built once from its
:class:`~whitted.compare.analysis.Analysis` as rows of text that the templates of
``summary.txt`` and ``report.html`` render; and ``findings.json``.
"""

from __future__ import annotations

import math

from ..templates import environment
from .analysis import (METHOD_NAMES, TIMING, Analysis, FloorStatement, capital, equal_time_how,
                       model_text, ratio_text, reach_text, speedup_text, spread_text)
from .results import WHITTED_LIGHTING, WHITTED_METHODS, Measurement, seconds_text

SUMMARY_NAME = "summary.txt"
FINDINGS_NAME = "findings.json"


def table(rows: list[list[str]]) -> list[str]:
    """Rows of cells as text lines, each column as wide as its widest cell."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  " + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]


def method_verdict(statement: FloorStatement) -> str:
    render, floor = statement.render, statement.floor
    path, best = statement.path, statement.path_best
    where = f"{render.setting.label}, {seconds_text(render.seconds)} (error {floor.error:.3g})"
    text = capital(METHOD_NAMES[statement.method]) + (
        f" is as good as it gets at {where}" if floor.settled
        else f" is still improving at its costliest render, {where}")
    if path is None and best is None:
        return text + "."
    if path is None:
        return (text + f"; the path tracer never got as close (its best: {best.rel_mse:.3g} at "
                f"{best.setting.label}, {seconds_text(best.seconds)}).")
    if path.how == "nearest":
        first = path.between[0]
        return (text + f"; the path tracer is more accurate from its fastest render on "
                f"({first.setting.label}, {seconds_text(first.seconds)}).")
    if path.value <= render.seconds:
        return (text + f"; the path tracer is as accurate already from about {seconds_text(path.value)} "
                f"on: faster there, and more accurate beyond.")
    return text + f"; from about {seconds_text(path.value)} on, the path tracer is more accurate."


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
    entry, methods = analysis.entry, analysis.table_methods
    noise = entry.reference_noise
    noisy = math.isfinite(noise) and noise > 0
    whitted = [m for m in WHITTED_METHODS if m in methods]
    verdicts = [method_verdict(s) for s in analysis.floors]
    scale = ("Errors are relative MSE against the converged path-traced reference: 0 is identical, "
             "1 about as far off as a black image"
             + (f"; this reference's own noise is about {noise:.2g}, and no render can measurably "
                f"score below it." if noisy else "."))
    return {
        "name": entry.name, "width": entry.width, "height": entry.height,
        "notes": list(entry.notes), "reference": {"spp": entry.reference_spp},
        "verdicts": verdicts, "scale": scale,
        "verdict": " ".join((verdicts or ["No Whitted render was done: there is no verdict to "
                                          "state."]) + [scale]),
        "floors": ([f.text for f in analysis.floors]
                   + ([model_text(entry)] if entry.path_model else [])),
        "decompositions": [d.text for d in analysis.decompositions],
        "noise_note": f", its noise ≈ {noise:.3g}" if noisy else "",
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
    return environment("whitted.compare").get_template("summary.txt.j2").render(
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
