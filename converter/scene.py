"""The scene model: what a legacy ``.scn`` file says, validated, with defaults filled in.

The converter computes with the spheres as numpy arrays (:class:`SphereArrays`); the list of
:class:`Sphere` objects a program reads and changes, :attr:`Scene.spheres`, is made from them
only when asked for (a million objects take seconds and hundreds of megabytes).
"""

from __future__ import annotations

import math
import os
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
    """A sphere's surface: the article's coefficients (diffuse: 1 - reflect - refract); a
    ``texture`` (an absolute path) replaces ``color``."""
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
    """Spheres as read-only arrays, one row per sphere: ``material`` and ``orientation`` index
    the distinct ``materials`` and ``(north, equator)`` pairs (by first use); ``line``: 0 none."""
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
        north, equator = self.orientations[int(self.orientation[k])]
        return Sphere(tuple(self.center[k].tolist()), float(self.radius[k]),
                      self.materials[int(self.material[k])], north, equator, int(self.line[k]))

    def to_list(self) -> list[Sphere]:
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


class Distinct:
    """Numbers values in order of first appearance; equal means of equal ``repr`` (not -0.0, 0.0)."""

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
    #: the spheres as objects (made from the arrays on first use), or assigned as arrays
    spheres: list[Sphere] = field(default_factory=list)
    #: line -> the comment of the statement there: it names its sphere and material
    comments: dict[int, str] = field(default_factory=dict)

    def sphere_arrays(self) -> SphereArrays:
        """The spheres as arrays: those held, or made anew from the list :attr:`spheres`."""
        arrays = self.__dict__.get("_sphere_arrays")
        return SphereArrays.of(self.__dict__["_sphere_list"]) if arrays is None else arrays

    def held_sphere_arrays(self) -> SphereArrays | None:
        """The arrays the scene holds until :attr:`spheres` is first read, or None."""
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


# The converter's vector arithmetic on 3-tuples of Python floats, written once.


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


def relative_path(path: Path, folder: Path) -> str:
    """``path`` relative to ``folder``, both real (the OS resolves '..' after a symlink)."""
    return Path(os.path.relpath(os.path.realpath(path), os.path.realpath(folder))).as_posix()
