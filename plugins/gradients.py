"""Gradients of the article's model: what a differentiable render of the Whitted integrator reads.

Why a module of its own. A plain render reads the scene's numbers once, as
plain values baked into opaque tables and kernels (:mod:`.scene.tables`):
that is what keeps it fast and its images the same bits run after run. A
gradient needs the opposite: every number a parameter feeds must be computed
from the parameter's own Dr.Jit value, so that Dr.Jit's AD graph leads from
the image back to it. So a differentiable render (``render_forward``,
``render_backward``, and so ``mi.render(scene, params)`` then ``dr.backward``
or ``dr.forward``) swaps in, for the columns a parameter carries, values
*attached* to the parameters (:class:`Attached`); everything else (the ray
tree's shape, what each ray hits, the shadow tests) is the plain render's.

What is differentiated, and what is not. The image is a sum over each
camera ray's tree of ``w·contribution`` (:mod:`.shading.shader`): it is
smooth in every ``article`` color (a uniform ``rgb`` or a bitmap texture's
texels: Mitsuba's textures are differentiable themselves), in KR and KT
(``reflect``, ``refract``: the path weights and the ``1 - KR - KT`` share),
in the integrator's ambient A, in each point light's intensity and position
(through ``cos``, the article's color ``I/(πd²)`` or the physical ``I/r²``),
and in the background's radiance (a ``constant`` emitter, evaluated by
Mitsuba's own differentiable texture). Visibility is not differentiated:
which surface a ray hits, where a shadow's edge falls, which way a ray bends
(the IOR), and where a sphere sits are held fixed, so a parameter that moves
an edge (a light's position moves its shadows' edges) gets only the
gradient of the smooth part. Mitsuba's ``prb`` has the same limit; what it
would take is what Mitsuba's ``prb_reparam`` and ``direct_projective`` do:
a reparameterisation of the rays (or sampling of the silhouette edges), so
that the moving discontinuities contribute their boundary term.

A weight that is 0 on every material leaves its effect out of the kernels
(:mod:`.scene.effects`): a scene without mirrors has no reflected rays, and
the gradient of KR there is 0 (render the scene with a small KR to get it).

Costs and limits. A bitmap texture is differentiated when it is stored as
floats (``format="variant"``). The render is recorded whole as an AD graph,
so its memory grows with the tree (benchmarks/RESULTS.md). ``scalar_rgb``
has no gradients: :func:`require_gradients` refuses them in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from whitted.errors import WhittedError

from .scene.materials import bsdf_key


def require_gradients(what: str) -> None:
    """Refuse a gradient in a variant without automatic differentiation (one clear line)."""
    if not dr.is_diff_v(mi.Float):
        raise WhittedError(f"whitted: {what} needs gradients, which the {mi.variant()} variant "
                           "cannot compute: use llvm_ad_rgb (or cuda_ad_rgb)")


@dataclass
class Attached:
    """The values a differentiable render reads from the parameters' Dr.Jit arrays.

    ============== ======================================================================
    ambient        mi.Float, the integrator's A
    lights         ``(position, strength)`` per point light, in the order of the scene's
                   (:func:`.scene.lights.point_lights`): strength is the article's color or
                   the intensity (physical lighting)
    material_table the materials' table (:meth:`.scene.materials.Materials.table`) with
                   the color, KR and KT columns computed from the BSDFs' parameters
    ============== ======================================================================
    """
    ambient: object
    lights: list
    material_table: tuple


def attached(scene, tables, integrator) -> Attached:
    """:class:`Attached` for a render of ``scene`` (whose tables are ``tables``) by the Whitted
    ``integrator``."""
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
        # the article's color I / (π d²) (see .scene.lights.article_color)
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
    bsdfs = {}
    for shape in scene.shapes():
        bsdfs.setdefault(id(shape.bsdf()), shape.bsdf())
    for bsdf in bsdfs.values():
        row = mi.UInt32(row_of[bsdf_key(bsdf)])
        if not bsdf.color.is_spatially_varying():
            value = bsdf.color.eval(dr.zeros(mi.SurfaceInteraction3f))
            dr.scatter(color, mi.Color3f(value), row)
        dr.scatter(reflect, mi.Float(bsdf._values["reflect"]), row)
        dr.scatter(refract, mi.Float(bsdf._values["refract"]), row)
    return row_of, ((color_tp, color), (f_tp, reflect), (f_tp, refract), ior, slot)
