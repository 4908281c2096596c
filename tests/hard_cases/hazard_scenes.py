"""One small scene per numerical hazard of docs/numerics.md, built with the scene model.

Each builder returns a :class:`whitted.converter.Scene`; ``HAZARDS`` maps the
catalogue's hazard names to them. Images are tiny (at most 48×32) so that
both variants and the float64 reference render each scene in well under a
second. :func:`transformed` makes the moved and scaled copies of the
invariance tests; they all compare with :func:`reference.assert_matches`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from whitted.converter import Light, Material, Scene, Sphere

W, H = 48, 32

GLASS = Material(color=(1.0, 1.0, 1.0), reflect=0.1, refract=0.85, ior=1.5)
MIRROR = Material(color=(0.9, 0.9, 0.9), reflect=0.8)
RED = Material(color=(0.9, 0.25, 0.2))
GREEN = Material(color=(0.25, 0.85, 0.3))
BLUE = Material(color=(0.2, 0.35, 0.9))
FLOOR = Material(color=(0.8, 0.8, 0.75))


def stripes(path: Path, width: int = 15, height: int = 7) -> Path:
    """An 8-bit sRGB PNG whose texels all differ: red from the column, green from the row."""
    import mitsuba as mi
    rows, cols = np.mgrid[0:height, 0:width]
    pixels = np.stack([(cols + 0.5) / width, (rows + 0.5) / height, np.full(rows.shape, 0.3)], axis=-1)
    mi.Bitmap((pixels * 255).round().astype(np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    return path


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _camera(**overrides) -> dict:
    return dict(width=W, height=H, eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.5, 0.0), **overrides)


# -- the hazards ---------------------------------------------------------------------------------

def texture_poles(tmp_dir: Path) -> Scene:
    """Two globes, each with a pole facing the eye; with an odd image, the middle pixel's ray
    meets the left globe's north pole exactly (sin(phi) = 0, |Vn·Vp| = 1 in float32 too).
    The seam is turned off the middle row: on it, the camera's own rounding (which differs
    between the variants) would pick the side."""
    texture = Material(texture=stripes(tmp_dir / "stripes.png"))
    return Scene(width=33, height=25, eye=(0.0, 0.0, 6.0), lookat=(0.0, 0.0, 0.0), fov=50.0, ambient=1.0,
                 spheres=[Sphere((0.0, 0.0, 0.0), 1.5, texture, north=(0.0, 0.0, 1.0), equator=(1.0, 0.37, 0.0)),
                          Sphere((2.6, 0.9, 0.0), 0.8, texture, north=(-0.5, -0.3, -0.9), equator=(0.0, 1.0, 0.0))])


#: a north axis whose float32 frame makes Vn·Vp round below -1 at the south pole
#: (found by search: about one axis in ten does so, in both variants)
TILTED_NORTH = (0.36, 0.29, 0.03)
TWIST = 0.42


def tilted_globe(tmp_dir: Path) -> Scene:
    """A globe seen from straight below its tilted south pole: the middle pixel's Vn·Vp
    rounds to -1.0000001 in float32, outside arccos's domain."""
    texture = Material(texture=stripes(tmp_dir / "stripes.png"))
    norm = math.sqrt(sum(c * c for c in TILTED_NORTH))
    eye = tuple(-6.0 * c / norm for c in TILTED_NORTH)
    equator = _cross(TILTED_NORTH, (0.3, 0.5, 0.8))
    up = tuple(u + TWIST * e for u, e in zip(_cross(TILTED_NORTH, equator), equator))   # seam off the rows
    return Scene(width=33, height=25, eye=eye, lookat=(0.0, 0.0, 0.0), up=up, fov=40.0, ambient=1.0,
                 spheres=[Sphere((0.0, 0.0, 0.0), 1.5, texture, north=TILTED_NORTH, equator=equator)])


def total_internal_reflection() -> Scene:
    """A glass ball holding an air bubble (IOR 1/1.5): rays inside the glass meet the bubble
    at grazing angles and are totally reflected (k < 0)."""
    return Scene(**_camera(depth=8, background=(0.8, 0.85, 0.95), ambient=0.3),
                 lights=[Light((4.0, 8.0, 6.0)), Light((-5.0, 3.0, 5.0), (0.4, 0.4, 0.4))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR),
                          Sphere((0.0, 0.9, 0.0), 1.4, Material(reflect=0.05, refract=0.9, ior=1.5)),
                          Sphere((0.25, 1.0, 0.3), 0.8, Material(refract=1.0, ior=1 / 1.5)),
                          Sphere((-1.5, 0.6, -3.0), 0.6, RED), Sphere((1.5, 0.6, -3.0), 0.6, GREEN)])


def grazing() -> Scene:
    """The eye just above a huge transparent floor looking along it: every floor pixel is a
    grazing hit (c1 near 0). Its IOR 0.8 makes n = 1.25 on entering, so rays with c1 < 0.6
    are totally reflected, and the rest bend away from the normal."""
    return Scene(width=W, height=H, eye=(0.0, 0.15, 6.0), lookat=(0.0, 0.05, 0.0), fov=60.0, depth=5,
                 background=(0.5, 0.6, 0.8), ambient=0.25, lights=[Light((2.0, 5.0, 3.0))],
                 spheres=[Sphere((0.0, -1000.0, 0.0), 1000.0, Material(color=(0.6, 0.7, 0.6), reflect=0.3,
                                                                      refract=0.6, ior=0.8)),
                          Sphere((0.0, -3.0, -4.0), 1.5, RED), Sphere((-1.5, 0.5, -2.0), 0.5, MIRROR),
                          Sphere((1.2, 0.4, -1.0), 0.4, BLUE)])


def low_ior() -> Scene:
    """IOR below 1 (0.6) and far below (0.02): from outside, n = 1/IOR > 1 and every ray
    beyond the critical angle is totally reflected; inside, rays bend towards the normal."""
    return Scene(**_camera(depth=6, background=(0.3, 0.3, 0.35)), lights=[Light((3.0, 6.0, 6.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR),
                          Sphere((-1.3, 0.8, 0.0), 1.0, Material(reflect=0.1, refract=0.85, ior=0.6)),
                          Sphere((1.3, 0.8, 0.0), 1.0, Material(color=(0.9, 0.9, 1.0), refract=0.9, ior=0.02)),
                          Sphere((0.0, 0.5, -3.0), 0.8, RED)])


def high_ior() -> Scene:
    """IOR 100 and 1000 (and 4 for contrast): a ray leaving such a ball meets its wall almost
    along the normal, where 1 − c1² keeps only c1's rounding error and n² magnifies it; near
    the silhouette that decided whether a ray left or was totally reflected."""
    return Scene(**_camera(depth=5, background=(0.3, 0.4, 0.6)), lights=[Light((3.0, 6.0, 6.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR),
                          Sphere((-1.6, 1.0, 0.0), 1.0, Material(refract=1.0, ior=100.0)),
                          Sphere((0.6, 1.0, 0.0), 1.0, Material(color=(0.9, 0.9, 1.0), refract=0.9, ior=1000.0)),
                          Sphere((2.2, 0.6, 1.0), 0.6, Material(reflect=0.1, refract=0.8, ior=4.0)),
                          Sphere((0.0, 0.6, -3.0), 0.6, RED)])


def large_floor() -> Scene:
    """A reflective floor sphere of radius 10^4 under unit spheres: its float32 surface is
    only known to ~10^-3, where Mitsuba's offset (1 + |p|)·9e-5 leaves acne on the floor."""
    return Scene(**_camera(depth=4, background=(0.4, 0.5, 0.7)),
                 lights=[Light((3.0, 6.0, 4.0)), Light((-4.0, 3.0, 5.0), (0.4, 0.4, 0.4))],
                 spheres=[Sphere((0.0, -1e4, 0.0), 1e4, Material(color=(0.8, 0.8, 0.75), reflect=0.3)),
                          Sphere((-1.2, 1.0, 0.0), 1.0, MIRROR), Sphere((1.3, 0.8, 0.8), 0.8, GREEN),
                          Sphere((0.4, 0.3, -2.0), 0.3, BLUE)])


def far_camera() -> Scene:
    """The eye 10^4 away with a telephoto lens: the quadratic's (f·d)² − (|f|² − r²) cancels
    for rays that start 10^4 radii from the sphere they hit."""
    scene = mirror_and_glass()
    distance = 1e4
    scene.eye = (0.0, 1.5 * distance / 8.0, distance)
    scene.fov = math.degrees(2 * math.atan(math.tan(math.radians(45.0) / 2) * 8.0 / distance))
    return scene


def far_occluder() -> Scene:
    """A ball of radius 0.02 just under a light 100 above the floor: shadow rays from the
    floor pass it 5000 radii from where they start."""
    return Scene(width=W, height=H, eye=(0.0, 6.0, 14.0), lookat=(0.0, 0.0, 0.0), ambient=0.2,
                 lights=[Light((0.0, 100.0, 0.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR), Sphere((0.0, 99.4, 0.0), 0.02, RED),
                          Sphere((2.5, 0.7, 0.0), 0.7, BLUE)])


def mirror_and_glass() -> Scene:
    """Every kind of secondary ray at once: a reflective floor, a mirror, glass, shadows."""
    return Scene(**_camera(depth=6, background=(0.3, 0.4, 0.6)),
                 lights=[Light((3.0, 6.0, 4.0)), Light((-4.0, 3.0, 5.0), (0.4, 0.4, 0.4))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.75), reflect=0.3)),
                          Sphere((-1.2, 1.0, 0.0), 1.0, MIRROR), Sphere((1.3, 0.8, 0.8), 0.8, GLASS),
                          Sphere((0.2, 0.3, 2.2), 0.3, BLUE), Sphere((1.0, 0.4, -2.5), 0.4, RED)])


def camera_inside() -> Scene:
    """The eye inside a glass sphere, which holds a red ball; a blue ball is outside."""
    return Scene(width=W, height=H, eye=(0.0, 0.3, 1.5), lookat=(0.0, 0.0, -1.0), fov=70.0, depth=6,
                 background=(0.6, 0.7, 0.9), lights=[Light((2.0, 2.0, 0.5)), Light((0.0, 8.0, 3.0))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 3.0, Material(reflect=0.1, refract=0.8, ior=1.4)),
                          Sphere((0.8, -0.4, -1.2), 0.6, RED), Sphere((-1.0, 0.0, -6.0), 1.5, BLUE)])


def light_inside() -> Scene:
    """A room: the eye and a light inside a large opaque sphere, and a second light 250 up
    inside a glass ball of radius 0.05, which must hide it from everything outside the ball
    (a shadow ray that stopped a fixed fraction of its length short of the light, as
    Mitsuba's do, would end before reaching the ball)."""
    return Scene(width=W, height=H, eye=(0.0, 0.5, 4.0), lookat=(0.0, 0.0, 0.0), fov=70.0, ambient=0.15,
                 lights=[Light((1.0, 2.0, 1.0)), Light((0.0, 250.0, 0.0))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 300.0, Material(color=(0.9, 0.85, 0.7))),
                          Sphere((0.0, 250.0, 0.0), 0.05, GLASS),
                          Sphere((-1.0, -1.0, -1.0), 1.0, RED), Sphere((1.5, -0.5, 0.0), 0.7, MIRROR)])


def light_on_surface() -> Scene:
    """Lights exactly on surfaces: on top of a ball (lighting the floor around it) and on the
    inner surface of a glass dome (lighting the dome's inside)."""
    return Scene(**_camera(depth=4), ambient=0.1,
                 lights=[Light((0.0, 1.6, 0.0)), Light((-2.0, 0.0, 0.0), (0.6, 0.6, 0.6))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR), Sphere((0.0, 0.8, 0.0), 0.8, RED),
                          Sphere((-2.0, 1.5, 0.0), 1.5, Material(color=(0.9, 0.9, 1.0), refract=0.7, ior=1.2))])


def light_on_floor() -> Scene:
    """Lights on a floor sphere of radius 100: one exactly on its top, two within a float64
    round-off of its surface; they light the balls' undersides, and the segments to them
    meet the floor at the light, many at grazing angles, where the float32 floor is only
    known to 10^-5."""
    height = -100.0 + math.sqrt(100.0 ** 2 - 1.5 ** 2)
    return Scene(width=W, height=H, eye=(0.0, 1.2, 5.0), lookat=(0.0, 0.7, 0.0), fov=55.0, ambient=0.1,
                 lights=[Light((0.0, 0.0, 0.0)), Light((-1.5, height, 0.0), (0.6, 0.6, 0.6)),
                         Light((1.5, height, 0.0), (0.6, 0.6, 0.6))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR), Sphere((-1.3, 1.0, -1.2), 1.0, RED),
                          Sphere((1.3, 0.8, -1.0), 0.8, BLUE), Sphere((0.0, 0.45, 1.0), 0.45, GREEN)])


def touching_and_nested() -> Scene:
    """Balls resting on the floor and on each other (touching exactly), and glass balls nested
    concentrically and tangent from inside."""
    return Scene(**_camera(depth=8, background=(0.5, 0.5, 0.6)), lights=[Light((3.0, 6.0, 4.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, FLOOR),
                          Sphere((-2.0, 0.75, 0.0), 0.75, RED), Sphere((-2.0, 2.0, 0.0), 0.5, BLUE),
                          Sphere((-0.75, 0.5, 0.0), 0.5, GREEN),
                          Sphere((1.5, 1.0, 0.0), 1.0, GLASS),
                          Sphere((1.5, 1.0, 0.0), 0.6, Material(refract=0.9, ior=1.33)),
                          Sphere((1.5, 1.3, 0.0), 0.3, Material(refract=1.0, ior=1 / 1.5))])


def light_at_hit() -> Scene:
    """A light exactly at the point the middle pixel's ray hits (the top of a ball seen from
    straight above): L = 0 there, and the light sits on the ball's surface."""
    return Scene(width=33, height=25, eye=(0.0, 10.0, 0.0), lookat=(0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0),
                 fov=30.0, ambient=0.2, lights=[Light((0.0, 1.0, 0.0)), Light((3.0, 4.0, 2.0), (0.5, 0.5, 0.5))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 1.0, RED), Sphere((0.0, -101.0, 0.0), 100.0, FLOOR)])


def facing_mirrors() -> Scene:
    """Two large, nearly flat mirrors facing each other (KR = 1, no loss) at depth 64, the eye
    between them on their common axis: the middle pixel's ray bounces along the axis to the
    last level, its neighbours drift off slowly, and a ball between the mirrors is seen
    again and again."""
    return Scene(width=33, height=25, eye=(0.0, 0.0, 1.5), lookat=(0.0, 0.0, -3.0), fov=60.0, depth=64,
                 background=(0.2, 0.2, 0.3), lights=[Light((0.0, 5.0, 0.0))],
                 spheres=[Sphere((0.0, 0.0, -1002.0), 1000.0, Material(reflect=1.0)),
                          Sphere((0.0, 0.0, 1002.0), 1000.0, Material(reflect=1.0)),
                          Sphere((0.8, -0.5, 0.0), 0.4, RED)])


#: hazard name (docs/numerics.md) -> builder; builders that need a folder take ``tmp_dir``
HAZARDS = {
    "texture_poles": texture_poles,
    "arccos_range": tilted_globe,
    "total_internal_reflection": total_internal_reflection,
    "grazing": grazing,
    "low_ior": low_ior,
    "high_ior": high_ior,
    "large_floor": large_floor,
    "far_camera": far_camera,
    "far_occluder": far_occluder,
    "camera_inside": camera_inside,
    "light_inside": light_inside,
    "light_on_surface": light_on_surface,
    "light_on_floor": light_on_floor,
    "touching_and_nested": touching_and_nested,
    "light_at_hit": light_at_hit,
    "facing_mirrors": facing_mirrors,
}


# -- giant spheres: the legacy floor, wall and sky (docs/numerics.md, hazard 14) -----------------

def giant_floor(radius: float) -> Scene:
    """A reflective floor sphere of ``radius`` (10^4 to 10^7) under a mirror ball, a glass ball
    and small opaque balls (radius 0.3 to 1) that touch it: contact shadows, the floor's
    reflections of the balls and the balls' reflections of the floor. Float32 places such a
    floor only to ulps of its radius, which from 10^6 on exceeds the gaps it must keep."""
    return Scene(**_camera(depth=5, background=(0.3, 0.4, 0.6)),
                 lights=[Light((3.0, 6.0, 4.0)), Light((-4.0, 3.0, 5.0), (0.4, 0.4, 0.4))],
                 spheres=[Sphere((0.0, -radius, 0.0), radius, Material(color=(0.8, 0.8, 0.75), reflect=0.3)),
                          Sphere((-1.2, 1.0, 0.0), 1.0, MIRROR), Sphere((1.3, 0.8, 0.8), 0.8, GLASS),
                          Sphere((0.2, 0.3, 2.2), 0.3, BLUE), Sphere((1.0, 0.4, -2.5), 0.4, RED),
                          Sphere((-2.6, 0.5, 1.4), 0.5, GREEN)])


def smallpt_box() -> Scene:
    """smallpt's Cornell box (Kevin Beason): six spheres of radius 10^5 as walls around a
    mirror ball and a glass ball, its area light as a point light under the ceiling, depth 8.
    smallpt starts its camera rays 140 units ahead of the camera, inside the box; a pinhole
    can only do so by standing there."""
    wall = 1e5
    return Scene(width=W, height=H, eye=(50.0, 46.0, 155.6), lookat=(50.0, 40.8, 81.6), fov=70.0,
                 depth=8, ambient=0.1, lights=[Light((50.0, 75.0, 81.6))],
                 spheres=[Sphere((wall + 1, 40.8, 81.6), wall, Material(color=(0.75, 0.25, 0.25))),
                          Sphere((-wall + 99, 40.8, 81.6), wall, Material(color=(0.25, 0.25, 0.75))),
                          Sphere((50.0, 40.8, wall), wall, Material(color=(0.75, 0.75, 0.75))),
                          Sphere((50.0, 40.8, -wall + 170), wall, Material(color=(0.0, 0.0, 0.0))),
                          Sphere((50.0, wall, 81.6), wall, Material(color=(0.75, 0.75, 0.75))),
                          Sphere((50.0, -wall + 81.6, 81.6), wall, Material(color=(0.75, 0.75, 0.75))),
                          Sphere((27.0, 16.5, 47.0), 16.5, Material(color=(0.999, 0.999, 0.999), reflect=0.999)),
                          Sphere((73.0, 16.5, 78.0), 16.5, Material(color=(0.999, 0.999, 0.999), refract=0.999,
                                                                    ior=1.5))])


def sky_dome() -> Scene:
    """The eye inside a sky dome of radius 10^5 (its inside lit by the lights), over a floor
    of radius 10^3 with a mirror ball and a glass ball on it."""
    return Scene(**_camera(depth=5, ambient=0.3),
                 lights=[Light((3.0, 6.0, 4.0)), Light((-40.0, 300.0, -50.0), (0.5, 0.5, 0.5))],
                 spheres=[Sphere((0.0, 0.0, 0.0), 1e5, Material(color=(0.45, 0.6, 0.9))),
                          Sphere((0.0, -1e3, 0.0), 1e3, Material(color=(0.8, 0.8, 0.75), reflect=0.2)),
                          Sphere((-1.2, 1.0, 0.0), 1.0, MIRROR), Sphere((1.3, 0.8, 0.8), 0.8, GLASS),
                          Sphere((0.4, 0.3, -2.0), 0.3, RED)])


#: giant-sphere hard case -> builder (tests/hard_cases/test_giants.py)
GIANTS = {
    "floor_1e4": lambda: giant_floor(1e4),
    "floor_1e5": lambda: giant_floor(1e5),
    "floor_1e6": lambda: giant_floor(1e6),
    "floor_1e7": lambda: giant_floor(1e7),
    "smallpt_box": smallpt_box,
    "sky_dome": sky_dome,
}


def build(name: str, tmp_dir: Path) -> Scene:
    builder = HAZARDS[name]
    return builder(tmp_dir) if builder in (texture_poles, tilted_globe) else builder()


# -- translated and scaled copies --------------------------------------------------------------

def transformed(scene: Scene, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> Scene:
    """``scene`` with every position p replaced by scale·p + offset and every radius scaled."""
    def f(p):
        return tuple(scale * c + o for c, o in zip(p, offset))
    return Scene(width=scene.width, height=scene.height, eye=f(scene.eye), lookat=f(scene.lookat),
                 up=scene.up, fov=scene.fov, background=scene.background, ambient=scene.ambient,
                 depth=scene.depth, samples=scene.samples,
                 lights=[Light(f(light.position), light.color) for light in scene.lights],
                 spheres=[Sphere(f(s.center), s.radius * scale, s.material, s.north, s.equator)
                          for s in scene.spheres])
