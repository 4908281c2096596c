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
origin). :func:`precision_warning` measures that from the model, for the
converter to warn about.
"""

from __future__ import annotations

import math
import sys

from .scene import Scene, Vec3

#: float32's unit round-off, 2^-24
EPSILON32 = 2.0 ** -24

#: :func:`float32_spread` above which a conversion warns: rounding the scene's
#: largest coordinate in the frame to float32 moves it by this fraction of the
#: smallest sphere's radius. Measured (docs/numerics.md, hazard 6): at 4e-3 (a
#: floor sphere of radius 10^4 under balls of 0.3) images stay within the
#: hazard tests' thresholds; at 4e-2 (radius 10^5) 5-6 % of the pixels are off.
SPREAD_WARNING = 1e-2


def scene_origin(scene: Scene) -> Vec3:
    """The world point the frame's origin stands for: the scene's ``lookat``."""
    return tuple(float(c) for c in scene.lookat)


def to_frame(point: Vec3, origin: Vec3) -> Vec3:
    """``point`` (world coordinates) in the frame whose origin is the world point ``origin``."""
    return (point[0] - origin[0], point[1] - origin[1], point[2] - origin[2])


def _length(v: Vec3) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def extent(scene: Scene, origin: Vec3) -> float:
    """The largest distance from ``origin`` that Mitsuba stores: the eye, and each sphere's
    center plus its radius (the size of the numbers that describe its surface)."""
    reach = _length(to_frame(scene.eye, origin))
    for sphere in scene.spheres:
        reach = max(reach, _length(to_frame(sphere.center, origin)) + sphere.radius)
    return reach


def float32_spread(scene: Scene) -> float:
    """How far float32 may move the scene's surfaces, as a fraction of its smallest sphere's
    radius: ε·extent / r_min (0 for a scene without spheres)."""
    if not scene.spheres:
        return 0.0
    smallest = min(sphere.radius for sphere in scene.spheres)
    return EPSILON32 * extent(scene, scene_origin(scene)) / smallest


def precision_warning(scene: Scene) -> str | None:
    """One line when the scene spans too many orders of magnitude for float32, else None."""
    spread = float32_spread(scene)
    if spread <= SPREAD_WARNING:
        return None
    smallest = min(sphere.radius for sphere in scene.spheres)
    return (f"{scene.source}: the scene spans {extent(scene, scene_origin(scene)):.3g} around its "
            f"lookat but its smallest sphere has radius {smallest:.3g}; Mitsuba's float32 positions "
            f"are off by up to {spread:.0%} of that radius, so small details may look wrong "
            f"(docs/numerics.md, 'Scenes far from the origin')")


def warn_precision(scene: Scene, stream=None) -> None:
    """:func:`precision_warning` as one line on ``stream`` (stderr), when there is one."""
    message = precision_warning(scene)
    if message:
        print(f"whitted: warning: {message}", file=stream or sys.stderr)
