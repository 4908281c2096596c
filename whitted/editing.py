"""Editing a loaded scene in its ``.scn`` file's terms: the edited model is described again
and what changed written through ``mi.traverse``, so the scene renders as the edited file
would, bit for bit (docs/notebook.md, "Editing a scene in the file's terms").
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from . import defaults as D
from .errors import WhittedError


class SceneEditor:
    """A scene loaded from a ``.scn`` file (or its text, or a model), edited in the file's
    coordinates: ``editor.scene`` the ``mi.Scene``, ``editor.model`` the model as edited,
    :meth:`scn` its text; ``overrides`` as :func:`whitted.load_scene`'s."""

    def __init__(self, source, variant: str | None = None, **overrides):
        from .converter import Scene, parse_file
        from .converter.description import describe
        from .converter.frame import warn_scene
        from .loading import _leaving_out, _loaded, mitsuba_dict, prepared
        params, without = prepared(variant, overrides)
        if isinstance(source, Scene):
            self.model = source
        else:
            self.model = parse_file(Path(source))
            warn_scene(self.model)
        self._description = describe(self.model, base_dir=None)
        loaded = _loaded(mitsuba_dict(self._description, params), meshes=True)
        self.scene = _leaving_out(loaded, without, self.model.source)

    @classmethod
    def loads(cls, text: str, variant: str | None = None, *, base_dir: str | os.PathLike = ".",
              **overrides) -> "SceneEditor":
        """An editor of a scene's ``.scn`` text (as :func:`whitted.loads`)."""
        from .converter import parse_text
        from .converter.frame import warn_scene
        from .loading import TEXT_NAME
        model = parse_text(text, Path(base_dir) / TEXT_NAME)
        warn_scene(model)
        return cls(model, variant, **overrides)

    def move_light(self, k: int, position) -> None:
        """Light ``k`` (from 0, in the file's order) to ``position`` (the file's coordinates)."""
        lights = list(self.model.lights)
        light = self._item(lights, k, "light")
        lights[k] = replace(light, position=D.check_point(position, "a light's position"))
        self._apply(replace(self.model, lights=lights))

    def move_sphere(self, k: int, center, radius: float | None = None) -> None:
        """Sphere ``k`` (from 0) to ``center`` (the file's coordinates), ``radius`` (None: kept)."""
        spheres = list(self.model.spheres)
        sphere = self._item(spheres, k, "sphere")
        radius = sphere.radius if radius is None else float(radius)
        if not radius > 0:
            raise WhittedError(f"a sphere's radius must be > 0, got {radius}")
        spheres[k] = replace(sphere, center=D.check_point(center, "a sphere's center"),
                             radius=radius)
        self._apply(replace(self.model, spheres=spheres))

    def set_color(self, k: int, color) -> None:
        """The color of sphere ``k`` (from 0), and of every sphere sharing its material."""
        spheres = list(self.model.spheres)
        material = self._item(spheres, k, "sphere").material
        if material.texture is not None:
            raise WhittedError(f"sphere {k} is textured: its texture, not a color, gives its base color")
        edited = replace(material, color=D.check_color(color))
        self._apply(replace(self.model, spheres=[replace(s, material=edited) if s.material == material else s
                                                 for s in spheres]))

    def scn(self, folder: str | os.PathLike = ".") -> str:
        """The edited scene as ``.scn`` text for a file in ``folder`` (textures relative to it)."""
        from .converter.scn_writer import scene_to_scn
        return scene_to_scn(self.model, folder)

    @staticmethod
    def _item(items: list, k: int, what: str):
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(items):
            raise WhittedError(f"no {what} {k!r}: the scene has {len(items)} {what}s, numbered from 0")
        return items[k]

    def _apply(self, model) -> None:
        import mitsuba as mi

        from .converter.description import describe
        description = describe(model, base_dir=None)
        changes = _differences(self._description.scene, description.scene)
        writes = {}
        for path, value in changes:
            key = _parameter(path, value, description.scene)
            if key is None:
                raise WhittedError(f"this edit changes how the scene is built ({'.'.join(map(str, path))}), "
                                   "which Mitsuba's parameters cannot change: make it in the .scn file "
                                   "and load that; the scene is left as it was")
            writes[key[0]] = key[1]
        params = mi.traverse(self.scene)
        for key, value in writes.items():
            params[key] = _as(params[key], value)
        params.update()
        self.model, self._description = model, description


def _differences(old, new, path=()) -> list:
    """``(path, new value)`` of every leaf where the descriptions ``old`` and ``new`` differ."""
    if isinstance(old, dict) and isinstance(new, dict):
        found = []
        for key in dict.fromkeys([*old, *new]):
            if key not in old or key not in new:
                found.append(((*path, key), new.get(key)))
            else:
                found += _differences(old[key], new[key], (*path, key))
        return found
    return [] if type(old) is type(new) and old == new else [(path, new)]


def _parameter(path: tuple, value, scene: dict):
    """``(key, value)`` of the Mitsuba parameter that makes a change, or None (a new scene); a
    sphere's transform made as its plugin makes it."""
    import mitsuba as mi
    import numpy as np

    from .converter.description import Matrix
    obj = scene.get(path[0]) if path else None
    kind = obj.get("type") if isinstance(obj, dict) else None
    if ((kind == "point" and path[1:] in (("position",), ("intensity", "value")))
            or (kind == "article" and path[1:] == ("color", "value"))
            or path in (("sensor", "near_clip"), ("sensor", "far_clip"))):
        return ".".join(path), value
    if kind == "sphere" and path[1:] in (("center",), ("radius",)):
        return f"{path[0]}.to_world", mi.ScalarAffineTransform4f().translate(
            mi.ScalarPoint3f(obj["center"])).scale(mi.ScalarVector3f(obj["radius"]))
    if kind == "sphere" and path[1:] == ("to_world",) and isinstance(value, Matrix):
        exact = mi.ScalarAffineTransform4d(mi.ScalarMatrix4d(np.array(value.rows, np.float64)))
        return f"{path[0]}.to_world", mi.ScalarAffineTransform4f(
            mi.ScalarMatrix4f(np.array(exact.matrix, np.float32)),
            mi.ScalarMatrix4f(np.array(exact.inverse_transpose, np.float32)))
    return None


def _as(current, value):
    """``value`` as the type of ``current``."""
    import mitsuba as mi
    if isinstance(value, mi.ScalarAffineTransform4f):
        return type(current)(value)
    if isinstance(current, float):
        return float(value)
    return type(current)(*value)
