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

The modules, in the order the work flows (each imports only those above it;
:mod:`.results` imports none of them):

=============== ==================================================================
``results``     the plain data: settings, measurements, per-scene results, options
``scenes``      the scene files of the command line, each read and parsed once
``planning``    which renders each scene gets, cheapest first
``curves``      the formulas: a method's curve read on log–log axes, the error
                floor, the reference's noise from its two halves
``budget``      ``--budget``: each scene's share of the time, the reference's
                affordable spp (from a probe), each render's predicted cost
``reference``   the path-traced reference: its plan (cache, budget probe, chunks and
                seeds), its two halves and its on-disk cache
``limits``      each Whitted method's limit (exact tree, converged anti-aliasing): what
                a render's depth and spp cost, the model's bias, the best ambient
``errormaps``   the images kept of each render: EXR, PNG, FLIP's error map
``analysis``    the floors, equal quality, equal time, what the error is made of
``csvfile``     results.csv: one row per render
``plot``        error_vs_time.png, its label placement, and each method's colour
``sheet``       contact_sheet.png, and the thumbnails it is made of
``summary``     the words: each scene's verdict and tables' rows, summary.txt (its Jinja2
                template, ``templates/``) and findings.json
``page``        report.html, from its Jinja2 template, with the summary's words
``report``      every output written in one go (:func:`write_all`)
``sweep``       one scene's work: reference, renders, scores (plain data in/out)
``cluster``     ``--workers``/``--scheduler``: the scenes' sweeps and the reference's
                chunks as tasks on a Dask cluster (:mod:`whitted.cluster`, docs/cluster.md)
``run``         the whole run: read, plan, sweep every scene, write the outputs
``cli``         the ``compare`` subcommand's options and printed summary
=============== ==================================================================
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
