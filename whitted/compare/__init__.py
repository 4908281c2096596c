"""``whitted compare``: what accuracy costs in time.

For each scene, a converged path-traced image is the reference (Mitsuba's
``path`` integrator at a high sample count, on the same converted scene). Then
three methods are swept and every render is timed and scored against it:

* ``whitted-article``: the article's model, max depth 1…D × an spp ladder;
* ``whitted-physical``: the same ray tree lit physically (inverse-square
  fall-off, albedo/π, no ambient), so the remaining gap to the reference is the
  indirect light the ray tree leaves out;
* ``path``: the path tracer itself over an spp ladder, which converges to the
  reference (its error falls as 1/spp until it meets the reference's own noise).

The modules, each importing only those before it in the order the work flows, are
listed in docs/compare.md, "Where the code lives".
"""

from __future__ import annotations

import importlib

#: public name -> submodule: imported on first use, so that building the CLI's
#: parser (which needs only :mod:`.cli`'s options) loads no numpy or Mitsuba
_EXPORTS = {
    "Budget": "budget", "add_arguments": "cli", "compare_command": "cli", "float_list": "cli",
    "int_list": "cli", "plan": "planning", "plan_scene": "planning", "ReferenceCache": "reference",
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
