"""``load_scene``: a ``mi.Scene`` from a legacy ``.scn`` or a converted ``.xml`` file.

A ``.scn`` file's description (:mod:`whitted.converter.description`, the very one the XML
writer writes out) goes to ``mi.load_dict`` without XML text: both routes build the same
scene (tests/test_scene_building.py).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from . import defaults as D
from .defaults import check_lighting
from .errors import WhittedError

#: Scene parameters that can be overridden at load time (``<default>`` entries of the XML),
#: with the check each override goes through.
OVERRIDES = {"spp": D.check_spp, "max_depth": D.check_depth, "ambient": D.check_ambient,
             "lighting": check_lighting, "width": lambda v: D.check_size(v, "width"),
             "height": lambda v: D.check_size(v, "height"), "without": D.check_without}

#: Mitsuba's parallel loading: off, slower at every size measured (benchmarks/RESULTS.md,
#: "Scene building").
PARALLEL = False


def mitsuba_dict(description, overrides: dict | None = None) -> dict:
    """The description's scene as ``mi.load_dict`` takes it, ``overrides`` replacing the
    defaults of its parameters."""
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


def _checked(overrides: dict) -> dict:
    unknown = sorted(set(overrides) - set(OVERRIDES))
    if unknown:
        raise WhittedError(f"unknown scene override(s) {', '.join(unknown)}; "
                           f"choose from {', '.join(OVERRIDES)}")
    return {k: OVERRIDES[k](v) for k, v in overrides.items() if v is not None}


def prepared(variant: str | None, overrides: dict) -> tuple[dict, tuple | None]:
    """Set ``variant``; the checked ``overrides`` but ``without``, and ``without``."""
    from .variant import set_variant
    set_variant(variant)
    params = _checked(overrides)
    return params, params.pop("without", None)


def load_scene(path: str | os.PathLike, variant: str | None = None, *, model=None,
               ellipsoids: bool | None = None, integrator: str = D.INTEGRATOR, meshes: bool = True,
               **overrides):
    """Load a ``.scn`` or ``.xml`` scene as a ``mi.Scene``, in ``variant`` (None: the current).

    ``model``: the ``.scn`` file's parsed model (not read again). ``ellipsoids``: load the
    sealed spheres of a ``.scn`` as ``ellipsoids`` shapes (:mod:`whitted.sealed`: the same
    image, loaded a hundred times faster; None: when at least ``sealed.MIN_GROUP`` share a
    radius). ``integrator``: what the scene will be rendered with (warnings, groups).
    ``meshes=False``: giant spheres stay ``sphere`` shapes, which the whitted integrator
    never traces (it intersects them in float64), instead of meshes for Mitsuba's own
    integrators. ``overrides``: ``spp``, ``max_depth``, ``ambient``, ``lighting``, ``width``,
    ``height`` and ``without`` (a portable ``.xml`` has only the first two, width and height).
    """
    import mitsuba as mi

    from .converter.parser import check_scene_file
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
    """Mitsuba's error from loading the scene ``where`` as one line: a plugin's own message
    (``FILE:LINE: message``), else Mitsuba's first line. A Ctrl-C that landed in a plugin's
    constructor comes back wrapped too: it is raised as the stop it is."""
    from .interrupt import requested
    if requested(error):
        raise KeyboardInterrupt from None
    text = str(error).strip()
    wrapped = _WRAPPED.match(text)
    if wrapped:
        line, kind, message = wrapped.groups()
        place = f"{where}:{line}" if line else f"{where}"
        return WhittedError(f"{place}: {message if kind in _PLAIN else f'{kind}: {message}'}")
    first = text.splitlines()[0] if text else type(error).__name__
    return WhittedError(f"{where}: Mitsuba could not load the scene: {first}")


#: A file an XML scene names (a texture's image, a giant sphere's mesh): ``<string name="filename" value="…"/>``.
_FILENAME = re.compile(rb'<string\s+name="filename"\s+value="([^"$]*)"')


def check_referenced_files(path: Path) -> None:
    """An error when a file the XML names is not beside it where it says (Mitsuba would
    quietly take a same-named file from the current folder)."""
    import html

    with open(path, "rb") as file:
        data = file.read()
    for match in dict.fromkeys(_FILENAME.findall(data)):
        named = html.unescape(match.decode("utf-8", "replace"))
        where = path.parent / named
        if not where.is_file():
            raise WhittedError(f"{path}: the file it names, {named}, does not exist (looked for {where})")


def loads(text: str, variant: str | None = None, *, base_dir: str | os.PathLike = ".",
          ellipsoids: bool | None = None, integrator: str = D.INTEGRATOR, **overrides):
    """Load a scene from its ``.scn`` text as a ``mi.Scene`` (texture paths relative to
    ``base_dir``; errors name ``<text>:LINE``); the rest as :func:`load_scene`."""
    import mitsuba as mi  # noqa: F401  (the variant hook runs on import)

    from .converter import parse_text
    from .converter.frame import warn_scene
    if not isinstance(text, str):
        raise WhittedError(f"loads takes the scene's text as a str, got {type(text).__name__}")
    params, without = prepared(variant, overrides)
    model = parse_text(text, Path(base_dir) / TEXT_NAME)
    warn_scene(model, integrator=integrator)
    try:
        return _leaving_out(_load_model(model, params, ellipsoids, integrator, text=text), without, TEXT_NAME)
    except RuntimeError as error:
        raise load_error(TEXT_NAME, error) from None


def _leaving_out(scene, without, where):
    """``scene``, its whitted integrator set to leave out the effects ``without`` (None: as loaded)."""
    if without is None:
        return scene
    from .plugins import whitted_or_none
    integrator = whitted_or_none(scene.integrator())
    if integrator is None:
        raise WhittedError(f"{where}: the scene has no without to override (its integrator is not "
                           "the whitted one)")
    integrator.without = without
    return scene


#: How :func:`loads` names scene text in messages (``<text>:3: ...``).
TEXT_NAME = "<text>"


def _load_model(model, params: dict, ellipsoids: bool | None, integrator: str, meshes: bool = True,
                text: str | None = None):
    """A parsed scene model as a ``mi.Scene``, remembered as loaded from it (:func:`recall`)."""
    scene, _, _, scale = _scene_dict(model, params, ellipsoids, integrator)
    loaded = _loaded(scene, meshes)
    remember(loaded, Source(model, scale, text))
    return loaded


def load_model_parts(model, params: dict, ellipsoids: bool | None, integrator: str, meshes: bool = True):
    """``(scene, bsdfs, described)``, what a fit (:mod:`whitted.fitting`) writes into: the
    loaded scene; each material -> the ids of its BSDFs and of its ``ellipsoids`` shapes
    (``sealed_K``); the model as the scene shows it (grouped spheres, lengths scaled)."""
    from .converter.description import _shared, first_spheres, material_ids
    scene, described, grouped, _ = _scene_dict(model, params, ellipsoids, integrator)
    ids = material_ids(model)
    bsdfs = {material: [ids[material]] for material in first_spheres(described)}
    for k, material in enumerate(grouped):
        bsdfs.setdefault(_shared(material), []).append(f"sealed_{k}")
    return _loaded(scene, meshes), bsdfs, described


def _scene_dict(model, params: dict, ellipsoids: bool | None, integrator: str) -> tuple[dict, object, list, float]:
    """The ``mi.load_dict`` form of ``model``, the model it describes, the material of each
    group of spheres (``sealed_K``) and the scale of its frame."""
    from .converter.description import describe
    held = model.held_sphere_arrays()
    count = len(held) if held is not None else len(model.spheres)
    grouping = None
    if ellipsoids or (ellipsoids is None and count >= D.SEALED_MIN_GROUP):
        from . import sealed
        grouping = sealed.choose(model, min_group=1 if ellipsoids else sealed.MIN_GROUP,
                                 classes=sealed.MAX_LAYERS, smaller=integrator == "whitted")
    if grouping is None:
        return mitsuba_dict(describe(model, base_dir=None), params), model, [], 1.0
    described = sealed.remaining(model, grouping)
    scene, grouped = _sealed_dict(described, model, grouping, params)
    return scene, described, grouped, grouping.scale


def _loaded(scene: dict, meshes: bool):
    """``mi.load_dict`` of ``scene`` (its giant spheres' meshes made spheres again unless ``meshes``)."""
    import mitsuba as mi
    return mi.load_dict(scene if meshes else _giants_as_spheres(scene), parallel=PARALLEL)


def _giants_as_spheres(scene: dict) -> dict:
    """``scene`` with the meshes of its ``exact_spheres`` made ``sphere`` shapes again."""
    from .converter.giants import parse_exact_spheres
    listed = scene.get("integrator", {}).get("exact_spheres")
    if not listed:
        return scene
    for key, center, radius in parse_exact_spheres(listed):
        shape = scene.get(key)
        if isinstance(shape, dict) and shape.get("type") == "ply":
            scene[key] = {"type": "sphere", "center": center, "radius": radius, "bsdf": shape["bsdf"]}
    return scene


def _sealed_dict(remaining, model, grouping, params: dict) -> tuple[dict, list]:
    """The ``mi.load_dict`` form of ``model`` in the scaled frame, its grouped spheres in
    ``ellipsoids`` shapes (``sealed_K``), one per material; and the material of each."""
    from . import sealed
    from .converter.description import clip_range, describe, material_dict, material_ids
    smallest = min([1.0, *(radius * grouping.scale for radius in grouping.radii)])
    description = describe(remaining, base_dir=None, smallest=smallest, ids=material_ids(model))
    scene = mitsuba_dict(description, params)
    # the clip range of the whole scene, scaled: the rest's alone may cut off grouped spheres
    scene["sensor"]["near_clip"], scene["sensor"]["far_clip"] = (d * grouping.scale for d in clip_range(model))
    materials = []
    for k, (material, radius, centers) in enumerate(sealed.groups(model, grouping, description.origin)):
        scene[f"sealed_{k}"] = sealed.ellipsoids(centers, material_dict(material, base_dir=None), radius)
        materials.append(material)
    return scene, materials


# Which ``.scn`` scene a loaded ``mi.Scene`` came from, for ``whitted trace`` (:func:`recall`).

#: how many scenes are remembered (the least recently loaded go first)
REMEMBERED = 16


@dataclass(frozen=True)
class Source:
    """A loaded scene's model (``whitted.converter.Scene``), its frame (world = frame / scale
    + ``model.lookat``) and the text it was parsed from when it came from no file (``loads``)."""
    model: object
    scale: float = 1.0
    text: str | None = None


_kept = None


def _store():
    """The scenes remembered (:class:`whitted.plugins.scene_tables.KeptByScene`, made on first use)."""
    global _kept
    if _kept is None:
        from .plugins.scene_tables import KeptByScene
        _kept = KeptByScene(REMEMBERED)
    return _kept


def remember(scene, source: Source) -> None:
    """``scene`` was loaded from ``source``."""
    _store().put(scene, source)


def recall(scene) -> Source | None:
    """What ``scene`` was loaded from, if :func:`remember` was told and it is still held."""
    return _store().get(scene)
