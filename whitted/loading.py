"""``load_scene``: a ``mi.Scene`` from a legacy ``.scn`` or a converted ``.xml`` file."""

from __future__ import annotations

import os
from pathlib import Path

from .defaults import check_depth, check_lighting
from .errors import WhittedError

#: Scene parameters that can be overridden at load time (``<default>`` entries of the XML).
OVERRIDES = ("spp", "max_depth", "ambient", "lighting")


def scene_xml(path: str | os.PathLike, model=None) -> str:
    """The Mitsuba XML of a legacy scene, with absolute texture paths (loadable from memory).
    ``model``: the scene model of ``path`` when already parsed (the file is not read again)."""
    from .converter import parse_file, scene_to_xml
    return scene_to_xml(model if model is not None else parse_file(path), base_dir=None)


def load_scene(path: str | os.PathLike, variant: str | None = None, *, model=None,
               ellipsoids: bool | None = None, **overrides):
    """Load a ``.scn`` or ``.xml`` scene as a ``mi.Scene``.

    ``variant`` selects a Mitsuba variant first (default: keep the current one).
    ``model`` is the already parsed scene model of a ``.scn`` ``path``
    (``whitted.converter.Scene``): the file is then not read again.
    ``ellipsoids``: load the *sealed* spheres of a ``.scn`` scene (opaque,
    untextured, holding neither the eye nor a light) of its commonest radius as
    Mitsuba ``ellipsoids`` shapes, in a frame scaled to make that radius 1
    (:mod:`whitted.sealed`: the same image, a hundred times faster to load than
    as ``sphere`` shapes). None (the default) does so when at least
    ``sealed.MIN_GROUP`` spheres share that radius, True whenever one does,
    False never. ``.xml`` files are loaded as written.
    ``overrides`` replace the scene's ``spp``, ``max_depth``, ``ambient`` or
    ``lighting`` ("article" or "physical").
    """
    import mitsuba as mi

    from .variant import set_variant
    set_variant(variant)
    unknown = sorted(set(overrides) - set(OVERRIDES))
    if unknown:
        raise WhittedError(f"unknown scene override(s) {', '.join(unknown)}; "
                           f"choose from {', '.join(OVERRIDES)}")
    params = {k: str(v) for k, v in overrides.items() if v is not None}
    if "lighting" in params:
        check_lighting(params["lighting"])
    if overrides.get("max_depth") is not None:
        check_depth(overrides["max_depth"])
    path = Path(path)
    if not path.exists():
        raise WhittedError(f"{path}: no such file")
    if path.is_dir():
        raise WhittedError(f"{path}: is a folder, not a scene file")
    try:
        if path.suffix.lower() == ".xml":
            return mi.load_file(str(path), **params)
        from . import sealed
        from .converter import parse_file
        model = model if model is not None else parse_file(path)
        grouping = None if ellipsoids is False else \
            sealed.choose(model, min_group=1 if ellipsoids else sealed.MIN_GROUP)
        if grouping is None:
            return mi.load_string(scene_xml(path, model), **params)
        return _load_sealed(model, grouping, params)
    except RuntimeError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise WhittedError(f"{path}: Mitsuba could not load the scene: {first}") from None


def _load_sealed(model, grouping, params: dict):
    """The scene with its grouped spheres (:func:`whitted.sealed.choose`) in ``ellipsoids``
    shapes: the rest is loaded from its XML, in the scaled frame, and its objects are put
    in one scene with the ellipsoids (one shape per material)."""
    import mitsuba as mi

    from . import sealed
    from .converter import scene_to_xml
    from .converter.xml_writer import _material_xml
    rest = mi.load_string(scene_to_xml(sealed.remaining(model, grouping), base_dir=None), **params)
    scene = {"type": "scene", "integrator": rest.integrator(), "sensor": rest.sensors()[0]}
    scene.update((f"emitter_{k}", emitter) for k, emitter in enumerate(rest.emitters()))
    scene.update((f"shape_{k}", shape) for k, shape in enumerate(rest.shapes()))
    for k, (material, centers) in enumerate(sealed.groups(model, grouping, origin=(0.0, 0.0, 0.0))):
        bsdf = "\n".join(_material_xml(material, f"sealed_{k}", None)).replace("<bsdf ", '<bsdf version="3.0.0" ', 1)
        scene[f"sealed_{k}"] = sealed.ellipsoids(centers, mi.load_string(bsdf))
    return mi.load_dict(scene)
