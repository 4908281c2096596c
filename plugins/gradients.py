"""Gradients of the article's model: what a differentiable render of the Whitted integrator
reads.

Why a module of its own. A plain render reads the scene's numbers once, as
plain values baked into opaque tables and kernels (:mod:`.scene_tables`):
that is what keeps it fast and its images the same bits run after run. A
gradient needs the opposite: every number a parameter feeds must be computed
from the parameter's own Dr.Jit value, so that Dr.Jit's AD graph leads from
the image back to it. So a differentiable render (``render_forward``,
``render_backward``, and so ``mi.render(scene, params)`` then ``dr.backward``
or ``dr.forward``) swaps in, for the columns a parameter carries, values
*attached* to the parameters (:class:`Attached`); everything else (the ray
tree's shape, what each ray hits, the shadow tests) is the plain render's.

What is differentiated, and what is not. The image is a sum over each camera ray's tree of
``w·contribution`` (:meth:`.recursion.Recursion.step`): it is smooth in every ``article``
color (a uniform ``rgb`` or a bitmap texture's texels: Mitsuba's textures are differentiable
themselves), in KR and KT (``reflect``, ``refract``: the path weights and the ``1 - KR -
KT`` share), in the integrator's ambient A, in each point light's intensity and position
(through ``cos``, the article's color ``I/(πd²)`` or the physical ``I/r²``), and in the
background's radiance (a ``constant`` emitter, evaluated by Mitsuba's own differentiable
texture). Visibility is not differentiated: which surface a ray hits, where a shadow's edge
falls, which way a ray bends (the IOR), and where a sphere sits are held fixed, so a
parameter that moves an edge (a light's position moves its shadows' edges) gets only the
gradient of the smooth part. Mitsuba's ``prb`` has the same limit; what it would take is
what Mitsuba's ``prb_projective`` and ``direct_projective`` do: sampling of the silhouette
edges, so that the moving discontinuities contribute their boundary term (``prb_projective``
is what differentiates a shape's position or size). A gradient render names, once, each
parameter with gradients enabled that it does not differentiate
(:func:`name_undifferentiated`).

A weight that is 0 on every material leaves its effect out of the kernels
(:mod:`.scene_tables`): a scene without mirrors has no reflected rays, and the gradient of
KR there is 0 (render the scene with a small KR to get it).

Costs and limits. A bitmap texture is differentiated when it is stored as floats
(``format="variant"``). The render is recorded whole as an AD graph, so its memory grows
with the tree (benchmarks/RESULTS.md). ``scalar_rgb`` has no gradients:
:func:`require_gradients` refuses them in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from whitted.errors import WhittedError

from .primitives import bsdf_key


def require_gradients(what: str) -> None:
    """Refuse a gradient in a variant without automatic differentiation (one clear line)."""
    if not dr.is_diff_v(mi.Float):
        raise WhittedError(f"whitted: {what} needs gradients, which the {mi.variant()} variant "
                           "cannot compute: use llvm_ad_rgb (or cuda_ad_rgb)")


#: what a differentiable render reads of a texture (an ``article`` color, a light's intensity,
#: the background's radiance): its values or texels, not the UV transform
TEXTURE_VALUES = ("value", "data")


def differentiated(scene, integrator) -> list:
    """The parameters' Dr.Jit values that a differentiable render of ``scene`` by the Whitted
    ``integrator`` reads from the parameters themselves, so that their gradients are computed:
    what :func:`attached` reads (the ambient, the point lights' positions and intensities, the
    ``article`` BSDFs' KR, KT and colors) and the background's radiance."""
    values = [value for name, value in getattr(integrator, "_values", {}).items()
              if name in integrator.DIFFERENTIABLE]
    bsdfs = _article_bsdfs(scene)
    for node in [*scene.emitters(), *(bsdf.color for bsdf in bsdfs)]:
        params = mi.traverse(node)
        values += [params[key] for key in params.keys()
                   if key == "position" or key.rsplit(".", 1)[-1] in TEXTURE_VALUES]
    for bsdf in bsdfs:
        values += [bsdf._values[name] for name in bsdf.DIFFERENTIABLE]
    return values


def _ad_indices(value) -> set:
    """The Dr.Jit AD variables of ``value`` (none: no gradients enabled)."""
    return {index >> 32 for index in dr.detail.collect_indices(value)} - {0}


def name_undifferentiated(scene, params, integrator, seen: dict) -> None:
    """Warn once per parameter (``seen``: key -> whether it is differentiated, kept between
    calls) about each parameter of ``params`` with gradients enabled that a differentiable
    render does not differentiate (:func:`differentiated`): its gradient is not computed."""
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


def _article_bsdfs(scene) -> list:
    """The scene's BSDFs (``article`` ones: the Whitted integrator renders no other), each once."""
    bsdfs = {}
    for shape in scene.shapes():
        bsdfs.setdefault(id(shape.bsdf()), shape.bsdf())
    return list(bsdfs.values())


@dataclass
class Attached:
    """The values a differentiable render reads from the parameters' Dr.Jit arrays.

    ============== ======================================================================
    ambient        mi.Float, the integrator's A
    lights         ``(position, strength)`` per point light, in the order of the scene's
                   (:func:`.scene_tables.point_lights`): strength is the article's color or
                   the intensity (physical lighting)
    material_table the materials' table (:meth:`.scene_tables.Materials.table`) with
                   the color, KR and KT columns computed from the BSDFs' parameters
    ============== ======================================================================
    """
    ambient: object
    lights: list
    material_table: tuple


def attached(scene, tables, integrator) -> Attached:
    """:class:`Attached` for a render of ``scene`` by the Whitted ``integrator``; ``tables``:
    the scene's analysis (:class:`.scene_tables.SceneAnalysis`: its ``material_table``)."""
    values = getattr(integrator, "_values", {})
    ambient = mi.Float(values["ambient"]) if "ambient" in values else mi.Float(integrator.ambient)
    physical = integrator.lighting == "physical"
    reference = mi.Point3f(*(float(c) for c in integrator.light_reference))
    return Attached(ambient, _lights(scene, physical, reference), _material_table(scene, tables))


def _lights(scene, physical: bool, reference) -> list:
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        params = mi.traverse(emitter)
        position = mi.Point3f(params["position"])
        intensity = mi.Color3f(params["intensity.value"])   # (a one-value intensity is gray)
        if physical:
            lights.append((position, intensity))
            continue
        # the article's color I / (π d²) (see .scene_tables.article_color)
        d2 = dr.squared_norm(position - reference)
        d2 = dr.select(d2 == 0, 1.0, d2)
        lights.append((position, intensity / (dr.pi * d2)))
    return lights


def _material_table(scene, tables):
    """The scene's material table with its color, KR and KT columns scattered from the BSDFs'
    own values (a uniform color's texture evaluated once; textured materials keep 0 there and
    evaluate their texture at the hit, as in a plain render)."""
    row_of, columns = tables.material_table
    (color_tp, color), (f_tp, reflect), (_, refract), ior, slot = columns
    size = dr.width(reflect)
    color, reflect, refract = dr.zeros(mi.Color3f, size), dr.zeros(mi.Float, size), dr.zeros(mi.Float, size)
    for bsdf in _article_bsdfs(scene):
        row = mi.UInt32(row_of[bsdf_key(bsdf)])
        if not bsdf.color.is_spatially_varying():
            value = bsdf.color.eval(dr.zeros(mi.SurfaceInteraction3f))
            dr.scatter(color, mi.Color3f(value), row)
        dr.scatter(reflect, mi.Float(bsdf._values["reflect"]), row)
        dr.scatter(refract, mi.Float(bsdf._values["refract"]), row)
    return row_of, ((color_tp, color), (f_tp, reflect), (f_tp, refract), ior, slot)
