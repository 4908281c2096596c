"""``summary.txt`` and ``findings.json``: the run's conclusions, in words and as JSON.

Per scene: what the budget did, the floors and what the error is made of, the
equal-quality table and the equal-time table, all read from the scene's
:class:`~whitted.compare.analysis.Analysis` (the page shows the same). An
interrupted run's summary and findings say so first (:func:`interruption_text`).
"""

from __future__ import annotations

import math

from .analysis import TIMING, Analysis, equal_time_how, reach_text, speedup_text, spread_text
from .results import WHITTED_LIGHTING, WHITTED_METHODS, seconds_text
from .timing import ratio_text
from .verdict import verdict

SUMMARY_NAME = "summary.txt"
FINDINGS_NAME = "findings.json"


def _table(rows: list[list[str]], indent: str = "  ") -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return [indent + "   ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]


def number(value: float) -> str:
    return f"{value:.3g}" if math.isfinite(value) else "—"


def equal_quality_rows(analysis: Analysis) -> list[dict]:
    """The equal-quality table's rows, as cells of text (summary.txt and the page)."""
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
    """The equal-time table's rows, as cells of text (summary.txt and the page); ``winner``:
    the more accurate method, "" where the interval holds 1 or nothing was compared."""
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
        noisy = math.isfinite(entry.reference_noise) and entry.reference_noise > 0
        noise = f", its noise ≈ {entry.reference_noise:.3g}" if noisy else ""
        lines += ["", f"{entry.name} ({entry.width}×{entry.height}; reference: path tracer, "
                      f"{entry.reference_spp} spp{noise})"]
        lines += [f"  {verdict(analysis)}"]
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


def json_safe(value):
    """``value`` with every non-finite number (NaN: not measured) as None: JSON has no NaN."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
