"""``results.csv``: one row per render that was done, rewritten after every scene so that an
interrupted run keeps the rows of the scenes that finished (columns: docs/compare.md).
"""

from __future__ import annotations

import csv
import io
import math
import os

from ..atomic import write_text
from .results import SceneResult

#: The CSV's columns; new ones are added at the end, so that readers of the old keep working.
CSV_COLUMNS = ("scene", "method", "integrator", "lighting", "spp", "max_depth", "seconds",
               "compile_seconds", "rel_mse", "flip", "repeats", "width", "height", "variant",
               "reference_spp", "seconds_min", "seconds_max", "seconds_each", "image", "image_png",
               "error_map", "reference_noise", "worker", "rel_mse_limit", "work")
CSV_NAME = "results.csv"


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
