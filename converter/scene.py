"""The scene model: what a legacy ``.scn`` file says, validated, with defaults filled in.

Data flows one way: text -> :class:`Scene` (parser) -> Mitsuba XML (xml_writer)
-> ``mi.Scene``. The defaults are the format's (``docs/scene-format.md``), taken from
:mod:`whitted.defaults`, their one home.

The converter computes with a scene's spheres as numpy arrays (:class:`SphereArrays`,
:meth:`Scene.sphere_arrays`). The parser reads a large file into arrays, making no object per
sphere; :attr:`Scene.spheres`, the list of :class:`Sphere` objects a program reads and
changes, is made from them the first time someone asks for it (a million objects take
seconds and hundreds of megabytes, the arrays a few tens of megabytes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .. import defaults as D

if TYPE_CHECKING:
    import numpy as np

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Light:
    """A point light; ``color`` is the article's light color (no distance fall-off)."""
    position: Vec3
    color: Vec3 = D.LIGHT_COLOR
    line: int = 0


@dataclass(frozen=True)
class Material:
    """A sphere's surface: the article's coefficients.

    The diffuse weight is 1 - reflect - refract; ``texture`` (an absolute path)
    replaces ``color`` as the base color when given.
    """
    color: Vec3 = D.COLOR
    reflect: float = D.REFLECT
    refract: float = D.REFRACT
    ior: float = D.IOR
    texture: Path | None = None


@dataclass(frozen=True)
class Sphere:
    center: Vec3
    radius: float
    material: Material = Material()
    north: Vec3 = D.NORTH
    equator: Vec3 = D.EQUATOR
    line: int = 0


@dataclass(frozen=True, eq=False)
class SphereArrays:
    """Spheres as arrays, one row per sphere, in order.

    ================ =======================================================================
    ``center``       N×3 float64: the centers
    ``radius``       N float64: the radii
    ``material``     N int64: each sphere's index into ``materials``
    ``materials``    the distinct materials (by repr: -0.0 apart from 0.0), in order of first use
    ``line``         N int64: each sphere's line in its file (0: none)
    ``orientation``  N int64: each sphere's index into ``orientations``
    ``orientations`` the distinct ``(north, equator)`` pairs, in order of first use
    ================ =======================================================================

    :meth:`sphere` and :meth:`to_list` give back equal objects (numbers as Python floats
    and ints). The arrays are not to be written to.
    """
    center: np.ndarray
    radius: np.ndarray
    material: np.ndarray
    materials: tuple[Material, ...]
    line: np.ndarray
    orientation: np.ndarray
    orientations: tuple[tuple[Vec3, Vec3], ...]

    def __len__(self) -> int:
        return len(self.radius)

    def sphere(self, k: int) -> Sphere:
        """The ``k``-th sphere as an object."""
        north, equator = self.orientations[int(self.orientation[k])]
        return Sphere(tuple(self.center[k].tolist()), float(self.radius[k]),
                      self.materials[int(self.material[k])], north, equator, int(self.line[k]))

    def to_list(self) -> list[Sphere]:
        """Every sphere as an object, in order."""
        orientations = [self.orientations[k] for k in self.orientation.tolist()]
        return list(map(Sphere, map(tuple, self.center.tolist()), self.radius.tolist(),
                        map(self.materials.__getitem__, self.material.tolist()),
                        (o[0] for o in orientations), (o[1] for o in orientations), self.line.tolist()))

    def textured(self) -> np.ndarray:
        """Per sphere: whether its material has a texture."""
        import numpy as np
        flags = np.array([m.texture is not None for m in self.materials], bool)
        return flags[self.material] if len(flags) else np.zeros(len(self), bool)

    @staticmethod
    def of(spheres: list[Sphere]) -> "SphereArrays":
        """The arrays of a list of spheres."""
        import numpy as np
        n = len(spheres)
        materials, orientations = Distinct(), Distinct()
        material = np.fromiter((materials.index(s.material) for s in spheres), np.int64, n)
        orientation = np.fromiter((orientations.index((s.north, s.equator)) for s in spheres), np.int64, n)
        center = np.array([s.center for s in spheres], np.float64).reshape(n, 3)
        radius = np.fromiter((s.radius for s in spheres), np.float64, n)
        line = np.fromiter((s.line for s in spheres), np.int64, n)
        return SphereArrays(center, radius, material, tuple(materials.values), line, orientation,
                            tuple(orientations.values))


def first_use(index: np.ndarray) -> np.ndarray:
    """The distinct values of the integer array ``index`` (from 0 on), in order of first
    appearance."""
    import numpy as np
    present = np.flatnonzero(np.bincount(index)) if len(index) else np.zeros(0, np.int64)
    if len(present) <= 16:    # few values, the usual case: no sort
        first = [int(np.argmax(index == v)) for v in present.tolist()]
        return present[np.argsort(first, kind="stable")]
    values, first = np.unique(index, return_index=True)
    return values[np.argsort(first)]


class Distinct:
    """Numbers values in order of first appearance, equal ones alike. Equal means of equal
    ``repr``, which tells -0.0 from 0.0 (``==`` does not)."""

    def __init__(self):
        self.values: list = []
        self._by_repr: dict[str, int] = {}
        self._by_id: dict[int, int] = {}   # the values held in self.values, by id

    def index(self, value) -> int:
        k = self._by_id.get(id(value))
        if k is None:
            k = self._by_repr.setdefault(repr(value), len(self.values))
            if k == len(self.values):
                self.values.append(value)
            if self.values[k] is value:
                self._by_id[id(value)] = k
        return k


@dataclass
class Scene:
    """A whole legacy scene. ``source`` is the file it came from (for messages and paths)."""
    source: Path = Path("<memory>")
    width: int = D.WIDTH
    height: int = D.HEIGHT
    eye: Vec3 = D.EYE
    lookat: Vec3 = D.LOOKAT
    up: Vec3 = D.UP
    fov: float = D.FOV
    background: Vec3 = D.BACKGROUND
    ambient: float = D.AMBIENT
    depth: int = D.DEPTH
    samples: int = D.SAMPLES
    #: the adaptive depth control's threshold (``minweight``); None: the integrator's default
    min_weight: float | None = None
    lights: list[Light] = field(default_factory=list)
    #: the spheres as objects (made from :meth:`sphere_arrays` on first use); assigning a
    #: :class:`SphereArrays` is allowed too
    spheres: list[Sphere] = field(default_factory=list)
    #: line -> the comment of the statement there (the text after ``#``, stripped): what
    #: names its sphere and material (converter/description.py, ``sphere_names``)
    comments: dict[int, str] = field(default_factory=dict)

    def sphere_arrays(self) -> SphereArrays:
        """The spheres as arrays: those the scene holds (:meth:`held_sphere_arrays`), or else
        made from the list :attr:`spheres` (then made anew on every call: the list may change)."""
        arrays = self.__dict__.get("_sphere_arrays")
        return SphereArrays.of(self.__dict__["_sphere_list"]) if arrays is None else arrays

    def held_sphere_arrays(self) -> SphereArrays | None:
        """The spheres as arrays when the scene holds them so (a parsed file's, or a
        :class:`SphereArrays` assigned to :attr:`spheres`) until :attr:`spheres` is first read;
        else None."""
        return self.__dict__.get("_sphere_arrays")


def _get_spheres(scene: Scene) -> list[Sphere]:
    spheres = scene.__dict__.get("_sphere_list")
    if spheres is None:
        # From now on the list is the truth (its owner may change it); the arrays go.
        spheres = scene.__dict__["_sphere_list"] = scene.__dict__["_sphere_arrays"].to_list()
        scene.__dict__["_sphere_arrays"] = None
    return spheres


def _set_spheres(scene: Scene, spheres) -> None:
    if isinstance(spheres, SphereArrays):
        scene.__dict__["_sphere_list"], scene.__dict__["_sphere_arrays"] = None, spheres
    else:
        scene.__dict__["_sphere_list"], scene.__dict__["_sphere_arrays"] = spheres, None


# After the dataclass is made: its __init__, __repr__ and __eq__ go through the property.
Scene.spheres = property(_get_spheres, _set_spheres,
                         doc="The spheres as objects, in order (made from the arrays on first use).")


# The converter's vector arithmetic on 3-tuples of Python floats, written once: the parser's
# checks, the description and the frame compute with the same formulas, bit for bit alike.


def sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def length(a: Vec3) -> float:
    return math.sqrt(dot(a, a))


def normalize(a: Vec3) -> Vec3:
    """``a`` / |a|, scaled first so that tiny or huge components neither underflow nor overflow."""
    scale = max(abs(c) for c in a)
    a = (a[0] / scale, a[1] / scale, a[2] / scale)
    n = length(a)
    return (a[0] / n, a[1] / n, a[2] / n)
