"""The converter's description -> one that names only Mitsuba's stock plugins (``whitted convert --portable``).

The default XML's plugins exist only in a process that imports ``whitted``; the portable form
is the same scene read physically, as ``whitted render --integrator path`` renders it, in
plugins every Mitsuba 3 build has. docs/portable.md has the mapping and what is not exact.
"""

from __future__ import annotations

import copy

from .. import defaults as D
from .description import Description, Param

#: weights below this are no lobe (1 − KR − KT can round to 1e-17 instead of 0)
NEGLIGIBLE = 1e-12

#: what the header says of every portable file
SUMMARY = (
    "Portable form: Mitsuba's stock plugins only (any Mitsuba 3 loads it, without whitted).",
    "It is the scene read physically, as `whitted render` with the path integrator renders the default XML:",
    "the `path` integrator (max_depth = the article's depth + 1), point lights with inverse-square",
    "fall-off (intensities matched to the article's light colors at lookat), Lambertian diffuse",
    "surfaces, indirect and sky light, no ambient term. The article's own model is the default",
    "XML of `whitted convert`, loaded in Python after `import whitted`.",
    "Parameters: spp, max_depth, width, height (mitsuba -D spp=256 ...).",
)


def _mix(parts: list[tuple[float, dict]]) -> dict:
    """The lobes ``(weight, bsdf)`` (at most two, weights > 0) as one BSDF with those shares."""
    if len(parts) == 1:
        return parts[0][1]
    (w0, b0), (w1, b1) = parts
    return {"type": "blendbsdf", "weight": w1 / (w0 + w1), "bsdf_0": b0, "bsdf_1": b1}


def stock_material(article: dict) -> dict:
    """The stock form of an ``article`` BSDF: ``(1 − KR − KT)·diffuse(B) + KR·mirror +
    KT·glass`` as nested ``blendbsdf``, diffuse and mirror ``twosided`` as the article's."""
    kr, kt = article["reflect"], article["refract"]
    diffuse = 1.0 - kr - kt
    surface = []
    if diffuse > NEGLIGIBLE:
        surface.append((diffuse, {"type": "diffuse", "reflectance": copy.deepcopy(article["color"])}))
    if kr > NEGLIGIBLE:
        surface.append((kr, {"type": "conductor", "material": "none"}))
    lobes = []
    if surface:
        lobes.append((sum(w for w, _ in surface), {"type": "twosided", "bsdf": _mix(surface)}))
    if kt > NEGLIGIBLE:
        lobes.append((kt, {"type": "dielectric", "int_ior": article["ior"], "ext_ior": 1.0}))
    return _mix(lobes)


def inexact(article: dict) -> list[str]:
    """Why the stock form of an ``article`` BSDF differs from it (empty when it is exact)."""
    kr, kt, ior = article["reflect"], article["refract"], article["ior"]
    diffuse = 1.0 - kr - kt
    reasons = []
    if kt > NEGLIGIBLE and ior != 1.0:
        reasons.append(f"Fresnel: dielectric sends a share F of KT = {kt:g} to the mirror direction "
                       f"(F = {((ior - 1.0) / (ior + 1.0)) ** 2:.3g} at normal incidence, 1 at grazing; the article "
                       f"refracts all of it, and both mirror it under total internal reflection)")
    # exact for B = 1 (a white color): docs/portable.md
    white = article["color"].get("type") == "rgb" and all(c == 1.0 for c in article["color"]["value"])
    if diffuse > NEGLIGIBLE and (kr > NEGLIGIBLE or kt > NEGLIGIBLE) and not white:
        reasons.append("blendbsdf of Mitsuba 3.8 to 3.9.1 at least weights a mirror reflection "
                       "mixed with a diffuse color B < 1 too low (docs/portable.md)")
    return reasons


def portable(description: Description) -> tuple[Description, list[str]]:
    """The portable form of ``description`` and the lines of its header comment."""
    scene = copy.deepcopy(description.scene)
    integrator = scene["integrator"]
    depth = description.defaults["max_depth"]
    # (the film's width and height are the description's parameters already)
    defaults = {"spp": description.defaults["spp"], "max_depth": D.path_depth(depth),
                "width": description.defaults["width"], "height": description.defaults["height"]}
    scene["integrator"] = {"type": "path", "max_depth": Param("max_depth")}
    notes = [*SUMMARY, f"The article's depth is {depth}: max_depth = {defaults['max_depth']}."]
    if integrator.get("min_weight") is not None:
        notes.append("The scene's minweight (the whitted integrator's adaptive depth) has no stock form.")
    _replace_materials(scene, notes)
    # the spheres held as arrays refer to their materials by id: nothing to change there
    return Description(scene, defaults, description.origin, description.source, description.spheres,
                       description.notes), notes


def _replace_materials(node: dict, notes: list[str]) -> None:
    """Every ``article`` BSDF under ``node`` (shared at the top level, or inline) made stock."""
    for key, child in node.items():
        if isinstance(child, dict) and child.get("type") == "article":
            notes += [f"Not exact, {key}: {reason}." for reason in inexact(child)]
            node[key] = stock_material(child)
        elif isinstance(child, dict):
            _replace_materials(child, notes)
