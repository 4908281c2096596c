"""Which spheres of a scene may be loaded as one Mitsuba ``ellipsoids`` shape, and in what frame.

Why. Mitsuba spends 60–140 µs of CPU on every ``sphere`` shape it loads (a
plugin object, an Embree geometry, a registry entry): seconds for a scene of
66 000 spheres. Its ``ellipsoids`` shape holds any number of primitives, built
from three tensors in a fraction of a millisecond per thousand. An ellipsoid
with three equal scales and the identity rotation is a sphere. Two things
keep it from being a drop-in replacement, and this module decides where
neither matters.

**Back faces.** The ellipsoids shape culls them: a ray that starts inside an
ellipsoid passes through it. In the article's model that never matters for a
*sealed* sphere: opaque (KT = 0) and not holding the eye. Every ray starts at
the eye or at a hit point, and by induction none starts inside a sealed
sphere: the eye is outside all of them; a ray that starts outside a sealed
sphere can only get in by crossing its surface, where it hits it (from
outside) and ends; from a hit on a sealed sphere the reflected ray and the
shadow rays leave into the outside half-space of its tangent plane (V·N < 0
gives R·N > 0, and shadow rays are cast only where N·L > 0), so they stay
outside that convex sphere, and it refracts nothing; a hit on any other
sphere lies outside every sealed one (it was reached from outside). Lights
need no condition: a shadow segment to a light inside a sealed sphere starts
outside it and meets its front face, which blocks it as the sphere shape's
would (and a segment to a light on its surface ends moved off it, to the
outside, as for a sphere shape). Nesting is covered by the same induction: a
sealed sphere inside a sealed one is never reached, one inside a glass sphere
is reached from outside. The only exceptions are hit points on two surfaces
at once (the contact point of touching spheres, the circle where two spheres
cross): a set of measure zero, which in float32 widens to where the gap
between two surfaces is below the integrator's ray offset (docs/numerics.md,
hazard 10), as it already does for sphere shapes.

**Accuracy.** Mitsuba 3.9's ellipsoid intersection moves the ray origin to
"the plane through the center" before solving its quadratic, but computes
that plane's distance in the unit sphere's coordinates as
``dot(-o, d) / norm(d)`` where ``|d| = 1/r``: for r ≠ 1 the point lands
``t·|1/r - 1|`` away from the plane and the quadratic cancels
catastrophically. Spheres of radius 10⁻² seen from 100 radii lose half their
hits; radius 10² spheres get hit distances wrong by 10⁻² r
(benchmarks/ellipsoids.py measures it). For r = 1 exactly the routine *is*
the sphere's (same plane step, same quadratic). So the ellipsoids hold the
sealed spheres of one radius, and the scene is loaded in a frame scaled so
that this radius is 1. The article's model is invariant under a similarity
transform: the image depends on the scene relative to itself (angles, and
light colors measured at ``lookat``, which the loader recomputes from the
scaled distances), and the Whitted integrator's ray offsets are relative
(docs/numerics.md), so the image changes by rounding only. So is the
physical model (point lights' intensities ``I = c·π·d²`` scale with the
distances they are divided by), but Mitsuba's own path tracer is not quite:
it moves rays off surfaces by an absolute ``(1 + max|p|)·9·10⁻⁵``, which the
scale makes smaller or larger against the scene (a level-2 sphereflake
path-traced in the scaled frame is 4 % darker, with or without ellipsoids:
fewer rays leak between its touching spheres).

This module works on the scene model (numpy, no Mitsuba): :func:`sealed`
says which spheres are sealed, :func:`choose` picks the radius and the
scale, :func:`remaining` gives the rest of the scene in that frame and
:func:`groups` the grouped spheres' centers, by material.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from .converter.frame import farthest
from .converter.scene import Material, Scene

#: a sealed sphere keeps the eye farther than this from its surface, relative to the size of
#: the numbers involved (float32 rounds them by 6e-8 of that): an eye closer than that might
#: round inside, and the sphere stays a real ``sphere`` shape
CLEARANCE = 1e-5
#: the largest distance from ``lookat`` a scaled scene may reach: light intensities
#: (color·π·d²) then stay below 10¹² as for a scene file (whitted.defaults.MAX_MAGNITUDE)
MAX_REACH = 1e6
#: the fewest spheres of one radius worth an ``ellipsoids`` shape by default: below this the
#: load time saved (~0.1 ms a sphere) is below a render's noise, and the scene is left as written
MIN_GROUP = 1000


@dataclass(frozen=True)
class Spheres:
    """A scene's spheres as arrays: centers (N×3), radii (N), and each one's index into
    ``materials`` (the distinct materials, in order of first use)."""
    center: np.ndarray
    radius: np.ndarray
    material: np.ndarray
    materials: list

    @staticmethod
    def of(scene: Scene) -> "Spheres":
        spheres = scene.spheres
        n = len(spheres)
        center = np.fromiter(itertools.chain.from_iterable(s.center for s in spheres), np.float64, 3 * n)
        radius = np.fromiter((s.radius for s in spheres), np.float64, n)
        by_id, by_value, materials = {}, {}, []

        def index(material: Material) -> int:
            k = by_id.get(id(material))
            if k is None:
                k = by_id[id(material)] = by_value.setdefault(material, len(by_value))
                if k == len(materials):
                    materials.append(material)
            return k

        material = np.fromiter((index(s.material) for s in spheres), np.int64, n)
        return Spheres(center.reshape(n, 3), radius, material, materials)


def sealed(scene: Scene, spheres: Spheres | None = None) -> np.ndarray:
    """Per sphere of ``scene``: whether it is opaque, untextured and does not hold the eye
    (nor has it within :data:`CLEARANCE` of its surface). Untextured: the loader's
    ellipsoids carry no texture frame (nothing in the argument needs it)."""
    spheres = spheres or Spheres.of(scene)
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
    ``radius``  the grouped spheres' radius in the scene file's units
    ``member``  per sphere of the scene, whether it is grouped
    ``spheres`` the scene's :class:`Spheres`
    =========== ================================================================
    """
    scale: float
    radius: float
    member: np.ndarray
    spheres: Spheres


def choose(scene: Scene, min_group: int = MIN_GROUP) -> Grouping | None:
    """The sealed spheres of the most common radius, if at least ``min_group`` (≥ 1) share
    it (ties: the larger radius), else None.

    None too when scaling would change the image: a light at ``lookat`` (its physical
    intensity is then defined with d = 1, a length in the file's units), or a scaled
    scene reaching beyond :data:`MAX_REACH`.
    """
    min_group = max(min_group, 1)
    if len(scene.spheres) < min_group:
        return None
    if any(tuple(light.position) == tuple(scene.lookat) for light in scene.lights):
        return None
    spheres = Spheres.of(scene)
    mask = sealed(scene, spheres)
    if mask.sum() < min_group:
        return None
    values, counts = np.unique(spheres.radius[mask], return_counts=True)
    best = np.flatnonzero(counts == counts.max())[-1]
    if counts[best] < min_group:
        return None
    r = float(values[best])
    if reach(scene) / r > MAX_REACH:
        return None
    return Grouping(1.0 / r, r, mask & (spheres.radius == r), spheres)


def reach(scene: Scene) -> float:
    """The largest distance from ``lookat`` of the eye, a light or a sphere's surface."""
    points = [scene.eye, *(light.position for light in scene.lights)]
    return farthest(scene.lookat, points, scene.spheres)[0]


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
                            for s in (scene.spheres[k] for k in keep)])


def groups(scene: Scene, grouping: Grouping, origin) -> list[tuple[Material, np.ndarray]]:
    """The grouped spheres by material: ``(material, centers)``, the centers (M×3, float64)
    in the scaled scene's coordinates minus ``origin`` (the loader's frame origin, a point
    of the scaled scene). Their radius there is 1."""
    spheres, scale = grouping.spheres, grouping.scale
    lookat = np.asarray(scene.lookat, np.float64)
    shift = lookat - np.asarray(origin, np.float64)
    result = []
    for k, material in enumerate(spheres.materials):
        pick = grouping.member & (spheres.material == k)
        if pick.any():
            result.append((material, (spheres.center[pick] - lookat) * scale + shift))
    return result


def ellipsoids(centers: np.ndarray, bsdf) -> dict:
    """The ``mi.load_dict`` entry of one ``ellipsoids`` shape of unit spheres at ``centers``
    (M×3): equal scales of 1, no rotation, and ``extent`` 1 (Mitsuba's default, 3, would
    triple them)."""
    import mitsuba as mi
    count = len(centers)
    return {"type": "ellipsoids", "extent": 1.0,
            "centers": mi.TensorXf(np.ascontiguousarray(centers, np.float32).reshape(count, 3)),
            "scales": mi.TensorXf(np.ones((count, 3), np.float32)),
            "quaternions": mi.TensorXf(np.tile(np.array([0.0, 0.0, 0.0, 1.0], np.float32), (count, 1))),
            "bsdf": bsdf}
