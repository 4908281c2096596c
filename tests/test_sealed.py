"""Which spheres may become Mitsuba ellipsoids (whitted/sealed.py): the conditions of the
exactness argument, sphere by sphere, and the frame that makes their radius 1."""

from __future__ import annotations

import math

import numpy as np
import pytest

from whitted import sealed as S
from whitted.converter.scene import Light, Material, Scene, Sphere

MATTE = Material(color=(0.8, 0.2, 0.2))
MIRROR = Material(color=(0.9, 0.9, 0.9), reflect=0.8)
GLASS = Material(color=(1.0, 1.0, 1.0), refract=0.9, ior=1.5)
TEXTURED = Material(texture="/nonexistent/earth.png")


def scene(spheres, lights=((0.0, 10.0, 0.0),), eye=(0.0, 0.0, 10.0), lookat=(0.0, 0.0, 0.0)):
    return Scene(eye=eye, lookat=lookat, lights=[Light(p) for p in lights],
                 spheres=[Sphere(c, r, m) for c, r, m in spheres])


def test_opaque_untextured_spheres_away_from_eye_and_lights_are_sealed():
    s = scene([((0, 0, 0), 1.0, MATTE), ((3, 0, 0), 1.0, MIRROR), ((-3, 0, 0), 1.0, GLASS),
               ((0, 3, 0), 1.0, TEXTURED)])
    assert S.sealed(s).tolist() == [True, True, False, False]


def test_a_sphere_around_the_eye_is_not_sealed_one_around_a_light_is():
    s = scene([((0, 0, 10), 2.0, MATTE),       # holds the eye
               ((0, 10, 0), 0.5, MATTE),       # holds the light: shadow rays meet its front face
               ((0, 0, 0), 50.0, MIRROR),      # a room holding both
               ((0, 0, 0), 1.0, MATTE),        # a ball inside the room: sealed
               ((5, 0, 0), 1.0, GLASS),        # glass is never sealed
               ((5, 0, 0), 0.5, MATTE)])       # a ball inside the glass: sealed
    assert S.sealed(s).tolist() == [False, True, False, True, False, True]


def test_an_eye_on_or_next_to_the_surface_keeps_the_sphere_real():
    on = scene([((0, 0, 9), 1.0, MATTE)])                  # the eye exactly on top
    near = scene([((0, 0, 9 - 1e-7), 1.0, MATTE)])         # 1e-7 above it: within clearance
    clear = scene([((0, 0, 9 - 1e-3), 1.0, MATTE)])        # 1e-3 above it
    assert S.sealed(on).tolist() == [False]
    assert S.sealed(near).tolist() == [False]
    assert S.sealed(clear).tolist() == [True]


def test_choose_groups_the_most_common_sealed_radius_and_scales_it_to_one():
    balls = [((3 * k, 0, -5), 0.25, MATTE) for k in range(5)] + [((3 * k, 3, -5), 0.5, MIRROR) for k in range(3)]
    floor = [((0, -1000, 0), 999.0, MATTE)]
    glass = [((3 * k, 6, -5), 0.5, GLASS) for k in range(4)]   # 0.5 is commoner only with glass counted
    s = scene(balls + floor + glass)
    g = S.choose(s, min_group=2)
    assert g.radius == 0.25 and g.scale == 4.0
    assert g.member.tolist() == [True] * 5 + [False] * 3 + [False] + [False] * 4
    assert S.choose(s, min_group=6) is None


def test_ties_go_to_the_larger_radius_and_materials_are_kept_apart():
    s = scene([((3 * k, 0, -5), 0.25, MATTE if k % 2 else MIRROR) for k in range(4)]
              + [((3 * k, 3, -5), 0.5, MATTE) for k in range(4)])
    g = S.choose(s, min_group=1)
    assert g.radius == 0.5
    s = scene([((3 * k, 0, -5), 0.25, MATTE if k % 2 else MIRROR) for k in range(5)])
    g = S.choose(s, min_group=1)
    parts = S.groups(s, g, origin=s.lookat)
    assert [(m, r, len(c)) for m, r, c in parts] == [(MIRROR, 1.0, 3), (MATTE, 1.0, 2)]


def test_no_grouping_when_scaling_would_change_the_image_or_overflow():
    balls = [((3 * k, 0, -5), 0.25, MATTE) for k in range(3)]
    assert S.choose(scene(balls, lights=((0, 0, 0),)), min_group=1) is None   # a light at lookat
    tiny = [((1e-3 * k, 0, -5), 1e-6, MATTE) for k in range(3)]
    assert S.choose(scene(tiny), min_group=1) is None                         # reach 10/1e-6 > 1e6


def test_remaining_scales_every_length_about_lookat_and_drops_the_group():
    lookat = (1.0, 2.0, 3.0)
    s = scene([((1, 2, -1), 0.5, MATTE), ((4, 2, -1), 0.5, MATTE), ((1, 6, 3), 2.0, GLASS)],
              lights=((1, 12, 3),), eye=(1, 2, 13), lookat=lookat)
    g = S.choose(s, min_group=2)
    assert g.scale == 2.0
    rest = S.remaining(s, g)
    assert rest.lookat == lookat and rest.eye == (1, 2, 23) and rest.lights[0].position == (1, 22, 3)
    assert [(sp.center, sp.radius, sp.material) for sp in rest.spheres] == [((1, 10, 3), 4.0, GLASS)]
    (material, radius, centers), = S.groups(s, g, origin=lookat)
    assert radius == 1.0
    assert material == MATTE
    np.testing.assert_array_equal(centers, [[0, 0, -8], [6, 0, -8]])
    # the same in another frame origin (a point of the scaled scene)
    (_, _, moved), = S.groups(s, g, origin=(0.0, 0.0, 0.0))
    np.testing.assert_array_equal(moved, [[1, 2, -5], [7, 2, -5]])


@pytest.mark.parametrize("scale", [486.0, 1 / 3, 1e-3])
def test_the_grouped_radius_is_exactly_one_in_float32(scale):
    r = 1 / scale
    s = scene([((3 * r * k, 0, -5), r, MATTE) for k in range(3)])
    g = S.choose(s, min_group=1)
    assert np.float32(g.radius * g.scale) == 1.0
    assert math.isclose(g.scale, scale)


def test_only_lights_limit_the_scaled_frame():
    """The scaled frame's limit is about light intensities (color·π·d², d from lookat): a
    floor sphere far beyond MAX_REACH·r does not switch grouping off, a light that far does."""
    balls = [((3 * k, 0, -5), 0.001, MATTE) for k in range(3)]
    floor = [((0, -1e4, 0), 1e4 - 1, MATTE)]                  # reach 2e4 / 1e-3 = 2e7 > 1e6
    assert S.choose(scene(balls + floor), min_group=1) is not None
    assert S.choose(scene(balls + floor, lights=((0.0, 2000.0, 0.0),)), min_group=1) is None


def test_other_radius_classes_are_grouped_in_the_scaled_frame():
    small = [((k, 0, -5), 0.25, MATTE) for k in range(4)]
    large = [((k, 3, -5), 0.5, MATTE) for k in range(2)]
    s = scene(small + large)
    g = S.choose(s, min_group=2, classes=S.MAX_LAYERS)
    assert g.radii == (0.25, 0.5) and g.member.all()
    assert [(r, len(c)) for _, r, c in S.groups(s, g, origin=s.lookat)] == [(1.0, 4), (2.0, 2)]
    assert S.choose(s, min_group=2).radii == (0.25,)    # for Mitsuba's own integrators


def test_a_giant_sphere_is_never_grouped():
    """A floor of radius 10^4 under balls of other radii (each radius once: the tie goes to
    the larger) stays for the converter to judge, which gives it to the Whitted integrator's
    float64 test; grouped, the scene would be scaled by 10^-4 around it."""
    balls = [((1.5 * k, r, 0), r, MATTE) for k, r in enumerate((0.3, 0.4, 0.5, 0.6))]
    s = scene(balls + [((0, -1e4, 0), 1e4, MATTE)], eye=(0.0, 1.5, 8.0))
    g = S.choose(s, min_group=1, classes=S.MAX_LAYERS)
    assert not g.member[-1] and g.radius == 0.6


def test_grouped_spheres_beyond_the_rest_are_not_clipped(llvm):
    """The sensor's clip range covers the grouped spheres, not only the rest of the scene: a
    row of balls running 60 units away beside one near ball is seen to its end, as without
    grouping."""
    import mitsuba as mi
    import whitted
    text = ("size 64 16\neye 0 0.5 6\nlookat 0 0.5 0\nfov 30\nlight 0 10 6\nbackground 0 0 0\n"
            "sphere 0 0.5 4 0.25 color 1 1 1 refract 0.5 1.5\n"
            + "".join(f"sphere {0.4 * k - 3} 0.5 {-2 * k} 0.5 color 0.2 0.9 0.2\n" for k in range(30)))
    grouped, plain = (whitted.render(whitted.loads(text, ellipsoids=e)).image for e in (True, False))
    assert grouped.max() > 0.1
    np.testing.assert_allclose(grouped, plain, atol=2e-3)
