"""Which spheres of a scene may be loaded as Mitsuba ``ellipsoids`` shapes (one holds any
number; a ``sphere`` shape each loads slowly by the ten thousand), and the frame that makes
them exact: docs/numerics.md, "Spheres as Mitsuba ellipsoids". Works on the scene model
(numpy, no Mitsuba).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import defaults as D
from .converter.description import Description, Mesh, describe, file_stem, material_dict, material_ids
from .converter.frame import farthest
from .converter.giants import coarse_candidates
from .converter.scene import Material, Scene, SphereArrays

#: a sealed sphere's surface is farther than this from the eye, relative to the numbers'
#: size (float32 rounds them by 6e-8 of it): a closer eye might round inside
CLEARANCE = 1e-5
#: the farthest a light of the scaled scene may be from ``lookat``: its intensity
#: (color·π·d²) then stays below defaults.MAX_MAGNITUDE
MAX_REACH = 1e6
#: the most other radii grouped for the Whitted integrator (a layer, and a traversal per
#: ray, each; a sphere left as a shape slows every shadow ray more)
MAX_LAYERS = 8


def sealed(scene: Scene, spheres: SphereArrays | None = None) -> np.ndarray:
    """Per sphere: whether it is opaque, untextured (an ellipsoid has no texture frame) and
    keeps the eye outside, :data:`CLEARANCE` away."""
    spheres = scene.sphere_arrays() if spheres is None else spheres
    if not len(spheres.radius):
        return np.zeros(0, bool)
    center, radius = spheres.center, spheres.radius
    opaque = np.array([m.refract == 0 and m.texture is None for m in spheres.materials], bool)
    clear = opaque[spheres.material]
    origin = np.asarray(scene.lookat, np.float64)
    size = radius + np.linalg.norm(center - origin, axis=1)
    eye = np.asarray(scene.eye, np.float64)
    distance = np.linalg.norm(eye - center, axis=1)
    return clear & (distance > radius + CLEARANCE * (size + np.linalg.norm(eye - origin)))


@dataclass(frozen=True)
class Grouping:
    """The spheres that go into ``ellipsoids`` shapes and the frame that makes them exact."""
    scale: float   # lengths times this about lookat: the commonest radius becomes 1
    radius: float   # the commonest, in the file's units
    member: np.ndarray   # per sphere, whether it is grouped
    spheres: SphereArrays
    radii: tuple[float, ...] = ()   # every grouped radius, ``radius`` first


def choose(scene: Scene, min_group: int = D.SEALED_MIN_GROUP, classes: int = 0,
           smaller: bool = True) -> Grouping | None:
    """The sealed spheres of the commonest radius if ``min_group`` share it, and of up to
    ``classes`` other radii, the ones most spheres share (ties: the larger), smaller ones
    only if ``smaller`` (Mitsuba's own test loses hits there); possible giants stay out.
    None too when scaling would change the image: a light at ``lookat`` (d = 1 in file
    units), or one beyond :data:`MAX_REACH`.
    """
    min_group = max(min_group, 1)
    spheres = scene.sphere_arrays()
    if len(spheres) < min_group:
        return None
    if any(tuple(light.position) == tuple(scene.lookat) for light in scene.lights):
        return None
    mask = sealed(scene, spheres) & ~coarse_candidates(spheres, tuple(scene.lookat))[1]
    if mask.sum() < min_group:
        return None
    values, counts = np.unique(spheres.radius[mask], return_counts=True)
    best = np.flatnonzero(counts == counts.max())[-1]
    if counts[best] < min_group:
        return None
    r = float(values[best])
    if farthest(scene.lookat, [light.position for light in scene.lights])[0] / r > MAX_REACH:
        return None
    radii = [r]
    if classes:   # other radii
        fine = mask & ((spheres.radius != r) if smaller else (spheres.radius > r))
        values, counts = np.unique(spheres.radius[fine], return_counts=True)
        order = np.lexsort((-values, -counts))[:classes]
        radii += [float(values[k]) for k in order]
    return Grouping(1.0 / r, r, mask & np.isin(spheres.radius, radii), spheres, tuple(radii))


def _about(point, origin, scale):
    return tuple(o + scale * (p - o) for p, o in zip(point, origin))


def remaining(scene: Scene, grouping: Grouping) -> Scene:
    """``scene`` without the grouped spheres, every length times ``grouping.scale`` about ``lookat``."""
    scale, origin = grouping.scale, scene.lookat
    keep = np.flatnonzero(~grouping.member).tolist()
    return replace(scene, eye=_about(scene.eye, origin, scale),
                   lights=[replace(light, position=_about(light.position, origin, scale))
                           for light in scene.lights],
                   spheres=[replace(s, center=_about(s.center, origin, scale), radius=s.radius * scale)
                            for s in map(grouping.spheres.sphere, keep)])


def groups(scene: Scene, grouping: Grouping, origin) -> list[tuple[Material, float, np.ndarray]]:
    """``(material, radius, centers)`` by radius and material, in the scaled scene, the
    centers (M×3) relative to ``origin`` (the loader's frame origin)."""
    spheres, scale = grouping.spheres, grouping.scale
    lookat = np.asarray(scene.lookat, np.float64)
    shift = lookat - np.asarray(origin, np.float64)
    result = []
    for radius in grouping.radii or (grouping.radius,):
        for k, material in enumerate(spheres.materials):
            pick = grouping.member & (spheres.material == k) & (spheres.radius == radius)
            if pick.any():
                scaled = 1.0 if radius == grouping.radius else radius * scale
                result.append((material, scaled, (spheres.center[pick] - lookat) * scale + shift))
    return result


#: the fields of a vertex of Mitsuba's ``ellipsoids`` PLY file: center, normal (unused),
#: the logarithms of the three scales, the rotation quaternion (real part first)
PLY_FIELDS = ("x", "y", "z", "nx", "ny", "nz", "scale_0", "scale_1", "scale_2",
              "rot_0", "rot_1", "rot_2", "rot_3")


def ellipsoids_ply(centers: np.ndarray) -> bytes:
    """A binary PLY of unit spheres at ``centers`` for Mitsuba's ``ellipsoids`` shape: log-scales
    0 (exactly 1), no rotation; the shape's ``scale_factor`` gives the radius."""
    rows = np.zeros((len(centers), len(PLY_FIELDS)), "<f4")
    rows[:, :3] = centers
    rows[:, 9] = 1.0
    header = "".join(["ply\nformat binary_little_endian 1.0\n", f"element vertex {len(centers)}\n",
                      *(f"property float {name}\n" for name in PLY_FIELDS), "end_header\n"])
    return header.encode("ascii") + rows.tobytes()


def described(scene: Scene, base_dir, min_group: int = D.SEALED_MIN_GROUP) -> Description:
    """The portable XML's description of ``scene``: the spheres grouped for Mitsuba's own
    integrators as ``ellipsoids`` shapes read from ``SCENE.sealed_K.ply`` files (docs/portable.md)."""
    grouping = choose(scene, min_group, classes=MAX_LAYERS, smaller=False)
    if grouping is None:
        return describe(scene, base_dir, block=True)
    ids = material_ids(scene)
    description = describe(remaining(scene, grouping), base_dir, smallest=1.0, block=True, ids=ids)
    stem = file_stem(scene)
    for k, (material, radius, centers) in enumerate(groups(scene, grouping, description.origin)):
        bsdf = f"sealed_{ids[material]}"
        if bsdf not in description.scene:
            description.scene[bsdf] = material_dict(material, base_dir)
        description.scene[f"sealed_{k}"] = {
            "type": "ellipsoids", "filename": Mesh(f"{stem}.sealed_{k}.ply", ellipsoids_ply(centers)),
            "scale_factor": float(radius), "extent": 1.0, "bsdf": {"type": "ref", "id": bsdf}}
    return description
