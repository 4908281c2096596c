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
  radius 1 (plugins/shading/layers.py); Mitsuba's own integrators would
  intersect them inexactly, so they are grouped only for the Whitted integrator.

This module works on the scene model (numpy, no Mitsuba): :func:`sealed`
says which spheres are sealed, :func:`choose` picks the radius and the
scale, :func:`remaining` gives the rest of the scene in that frame and
:func:`groups` the grouped spheres' centers, by material.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

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
#: the fewest spheres of one radius worth an ``ellipsoids`` shape by default: below this the
#: load time saved (~0.1 ms a sphere) is below a render's noise, and the scene is left as written
MIN_GROUP = 1000


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


def choose(scene: Scene, min_group: int = MIN_GROUP, classes: int = 0) -> Grouping | None:
    """The sealed spheres of the most common radius, if at least ``min_group`` (≥ 1) share
    it (ties: the larger radius), else None; and those of up to ``classes`` other radii,
    the ones most spheres share (ties: the larger radius).

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
    mask = sealed(scene, spheres)
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
    if classes:   # other radii, but not spheres float32 places too coarsely (converter/giants.py)
        fine = mask & ~_coarse(scene, spheres) & (spheres.radius != r)
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
    return farthest(scene.lookat, [light.position for light in scene.lights], [])[0]


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
    ``centers`` (M×3): :func:`whitted.plugins.scene.layers.ellipsoids_shape`, which the
    integrator's layers build too (the loader builds on the plugins, not the other way)."""
    from .plugins.scene.layers import ellipsoids_shape
    return ellipsoids_shape(centers, bsdf, radius)
