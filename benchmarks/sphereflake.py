"""Eric Haines' sphereflake ("balls" of the Standard Procedural Databases) as a ``.scn`` scene.

The SPD's sphereflake is the classic yardstick of ray tracers (Haines, "A Proposal for
Standard Graphics Environments", IEEE CG&A, 1987): a scene that grows ninefold per level,
all spheres, mirrors and shadows, exactly what the article's tracer does. Every sphere
blooms nine children of a third its radius, touching it (six around its own axis' equator,
three above), turned from +Z onto that axis as in the SPD. The SPD's view, lights and
materials are kept; its square floor becomes a sphere of radius :data:`FLOOR_RADIUS` with
its top at the square's height, and its ambient 0.2 and 0.5 specular reflection become the
article's A = 0.2 and a reflection of 0.5.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whitted.atomic import check_writable, write_text
from whitted.converter.scene import Light, Material, Scene, Sphere, Vec3
from whitted.converter.scn_writer import scene_to_scn
from whitted.defaults import MAX_MAGNITUDE
from whitted.errors import WhittedError

from . import run_main

#: the levels written here (0 is a lone sphere; 6 holds 597 871 spheres)
LEVELS = range(0, 7)
#: the first sphere's radius (the whole flake fits in a sphere of radius 1), a child's over its parent's
RADIUS = 0.5
SCALE = 1.0 / 3.0
#: flat in view, small enough for precise 32-bit intersections (the benchmark also renders 10⁴)
FLOOR_RADIUS = 1000.0
FLOOR_HEIGHT = -0.5

FLAKE = Material(color=(1.0, 0.9, 0.7), reflect=0.5)
FLOOR = Material(color=(1.0, 0.75, 0.33))


#: the nine children's directions around a sphere whose axis is +Z: six on the equator, 60° apart,
#: and three above, 120° apart, at the elevation arcsin(sqrt(2/3)) (its cosine 1/sqrt(3))
CHILDREN = ([(math.cos(a), math.sin(a), 0.0) for a in (math.radians(15.0 + 60.0 * k) for k in range(6))]
            + [(math.cos(a) / math.sqrt(3.0), math.sin(a) / math.sqrt(3.0), math.sqrt(2.0 / 3.0))
               for a in (math.radians(45.0 + 120.0 * k) for k in range(3))])


@dataclass
class FlakeArrays:
    """The flake, one row per sphere, each parent before its children (depth first): its
    ``axes`` point from the parent to it (+Z for the first), its ``parents`` index (-1 first)."""
    centers: np.ndarray
    radii: np.ndarray
    axes: np.ndarray
    parents: np.ndarray
    levels: np.ndarray


def _turn_z_to_many(axes: np.ndarray, v: Vec3) -> np.ndarray:
    """``v`` turned by the smallest rotation taking +Z onto each row of ``axes``: Rodrigues'
    formula in the float operations of the SPD's recursion (tests/test_sphereflake.py)."""
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
    """The flake's spheres down to ``level``, a level at a time with numpy (level 6
    in about a second), each value by the float operations of the sphere-by-sphere recursion."""
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


def count(level: int) -> int:
    """1 + 9 + ... + 9^level."""
    return (9 ** (level + 1) - 1) // 8


def floor(floor_radius: float = FLOOR_RADIUS) -> Sphere:
    """The floor: a sphere of radius ``floor_radius`` whose top is at :data:`FLOOR_HEIGHT`."""
    if not floor_radius > 0:
        raise ValueError(f"the floor's radius must be positive, got {floor_radius}")
    return Sphere((0.0, 0.0, FLOOR_HEIGHT - floor_radius), floor_radius, FLOOR)


def scene(level: int, floor_radius: float = FLOOR_RADIUS) -> Scene:
    """The SPD's sphereflake scene at ``level``: the flake's spheres, then the floor sphere."""
    f = flake_arrays(level)
    spheres = [Sphere(tuple(center), radius, FLAKE) for center, radius in zip(f.centers.tolist(), f.radii.tolist())]
    light = (1.0 / math.sqrt(3.0),) * 3
    return Scene(source=Path(f"sphereflake{level}.scn"), width=512, height=512, eye=(2.1, 1.3, 1.7),
                 lookat=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), fov=45.0, background=(0.078, 0.361, 0.753),
                 ambient=0.2, depth=5, samples=1, spheres=spheres + [floor(floor_radius)],
                 lights=[Light(p, light) for p in ((4.0, 3.0, 2.0), (1.0, -4.0, 4.0), (-3.0, 1.0, 5.0))])


def title(level: int, floor_radius: float = FLOOR_RADIUS) -> str:
    floor_text = "" if floor_radius == FLOOR_RADIUS else f" of radius {floor_radius:g}"
    return (f"Eric Haines' sphereflake (SPD 'balls'), level {level}: {count(level)} spheres "
            f"and a floor sphere{floor_text}; benchmarks/sphereflake.py")


def write(level: int, path: str | Path, floor_radius: float = FLOOR_RADIUS) -> Path:
    """The scene written to ``path`` whole or not at all."""
    path = Path(path)
    write_text(path, scene_to_scn(scene(level, floor_radius), ".", title(level, floor_radius)))
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Write the SPD sphereflake as a .scn scene.")
    parser.add_argument("level", type=int, choices=list(LEVELS),
                        help=f"recursion level ({LEVELS.start}…{LEVELS.stop - 1})")
    parser.add_argument("--floor-radius", type=float, default=FLOOR_RADIUS, metavar="R",
                        help=f"the floor sphere's radius, its top {FLOOR_HEIGHT} below the flake's center "
                             f"(default {FLOOR_RADIUS:g})")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.scn", help="the scene file to write")
    args = parser.parse_args(argv)
    # the floor's center, at FLOOR_HEIGHT - R, within the scene format's numbers
    if not 0 < args.floor_radius <= float(MAX_MAGNITUDE) + FLOOR_HEIGHT:
        parser.error(f"--floor-radius must be positive and at most {MAX_MAGNITUDE} - 0.5, "
                     f"got {args.floor_radius}")
    try:
        check_writable(args.output)
        write(args.level, args.output, args.floor_radius)
    except WhittedError as error:
        parser.error(str(error))
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main))
