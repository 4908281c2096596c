"""Scene model -> one plain-Python description of the Mitsuba scene, in ``mi.load_dict`` form.

The XML (:mod:`.xml_writer`) and ``mi.load_dict`` (:mod:`whitted.loading`) are both built
from it, so every formula is written once. It imports neither Mitsuba nor Dr.Jit: Mitsuba
objects and the XML's ``$name`` parameters are markers (:class:`LookAt`, :class:`Matrix`,
:class:`Param`). Light intensities: docs/radiometry.md.
"""

from __future__ import annotations

import math
import os
import re
import unicodedata
from dataclasses import dataclass, field, replace
from pathlib import Path

from typing import TYPE_CHECKING

from .. import defaults as D
from .frame import farthest, scene_origin, surface_distances, to_frame
from .giants import cached, coarse_spheres, exact_spheres, mesh_bytes
from .scene import Material, Scene, Sphere, SphereArrays, Vec3
from .scene import cross, dot, normalize, relative_path, sub

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class Param:
    """A scene parameter: ``$name`` in the XML, its default or override in the dict."""
    name: str


@dataclass(frozen=True)
class LookAt:
    """A ``to_world`` transform as Mitsuba's ``lookat`` (computed by Mitsuba, in float64)."""
    origin: Vec3
    target: Vec3
    up: Vec3


@dataclass(frozen=True)
class Matrix:
    """A ``to_world`` transform given as a 4×4 matrix, row by row."""
    rows: tuple[tuple[float, float, float, float], ...]


@dataclass(frozen=True)
class Mesh:
    """A mesh shape's ``filename``, with the PLY file's bytes (:mod:`.giants`)."""
    filename: str
    data: bytes = field(repr=False)


@dataclass(frozen=True, eq=False)
class SphereBlock:
    """Spheres held as arrays rather than in ``scene``: sphere ``k`` is ``sphere_{names[k]}``,
    unless ``k`` is in ``in_scene`` (textured or meshed). They come after every other object."""
    center: np.ndarray
    radius: np.ndarray
    material: np.ndarray
    material_ids: tuple[str, ...]
    names: list[str]
    in_scene: frozenset = frozenset()

    def __len__(self) -> int:
        return len(self.radius)


@dataclass
class Description:
    """A Mitsuba scene as plain Python: ``scene`` in ``mi.load_dict`` form with the markers
    above, the ``defaults`` of its parameters, the world point ``origin`` of its frame, the
    spheres it leaves out, and ``notes``: material id -> where the file first writes it."""
    scene: dict
    defaults: dict = field(default_factory=dict)
    origin: Vec3 = (0.0, 0.0, 0.0)
    source: str = ""
    spheres: SphereBlock | None = None
    notes: dict = field(default_factory=dict)


def light_intensity(scene: Scene, position: Vec3, color: Vec3) -> Vec3:
    """Point-light intensity that matches the article's brightness at ``lookat``."""
    d2 = dot(sub(position, scene.lookat), sub(position, scene.lookat)) or 1.0
    return tuple(c * math.pi * d2 for c in color)


def clip_range(scene: Scene, spheres: SphereArrays | None = None) -> tuple[float, float]:
    """Near and far clip distances that contain every sphere seen from the eye."""
    spheres = scene.sphere_arrays() if spheres is None else spheres
    far = 4.0 * farthest(scene.eye, [scene.lookat], spheres)[0]
    # Mitsuba starts primary rays on the near plane: 1e-12 of far keeps them at the eye while
    # the directions stay float32-exact (they degrade only below about 1e-16), unless a giant
    # sphere sets far (radius 1e12: 8 units): never past a thousandth of the nearest surface.
    gap = float(surface_distances(scene.eye, spheres).min()) if len(spheres) else math.inf
    return max(min(far * 1e-12, gap * 1e-3), far * 1e-16), far


def _rgb(value: Vec3) -> dict:
    return {"type": "rgb", "value": tuple(float(c) for c in value)}


def _shared(material: Material) -> Material:
    """The material as written: a texture replaces the color, which then plays no part."""
    return material if material.texture is None else replace(material, color=Material.color)


def slug(text: str) -> str:
    """``text`` as part of an id: lowercase ASCII letters and digits joined by ``_``, at most 24."""
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode().lower()
    text = re.sub(r"[^a-z0-9]+", "_", text).strip("_")
    if len(text) > 24:
        cut = text.rfind("_", 0, 25)
        text = text[:cut] if cut > 0 else text[:24]
    return text


def sphere_names(scene: Scene, spheres: SphereArrays) -> list[str]:
    """Per sphere, what its ids end in: ``l12_the_floor`` (line 12, comment "the floor"),
    ``l12`` without a comment, its index without a line of its own."""
    import numpy as np
    line = spheres.line
    lines, first = np.unique(line, return_index=True)
    names = list(map("l%d".__mod__, line.tolist()))
    shared = np.ones(len(line), bool)
    shared[first[lines > 0]] = False
    for k in np.flatnonzero(shared).tolist():
        names[k] = str(k)
    for number, text in scene.comments.items():
        i = int(lines.searchsorted(number))
        if i < len(lines) and lines[i] == number > 0 and slug(text):
            names[first[i]] = f"l{number}_{slug(text)}"
    return names


def first_spheres(scene: Scene, spheres: SphereArrays | None = None) -> dict:
    """Each distinct material as written (:func:`_shared`) -> the index of its first sphere."""
    import numpy as np
    spheres = scene.sphere_arrays() if spheres is None else spheres
    firsts: dict[Material, int] = {}
    for k in np.sort(np.unique(spheres.material, return_index=True)[1]).tolist():
        firsts.setdefault(_shared(spheres.materials[int(spheres.material[k])]), k)
    return firsts


def material_ids(scene: Scene, names: list[str] | None = None, firsts: dict | None = None) -> dict:
    """Each distinct material as written -> its id: ``material_`` and its first sphere's name,
    or ``material_K`` (K its place in order of first use) when that sphere has no line."""
    names = sphere_names(scene, scene.sphere_arrays()) if names is None else names
    firsts = first_spheres(scene) if firsts is None else firsts
    return {material: f"material_{names[k]}" if names[k][0] == "l" else f"material_{i}"
            for i, (material, k) in enumerate(firsts.items())}


def line_label(scene: Scene, line: int) -> str:
    """The statement on ``line`` as a person finds it in the file: ``line 12 (the floor)``."""
    comment = scene.comments.get(line)
    return f"line {line} ({comment})" if comment else f"line {line}"


def material_labels(scene: Scene) -> dict:
    """Each material id -> its first sphere's :func:`line_label`, or the id without a line."""
    spheres = scene.sphere_arrays()
    names, firsts = sphere_names(scene, spheres), first_spheres(scene, spheres)
    return {mid: line_label(scene, int(spheres.line[k])) if names[k][0] == "l" else mid
            for mid, k in zip(material_ids(scene, names, firsts).values(), firsts.values())}


def material_dict(material: Material, base_dir: Path | None) -> dict:
    """The ``article`` BSDF of ``material`` (the loader's ellipsoids take it too)."""
    if material.texture is None:
        color = _rgb(material.color)
    else:
        path = str(material.texture) if base_dir is None else relative_path(material.texture, base_dir)
        color = {"type": "bitmap", "filename": path, "filter_type": "nearest", "wrap_mode": "clamp"}
    return {"type": "article", "color": color, "reflect": float(material.reflect),
            "refract": float(material.refract), "ior": float(material.ior)}


def _sphere(sphere: Sphere, origin: Vec3, material_id: str, mesh: Mesh | None = None) -> dict:
    """The ``ply`` shape of ``mesh`` when given, else the textured ``sphere``: on the local axes
    (Ve, Vn x Ve, Vn), Mitsuba's sphere UV is the article's lat/long mapping (v = 0 the north
    pole and a bitmap's top row)."""
    if mesh is not None:
        return {"type": "ply", "filename": mesh, "bsdf": {"type": "ref", "id": material_id}}
    center, z, equator = to_frame(sphere.center, origin), normalize(sphere.north), sphere.equator
    d = dot(equator, z)
    x = normalize((equator[0] - d * z[0], equator[1] - d * z[1], equator[2] - d * z[2]))
    y, r = cross(z, x), sphere.radius
    rows = tuple((x[i] * r, y[i] * r, z[i] * r, center[i]) for i in range(3)) + ((0.0, 0.0, 0.0, 1.0),)
    return {"type": "sphere", "to_world": Matrix(rows), "bsdf": {"type": "ref", "id": material_id}}


def describe(scene: Scene, base_dir: str | os.PathLike | None, smallest: float | None = None,
             block: bool = False, ids: dict | None = None) -> Description:
    """The description of ``scene``, texture paths relative to ``base_dir`` (None: absolute).
    ``smallest``: see :func:`.giants.coarse_spheres`. ``block``: a parsed file's plain spheres
    go in :attr:`Description.spheres`. ``ids``: the material ids of a larger scene."""
    import numpy as np

    from .scn_writer import material_text
    base_dir = None if base_dir is None else Path(os.path.abspath(base_dir))
    spheres = scene.sphere_arrays()
    sphere = spheres.sphere
    names, firsts = sphere_names(scene, spheres), first_spheres(scene, spheres)
    ids = material_ids(scene, names, firsts) if ids is None else ids
    origin = scene_origin(scene)
    near, far = clip_range(scene, spheres)
    defaults = {"spp": int(scene.samples), "max_depth": int(scene.depth),
                "ambient": float(scene.ambient), "lighting": D.LIGHTING,
                "width": int(scene.width), "height": int(scene.height)}
    integrator = {"type": "whitted", "max_depth": Param("max_depth"), "ambient": Param("ambient"),
                  "lighting": Param("lighting")}
    if scene.min_weight is not None:   # else the integrator's own default
        defaults["min_weight"] = float(scene.min_weight)
        integrator["min_weight"] = Param("min_weight")
    integrator["light_reference"] = to_frame(scene.lookat, origin)
    # Spheres too coarse in float32 for the whitted integrator, and for Mitsuba's (meshed).
    giants, misplaced = coarse_spheres(scene, origin, smallest, spheres)
    meshed = {k for k in misplaced if sphere(k).material.texture is None}
    giants = sorted(set(giants) | meshed)
    if giants:
        # Their exact values, for the integrator to intersect in float64 (plugins/hits.py).
        integrator["exact_spheres"] = exact_spheres(
            (f"sphere_{names[k]}", to_frame(sphere(k).center, origin), sphere(k).radius) for k in giants)
    objects: dict = {"type": "scene", "integrator": integrator}
    objects["sensor"] = {
        "type": "perspective", "fov_axis": "x", "fov": float(scene.fov),
        "near_clip": near, "far_clip": far,
        "to_world": LookAt(to_frame(scene.eye, origin), to_frame(scene.lookat, origin), normalize(scene.up)),
        "sampler": {"type": "independent", "sample_count": Param("spp")},
        "film": {"type": "hdrfilm", "width": Param("width"), "height": Param("height"),
                 "pixel_format": "rgb", "rfilter": {"type": "box"}},
    }
    if any(c > 0 for c in scene.background):
        objects["background"] = {"type": "constant", "radiance": _rgb(scene.background)}
    for i, light in enumerate(scene.lights):
        objects[f"light_{i}"] = {"type": "point", "position": to_frame(light.position, origin),
                                 "intensity": _rgb(light_intensity(scene, light.position, light.color))}
    # Identical materials are described once and shared by reference (a small dispatch).
    description = Description(objects, defaults, origin, scene.source.name)
    for material, k in firsts.items():
        objects[ids[material]] = material_dict(material, base_dir)
        line = sphere(k).line
        if line > 0 and block:   # for the XML's readers: where the file first writes it
            comment = f"  # {scene.comments[line]}" if scene.comments.get(line) else ""
            text = material_text(sphere(k), base_dir or scene.source.parent)
            description.notes[ids[material]] = f"{scene.source.name}:{line}: {text}{comment}"
    # The spheres: plain ones in the scene or in a block, textured and meshed ones in the scene.
    by_index = [ids.get(_shared(material), "") for material in spheres.materials]
    special = sorted(meshed | set(np.flatnonzero(spheres.textured()).tolist()))
    center = spheres.center - origin
    if block and scene.held_sphere_arrays() is not None:
        description.spheres = SphereBlock(center, spheres.radius, spheres.material, tuple(by_index), names,
                                          frozenset(special))
    else:
        for name, (x, y, z), radius, m in zip(names, center.tolist(), spheres.radius.tolist(),
                                              spheres.material.tolist()):
            description.scene[f"sphere_{name}"] = {"type": "sphere", "center": (x, y, z), "radius": radius,
                                                   "bsdf": {"type": "ref", "id": by_index[m]}}
    for k in special:
        mesh = None
        if k in meshed:
            data = mesh_bytes(sphere(k), origin, scene.eye, scene.lookat)
            mesh = Mesh(str(cached(data)) if base_dir is None else f"{file_stem(scene)}.sphere_{names[k]}.ply", data)
        description.scene[f"sphere_{names[k]}"] = _sphere(sphere(k), origin, by_index[int(spheres.material[k])], mesh)
    return description


def file_stem(scene: Scene) -> str:
    """The scene file's name without its suffix, as a safe file name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", Path(scene.source).stem).strip("_.") or "scene"


def meshes(description: Description) -> list[Mesh]:
    """The mesh files ``description`` refers to, in order."""
    return [node["filename"] for node in description.scene.values()
            if isinstance(node, dict) and isinstance(node.get("filename"), Mesh)]
