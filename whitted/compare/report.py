"""Every output of ``whitted compare``, written in one go, each file atomically.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from ..atomic import atomic_path, write_text
from .analysis import Analysis, analyse
from .csvfile import CSV_NAME, write_csv
from .page import PAGE_NAME, write_page
from .plot import PLOT_NAME, SCENE_PLOT, plot_error_vs_time
from .results import SceneResult
from .sheet import SHEET_NAME, contact_sheet
from .summary import FINDINGS_NAME, SUMMARY_NAME, findings, interruption_text, json_safe, summary

#: Every output, by the name the page gives it, in the order the command lists them.
FILES = {"page": PAGE_NAME, "summary": SUMMARY_NAME, "findings": FINDINGS_NAME, "csv": CSV_NAME,
         "plot": PLOT_NAME, "sheet": SHEET_NAME}


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
