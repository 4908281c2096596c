"""What a differentiable render of the Whitted integrator reads (docs/gradients.md).

A plain render bakes the scene's numbers into opaque tables (:mod:`.scene_tables`); a
gradient needs them computed from the parameters' own Dr.Jit values, which
``render_forward`` and ``render_backward`` swap in (:class:`Attached`); the ray tree, the
hits and the shadow tests stay the plain render's.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from .primitives import bsdf_key
from .scene_tables import COLOR, scene_tables


def differentiated(scene, integrator) -> list:
    """The parameters' Dr.Jit values a differentiable render reads, so that their gradients
    are computed: what :func:`attached` reads, and the background's radiance."""
    values = [value for name, value in getattr(integrator, "_values", {}).items()
              if name in integrator.DIFFERENTIABLE]
    bsdfs = scene_tables(scene).materials.bsdfs
    for node in [*scene.emitters(), *(bsdf.color for bsdf in bsdfs)]:
        params = mi.traverse(node)   # a texture's values or texels, not its UV transform
        values += [params[key] for key in params.keys()
                   if key == "position" or key.rsplit(".", 1)[-1] in ("value", "data")]
    for bsdf in bsdfs:
        values += [bsdf._values[name] for name in bsdf.DIFFERENTIABLE]
    return values


def _ad_indices(value) -> set:
    """The Dr.Jit AD variables of ``value`` (none: no gradients enabled)."""
    return {index >> 32 for index in dr.detail.collect_indices(value)} - {0}


def name_undifferentiated(scene, params, integrator, seen: dict) -> None:
    """Warn once per parameter (``seen``: key -> whether it is differentiated) about each
    one with gradients enabled that a differentiable render does not differentiate."""
    enabled = [key for key in params.keys() if key not in seen and _ad_indices(params[key])]
    if not enabled:
        return
    read = set().union(*map(_ad_indices, differentiated(scene, integrator)))
    for key in enabled:
        seen[key] = bool(_ad_indices(params[key]) & read)
        if not seen[key]:
            mi.Log(mi.LogLevel.Warn, f"whitted: '{key}' has gradients enabled but is not differentiated: "
                   "the whitted integrator holds visibility fixed (what a ray hits, the IOR) and "
                   "differentiates only the article BSDFs' color, reflect and refract, the ambient, "
                   "the point lights' intensity and position and the background, so its gradient "
                   "is not computed; for a shape's position or size render with Mitsuba's "
                   "prb_projective integrator (docs/gradients.md)")


@dataclass
class Attached:
    """The values a differentiable render reads from the parameters' Dr.Jit arrays: the
    ambient A, ``(position, strength)`` per point light, and the material table."""
    ambient: object
    lights: list
    material_table: tuple


def attached(scene, analysis, integrator) -> Attached:
    """:class:`Attached` for a render of ``scene`` by ``integrator`` (its ``analysis``)."""
    values = getattr(integrator, "_values", {})
    ambient = mi.Float(values["ambient"]) if "ambient" in values else mi.Float(integrator.ambient)
    reference = mi.Point3f(*(float(c) for c in integrator.light_reference))
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        params = mi.traverse(emitter)
        position = mi.Point3f(params["position"])
        intensity = mi.Color3f(params["intensity.value"])   # (a one-value intensity is gray)
        if integrator.lighting == "physical":
            lights.append((position, intensity))
            continue
        # the article's color I / (π d²) (see .scene_tables.article_color)
        d2 = dr.squared_norm(position - reference)
        d2 = dr.select(d2 == 0, 1.0, d2)
        lights.append((position, intensity / (dr.pi * d2)))

    # The material table with its color, KR and KT columns scattered from the BSDFs' own
    # values (a textured material's color stays 0: its texture is read at the hit, unless the
    # render leaves textures out).
    row_of, ((color_tp, _), (f_tp, reflect), _, ior, slot) = analysis.material_table
    size = dr.width(reflect)
    color, reflect, refract = dr.zeros(mi.Color3f, size), dr.zeros(mi.Float, size), dr.zeros(mi.Float, size)
    surfaces = analysis.surfaces   # (rows in the same order as the BSDFs)
    for k, bsdf in enumerate(analysis.tables.materials.bsdfs):
        row = mi.UInt32(row_of[bsdf_key(bsdf)])
        if not bsdf.color.is_spatially_varying():
            value = bsdf.color.eval(dr.zeros(mi.SurfaceInteraction3f))
            dr.scatter(color, mi.Color3f(value), row)
        elif bsdf_key(bsdf) not in surfaces.textures:   # left out: drawn as the plain render does
            dr.scatter(color, mi.Color3f(*surfaces.rows[k, COLOR].tolist()), row)
        dr.scatter(reflect, mi.Float(bsdf._values["reflect"]), row)
        dr.scatter(refract, mi.Float(bsdf._values["refract"]), row)
    table = row_of, ((color_tp, color), (f_tp, reflect), (f_tp, refract), ior, slot)
    return Attached(ambient, lights, table)
