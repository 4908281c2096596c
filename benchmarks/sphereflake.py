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
Level L holds 1 + 9 + ... + 9^L spheres: 1, 10, 91, 820, 7 381, 66 430, 597 871.

The scene around it is the SPD's: eye (2.1, 1.3, 1.7) looking at the origin
with +Z up, a 45° field of view on a 512×512 image, a sky-blue background,
three white point lights of intensity 1/sqrt(3), golden mirror-like spheres
(reflection 0.5) and a matte beige floor 1/2 below the origin. The SPD's floor is a
square polygon; the scene format has spheres only, so a sphere of radius
:data:`FLOOR_RADIUS` (10³; any other with ``--floor-radius``) stands in for it,
its top at the square's height. The
SPD gives the floor an ambient 0.2 and diffuse 0.8, which is the article's
model with A = 0.2; its spheres' 0.5 diffuse and 0.5 specular reflection
become a reflection coefficient of 0.5 (the article has no highlights).
Depth 5, one ray per pixel.

Usage::

    python -m benchmarks.sphereflake LEVEL [--floor-radius R] -o FILE.scn
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whitted.converter.scene import Light, Material, Scene, Sphere, Vec3

from .scenes import number, to_scn

#: the levels written here (0 is a lone sphere); 6, 597 871 spheres, is the benchmark's largest
LEVELS = range(0, 7)
#: the first sphere's radius (the SPD's: the whole flake fits in a sphere of radius 1)
RADIUS = 0.5
#: a child's radius over its parent's
SCALE = 1.0 / 3.0
#: the floor's default radius: large enough to look flat in view (it drops 0.05 at 10 units
#: from its top), small enough to keep 32-bit float intersections precise; the benchmark
#: also renders a floor of radius 10⁴ (``--floor-radius``), flatter and harder on precision
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


@dataclass(frozen=True)
class FlakeSphere:
    """One sphere of the flake: its ``parent``'s index (-1 for the first) and ``level`` (0 first)."""
    center: Vec3
    radius: float
    axis: Vec3
    parent: int
    level: int


@dataclass
class FlakeArrays:
    """The flake as arrays, one row per sphere, each parent before its children (depth first)."""
    centers: np.ndarray    # (N, 3) float64
    radii: np.ndarray      # (N,) float64
    axes: np.ndarray       # (N, 3): the direction from its parent to it (+Z for the first)
    parents: np.ndarray    # (N,) int64, -1 for the first
    levels: np.ndarray     # (N,) int64


def _turn_z_to_many(axes: np.ndarray, v: Vec3) -> np.ndarray:
    """``v`` turned by the smallest rotation that takes +Z onto each row of ``axes`` (unit
    vectors), by Rodrigues' formula in the float operations of the SPD's sphere-at-a-time
    recursion (tests/test_sphereflake.py holds it to that recursion, bit for bit)."""
    ax, ay, az = axes[:, 0], axes[:, 1], axes[:, 2]
    # math.hypot, not np.hypot: the two round differently in the last bit now and then
    s = np.fromiter(map(math.hypot, ax.tolist(), ay.tolist()), dtype=np.float64, count=len(ax))
    pole = s == 0.0
    safe = np.where(pole, 1.0, s)
    kx, ky = -ay / safe, ax / safe
    c = az
    x, y, z = v
    k_dot_v = kx * x + ky * y
    out = np.empty_like(axes)
    out[:, 0] = x * c + ky * z * s + kx * k_dot_v * (1 - c)
    out[:, 1] = y * c - kx * z * s + ky * k_dot_v * (1 - c)
    out[:, 2] = z * c + (kx * y - ky * x) * s
    if pole.any():                         # axis = +Z (v itself) or -Z (half a turn about Y)
        up = az[pole] > 0
        out[pole] = np.where(up[:, None], np.array(v), np.array((-v[0], v[1], -v[2])))
    return out


def flake_arrays(level: int) -> FlakeArrays:
    """The flake's spheres down to ``level`` as arrays, in :func:`flake`'s order.

    Built a level at a time with numpy (level 6, 597 871 spheres, in about a second),
    each value by the same float operations as the sphere-by-sphere recursion, so the
    written scene is the same text.
    """
    if level not in LEVELS:
        raise ValueError(f"the sphereflake's level must be in {LEVELS.start}…{LEVELS.stop - 1}, got {level}")
    total = count(level)
    centers, axes = np.empty((total, 3)), np.empty((total, 3))
    radii, parents, levels = np.empty(total), np.empty(total, dtype=np.int64), np.empty(total, dtype=np.int64)
    # this level's spheres, breadth first, and where each goes in the depth-first order
    c, a = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    index = np.zeros(1, dtype=np.int64)
    radius = RADIUS
    centers[index], axes[index], radii[index], parents[index], levels[index] = c, a, radius, -1, 0
    for depth in range(level):
        child_radius = radius * SCALE
        distance = radius + child_radius
        n = len(index)
        d = np.stack([_turn_z_to_many(a, v) for v in CHILDREN], axis=1)     # (n, 9, 3)
        c = (c[:, None, :] + distance * d).reshape(n * 9, 3)
        a = d.reshape(n * 9, 3)
        # the j-th child comes after its parent and its j elder siblings' subtrees
        subtree = count(level - depth - 1)
        child_index = (index[:, None] + 1 + subtree * np.arange(9)).reshape(n * 9)
        centers[child_index], axes[child_index], radii[child_index] = c, a, child_radius
        parents[child_index], levels[child_index] = np.repeat(index, 9), depth + 1
        index, radius = child_index, child_radius
    return FlakeArrays(centers, radii, axes, parents, levels)


def flake(level: int) -> list[FlakeSphere]:
    """The flake's spheres down to ``level``, each parent before its children (depth first)."""
    f = flake_arrays(level)
    return [FlakeSphere(tuple(center), radius, tuple(axis), parent, depth)
            for center, radius, axis, parent, depth in
            zip(f.centers.tolist(), f.radii.tolist(), f.axes.tolist(), f.parents.tolist(), f.levels.tolist())]


def count(level: int) -> int:
    """The flake's sphere count at ``level``: 1 + 9 + ... + 9^level."""
    return (9 ** (level + 1) - 1) // 8


def floor(floor_radius: float = FLOOR_RADIUS) -> Sphere:
    """The floor: a sphere of radius ``floor_radius`` whose top is at :data:`FLOOR_HEIGHT`."""
    if not floor_radius > 0:
        raise ValueError(f"the floor's radius must be positive, got {floor_radius}")
    return Sphere((0.0, 0.0, FLOOR_HEIGHT - floor_radius), floor_radius, FLOOR)


def scene(level: int, floor_radius: float = FLOOR_RADIUS) -> Scene:
    """The SPD's sphereflake scene at ``level``: the flake's spheres, then the floor sphere."""
    f = flake_arrays(level)
    color = (LIGHT_INTENSITY,) * 3
    spheres = [Sphere(tuple(center), radius, FLAKE) for center, radius in zip(f.centers.tolist(), f.radii.tolist())]
    return Scene(source=Path(f"sphereflake{level}.scn"), width=SIZE, height=SIZE, eye=EYE, lookat=LOOKAT,
                 up=UP, fov=FOV, background=BACKGROUND, ambient=AMBIENT, depth=DEPTH, samples=1,
                 lights=[Light(p, color) for p in LIGHT_POSITIONS],
                 spheres=spheres + [floor(floor_radius)])


def title(level: int, floor_radius: float = FLOOR_RADIUS) -> str:
    """The first line's comment of the level-``level`` scene."""
    floor_text = "" if floor_radius == FLOOR_RADIUS else f" of radius {number(floor_radius)}"
    return (f"Eric Haines' sphereflake (SPD 'balls'), level {level}: {count(level)} spheres "
            f"and a floor sphere{floor_text}; benchmarks/sphereflake.py")


def write(level: int, path: str | Path, floor_radius: float = FLOOR_RADIUS) -> Path:
    """Write the level-``level`` sphereflake, its floor of radius ``floor_radius``, to ``path``."""
    path = Path(path)
    path.write_text(to_scn(scene(level, floor_radius), title(level, floor_radius)))
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Write the SPD sphereflake as a .scn scene.")
    parser.add_argument("level", type=int, choices=list(LEVELS),
                        help=f"recursion level ({LEVELS.start}…{LEVELS.stop - 1})")
    parser.add_argument("--floor-radius", type=float, default=FLOOR_RADIUS, metavar="R",
                        help=f"the floor sphere's radius, its top {FLOOR_HEIGHT} below the flake's center "
                             f"(default {number(FLOOR_RADIUS)})")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.scn", help="the scene file to write")
    args = parser.parse_args(argv)
    if not args.floor_radius > 0:
        parser.error(f"--floor-radius must be positive, got {args.floor_radius}")
    write(args.level, args.output, args.floor_radius)
    return 0


if __name__ == "__main__":
    sys.exit(main())
