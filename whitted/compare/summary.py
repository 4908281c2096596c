"""``summary.txt`` and ``findings.json``: the run's conclusions in words and as JSON, read
from each scene's :class:`~whitted.compare.analysis.Analysis` (as the page is).
"""

from __future__ import annotations

import math

from .analysis import (METHOD_NAMES, TIMING, Analysis, FloorStatement, capital, equal_time_how,
                       model_text, ratio_text, reach_text, speedup_text, spread_text)
from .results import WHITTED_LIGHTING, WHITTED_METHODS, seconds_text

SUMMARY_NAME = "summary.txt"
FINDINGS_NAME = "findings.json"


def _table(rows: list[list[str]], indent: str = "  ") -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return [indent + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]


def method_verdict(statement: FloorStatement) -> str:
    name = METHOD_NAMES[statement.method]
    render, floor = statement.render, statement.floor
    where = f"{render.setting.label}, {seconds_text(render.seconds)} (error {floor.error:.3g})"
    if floor.settled:
        text = f"{capital(name)} is as good as it gets at {where}"
    else:
        text = f"{capital(name)} is still improving at its costliest render, {where}"
    path, best = statement.path, statement.path_best
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


def scale_text(reference_noise: float = math.nan) -> str:
    noise = (f"; this reference's own noise is about {reference_noise:.2g}, and no render can "
             f"measurably score below it" if math.isfinite(reference_noise) and reference_noise > 0 else "")
    return ("Errors are relative MSE against the converged path-traced reference: 0 is identical, "
            f"1 about as far off as a black image{noise}.")


def verdict(analysis: Analysis) -> str:
    sentences = [method_verdict(s) for s in analysis.floors]
    if not sentences:
        sentences = ["No Whitted render was done: there is no verdict to state."]
    return " ".join(sentences + [scale_text(analysis.entry.reference_noise)])


def number(value: float) -> str:
    return f"{value:.3g}" if math.isfinite(value) else "—"


def equal_quality_rows(analysis: Analysis) -> list[dict]:
    """The equal-quality table's rows as cells of text, for summary.txt and the page."""
    methods = analysis.table_methods
    whitted = [m for m in WHITTED_METHODS if m in methods]
    return [{"level": f"{row.level:g}",
             "cells": [{"text": reach_text(row.reach.get(m)),
                        "reached": m in row.reach and row.reach[m].fastest is not None}
                       for m in methods],
             "fastest": row.fastest_method or "none",
             "speedups": [speedup_text(row, m) for m in whitted]}
            for row in analysis.equal_quality]


def equal_time_rows(analysis: Analysis) -> list[dict]:
    """The equal-time table's rows as cells of text; ``winner``: the more accurate method (""
    where the interval holds 1 or nothing was compared)."""
    rows = []
    for row in analysis.equal_time:
        m = row.whitted
        compared = row.rel_mse is not None and row.outside is None
        winner = "" if row.interval is not None and row.interval.straddles_one else \
            "whitted" if row.ratio < 1 else "path"
        rows.append({
            "method": m.setting.method, "label": m.setting.label,
            "seconds": seconds_text(m.seconds), "time": spread_text(m), "rel_mse": number(m.rel_mse),
            "path_rel_mse": number(row.rel_mse.value) if compared else "—",
            "ratio": ratio_text(row.interval) if math.isfinite(row.ratio) else "—",
            "winner": winner if math.isfinite(row.ratio) else "", "flip": number(m.flip),
            "path_flip": number(row.flip.value) if compared and row.flip else "—",
            "how": equal_time_how(row), "outside": row.outside is not None})
    return rows


def equal_quality_lines(analysis: Analysis) -> list[str]:
    whitted = [m for m in WHITTED_METHODS if m in analysis.table_methods]
    header = (["rel_mse ≤"] + analysis.table_methods + ["fastest"]
              + [f"{WHITTED_LIGHTING[m]} vs path" for m in whitted])
    return _table([header] + [[r["level"], *(c["text"] for c in r["cells"]), r["fastest"],
                               *r["speedups"]] for r in equal_quality_rows(analysis)])


def equal_time_lines(analysis: Analysis) -> list[str]:
    columns = ["method", "label", "seconds", "rel_mse", "path_rel_mse", "ratio", "flip", "path_flip",
               "how"]
    return _table([["method", "setting", "time", "rel_mse", "path rel_mse then", "ratio", "flip",
                    "path flip then", "path read"]]
                  + [[r[c] for c in columns] for r in equal_time_rows(analysis)])


def interruption_text(done: int, planned: int) -> str:
    if done == 0:
        return "Interrupted before any render was done: nothing was measured."
    return f"Interrupted after {done} of {planned} renders; the conclusions are drawn from those."


def scene_words(analysis: Analysis) -> dict:
    """What summary.txt and the page say of one scene (both templates read this)."""
    entry = analysis.entry
    methods = analysis.table_methods
    noisy = math.isfinite(entry.reference_noise) and entry.reference_noise > 0
    return {
        "name": entry.name, "width": entry.width, "height": entry.height, "verdict": verdict(analysis),
        "notes": list(entry.notes),
        "floors": ([f.text for f in analysis.floors]
                   + ([model_text(entry)] if entry.path_model else [])),
        "decompositions": [d.text for d in analysis.decompositions],
        "noise_note": f", its noise ≈ {entry.reference_noise:.3g}" if noisy else "",
        "methods": methods, "whitted": [WHITTED_LIGHTING[m] for m in WHITTED_METHODS
                                        if m in methods],
        "equal_quality": equal_quality_rows(analysis), "equal_time": equal_time_rows(analysis),
        "equal_quality_lines": (equal_quality_lines(analysis)
                                if analysis.equal_quality and entry.measurements else []),
        "equal_time_lines": equal_time_lines(analysis) if analysis.equal_time else []}


def environment():
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader("whitted.compare", "templates"),
                              autoescape=jinja2.select_autoescape(["html.j2"]),
                              undefined=jinja2.StrictUndefined, trim_blocks=True,
                              lstrip_blocks=True, keep_trailing_newline=False)


def summary(analyses: list[Analysis], equal_time: bool = True,
            interrupted: tuple[int, int] | None = None) -> str:
    """``summary.txt``; ``interrupted``: (renders done, planned) of a stopped run, said first."""
    scenes = [{**scene_words(a), "reference": {"spp": a.entry.reference_spp}} for a in analyses]
    return environment().get_template("summary.txt.j2").render(
        scenes=scenes, timing=TIMING, equal_time=equal_time,
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
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
