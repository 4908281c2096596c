"""Giant spheres (docs/numerics.md, hazard 14): floors of radius 10^4 to 10^7 under small
balls, smallpt's Cornell box of six radius-10^5 walls, the eye inside a sky dome of radius
10^5. The Whitted integrator must match the float64 reference in both variants, with the
hazard suite's thresholds, at one sample per pixel.
"""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
import whitted
from conftest import VARIANTS
from reference import Reference, assert_matches
from whitted.converter import scene_to_xml
from whitted.converter.description import describe
from whitted.converter.giants import giant_spheres, parse_exact_spheres


@pytest.fixture(scope="module")
def giants():
    """``giants(name, what)``: the model, its reference image ("reference") or its render in
    a variant, each computed once."""
    cache = {}

    def get(name: str, what: str, **options):
        key = (name, what, tuple(sorted(options.items())))
        if (name, "model") not in cache:
            cache[(name, "model")] = hs.GIANTS[name]()
        model = cache[(name, "model")]
        if key not in cache:
            if what == "reference":
                cache[key] = Reference(model).render()
            else:
                previous = mi.variant()
                whitted.set_variant(what)
                try:
                    scene = mi.load_string(scene_to_xml(model, base_dir=None), **options)
                    cache[key] = whitted.render(scene).image
                finally:
                    whitted.set_variant(previous)
        return cache[key]
    return get


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("name", list(hs.GIANTS))
def test_giant_scene_matches_the_reference(giants, name, variant):
    assert_matches(giants(name, variant), giants(name, "reference"))


def test_the_scenes_show_what_they_test(giants):
    """The floors are seen with their contact shadows and reflections, smallpt's box with
    its colored walls: not black images that would match anything."""
    for name in hs.GIANTS:
        image = giants(name, "reference")
        assert image.mean() > 0.15 and image.std() > 0.05, name
    box = giants("smallpt_box", "reference")
    left, right = box[:, :4].mean(axis=(0, 1)), box[:, -4:].mean(axis=(0, 1))
    assert left[0] > 2 * left[2] and right[2] > 2 * right[0]   # red wall left, blue right


def test_which_spheres_are_giant():
    """Floors from 10^4 on under balls of 0.3, and the sky dome; not smallpt's walls (float32
    places them to 0.07, 4e-3 of its balls' radius 16.5, and renders them right), nor the
    floors of radius 100 to 1000 of the other hazard scenes (but large_floor's 10^4), nor
    the sky dome scene's floor of radius 10^3."""
    for name in ("floor_1e4", "floor_1e5", "floor_1e6", "floor_1e7"):
        model = hs.GIANTS[name]()
        assert giant_spheres(model, model.lookat) == [0], name
    box = hs.smallpt_box()
    assert giant_spheres(box, box.lookat) == []
    dome = hs.sky_dome()
    assert giant_spheres(dome, dome.lookat) == [0]
    for name in hs.HAZARDS:
        if name not in ("texture_poles", "arccos_range"):
            model = hs.HAZARDS[name]()
            giant = "exact_spheres" in describe(model, None).scene["integrator"]
            assert giant == (name == "large_floor"), name   # its floor has radius 10^4


def test_the_integrator_gets_the_exact_values():
    """The XML's ``exact_spheres`` holds the file's center minus lookat and radius in float64
    (float32 would hold the floor's center -10000000.5 as -10000000)."""
    model = hs.giant_floor(1e7)
    integrator = describe(model, None).scene["integrator"]
    [(key, center, radius)] = parse_exact_spheres(integrator["exact_spheres"])
    assert key == "sphere_0" and center == (0.0, -10000000.5, 0.0) and radius == 1e7
    assert float(np.float32(center[1])) != center[1]


@pytest.mark.parametrize("variant", VARIANTS)
def test_without_the_exact_values_the_floor_breaks_up(giants, variant):
    """The same XML with ``exact_spheres`` emptied is what the integrator did before: on a
    floor of radius 10^6 its offsets lift shadow and reflection rays over the balls."""
    model = hs.giant_floor(1e6)
    xml = scene_to_xml(model, base_dir=None)
    start = xml.index('<string name="exact_spheres"')
    xml = xml[:start] + xml[xml.index("/>", start) + 2:]
    previous = mi.variant()
    whitted.set_variant(variant)
    try:
        image = whitted.render(mi.load_string(xml)).image
    finally:
        whitted.set_variant(previous)
    off = (np.abs(image - giants("floor_1e6", "reference")).max(axis=2) > 0.02).mean()
    assert off > 0.05


@pytest.mark.parametrize("text, message", [
    ("sphere_0 0 0 0 1", "expected 'id: x y z r'"),
    ("sphere_0: 0 0 1", "expected 'id: x y z r'"),
    ("sphere_0: 0 0 zero 1", "four numbers"),
    ("sphere_0: 0 0 0 -1", "positive"),
])
def test_a_malformed_exact_spheres_property_is_refused(text, message):
    with pytest.raises(ValueError, match=message):
        parse_exact_spheres(text)
