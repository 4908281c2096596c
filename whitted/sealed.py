"""Which spheres of a scene may be loaded as one Mitsuba ``ellipsoids`` shape, and in what frame.

Why. Mitsuba builds a plugin object, an Embree geometry and a registry entry for
every ``sphere`` shape, which makes a scene of tens of thousands of spheres slow
to load; its ``ellipsoids`` shape holds any number of primitives, built from
three tensors (benchmarks/RESULTS.md, "Mitsuba's ellipsoids shape as a fast path
for spheres"). An ellipsoid with three equal scales and the identity rotation is
a sphere but for two things, and this module decides where neither matters
(docs/numerics.md, "Spheres as Mitsuba ellipsoids", has the proof and the
measurements):

* the shape culls back faces, which never changes a result for a *sealed*
  sphere (opaque, untextured, not holding the eye): no ray of the article's
  model starts inside one;
* Mitsuba's ellipsoid intersection is exact only at radius 1, so the scene is
  loaded in a frame scaled to make the commonest radius 1. The article's model
  is invariant under that similarity (the image changes by rounding only);
  Mitsuba's path tracer, whose ray offsets are absolute, is not quite. Spheres
  of other radii may be grouped too, by radius (``classes``): the Whitted
  integrator traces each such class in a frame of its own, scaled to make its
  radius 1 (plugins/hits.py), whatever the radius. Mitsuba's own
  integrators intersect them with Mitsuba's test: below radius 1 it loses hits
  (its origin step overshoots the center plane), above it finds every one, a
  float32 cancellation misplacing them along the ray by up to a few hundredths
  of the radius from 300 radii away (the step falls short; docs/numerics.md,
  "Mitsuba's own integrators on the grouped scene"), so for them only radii
  above the commonest are grouped (``smaller=False``). No ``shapegroup``/``instance`` form helps: an instance
  scaled by r hands the unit ellipsoid the same ray as an ellipsoid of radius r.

This module works on the scene model (numpy, no Mitsuba): :func:`sealed`
says which spheres are sealed, :func:`choose` picks the radius and the
scale, :func:`remaining` gives the rest of the scene in that frame and
:func:`groups` the grouped spheres' centers, by material. :func:`described`
gives the converter's description with the groups as ``ellipsoids`` shapes
read from PLY files, for the portable XML: the stock ``mitsuba`` command then
loads a sphereflake of 597 872 spheres in seconds instead of minutes and
gigabytes (docs/portable.md).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import defaults as D
from .converter.description import Description, Mesh, describe, file_stem, material_dict, material_ids
from .converter.frame import farthest
from .converter.giants import coarse_candidates
from .converter.scene import Material, Scene, SphereArrays

#: a sealed sphere keeps the eye farther than this from its surface, relative to the size of
#: the numbers involved (float32 rounds them by 6e-8 of that): an eye closer than that might
#: round inside, and the sphere stays a real ``sphere`` shape
CLEARANCE = 1e-5
#: the largest distance from ``lookat`` a light of the scaled scene may have: light
#: intensities (color·π·d²) then stay below 10¹² as for a scene file
#: (whitted.defaults.MAX_MAGNITUDE)
MAX_REACH = 1e6
#: the most radii besides the commonest that are grouped for the Whitted integrator, which
#: traces each in a layer of its own (a traversal per ray each; a sphere left as a shape makes
#: every shadow ray take the slower nearest-hit query instead): the classes of most spheres
MAX_LAYERS = 8
#: the fewest spheres of one radius worth an ``ellipsoids`` shape by default (its reasons:
#: whitted.defaults.SEALED_MIN_GROUP)
MIN_GROUP = D.SEALED_MIN_GROUP


def sealed(scene: Scene, spheres: SphereArrays | None = None) -> np.ndarray:
    """Per sphere of ``scene``: whether it is opaque, untextured and does not hold the eye
    (nor has it within :data:`CLEARANCE` of its surface). Untextured: the loader's
    ellipsoids carry no texture frame (nothing in the argument needs it)."""
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
    """The spheres that go into ``ellipsoids`` shapes and the frame that makes them exact.

    =========== ================================================================
    ``scale``   lengths are multiplied by this about ``lookat``: the grouped
                spheres' radius becomes 1
    ``radius``  the commonest grouped radius in the scene file's units
    ``member``  per sphere of the scene, whether it is grouped
    ``spheres`` the scene's spheres as arrays (:class:`~whitted.converter.scene.SphereArrays`)
    ``radii``   every grouped radius (``radius`` first), in the file's units
    =========== ================================================================
    """
    scale: float
    radius: float
    member: np.ndarray
    spheres: SphereArrays
    radii: tuple[float, ...] = ()


def choose(scene: Scene, min_group: int = MIN_GROUP, classes: int = 0,
           smaller: bool = True) -> Grouping | None:
    """The sealed spheres of the most common radius, if at least ``min_group`` (≥ 1) share
    it (ties: the larger radius), else None, leaving out those float32 may place too
    coarsely (possible giants: the converter judges them); and those of up to ``classes`` other radii,
    the ones most spheres share (ties: the larger radius), radii below the commonest only
    if ``smaller`` (the Whitted integrator's layers trace them exactly, Mitsuba's own
    ellipsoid test does not).

    None too when scaling would change the image: a light at ``lookat`` (its physical
    intensity is then defined with d = 1, a length in the file's units), or a light of
    the scaled scene farther than :data:`MAX_REACH` from it.
    """
    min_group = max(min_group, 1)
    spheres = scene.sphere_arrays()
    if len(spheres) < min_group:
        return None
    if any(tuple(light.position) == tuple(scene.lookat) for light in scene.lights):
        return None
    # spheres float32 may place too coarsely (converter/giants.py) stay for the converter to judge
    mask = sealed(scene, spheres) & ~_coarse(scene, spheres)
    if mask.sum() < min_group:
        return None
    values, counts = np.unique(spheres.radius[mask], return_counts=True)
    best = np.flatnonzero(counts == counts.max())[-1]
    if counts[best] < min_group:
        return None
    r = float(values[best])
    if light_reach(scene) / r > MAX_REACH:
        return None
    radii = [r]
    if classes:   # other radii
        fine = mask & ((spheres.radius != r) if smaller else (spheres.radius > r))
        values, counts = np.unique(spheres.radius[fine], return_counts=True)
        order = np.lexsort((-values, -counts))[:classes]
        radii += [float(values[k]) for k in order]
    return Grouping(1.0 / r, r, mask & np.isin(spheres.radius, radii), spheres, tuple(radii))


def _coarse(scene: Scene, spheres: SphereArrays) -> np.ndarray:
    """Per sphere: whether it may be giant (converter/giants.py): such spheres stay for the
    converter to judge."""
    return coarse_candidates(spheres, tuple(scene.lookat))[1]


def light_reach(scene: Scene) -> float:
    """The largest distance from ``lookat`` of a light (what light intensities grow with)."""
    return farthest(scene.lookat, [light.position for light in scene.lights])[0]


def _about(point, origin, scale):
    return tuple(o + scale * (p - o) for p, o in zip(point, origin))


def remaining(scene: Scene, grouping: Grouping) -> Scene:
    """``scene`` without the grouped spheres, every length multiplied by ``grouping.scale``
    about its ``lookat`` (which stays put): eye, lights, sphere centers and radii. Colors,
    angles and texture orientations are unchanged."""
    scale, origin = grouping.scale, scene.lookat
    keep = np.flatnonzero(~grouping.member).tolist()
    return replace(scene, eye=_about(scene.eye, origin, scale),
                   lights=[replace(light, position=_about(light.position, origin, scale))
                           for light in scene.lights],
                   spheres=[replace(s, center=_about(s.center, origin, scale), radius=s.radius * scale)
                            for s in map(grouping.spheres.sphere, keep)])


def groups(scene: Scene, grouping: Grouping, origin) -> list[tuple[Material, float, np.ndarray]]:
    """The grouped spheres by radius and material: ``(material, radius, centers)``, the
    radius and the centers (M×3, float64) in the scaled scene's coordinates, the centers
    minus ``origin`` (the loader's frame origin, a point of the scaled scene). The commonest
    radius is 1 there."""
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


def ellipsoids(centers: np.ndarray, bsdf, radius: float = 1.0) -> dict:
    """The ``mi.load_dict`` entry of one ``ellipsoids`` shape of spheres of ``radius`` at
    ``centers`` (M×3): :func:`whitted.plugins.primitives.ellipsoids_shape`, which the
    integrator's layers build too (the loader builds on the plugins, not the other way)."""
    from .plugins.primitives import ellipsoids_shape
    return ellipsoids_shape(centers, bsdf, radius)


#: the fields of a vertex of Mitsuba's ``ellipsoids`` PLY file: center, normal (unused),
#: the logarithms of the three scales, the rotation quaternion (real part first)
PLY_FIELDS = ("x", "y", "z", "nx", "ny", "nz", "scale_0", "scale_1", "scale_2",
              "rot_0", "rot_1", "rot_2", "rot_3")


def ellipsoids_ply(centers: np.ndarray) -> bytes:
    """A binary PLY file of unit spheres at ``centers`` (M×3) as Mitsuba's ``ellipsoids``
    shape reads it: log-scales 0 (Mitsuba takes their exponential: exactly 1) and the identity
    rotation; the shape's ``scale_factor`` gives the radius."""
    rows = np.zeros((len(centers), len(PLY_FIELDS)), "<f4")
    rows[:, :3] = centers
    rows[:, 9] = 1.0
    header = "".join(["ply\nformat binary_little_endian 1.0\n", f"element vertex {len(centers)}\n",
                      *(f"property float {name}\n" for name in PLY_FIELDS), "end_header\n"])
    return header.encode("ascii") + rows.tobytes()


def described(scene: Scene, base_dir, min_group: int = MIN_GROUP) -> Description:
    """The converter's description of ``scene`` (block form, for the XML writer) with the
    spheres :func:`choose` groups for Mitsuba's own integrators (``smaller=False``) as one
    ``ellipsoids`` shape per radius and material, read from a PLY file beside the XML
    (``SCENE.sealed_K.ply``: a :class:`~whitted.converter.description.Mesh`, written as the
    giant spheres' meshes are), its BSDF ``sealed_`` and the material's id, in the frame that
    makes the commonest radius 1; the plain description when nothing is grouped."""
    grouping = choose(scene, min_group, classes=MAX_LAYERS, smaller=False)
    if grouping is None:
        return describe(scene, base_dir, block=True)
    # the grouped radii are 1 and above in this frame: the smallest detail is 1 (as in the loader)
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
