"""``trace_pixel``: the ray tree of a pixel, as the renderer computed it (recorded by
:mod:`.record`), moved to the scene file's coordinates, each sphere and light named by its line.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import WhittedError
from .nodes import Node, SphereRef, text


@dataclass
class SceneView:
    """The scene's spheres and lights in the file's coordinates and names (world = frame /
    ``scale`` + ``origin``)."""
    source: str                   # the file's name ("tir.scn"), or what the scene was loaded from
    origin: np.ndarray
    scale: float
    centers: np.ndarray           # (N, 3), the file's coordinates
    radii: np.ndarray             # (N,)
    lines: np.ndarray | None      # (N,), each sphere's line in the file (None: no file)
    names: list | None = None     # each sphere's name where there is no file (its shape's id)
    colors: np.ndarray | None = None   # (N, 3), each sphere's color (textured ones grey)
    glass: np.ndarray | None = None    # (N,), whether each sphere refracts (KT > 0)
    surfaces: np.ndarray | None = None   # (N, 6), each sphere's color (nan: textured), KR, KT, IOR
    text: list | None = None      # the file's lines
    lights: list = field(default_factory=list)   # (position, color, line) in the file's terms
    eye: tuple | None = None

    def position(self, p) -> tuple:
        return tuple(float(c) for c in np.asarray(p, np.float64) / self.scale + self.origin)

    def length(self, t: float) -> float:
        return float(t) / self.scale

    def sphere(self, k: int) -> SphereRef:
        center, radius = tuple(map(float, self.centers[k])), float(self.radii[k])
        if self.lines is None:
            name = self.names[k] if self.names else f"sphere {k}"
            return SphereRef(k, center, radius, name=name)
        line = int(self.lines[k])
        statement, comment = self.words(line)
        return SphereRef(k, center, radius, line=line, statement=statement, comment=comment,
                         name=f"{self.source}:{line}")

    def sphere_at(self, p, n, material: dict | None = None) -> SphereRef | None:
        """The sphere whose surface holds the point ``p`` (file coordinates): the nearest relative
        to its size; of several within float32's reach, one whose surface is the ``material``
        shaded there (spheres may coincide), then the one whose normal there is ``n``."""
        if not len(self.radii):
            return None
        p, n = np.asarray(p, np.float64), np.asarray(n, np.float64)
        offset = p - self.centers
        distance = np.sqrt(np.einsum("ij,ij->i", offset, offset))
        size = self.radii + np.sqrt(np.einsum("ij,ij->i", self.centers - self.origin, self.centers - self.origin))
        gap = np.abs(distance - self.radii) / np.maximum(size, 1e-300)
        near = np.flatnonzero(gap <= 1e-4)
        if not len(near):
            k = int(np.argmin(gap))
            return self.sphere(k) if gap[k] <= 1e-2 else None
        if len(near) > 1:
            near = self._shaded(near, material)
        if len(near) > 1:
            agree = np.einsum("ij,j->i", offset[near], n) / np.maximum(distance[near], 1e-300)
            return self.sphere(int(near[np.argmax(agree - gap[near])]))
        return self.sphere(int(near[0]))

    def _shaded(self, near: np.ndarray, material: dict | None) -> np.ndarray:
        """Of the spheres ``near``, those whose surface is ``material`` (all where none is)."""
        if material is None or self.surfaces is None:
            return near
        m = material
        shaded = np.array([*m["color"], m["reflect"], m["refract"], m["ior"]], np.float64)
        surfaces = self.surfaces[near]
        same = np.isclose(surfaces, shaded, rtol=1e-6, atol=1e-7) | np.isnan(surfaces)
        same[:, 5] |= surfaces[:, 4] == 0   # (the IOR of a sphere that does not refract: unused)
        match = near[same.all(axis=1)]
        return match if len(match) else near

    def light(self, position, index: int | None = None) -> int | None:
        """The file's light at ``position``: the nearest; of several as near (lights may share a
        spot), the renderer's ``index`` (its lights are the file's, in order)."""
        if not self.lights:
            return None
        spots = np.array([p for p, _, _ in self.lights], np.float64)
        distance = np.linalg.norm(spots - np.asarray(position), axis=1)
        if index is not None and index < len(distance) and distance[index] <= distance.min():
            return index
        return int(np.argmin(distance))

    def words(self, line: int | None) -> tuple[str | None, str | None]:
        """The statement that starts on ``line`` of the file, its lines continued with a ``\\``
        joined, and its comment (the first ``#`` outside quotes on those lines), as the parser
        reads them."""
        if not line or not self.text or not 0 < line <= len(self.text):
            return None, None
        from ..converter.parser import token_spans
        parts, comment = [], None
        for text in self.text[line - 1:]:
            spans, continued, mark = token_spans(text)
            if spans:
                parts.append(text[spans[0][0]:spans[-1][1]].strip())
            if comment is None and mark >= 0:
                comment = text[mark + 1:].strip() or None
            if not continued:
                break
        return " ".join(parts) or None, comment


def scene_view(scene) -> SceneView:
    """A loaded scene's :class:`SceneView`: from its ``.scn`` model, else from its shapes' ids."""
    from ..loading import recall
    source = recall(scene)
    sensor = scene.sensors()[0]
    if source is not None:
        model = source.model
        arrays = model.sphere_arrays()
        text = source.text
        if text is None:
            with contextlib.suppress(OSError):
                text = Path(model.source).read_text(encoding="utf-8", errors="replace")
        palette = np.array([(0.7, 0.7, 0.7) if m.texture is not None else m.color for m in arrays.materials]
                           or [(0.7, 0.7, 0.7)], np.float64)
        glass = np.array([m.refract > 0 for m in arrays.materials] or [False])
        surfaces = np.array([(*((np.nan,) * 3 if m.texture is not None else m.color), m.reflect, m.refract,
                              m.ior) for m in arrays.materials] or [(np.nan,) * 6], np.float64)
        material = np.asarray(arrays.material, np.int64)
        return SceneView(source=Path(str(model.source)).name, origin=np.asarray(model.lookat, np.float64),
                         scale=float(source.scale), centers=np.asarray(arrays.center, np.float64).reshape(-1, 3),
                         radii=np.asarray(arrays.radius, np.float64), lines=np.asarray(arrays.line),
                         colors=palette[material], glass=glass[material], surfaces=surfaces[material],
                         text=None if text is None else text.splitlines(),
                         lights=[(tuple(light.position), tuple(light.color), light.line) for light in model.lights],
                         eye=tuple(model.eye))
    from ..plugins.scene_tables import scene_tables
    tables = scene_tables(scene)
    primitives = tables.primitives
    spheres = np.flatnonzero(primitives.sphere)
    shapes = scene.shapes()
    owner = np.searchsorted(primitives.first, spheres, side="right") - 1
    names = [shapes[s].id() + (f"[{p - primitives.first[s]}]" if primitives.counts[s] > 1 else "")
             for p, s in zip(spheres.tolist(), owner.tolist())]
    eye = tuple(float(c) for c in np.asarray(sensor.world_transform().translation()).reshape(-1))
    return SceneView(source="the scene", origin=np.zeros(3), scale=1.0,
                     centers=primitives.center[:, spheres].T.copy(), radii=primitives.radius[spheres].copy(),
                     lines=None, names=names,
                     lights=[(tuple(map(float, p)), tuple(map(float, c)), None) for p, c in tables.lights],
                     eye=eye)


@dataclass
class PixelTree:
    """The ray tree of pixel ``(x, y)``, whose contributions add up to ``color``."""
    x: int
    y: int
    root: Node
    color: tuple
    view: SceneView = field(repr=False)
    settings: dict = field(default_factory=dict, repr=False)

    def total(self) -> tuple:
        return self.root.total()

    def nodes(self) -> list[Node]:
        return list(self.root.walk())

    def __str__(self) -> str:
        return text([self])

    def json(self) -> dict:
        return {"pixel": [self.x, self.y], "color": list(self.color), "sum": list(self.total()),
                "rays": self.root.count(), "tree": self.root.json()}

    def _repr_html_(self) -> str:
        from .page import fragment
        return fragment(self.view, [self])


class Traces(list):
    """The trees of several pixels of one scene (:func:`trace_pixels`), shown together."""

    def __init__(self, trees, view: SceneView, settings: dict, scene=None):
        super().__init__(trees)
        self.view, self.settings, self.scene = view, settings, scene   # scene: the mi.Scene traced

    def __str__(self) -> str:
        return text(self)

    def json(self) -> dict:
        return {"scene": self.view.source, "settings": self.settings,
                "coordinates": "the scene file's" if self.view.lines is not None else "the loaded scene's",
                "pixels": [tree.json() for tree in self]}

    def _repr_html_(self) -> str:
        from .page import fragment
        return fragment(self.view, list(self))


def trace_pixels(scene, pixels, *, variant: str | None = None, max_depth: int | None = None,
                 ambient: float | None = None, lighting: str | None = None,
                 min_weight: float | None = None) -> Traces:
    """The ray trees of ``pixels`` (``(x, y)`` from the top left, or percentages such as
    ``("50%", "45%")``) of ``scene`` (a ``mi.Scene`` or a path), as a 1 spp render traces them."""
    from ..rendering import check_article_materials, check_settings, whitted_integrator
    check_settings(None, max_depth, lighting, "whitted", min_weight, ambient=ambient)
    path = scene if isinstance(scene, (str, os.PathLike)) else None
    if path is not None:
        from ..loading import load_scene
        from ..rendering import quiet_mitsuba
        with quiet_mitsuba():
            scene = load_scene(path, variant=variant, meshes=False, max_depth=max_depth, ambient=ambient,
                               lighting=lighting)
    elif variant is not None:
        raise WhittedError("variant applies to a scene given by its path; a loaded scene keeps its own")
    if not scene.sensors():
        raise WhittedError(f"{path}: the scene has no sensor (camera) to trace from" if path is not None
                           else "the scene has no sensor (camera) to trace from")
    width, height = (int(c) for c in scene.sensors()[0].film().crop_size())
    pixels = [(_coordinate(x, width), _coordinate(y, height)) for x, y in pixels]
    for x, y in pixels:
        if not (0 <= x < width and 0 <= y < height):
            raise WhittedError(f"pixel ({x}, {y}) is outside the {width}x{height} image "
                               f"(x from 0 to {width - 1}, y from 0 to {height - 1})")
    check_article_materials(scene)
    integrator = whitted_integrator(scene, max_depth=max_depth, lighting=lighting, ambient=ambient,
                                    min_weight=min_weight)
    from .record import Recorder
    recorder = Recorder()
    unique = list(dict.fromkeys(pixels))
    colors = integrator.trace_pixels(scene, unique, recorder)
    roots = recorder.trees()
    recorder.blockers(roots)
    flat = np.concatenate([np.asarray(c, np.float64).reshape(3, -1).T for c in colors])
    view = scene_view(scene)
    if view.lines is None and path is not None:
        view.source = Path(path).name   # (a converted .xml: no scene file names its spheres)
    for root in roots:
        _to_file(root, view)
    used = {k: v for k, v in integrator.settings().items() if k not in ("exact_spheres", "light_reference")}
    trees = {p: PixelTree(p[0], p[1], root, tuple(map(float, color)), view, used)
             for p, root, color in zip(unique, roots, flat)}
    return Traces([trees[p] for p in pixels], view, used, scene)


def _coordinate(value, size: int) -> int:
    if isinstance(value, str) and value.strip().endswith("%"):
        try:
            share = float(value.strip()[:-1]) / 100
        except ValueError:
            raise WhittedError(f"pixel coordinate {value!r} is not a percentage such as 45%") from None
        if not 0 <= share <= 1:
            raise WhittedError(f"pixel coordinate {value} must be from 0% to 100%")
        return min(_percent_of(value.strip()[:-1], size), size - 1)
    try:
        return int(value)
    except (TypeError, ValueError):
        raise WhittedError(f"pixel coordinate {value!r} is neither a whole number nor a percentage") from None


def _percent_of(number: str, size: int) -> int:
    """The pixel ``number`` percent into ``size`` pixels, in decimal: 29% of 100 is pixel 29,
    where binary floating point makes 0.29 · 100 = 28.999… and picks the pixel before."""
    from decimal import Decimal
    return int(Decimal(number) * size / 100)


def trace_pixel(scene, x: int, y: int, **options) -> PixelTree:
    """The ray tree of pixel ``(x, y)`` of ``scene`` (:func:`trace_pixels`' options)."""
    return trace_pixels(scene, [(x, y)], **options)[0]


def _to_file(root: Node, view: SceneView) -> None:
    for node in root.walk():
        node.origin = view.position(node.origin)
        if node.hit:
            node.position = view.position(node.position)
            node.distance = view.length(node.distance)
            node.sphere = view.sphere_at(node.position, node.normal, node.material)
        for term in node.lights:
            term.position = view.position(term.position)
            k = view.light(term.position, term.index)
            if k is not None:
                term.index = k
                _, _, term.line = view.lights[k]
                term.statement = view.words(term.line)[0]
            if term.shadow is not None:
                term.shadow.update(origin=view.position(term.shadow["origin"]),
                                   length=view.length(term.shadow["length"]))
            if term.blocker_point is not None:
                term.blocker_point = view.position(term.blocker_point)
                term.blocker = view.sphere_at(term.blocker_point, term.blocker_normal)
