"""Eric Haines' sphereflake ("balls" of the Standard Procedural Databases) as a ``.scn`` scene.

Why this scene: the SPD's sphereflake is the classic yardstick of ray tracers
(Haines, "A Proposal for Standard Graphics Environments", IEEE CG&A, 1987):
one scene whose size grows by a factor of 9 per level, all of it spheres,
mirrors and shadows, exactly what the article's tracer does. ``make bench``
renders it with whitted and with POV-Ray (povray.py) and times the parser on
its largest level.

The geometry: a sphere of radius 1/2 at the origin, growing along +Z. Every
sphere of radius r "blooms" nine children of radius r/3 that touch it (their
centers lie at r + r/3 from its center): six around its equator, 60° apart,
and three above it, 120° apart, whose directions make an angle of
arcsin(sqrt(2/3)) (54.7°) with the equator plane. "Equator" and "above" refer to the
sphere's own axis, the direction from its parent to it (+Z for the first
sphere); the children's directions are turned from +Z onto that axis by the
smallest rotation, as in the SPD, so the flake looks the same as the SPD's.
Level L holds 1 + 9 + ... + 9^L spheres: 1, 10, 91, 820, 7 381, 66 430.

The scene around it is the SPD's: eye (2.1, 1.3, 1.7) looking at the origin
with +Z up, a 45° field of view on a 512×512 image, a sky-blue background,
three white point lights of intensity 1/sqrt(3), golden mirror-like spheres
(reflection 0.5) and a matte beige floor 1/2 below the origin. The SPD's floor is a
square polygon; the scene format has spheres only, so a sphere of radius
:data:`FLOOR_RADIUS` stands in for it, its top at the square's height. The
SPD gives the floor an ambient 0.2 and diffuse 0.8, which is the article's
model with A = 0.2; its spheres' 0.5 diffuse and 0.5 specular reflection
become a reflection coefficient of 0.5 (the article has no highlights).
Depth 5, one ray per pixel.

Usage::

    python benchmarks/sphereflake.py LEVEL -o FILE.scn
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from whitted.converter.scene import Light, Material, Scene, Sphere, Vec3  # noqa: E402

#: levels the SPD defines (0 is a lone sphere); 5 is the benchmark's largest
LEVELS = range(0, 6)
#: the first sphere's radius (the SPD's: the whole flake fits in a sphere of radius 1)
RADIUS = 0.5
#: a child's radius over its parent's
SCALE = 1.0 / 3.0
#: the floor's radius: large enough to look flat in view (it drops 0.05 at 10 units
#: from its top), small enough to keep 32-bit float intersections precise
FLOOR_RADIUS = 1000.0
#: the SPD's floor height: half the flake's bounding radius below its center
FLOOR_HEIGHT = -0.5

EYE: Vec3 = (2.1, 1.3, 1.7)
LOOKAT: Vec3 = (0.0, 0.0, 0.0)
UP: Vec3 = (0.0, 0.0, 1.0)
FOV = 45.0
SIZE = 512
DEPTH = 5
BACKGROUND: Vec3 = (0.078, 0.361, 0.753)
AMBIENT = 0.2
LIGHT_POSITIONS: tuple[Vec3, ...] = ((4.0, 3.0, 2.0), (1.0, -4.0, 4.0), (-3.0, 1.0, 5.0))
#: each light's intensity: the SPD scales its three lights by 1/sqrt(3)
LIGHT_INTENSITY = 1.0 / math.sqrt(3.0)
FLAKE = Material(color=(1.0, 0.9, 0.7), reflect=0.5)
FLOOR = Material(color=(1.0, 0.75, 0.33))


def _children_directions() -> list[Vec3]:
    """The nine children's directions around a sphere whose axis is +Z."""
    directions = []
    for k in range(6):                                    # the equator, 60° apart
        azimuth = math.radians(15.0 + 60.0 * k)
        directions.append((math.cos(azimuth), math.sin(azimuth), 0.0))
    ring = 1.0 / math.sqrt(3.0)                            # cos of the elevation arcsin(sqrt(2/3))
    for k in range(3):                                    # above, 120° apart
        azimuth = math.radians(45.0 + 120.0 * k)
        directions.append((ring * math.cos(azimuth), ring * math.sin(azimuth), math.sqrt(2.0 / 3.0)))
    return directions


CHILDREN = _children_directions()


def _turn_z_to(axis: Vec3, v: Vec3) -> Vec3:
    """``v`` turned by the smallest rotation that takes +Z onto the unit vector ``axis``."""
    ax, ay, az = axis
    s = math.hypot(ax, ay)                 # sin of the angle between +Z and axis
    if s == 0.0:                           # axis = +Z, or -Z: half a turn about Y
        return v if az > 0 else (-v[0], v[1], -v[2])
    kx, ky = -ay / s, ax / s               # the rotation's unit axis, +Z × axis, normalized
    c = az
    x, y, z = v
    k_dot_v = kx * x + ky * y
    # Rodrigues: v cos + (k × v) sin + k (k·v)(1 - cos), with k = (kx, ky, 0)
    return (x * c + ky * z * s + kx * k_dot_v * (1 - c),
            y * c - kx * z * s + ky * k_dot_v * (1 - c),
            z * c + (kx * y - ky * x) * s)


@dataclass(frozen=True)
class FlakeSphere:
    """One sphere of the flake: its ``parent``'s index (-1 for the first) and ``level`` (0 first)."""
    center: Vec3
    radius: float
    axis: Vec3
    parent: int
    level: int


def flake(level: int) -> list[FlakeSphere]:
    """The flake's spheres down to ``level``, each parent before its children (depth first)."""
    if level not in LEVELS:
        raise ValueError(f"the sphereflake's level must be in {LEVELS.start}…{LEVELS.stop - 1}, got {level}")
    spheres: list[FlakeSphere] = []

    def grow(center: Vec3, radius: float, axis: Vec3, parent: int, depth: int) -> None:
        index = len(spheres)
        spheres.append(FlakeSphere(center, radius, axis, parent, depth))
        if depth == level:
            return
        child_radius = radius * SCALE
        distance = radius + child_radius
        for direction in CHILDREN:
            d = _turn_z_to(axis, direction)
            child = tuple(c + distance * e for c, e in zip(center, d))
            grow(child, child_radius, d, index, depth + 1)

    grow((0.0, 0.0, 0.0), RADIUS, (0.0, 0.0, 1.0), -1, 0)
    return spheres


def count(level: int) -> int:
    """The flake's sphere count at ``level``: 1 + 9 + ... + 9^level."""
    return (9 ** (level + 1) - 1) // 8


def scene(level: int) -> Scene:
    """The SPD's sphereflake scene at ``level``: the flake's spheres, then the floor sphere."""
    floor = Sphere((0.0, 0.0, FLOOR_HEIGHT - FLOOR_RADIUS), FLOOR_RADIUS, FLOOR)
    color = (LIGHT_INTENSITY,) * 3
    return Scene(source=Path(f"sphereflake{level}.scn"), width=SIZE, height=SIZE, eye=EYE, lookat=LOOKAT,
                 up=UP, fov=FOV, background=BACKGROUND, ambient=AMBIENT, depth=DEPTH, samples=1,
                 lights=[Light(p, color) for p in LIGHT_POSITIONS],
                 spheres=[Sphere(s.center, s.radius, FLAKE) for s in flake(level)] + [floor])


def _num(x: float) -> str:
    """The shortest text that reads back as ``x`` ('-0.0' written as '0')."""
    return "0" if x == 0 else repr(float(x)) if x != int(x) or abs(x) >= 1e15 else str(int(x))


def _nums(values) -> str:
    return " ".join(_num(v) for v in values)


def to_scn(model: Scene, title: str = "") -> str:
    """``model`` as ``.scn`` text (colors, reflection and refraction; no textures)."""
    lines = [f"# {title}" if title else "# written by benchmarks/sphereflake.py",
             f"size {model.width} {model.height}", f"eye {_nums(model.eye)}",
             f"lookat {_nums(model.lookat)}", f"up {_nums(model.up)}", f"fov {_num(model.fov)}",
             f"background {_nums(model.background)}", f"ambient {_num(model.ambient)}",
             f"depth {model.depth}", f"samples {model.samples}"]
    lines += [f"light {_nums(light.position)} {_nums(light.color)}" for light in model.lights]
    for s in model.spheres:
        m = s.material
        if m.texture is not None:
            raise ValueError("to_scn writes untextured spheres only")
        line = f"sphere {_nums(s.center)} {_num(s.radius)} color {_nums(m.color)}"
        if m.reflect:
            line += f" reflect {_num(m.reflect)}"
        if m.refract:
            line += f" refract {_num(m.refract)} {_num(m.ior)}"
        lines.append(line)
    return "\n".join(lines) + "\n"


def write(level: int, path: str | Path) -> Path:
    """Write the level-``level`` sphereflake to ``path``."""
    path = Path(path)
    title = (f"Eric Haines' sphereflake (SPD 'balls'), level {level}: {count(level)} spheres "
             f"and a floor sphere; benchmarks/sphereflake.py")
    path.write_text(to_scn(scene(level), title))
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Write the SPD sphereflake as a .scn scene.")
    parser.add_argument("level", type=int, choices=list(LEVELS), help="recursion level (0…5)")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.scn", help="the scene file to write")
    args = parser.parse_args(argv)
    write(args.level, args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
