"""``load_scene``: a ``mi.Scene`` from a ``.scn`` or ``.xml`` file. A ``.scn`` file's
description, the one the XML writer writes out, goes to ``mi.load_dict`` without XML text.
"""

from __future__ import annotations

import functools
import os
import re
from dataclasses import dataclass
from pathlib import Path

from . import defaults as D
from .errors import WhittedError, first_line

#: the scene parameters a load may override (the XML's ``<default>``s), and their checks
OVERRIDES = {"spp": D.check_spp, "max_depth": D.check_depth, "ambient": D.check_ambient,
             "lighting": D.check_lighting, "width": lambda v: D.check_size(v, "width"),
             "height": lambda v: D.check_size(v, "height"), "without": D.check_without}

#: Mitsuba's parallel loading: off, slower at every size measured (benchmarks/RESULTS.md,
#: "Scene building").
PARALLEL = False


def mitsuba_dict(description, overrides: dict | None = None) -> dict:
    """The description's scene as ``mi.load_dict`` takes it, with ``overrides``."""
    import mitsuba as mi

    from .converter.description import LookAt, Matrix, Mesh, Param
    from .converter.giants import cached
    values = {**description.defaults, **(overrides or {})}

    def convert(value):
        if isinstance(value, dict):
            return {key: convert(v) for key, v in value.items()}
        if isinstance(value, Param):
            return values[value.name]
        if isinstance(value, LookAt):
            return mi.ScalarTransform4d().look_at(origin=value.origin, target=value.target, up=value.up)
        if isinstance(value, Mesh):   # the same bytes as the XML's file, from the mesh cache
            return str(cached(value.data))
        if isinstance(value, Matrix):
            return mi.ScalarTransform4d([list(row) for row in value.rows])
        return value
    return convert(description.scene)


def checked_overrides(overrides: dict) -> dict:
    """``overrides`` checked by :data:`OVERRIDES`, those not None."""
    unknown = sorted(set(overrides) - set(OVERRIDES))
    if unknown:
        raise WhittedError(f"unknown scene override(s) {', '.join(unknown)}; "
                           f"choose from {', '.join(OVERRIDES)}")
    return {k: OVERRIDES[k](v) for k, v in overrides.items() if v is not None}


def prepared(variant: str | None, overrides: dict) -> tuple[dict, tuple | None]:
    """Set ``variant``; the checked ``overrides`` but ``without``, and ``without``."""
    from .variant import set_variant
    set_variant(variant)
    params = checked_overrides(overrides)
    return params, params.pop("without", None)


def load_scene(path: str | os.PathLike, variant: str | None = None, *, model=None,
               ellipsoids: bool | None = None, integrator: str = D.INTEGRATOR, meshes: bool = True,
               **overrides):
    """Load a ``.scn`` or ``.xml`` scene as a ``mi.Scene``, in ``variant`` (None: the current).

    ``model``: the ``.scn`` file's parsed model. ``ellipsoids``: sealed spheres as
    ``ellipsoids`` shapes (:mod:`whitted.sealed`; None: for large groups). ``integrator``:
    what will render it. ``meshes=False``: giant spheres stay spheres (the whitted
    integrator intersects them in float64). ``overrides``: :data:`OVERRIDES`.
    """
    import mitsuba as mi

    from .converter.parser import check_scene_file
    D.check_integrator(integrator)
    params, without = prepared(variant, overrides)
    path = Path(path)
    xml = path.suffix.lower() == ".xml"
    if xml or model is not None:
        check_scene_file(path)   # else parse_file checks it
    if xml:
        check_referenced_files(path)
    try:
        if xml:
            return _leaving_out(mi.load_file(str(path), parallel=PARALLEL,
                                             **{k: str(v) for k, v in params.items()}), without, path)
        from .converter import parse_file
        from .converter.frame import warn_scene
        if model is None:
            model = parse_file(path)
            warn_scene(model, integrator=integrator)
        return _leaving_out(_load_model(model, params, ellipsoids, integrator, meshes), without, path)
    except RuntimeError as error:
        unused = re.findall(r"^\s*- \$(\w+)=", str(error), re.M)
        if "unused parameters" in str(error) and unused:
            # e.g. ambient or lighting given for a portable scene, which has neither
            raise WhittedError(f"{path}: the scene has no {' or '.join(unused)} to override") from None
        raise load_error(path, error) from None


#: A plugin's exception as Mitsuba wraps it: ``At FILE (line N, col M): failed to
#: instantiate ...``, a traceback, then ``TYPE: message``, the line a user needs.
_WRAPPED = re.compile(r"^(?:\[[^]]*\] )?At [^\n]*?(?:\(line (\d+), col \d+\))?: failed to instantiate "
                      r".*?Traceback \(most recent call last\):\n(?:  .*\n)*(\w+): (.*)", re.S)
#: the exceptions our plugins raise for a bad parameter: their message is the whole story
_PLAIN = ("WhittedError", "SceneError", "ParameterError", "ValueError")


def load_error(where, error: BaseException) -> WhittedError:
    """Mitsuba's load error as one line: a plugin's own message, else Mitsuba's first line
    (a wrapped Ctrl-C is raised as the stop it is)."""
    from .interrupt import requested
    if requested(error):
        raise KeyboardInterrupt from None
    text = str(error).strip()
    wrapped = _WRAPPED.match(text)
    if wrapped:
        line, kind, message = wrapped.groups()
        place = f"{where}:{line}" if line else f"{where}"
        return WhittedError(f"{place}: {message if kind in _PLAIN else f'{kind}: {message}'}")
    return WhittedError(f"{where}: Mitsuba could not load the scene: {first_line(error)}")


#: a file an XML scene names (a texture, a giant sphere's mesh)
_FILENAME = re.compile(rb'<string\s+name="filename"\s+value="([^"$]*)"')


def named_files(path: Path) -> list[str]:
    """The files an XML scene names, as it names them."""
    import html

    with open(path, "rb") as file:
        names = dict.fromkeys(_FILENAME.findall(file.read()))
    return [html.unescape(name.decode("utf-8", "replace")) for name in names]


def check_referenced_files(path: Path) -> None:
    """An error when a file the XML names is missing (Mitsuba would take one from the cwd)."""
    for named in named_files(path):
        where = path.parent / named
        if not where.is_file():
            raise WhittedError(f"{path}: the file it names, {named}, does not exist (looked for {where})")


def loads(text: str, variant: str | None = None, *, base_dir: str | os.PathLike = ".",
          ellipsoids: bool | None = None, integrator: str = D.INTEGRATOR, **overrides):
    """:func:`load_scene` of ``.scn`` text (textures relative to ``base_dir``)."""
    from .converter import parse_text
    from .converter.frame import warn_scene
    if not isinstance(text, str):
        raise WhittedError(f"loads takes the scene's text as a str, got {type(text).__name__}")
    D.check_integrator(integrator)
    params, without = prepared(variant, overrides)
    model = parse_text(text, Path(base_dir) / TEXT_NAME)
    warn_scene(model, integrator=integrator)
    try:
        return _leaving_out(_load_model(model, params, ellipsoids, integrator, text=text), without, TEXT_NAME)
    except RuntimeError as error:
        raise load_error(TEXT_NAME, error) from None


def _leaving_out(scene, without, where):
    if without is None:
        return scene
    from .plugins import whitted_or_none
    integrator = whitted_or_none(scene.integrator())
    if integrator is None:
        raise WhittedError(f"{where}: the scene has no without to override (its integrator is not "
                           "the whitted one)")
    integrator.without = without
    return scene


TEXT_NAME = "<text>"


def _load_model(model, params: dict, ellipsoids: bool | None, integrator: str, meshes: bool = True,
                text: str | None = None):
    scene, _, _, scale = _scene_dict(model, params, ellipsoids, integrator)
    loaded = _loaded(scene, meshes)
    _store().put(loaded, Source(model, scale, text))
    return loaded


def load_model_parts(model, params: dict, ellipsoids: bool | None, integrator: str, meshes: bool = True):
    """``(scene, bsdfs, shown)`` for a fit: the loaded scene, each material's BSDF and
    ``sealed_K`` ids, and the model as the scene shows it."""
    from .converter.description import _shared, first_spheres, material_ids
    scene, shown, grouped, _ = _scene_dict(model, params, ellipsoids, integrator)
    ids = material_ids(model)
    bsdfs = {material: [ids[material]] for material in first_spheres(shown)}
    for k, material in enumerate(grouped):
        bsdfs.setdefault(_shared(material), []).append(f"sealed_{k}")
    return _loaded(scene, meshes), bsdfs, shown


def _scene_dict(model, params: dict, ellipsoids: bool | None, integrator: str) -> tuple[dict, object, list, float]:
    """``model``'s ``mi.load_dict`` form, the model it shows, each group's material, the scale."""
    from .converter.description import describe
    held = model.held_sphere_arrays()
    count = len(held) if held is not None else len(model.spheres)
    grouping = None
    if ellipsoids or (ellipsoids is None and count >= D.SEALED_MIN_GROUP):
        from . import sealed
        grouping = sealed.choose(model, min_group=1 if ellipsoids else D.SEALED_MIN_GROUP,
                                 classes=sealed.MAX_LAYERS, smaller=integrator == "whitted")
    if grouping is None:
        return mitsuba_dict(describe(model, base_dir=None), params), model, [], 1.0
    shown = sealed.remaining(model, grouping)
    scene, grouped = _sealed_dict(shown, model, grouping, params)
    return scene, shown, grouped, grouping.scale


def _loaded(scene: dict, meshes: bool):
    """``mi.load_dict(scene)``; ``meshes=False``: giant spheres' meshes made spheres again."""
    import mitsuba as mi

    from .converter.giants import parse_exact_spheres
    listed = "" if meshes else scene.get("integrator", {}).get("exact_spheres")
    for key, center, radius in parse_exact_spheres(listed or ""):
        shape = scene.get(key)
        if isinstance(shape, dict) and shape.get("type") == "ply":
            scene[key] = {"type": "sphere", "center": center, "radius": radius, "bsdf": shape["bsdf"]}
    return mi.load_dict(scene, parallel=PARALLEL)


def _sealed_dict(remaining, model, grouping, params: dict) -> tuple[dict, list]:
    """``model`` in the scaled frame, its grouped spheres in ``sealed_K`` shapes; each's material."""
    from . import sealed
    from .converter.description import clip_range, describe, material_dict, material_ids
    from .plugins.primitives import ellipsoids_shape
    smallest = min([1.0, *(radius * grouping.scale for radius in grouping.radii)])
    description = describe(remaining, base_dir=None, smallest=smallest, ids=material_ids(model))
    scene = mitsuba_dict(description, params)
    # the clip range of the whole scene, scaled: the rest's alone may cut off grouped spheres
    scene["sensor"]["near_clip"], scene["sensor"]["far_clip"] = (d * grouping.scale for d in clip_range(model))
    materials = []
    for k, (material, radius, centers) in enumerate(sealed.groups(model, grouping, description.origin)):
        scene[f"sealed_{k}"] = ellipsoids_shape(centers, material_dict(material, base_dir=None), radius)
        materials.append(material)
    return scene, materials


#: how many loaded scenes' sources ``whitted trace`` can recall (least recent go first)
REMEMBERED = 16


@dataclass(frozen=True)
class Source:
    """A loaded scene's model, its frame (world = frame / scale + lookat), :func:`loads`' text."""
    model: object
    scale: float = 1.0
    text: str | None = None


@functools.cache
def _store():
    from .plugins.scene_tables import KeptByScene
    return KeptByScene(REMEMBERED)


def recall(scene) -> Source | None:
    """What ``scene`` was loaded from, if it is still held."""
    return _store().get(scene)
