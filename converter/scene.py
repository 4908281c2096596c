"""The scene model: what a legacy ``.scn`` file says, validated, with defaults filled in.

Data flows one way: text -> :class:`Scene` (parser) -> Mitsuba XML (xml_writer)
-> ``mi.Scene``. Every default of ``shared/scene-format.md`` lives here, once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Light:
    """A point light; ``color`` is the article's light colour (no distance fall-off)."""
    position: Vec3
    color: Vec3 = (1.0, 1.0, 1.0)
    line: int = 0


@dataclass(frozen=True)
class Material:
    """A sphere's surface: the article's coefficients.

    The diffuse weight is 1 - reflect - refract; ``texture`` (an absolute path)
    replaces ``color`` as the base colour when given.
    """
    color: Vec3 = (1.0, 1.0, 1.0)
    reflect: float = 0.0
    refract: float = 0.0
    ior: float = 1.0
    texture: Path | None = None


@dataclass(frozen=True)
class Sphere:
    center: Vec3
    radius: float
    material: Material = Material()
    north: Vec3 = (0.0, 1.0, 0.0)
    equator: Vec3 = (0.0, 0.0, -1.0)
    line: int = 0


@dataclass
class Scene:
    """A whole legacy scene. ``source`` is the file it came from (for messages and paths)."""
    source: Path = Path("<memory>")
    width: int = 640
    height: int = 400
    eye: Vec3 = (0.0, 0.0, 10.0)
    lookat: Vec3 = (0.0, 0.0, 0.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    fov: float = 45.0
    background: Vec3 = (0.0, 0.0, 0.0)
    ambient: float = 0.2
    depth: int = 5
    samples: int = 1
    lights: list[Light] = field(default_factory=list)
    spheres: list[Sphere] = field(default_factory=list)
