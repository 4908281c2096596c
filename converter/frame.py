"""The frame the converted scene is written in: world coordinates minus the scene's ``lookat``.

Mitsuba stores positions in float32, whose spacing grows with the magnitude; subtracting
``lookat`` (in float64) gives what fills the image float32's finest spacing however far from
the origin the file puts it (docs/numerics.md, hazard 6). What a frame cannot fix is warned
about here, as are scenes that draw nothing useful.
"""

from __future__ import annotations

import math
import sys

from ..float32 import UNIT_ROUNDOFF
from .giants import coarse_spheres
from .scene import Scene, SphereArrays, Vec3, length, normalize, sub


#: :func:`float32_spread` above which a conversion warns (measured: docs/numerics.md, hazard 6)
SPREAD_WARNING = 0.1
#: the IOR above which float32 decides where rays leave a sphere (measured: hazard 15)
IOR_WARNING = 1e4


def scene_origin(scene: Scene) -> Vec3:
    """The world point the frame's origin stands for: the scene's ``lookat``."""
    return tuple(float(c) for c in scene.lookat)


#: ``to_frame(point, origin)``: a world point in the frame whose origin is the world point ``origin``
to_frame = sub


def farthest(origin: Vec3, points=(), spheres: SphereArrays | None = None,
             mask: np.ndarray | None = None) -> tuple[float, int | None]:
    """The largest distance from ``origin`` of ``points`` and of the surfaces of ``spheres``
    (those of ``mask``), and the index of the sphere that sets it (None: a point, or none)."""
    reach, which = 0.0, None
    for point in points:
        reach = max(reach, length(to_frame(point, origin)))
    if spheres is not None and len(spheres):
        import numpy as np
        x, y, z = (spheres.center - origin).T
        size = np.sqrt(x * x + y * y + z * z) + spheres.radius
        if mask is not None:
            size = np.where(mask, size, -np.inf)
        k = int(np.argmax(size))
        if size[k] > reach:
            reach, which = float(size[k]), k
    return reach, which


def surface_distances(origin: Vec3, spheres: SphereArrays):
    """Each sphere's surface's distance from ``origin``, inside it or out (an array)."""
    import numpy as np
    distances = np.linalg.norm(spheres.center - np.asarray(origin, np.float64), axis=1)
    return np.abs(distances - spheres.radius)


def extent(scene: Scene, origin: Vec3, spheres: SphereArrays) -> tuple[float, int | None]:
    """:func:`farthest` of the eye and the spheres but the giant ones (:mod:`.giants`)."""
    import numpy as np
    mask = np.ones(len(spheres), bool)
    mask[coarse_spheres(scene, origin, spheres=spheres)[0]] = False
    return farthest(origin, [scene.eye], spheres, mask)


def float32_spread(scene: Scene) -> float:
    """How far float32 may move the scene's surfaces, as a fraction of its least radius."""
    spheres = scene.sphere_arrays()
    if not len(spheres):
        return 0.0
    return UNIT_ROUNDOFF * extent(scene, scene_origin(scene), spheres)[0] / float(spheres.radius.min())


def _where(scene: Scene, sphere) -> str:
    return f"{scene.source}:{sphere.line}" if sphere.line else f"{scene.source}"


def precision_warning(scene: Scene) -> str | None:
    """One line when float32 cannot hold the scene for the Whitted integrator, else None."""
    spread = float32_spread(scene)
    if spread <= SPREAD_WARNING:
        return None
    spheres = scene.sphere_arrays()
    reach, which = extent(scene, scene_origin(scene), spheres)
    farthest = None if which is None else spheres.sphere(which)
    smallest = spheres.sphere(int(spheres.radius.argmin()))   # the first of the least radius
    what = "the eye" if farthest is None else f"the sphere at {_where(scene, farthest)}"
    return (f"{scene.source}: {what} lies {reach:.3g} from the lookat, but the sphere at "
            f"{_where(scene, smallest)} has radius {smallest.radius:.3g}: Mitsuba's float32 positions "
            f"are off by up to {spread:.0%} of that radius, so its details may look wrong; bring "
            f"{'the eye' if farthest is None else 'that sphere'} closer to the lookat or make the "
            f"small spheres larger (docs/numerics.md, hazard 6)")


def ior_warning(scene: Scene) -> str | None:
    """One line naming the first refracting sphere of IOR above :data:`IOR_WARNING`, else None:
    a ray inside it leaves only within 1/IOR of the normal, closer than float32 directions
    follow (docs/numerics.md, hazard 15)."""
    import numpy as np
    spheres = scene.sphere_arrays()
    strong = [m.refract > 0 and m.ior > IOR_WARNING for m in spheres.materials]
    found = np.flatnonzero(np.asarray(strong, bool)[spheres.material]) if any(strong) else ()
    if not len(found):
        return None
    sphere = spheres.sphere(int(found[0]))
    return (f"{_where(scene, sphere)}: IOR {sphere.material.ior:g}: above {IOR_WARNING:g}, float32 "
            f"rounding decides whether rays leave this sphere or are totally reflected near its "
            f"outline (docs/numerics.md, hazard 15)")


def path_warning(scene: Scene) -> str | None:
    """One line naming the first textured sphere that Mitsuba's own integrators misplace (a
    mesh would lose its texture mapping; docs/numerics.md, hazard 14), else None."""
    spheres = scene.sphere_arrays()
    flags = spheres.textured()
    misplaced = coarse_spheres(scene, scene_origin(scene), spheres=spheres)[1] if flags.any() else ()
    found = next((k for k in misplaced if flags[k]), None)
    if found is not None:
        sphere = spheres.sphere(found)
        return (f"{_where(scene, sphere)}: Mitsuba's own integrators place this textured sphere of "
                f"radius {sphere.radius:.3g} only to ulps of its size (float32), more than their ray "
                f"offset there: expect acne on it with the path integrator; the whitted integrator "
                f"intersects it exactly, or leave its texture out to have it meshed "
                f"(docs/numerics.md, hazard 14)")
    return None


def sight_warning(scene: Scene, integrator: str = "whitted") -> str | None:
    """One line when ``scene`` draws nothing useful (the first of: no sphere, the eye on a
    sphere's surface, the eye shut in an opaque sphere no other reaches into, nothing in the
    cone through the image's corners, no light and ``ambient`` below 1; for ``integrator``
    "path", which has no ambient term: no light and a black background), else None."""
    import numpy as np
    spheres = scene.sphere_arrays()
    if not len(spheres):
        return f"{scene.source}: no sphere: the image is only the background; add `sphere X Y Z R`"
    x, y, z = (spheres.center - np.asarray(scene.eye, np.float64)).T
    r, d2 = spheres.radius, x * x + y * y + z * z
    on = np.flatnonzero(surface_distances(scene.eye, spheres) <= 1e-9 * r)
    if len(on):   # a camera ray starts on it: inside or outside by rounding (the variants differ)
        where = _where(scene, spheres.sphere(int(on[0])))
        return (f"{where}: the eye is on this sphere's surface: what the camera rays see first is "
                f"decided by rounding; move `eye` off it")
    opaque = np.array([m.refract == 0 and m.texture is None for m in spheres.materials], bool)
    held = np.flatnonzero((d2 < r * r) & opaque[spheres.material])   # opaque, around the eye
    if len(held):
        k = int(held[np.argmin(r[held])])
        sx, sy, sz, sr = x[k], y[k], z[k], r[k]
        d = np.sqrt((x - sx) ** 2 + (y - sy) ** 2 + (z - sz) ** 2)
        if not ((d < r + sr) & (d + sr > r)).any():   # no sphere reaches into it (itself: no)
            where = _where(scene, spheres.sphere(k))
            return (f"{where}: the eye is inside this opaque sphere, which holds no other sphere: the "
                    f"image shows only its inside; move `eye` out of it (or make it `refract`)")
    t = math.atan(math.tan(math.radians(scene.fov) / 2) * math.hypot(1, scene.height / scene.width))
    f, cos_t, sin_t = normalize(sub(scene.lookat, scene.eye)), math.cos(t), math.sin(t)
    seen = (d2 <= r * r) | (f[0] * x + f[1] * y + f[2] * z >= cos_t * np.sqrt(abs(d2 - r * r)) - sin_t * r)
    if not seen.any():
        return (f"{scene.source}: no sphere is in the camera's view: the image is only the "
                f"background; point `lookat` at the spheres (or widen `fov`)")
    if scene.lights:
        return None
    if integrator == "path":
        if any(scene.background):   # a constant environment emitter lights it
            return None
        return (f"{scene.source}: no light and a black background: the path tracer has no ambient "
                f"term, so the image is all black; add `light X Y Z`")
    if scene.ambient < 1:
        return (f"{scene.source}: no light: only the ambient term ({scene.ambient:g}) lights the "
                f"scene; add `light X Y Z`")
    return None


def twin_warning(scene: Scene) -> str | None:
    """One line naming the first sphere that repeats an earlier one's centre and radius with
    another material or orientation, or refracting, else None: which of the two surfaces a ray
    meets is then decided by rounding, and the two variants differ."""
    import numpy as np
    spheres = scene.sphere_arrays()
    if len(spheres) < 2:
        return None
    keys = np.column_stack([spheres.center, spheres.radius]) + 0.0   # -0.0 as 0.0
    bits = np.ascontiguousarray(keys).view(np.uint64)
    mixed = bits[:, 0] ^ bits[:, 1] * np.uint64(0x9E3779B97F4A7C15) \
        ^ bits[:, 2] * np.uint64(0xC2B2AE3D27D4EB4F) ^ bits[:, 3] * np.uint64(0x165667B19E3779F9)
    order = np.argsort(mixed, kind="stable")   # equal keys: adjacent, in file order
    refracting = np.array([m.refract > 0 for m in spheres.materials], bool)
    textured = spheres.textured()
    twins = [(int(order[k]), int(order[k + 1])) for k in np.flatnonzero(np.diff(mixed[order]) == 0)]
    for first, second in sorted(twins, key=lambda pair: pair[1]):
        looks = spheres.material[first] != spheres.material[second] or textured[first] and \
            spheres.orientation[first] != spheres.orientation[second]
        if (keys[first] == keys[second]).all() and (looks or refracting[spheres.material[first]]):
            line = spheres.sphere(first).line
            return (f"{_where(scene, spheres.sphere(second))}: the same centre and radius as the "
                    f"sphere {f'of line {line}' if line else 'before it'}: which of the two a ray "
                    f"meets is decided by rounding (the variants differ); remove one")
    return None


def warn_scene(scene: Scene, integrator: str = "whitted") -> None:
    """Every warning about a parsed scene, one line each on stderr."""
    _warn(sight_warning(scene, integrator), twin_warning(scene))
    warn_precision(scene, integrator)


def warn_precision(scene: Scene, integrator: str = "whitted") -> None:
    """:func:`precision_warning` on stderr, or for ``integrator`` "path" :func:`path_warning`
    when there is none; then :func:`ior_warning`."""
    _warn(precision_warning(scene) or (path_warning(scene) if integrator == "path" else None),
          ior_warning(scene))


def _warn(*messages: str | None) -> None:
    for message in filter(None, messages):
        print(f"whitted: warning: {message}", file=sys.stderr)
