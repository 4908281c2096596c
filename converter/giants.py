"""Giant spheres: the legacy floor, wall and sky, which float32 cannot place finely enough.

A format of spheres only makes floors, walls and skies of huge ones; Mitsuba places a float32
sphere only to ulps of its radius, more than the gaps beside it (docs/numerics.md, hazard 14).
The *giant* spheres go to the whitted integrator's ``exact_spheres`` (intersected in float64,
plugins/hits.py); for Mitsuba's own integrators the misplaced ones become meshes.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import math
import os
import tempfile
import time
from pathlib import Path

from ..atomic import atomic_path, remove_stale_leftovers
from ..defaults import MESH_CACHE_BYTES, STALE_SECONDS
from ..float32 import UNIT_ROUNDOFF, hit_error
from ..float32 import exact_spheres, parse_exact_spheres  # noqa: F401  (the format, re-exported)
from .scene import Scene, Sphere, SphereArrays, Vec3

#: a sphere is giant when its float32 error exceeds this fraction of the finest detail beside
#: it (measured: docs/numerics.md, hazard 14)
GIANT_FRACTION = 1e-2


def _detail_near(spheres: SphereArrays, k: int) -> float:
    """The finest detail next to sphere ``k``'s surface: over the other spheres, the larger of
    radius and gap."""
    import numpy as np
    if len(spheres) <= 1:
        return math.inf
    x, y, z = (spheres.center - spheres.center[k]).T
    gap = np.abs(np.abs(np.sqrt(x * x + y * y + z * z) - spheres.radius[k]) - spheres.radius)
    detail = np.maximum(spheres.radius, gap)
    detail[k] = np.inf
    return float(detail.min())


def coarse_spheres(scene: Scene, origin: Vec3, smallest: float | None = None,
                   spheres: SphereArrays | None = None) -> tuple[list[int], list[int]]:
    """``(giant, misplaced)``: the spheres (in the frame of ``origin``) whose float32 error
    exceeds :data:`GIANT_FRACTION` of the detail beside them, and those whose float32 test is
    coarser than :data:`MISPLACED_RATIO` times Mitsuba's ray offset. ``smallest``: the least
    radius of spheres held elsewhere (the loader's ellipsoids). Cached with the arrays.
    """
    spheres = scene.sphere_arrays() if spheres is None else spheres
    key = ("coarse", tuple(origin), smallest)
    cache = spheres.__dict__.setdefault("_cache", {})
    if key not in cache:
        import numpy as np
        cache.clear()
        giant, misplaced = [], []
        if len(spheres):
            radius = spheres.radius
            x, y, z = (spheres.center - origin).T
            c = np.abs(spheres.center - origin).max(axis=1)
            error, candidate = coarse_candidates(spheres, origin, smallest)
            offset = MISPLACED_RATIO * RAY_EPSILON * (1 + np.abs(np.sqrt(x * x + y * y + z * z) - radius))
            misplaced = np.flatnonzero(UNIT_ROUNDOFF * (radius + c) > offset).tolist()
            limit = smallest if smallest is not None else math.inf
            giant = [k for k in np.flatnonzero(candidate).tolist()
                     if float(error[k]) > GIANT_FRACTION * min(_detail_near(spheres, k), limit)]
        cache[key] = giant, misplaced
    giant, misplaced = cache[key]
    return list(giant), list(misplaced)


def coarse_candidates(spheres: SphereArrays, origin: Vec3, smallest: float | None = None):
    """``(error, candidate)`` per sphere: the float32 error bound, and whether it exceeds
    :data:`GIANT_FRACTION` of the scene's smallest radius (only these can be giant)."""
    import numpy as np
    detail = min(float(spheres.radius.min()), math.inf if smallest is None else smallest)
    error = hit_error(spheres.radius, np.abs(spheres.center - origin).max(axis=1))
    return error, error > GIANT_FRACTION * detail


#: Mitsuba's own ray offset near a point p is ``(1 + max|p_i|)·RayEpsilon``, RayEpsilon = 1500 ε
RAY_EPSILON = 1500 * UNIT_ROUNDOFF
#: the mesh's deviation from its sphere relative to the eye's distance (below a pixel)
MESH_TOLERANCE = 2e-4
#: the least height of the eye above a meshed sphere, in distances from the eye to the lookat
MIN_HEIGHT = 1e-2
#: how much coarser than Mitsuba's ray offset a float32 sphere may be before it is meshed
#: (docs/numerics.md, hazard 14)
MISPLACED_RATIO = 1.4


def sphere_mesh(center: Vec3, radius: float, eye: Vec3, view: float):
    """A closed, watertight triangle mesh inscribed in the sphere, finest where the eye is
    nearest: ``(positions, normals, faces)``, faces counter-clockwise from outside. Rings of
    latitude around the point nearest the eye, spaced to stay within :data:`MESH_TOLERANCE`
    (docs/numerics.md, hazard 14). ``view``: the eye's distance to the lookat."""
    import numpy as np
    c = np.asarray(center, np.float64)
    offset = np.asarray(eye, np.float64) - c
    length = float(np.linalg.norm(offset))
    axis = offset / length if length > 0 else np.array([0.0, 1.0, 0.0])
    # two unit vectors perpendicular to the axis
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    height = max(abs(length - radius), MIN_HEIGHT * view)
    thetas, counts = [0.0], [1]
    theta, count = 0.0, 8
    while True:
        # a lower bound of the eye's distance to the next ring (arc s): h + 2s/π from
        # outside, h + s/π from inside
        arc = radius * theta
        near = height + (2 if length > radius else 1) * arc / np.pi
        step = np.sqrt(2 * MESH_TOLERANCE * near / radius)
        if theta + 1.5 * step >= np.pi:
            break
        theta += step
        while 2 * np.pi / count * np.sin(theta) > step:
            count *= 2
        thetas.append(theta)
        counts.append(count)
    thetas.append(np.pi)
    counts.append(1)
    rings, positions, start = [], [], 0
    for theta, count in zip(thetas, counts):
        phi = 2 * np.pi * np.arange(count) / count
        direction = (np.cos(theta) * axis[None, :] +
                     np.sin(theta) * (np.cos(phi)[:, None] * u[None, :] + np.sin(phi)[:, None] * v[None, :]))
        if count == 1:
            direction = np.array([axis if theta == 0 else -axis])
        positions.append(direction)
        rings.append(np.arange(start, start + count))
        start += count
    faces = []
    for inner, outer in zip(rings[:-1], rings[1:]):
        m, n = len(inner), len(outer)
        if m == 1:        # the fan around the anchor
            faces.append(np.stack([np.full(n, inner[0]), outer, np.roll(outer, -1)], axis=1))
        elif n == 1:      # the fan around the antipode
            faces.append(np.stack([inner, np.full(m, outer[0]), np.roll(inner, -1)], axis=1))
        elif n == m:
            a, b = inner, np.roll(inner, -1)
            p, q = outer, np.roll(outer, -1)
            faces += [np.stack([a, p, q], axis=1), np.stack([a, q, b], axis=1)]
        else:             # n = 2 m: each inner edge meets two outer edges
            a, b = inner, np.roll(inner, -1)
            p, mid, q = outer[0::2], outer[1::2], np.roll(outer[0::2], -1)
            faces += [np.stack([a, p, mid], axis=1), np.stack([a, mid, b], axis=1),
                      np.stack([b, mid, q], axis=1)]
    normals = np.concatenate(positions)
    faces = np.concatenate(faces)
    # outward-facing: the winding that makes (p1 - p0) × (p2 - p0) point away from the center
    p0, p1, p2 = (normals[faces[:, k]] for k in range(3))
    flip = np.einsum("ij,ij->i", np.cross(p1 - p0, p2 - p0), p0 + p1 + p2) < 0
    faces[flip] = faces[flip][:, [0, 2, 1]]
    return c + radius * normals, normals, faces


def ply_bytes(positions, normals, faces) -> bytes:
    """A binary PLY of the mesh (float32). Each vertex holds ``giant_0``: Mitsuba merges meshes
    that share a BSDF unless they carry attributes, and the integrator finds each by its id."""
    import numpy as np
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(positions)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\nproperty float giant_0\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    vertices = np.concatenate([positions, normals, np.zeros((len(positions), 1))], axis=1).astype("<f4")
    face_records = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face_records["n"], face_records["i"] = 3, faces
    return header.encode("ascii") + vertices.tobytes() + face_records.tobytes()


#: meshes kept in memory (a few MB each): all six walls of a giant box, shared by its frames
MESH_MEMORY = 8


def mesh_bytes(sphere: Sphere, origin: Vec3, eye: Vec3, lookat: Vec3) -> bytes:
    """The PLY file of ``sphere``'s mesh (:func:`sphere_mesh`) in the frame of ``origin``."""
    center = tuple(float(c - o) for c, o in zip(sphere.center, origin))
    eye = tuple(float(c - o) for c, o in zip(eye, origin))
    view = sum((a - b) ** 2 for a, b in zip(eye, (c - o for c, o in zip(lookat, origin)))) ** 0.5
    return _mesh_bytes(center, float(sphere.radius), eye, float(view))


@functools.lru_cache(maxsize=MESH_MEMORY)
def _mesh_bytes(center: Vec3, radius: float, eye: Vec3, view: float) -> bytes:
    return ply_bytes(*sphere_mesh(center, radius, eye, view))


def cache_folder() -> Path:
    """Where meshes of scenes loaded without an XML file live, each named by its content."""
    return Path(tempfile.gettempdir()) / f"whitted-meshes-{os.getuid() if hasattr(os, 'getuid') else 0}"


def cached(data: bytes) -> Path:
    """The cached file holding ``data``: written when missing, its time of use renewed."""
    folder = cache_folder()
    path = folder / f"{hashlib.sha256(data).hexdigest()[:32]}.ply"
    if path.is_file():
        with contextlib.suppress(OSError):
            os.utime(path)   # used now: the last to go (prune)
        return path
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    prune(folder, MESH_CACHE_BYTES, STALE_SECONDS)
    return path


def prune(folder: Path, limit: int = MESH_CACHE_BYTES, stale: float = STALE_SECONDS) -> list[Path]:
    """Remove killed writers' leftovers, then the least recently used meshes down to ``limit``
    bytes (none used in the last ``stale`` seconds); return what was removed."""
    removed = remove_stale_leftovers(folder, stale)
    meshes = []
    for path in folder.glob("*.ply"):
        with contextlib.suppress(OSError):
            info = path.stat()
            meshes.append((info.st_mtime, info.st_size, path))
    total = sum(size for _, size, _ in meshes)
    now = time.time()
    for used, size, path in sorted(meshes):
        if total <= limit or now - used <= stale:
            break
        with contextlib.suppress(OSError):
            path.unlink()
            total -= size
            removed.append(path)
    return removed
