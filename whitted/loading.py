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


def load_scene(path: str | os.PathLike, variant: str | None = None, *, model=None, **overrides):
    """Load a ``.scn`` or ``.xml`` scene as a ``mi.Scene``.

    ``variant`` selects a Mitsuba variant first (default: keep the current one).
    ``model`` is the already parsed scene model of a ``.scn`` ``path``
    (``whitted.converter.Scene``): the file is then not read again.
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
        return mi.load_string(scene_xml(path, model), **params)
    except RuntimeError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise WhittedError(f"{path}: Mitsuba could not load the scene: {first}") from None
