"""Valid scenes that draw nothing useful, found from the scene model, each with one line that
says what the user probably meant: no sphere at all or none in the camera's view (the image
is all background), the eye shut inside an opaque sphere, no light.

Deliberate scenes stay quiet. An eye inside a sphere is a dome or a room (a sky dome, smallpt's
box, tests/hard_cases) as long as another sphere reaches inside it, and a glass or textured
sphere around the eye is seen through or is a panorama; only an opaque, untextured sphere that
holds the eye and nothing else is warned about. A scene without lights whose ``ambient`` is 1
is flat shading on purpose (its lights would change nothing).

The view test is a cone around the view direction through the image's corners, which holds
the whole view: a sphere outside it is certainly not seen. The tests are written once, per
sphere, in arithmetic that numpy arrays and Python floats both take: a scene held as arrays
(:meth:`~.scene.Scene.held_sphere_arrays`, up to millions of spheres) is checked without a
Python loop, a small scene's list without numpy.
"""

from __future__ import annotations

import math
import sys

from .frame import warn_precision
from .scene import Scene
from .vectors import normalize, sub


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
