"""The scene model: what a legacy ``.scn`` file says, validated, with defaults filled in.

Data flows one way: text -> :class:`Scene` (parser) -> Mitsuba XML (xml_writer)
-> ``mi.Scene``. The defaults are the format's (``docs/scene-format.md``), taken from
:mod:`whitted.defaults`, their one home.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .. import defaults as D

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
    spheres: list[Sphere] = field(default_factory=list)
