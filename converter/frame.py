"""The frame the converted scene is written in: world coordinates minus the scene's ``lookat``.

Why a frame of its own. Mitsuba stores every position in float32, whose
spacing grows with the magnitude: a coordinate near 10^6 is only known to
0.06, near 10^7 to 0.5. A scene written in the coordinates of its file loses
its detail when the file puts it far from the origin (docs/numerics.md,
"Scenes far from the origin"), although the article's model has no preferred
origin: the image depends only on the scene relative to itself. So the
converter subtracts one point of the scene, the *scene origin*, from every
position (in float64, where the subtraction is exact to 10^-16 of the
coordinates), and Mitsuba stores the small differences.

Why ``lookat``. It is where the camera looks, so the geometry that fills the
image lies around it and gets float32's finest spacing; it is the point the
article's light colors are measured at already (the integrator's
``light_reference``), which in this frame is the origin. Measured on the
hazard scenes (docs/numerics.md) it does as well as the eye everywhere and
better where the eye is far from what it sees (a telephoto view from 10^4
away), where an eye-centered frame would put the whole scene 10^4 out.

What a frame cannot fix: a scene whose own extent is large against its
smallest detail (a floor sphere of radius 10^7 under balls of radius 0.1: in
float32 the floor's surface near them is only known to ~0.5 whatever the
origin). Such giant spheres are handed to the integrator exactly
(:mod:`.giants`); what remains is an eye far from small spheres.
:func:`precision_warning` measures that from the model, for the converter to
warn about, and :func:`path_warning` names the spheres Mitsuba's own
integrators still misplace.
"""

from __future__ import annotations

import math
import sys

from ..float32 import UNIT_ROUNDOFF
from .giants import coarse_spheres, giant_spheres, mitsuba_misplaces
from .scene import Scene, Sphere, SphereArrays, Vec3, length, normalize, sub


#: :func:`float32_spread` above which a conversion warns: rounding the scene's
#: largest coordinate in the frame to float32 moves it by this fraction of the
#: smallest sphere's radius. Giant spheres do not count (the Whitted integrator
#: intersects them exactly: converter/giants.py), so only a far eye can reach it.
#: Measured (docs/numerics.md, hazard 6): mirror-and-glass seen from 10^5 away (0.02)
#: has 0.2 % of its pixels off by more than 0.02, from 10^6 (0.2) 2 %, from 10^7 19 %.
SPREAD_WARNING = 0.1



def scene_origin(scene: Scene) -> Vec3:
    """The world point the frame's origin stands for: the scene's ``lookat``."""
    return tuple(float(c) for c in scene.lookat)


def to_frame(point: Vec3, origin: Vec3) -> Vec3:
    """``point`` (world coordinates) in the frame whose origin is the world point ``origin``."""
    return (point[0] - origin[0], point[1] - origin[1], point[2] - origin[2])


def farthest(origin: Vec3, points=(), spheres=()) -> tuple[float, Sphere | None]:
    """The largest distance from ``origin`` of ``points`` and of the surfaces of ``spheres``
    (a sphere counts as its center's distance plus its radius: the size of the numbers that
    describe its surface), 0 when there are none, and the sphere that sets it (None: one of
    the points, or nothing). The one computation of how far a scene reaches: its frame's
    extent, the camera's clip range and the loader's scaled frame all ask it."""
    reach, which = 0.0, None
    for point in points:
        reach = max(reach, length(to_frame(point, origin)))
    for sphere in spheres:
        size = length(to_frame(sphere.center, origin)) + sphere.radius
        if size > reach:
            reach, which = size, sphere
    return reach, which


def farthest_index(origin: Vec3, points=(), spheres: SphereArrays | None = None,
                   mask: np.ndarray | None = None) -> tuple[float, int | None]:
    """:func:`farthest` of spheres given as arrays (those of ``mask`` only, when given): the
    reach, and the index of the sphere that sets it (None: one of the points, or nothing).
    The same numbers as :func:`farthest`, bit for bit."""
    import numpy as np
    reach, which = 0.0, None
    for point in points:
        reach = max(reach, length(to_frame(point, origin)))
    if spheres is not None and len(spheres):
        offset = spheres.center - origin
        x, y, z = offset.T
        size = np.sqrt(x * x + y * y + z * z) + spheres.radius
        if mask is not None:
            size = np.where(mask, size, -np.inf)
        k = int(np.argmax(size))
        if size[k] > reach:
            reach, which = float(size[k]), k
    return reach, which


def extent(scene: Scene, origin: Vec3) -> float:
    """The largest distance from ``origin`` that Mitsuba stores and the Whitted integrator
    relies on: the eye, and each sphere's center plus its radius (the size of the numbers
    that describe its surface), giant spheres but for (:mod:`.giants`)."""
    return _farthest(scene, origin)[0]


def _farthest(scene: Scene, origin: Vec3) -> tuple[float, Sphere | None]:
    """``(extent, sphere)``: :func:`extent` and the sphere that sets it (None: the eye)."""
    spheres = scene.held_sphere_arrays()
    giants = set(giant_spheres(scene, origin, spheres=spheres))
    if spheres is None:
        return farthest(origin, [scene.eye], (s for k, s in enumerate(scene.spheres) if k not in giants))
    import numpy as np
    mask = None
    if giants:
        mask = np.ones(len(spheres), bool)
        mask[list(giants)] = False
    reach, which = farthest_index(origin, [scene.eye], spheres, mask)
    return reach, None if which is None else spheres.sphere(which)


def float32_spread(scene: Scene) -> float:
    """How far float32 may move the scene's surfaces, as a fraction of its smallest sphere's
    radius: ε·extent / r_min (0 for a scene without spheres)."""
    spheres = scene.held_sphere_arrays()
    if spheres is not None:
        if not len(spheres):
            return 0.0
        smallest = float(spheres.radius.min())
    else:
        if not scene.spheres:
            return 0.0
        smallest = min(sphere.radius for sphere in scene.spheres)
    return UNIT_ROUNDOFF * extent(scene, scene_origin(scene)) / smallest


def _where(scene: Scene, sphere) -> str:
    return f"{scene.source}:{sphere.line}" if sphere.line else f"{scene.source}"


def _smallest(scene: Scene) -> Sphere:
    """The first sphere of the least radius."""
    spheres = scene.held_sphere_arrays()
    if spheres is None:
        return min(scene.spheres, key=lambda sphere: sphere.radius)
    import numpy as np
    return spheres.sphere(int(np.argmin(spheres.radius)))


def precision_warning(scene: Scene) -> str | None:
    """One line when float32 cannot hold the scene for the Whitted integrator, else None."""
    spread = float32_spread(scene)
    if spread <= SPREAD_WARNING:
        return None
    origin = scene_origin(scene)
    reach, farthest = _farthest(scene, origin)
    smallest = _smallest(scene)
    what = "the eye" if farthest is None else f"the sphere at {_where(scene, farthest)}"
    return (f"{scene.source}: {what} lies {reach:.3g} from the lookat, but the sphere at "
            f"{_where(scene, smallest)} has radius {smallest.radius:.3g}: Mitsuba's float32 positions "
            f"are off by up to {spread:.0%} of that radius, so its details may look wrong; bring "
            f"{'the eye' if farthest is None else 'that sphere'} closer to the lookat or make the "
            f"small spheres larger (docs/numerics.md, hazard 6)")


def path_warning(scene: Scene) -> str | None:
    """One line naming the first sphere that Mitsuba's own integrators (``--integrator
    path``) place less finely than their ray offset near the scene, else None.

    Such spheres are handed to Mitsuba as meshes (:mod:`.giants`), but for textured ones,
    whose lat/long mapping a mesh would not carry: those stay ``sphere`` shapes, and rays
    leaving them meet them again (acne; docs/numerics.md, hazard 14).
    """
    origin = scene_origin(scene)
    spheres = scene.held_sphere_arrays()
    if spheres is None:
        textured = (k for k, sphere in enumerate(scene.spheres) if sphere.material.texture is not None)
        found = next((k for k in textured if mitsuba_misplaces(scene.spheres[k], origin)), None)
        sphere = None if found is None else scene.spheres[found]
    else:
        flags = spheres.textured()
        found = next((k for k in (coarse_spheres(scene, origin)[1] if flags.any() else ()) if flags[k]), None)
        sphere = None if found is None else spheres.sphere(found)
    if sphere is not None:
        return (f"{_where(scene, sphere)}: Mitsuba's own integrators place this textured sphere of "
                f"radius {sphere.radius:.3g} only to ulps of its size (float32), more than their ray "
                f"offset there: expect acne on it with the path integrator; the whitted integrator "
                f"intersects it exactly, or leave its texture out to have it meshed "
                f"(docs/numerics.md, hazard 14)")
    return None


def warn_precision(scene: Scene, stream=None, integrator: str = "whitted") -> None:
    """:func:`precision_warning` (or, for ``integrator`` "path", :func:`path_warning` too)
    as one line on ``stream`` (stderr), when there is one."""
    message = precision_warning(scene)
    if integrator == "path":
        message = message or path_warning(scene)
    if message:
        print(f"whitted: warning: {message}", file=stream or sys.stderr)


# Valid scenes that draw nothing useful, each with one line that says what the user probably
# meant: no sphere in the camera's view, the eye shut inside an opaque sphere, no light.
# Deliberate scenes stay quiet: an eye inside a sphere is a dome or a room as long as another
# sphere reaches inside it; a glass or textured sphere around the eye is seen through; a scene
# without lights whose ``ambient`` is 1 is flat shading on purpose. The view test is a cone
# through the image's corners, which holds the whole view. The tests are written in
# arithmetic that numpy arrays and Python floats both take (arrays: no Python loop).



def _holds_eye(x, y, z, r, opaque):
    """Whether the sphere of center (x, y, z) (relative to the eye) and radius r is opaque (and
    untextured) and holds the eye."""
    return (x * x + y * y + z * z < r * r) & opaque


def _reaches_into(x, y, z, r, opaque, shell, sqrt):
    """Whether the sphere (x, y, z, r) has a part inside ``shell`` (x, y, z, r) and does not
    hold it whole (the shell itself does not count)."""
    d = sqrt((x - shell[0]) ** 2 + (y - shell[1]) ** 2 + (z - shell[2]) ** 2)
    return (d < r + shell[3]) & (d + shell[3] > r)


def _seen(x, y, z, r, opaque, f, cos_t, sin_t, sqrt):
    """Whether the sphere (x, y, z, r) may meet the cone of axis ``f`` and half-angle t from
    the eye, or holds the eye."""
    d2 = x * x + y * y + z * z
    return (d2 <= r * r) | (f[0] * x + f[1] * y + f[2] * z >= cos_t * sqrt(abs(d2 - r * r)) - sin_t * r)


def _view_cone(scene: Scene):
    """The axis of the cone through the image's corners, and the cosine and sine of its
    half-angle."""
    tan_x = math.tan(math.radians(scene.fov) / 2)
    t = math.atan(tan_x * math.hypot(1.0, scene.height / scene.width))
    return normalize(sub(scene.lookat, scene.eye)), math.cos(t), math.sin(t)


def _columns(scene: Scene):
    """``(each, sphere, sqrt)``: ``each(test, *args)`` is ``test`` of every sphere (center
    relative to the eye, radius, opaque) as a list or an array, ``sphere(k)`` the k-th sphere."""
    arrays = scene.held_sphere_arrays()
    if arrays is None:
        eye, spheres = scene.eye, scene.spheres
        rows = [(*sub(s.center, eye), s.radius, s.material.refract == 0 and s.material.texture is None)
                for s in spheres]
        return (lambda test, *args: [test(*row, *args) for row in rows]), spheres.__getitem__, math.sqrt
    import numpy as np
    x, y, z = (arrays.center - np.asarray(scene.eye, np.float64)).T
    flags = np.array([m.refract == 0 and m.texture is None for m in arrays.materials], bool)
    opaque = flags[arrays.material] if len(flags) else np.zeros(len(arrays), bool)
    return (lambda test, *args: test(x, y, z, arrays.radius, opaque, *args)), arrays.sphere, np.sqrt


def _true_at(mask) -> list[int]:
    return mask.nonzero()[0].tolist() if hasattr(mask, "nonzero") else [k for k, v in enumerate(mask) if v]


def _any(mask) -> bool:
    return bool(mask.any()) if hasattr(mask, "any") else any(mask)


def sight_warning(scene: Scene) -> str | None:
    """One line when ``scene`` draws nothing useful (the first of: no sphere, the eye shut in
    a sphere, nothing in view, no light), else None."""
    each, sphere, sqrt = _columns(scene)
    radii = each(lambda x, y, z, r, opaque: r)
    if not len(radii):
        return f"{scene.source}: no sphere: the image is only the background; add `sphere X Y Z R`"
    held = _true_at(each(_holds_eye))
    if held:
        k = min(held, key=lambda k: radii[k])
        shell = (*sub(sphere(k).center, scene.eye), sphere(k).radius)
        if not _any(each(_reaches_into, shell, sqrt)):
            where = f"{scene.source}:{sphere(k).line}" if sphere(k).line else f"{scene.source}"
            return (f"{where}: the eye is inside this opaque sphere, which holds no other sphere: the "
                    f"image shows only its inside; move `eye` out of it (or make it `refract`)")
    if not _any(each(_seen, *_view_cone(scene), sqrt)):
        return (f"{scene.source}: no sphere is in the camera's view: the image is only the "
                f"background; point `lookat` at the spheres (or widen `fov`)")
    if not scene.lights and scene.ambient < 1:
        return (f"{scene.source}: no light: only the ambient term ({scene.ambient:g}) lights the "
                f"scene; add `light X Y Z`")
    return None


def warn_scene(scene: Scene, stream=None, integrator: str = "whitted") -> None:
    """Every warning about a parsed scene, one line each on ``stream`` (stderr): its
    :func:`sight_warning`, and :func:`.frame.warn_precision`'s."""
    message = sight_warning(scene)
    if message:
        print(f"whitted: warning: {message}", file=stream or sys.stderr)
    warn_precision(scene, stream, integrator)
