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
``plan``        which renders each scene gets, cheapest first
``budget``      ``--budget``: each scene's share of the time, each render's cost
``reference``   the path-traced reference and its on-disk cache
``report``      results.csv, the error-against-time plot, contact sheet, table
``sweep``       one scene's work: reference, renders, scores (plain data in/out)
``run``         the whole run: read, plan, sweep every scene, write the outputs
``cli``         the ``compare`` subcommand's options and printed summary
=============== ==================================================================
"""

from __future__ import annotations

from .budget import Budget
from .cli import add_arguments, compare_command, float_list, int_list
from .plan import plan, plan_scene
from .reference import ReferenceCache
from .results import METHODS, WHITTED_METHODS, Measurement, Options, SceneResult, Setting
from .run import compare
from .scenes import SceneFile, scene_files, scene_names
from .sweep import sweep_scene

__all__ = ["METHODS", "WHITTED_METHODS", "Budget", "Measurement", "Options", "ReferenceCache",
           "SceneFile", "SceneResult", "Setting", "add_arguments", "compare", "compare_command",
           "float_list", "int_list", "plan", "plan_scene", "scene_files", "scene_names",
           "sweep_scene"]
