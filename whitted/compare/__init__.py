"""``whitted compare``: what accuracy costs in time. Each scene's converged path-traced
reference scores the article's model, the same ray tree lit physically, and the path tracer
itself, each over a ladder of depths and spp; docs/compare.md says how, and where the code lives.
"""

from __future__ import annotations

import importlib

#: public name -> submodule, imported on first use: the CLI's parser loads no numpy or Mitsuba
_EXPORTS = {
    "Budget": "budget", "add_arguments": "cli", "compare_command": "cli", "float_list": "cli",
    "int_list": "cli", "plan": "scenes", "plan_scene": "scenes", "ReferenceCache": "reference",
    "METHODS": "results", "WHITTED_METHODS": "results", "Measurement": "results",
    "Comparison": "results", "Limit": "results",
    "Options": "results", "SceneResult": "results", "Setting": "results", "compare": "run",
    "SceneFile": "scenes", "scene_files": "scenes", "scene_names": "scenes", "sweep_scene": "sweep",
    "analyse": "analysis", "Analysis": "analysis", "write_all": "report",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
