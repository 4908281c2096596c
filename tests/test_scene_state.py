"""What the integrator reads from a scene is computed once per scene state (plugins/scene_state.py).

A second render of an unchanged scene reads nothing again; a change made
through Mitsuba's own ``mi.traverse(scene)`` + ``params.update()`` shows in
the next render, which must match the float64 reference of the changed scene.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mitsuba as mi
import numpy as np
import pytest

import whitted
from reference import assert_matches, render_reference
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml



def model() -> Scene:
    return Scene(width=40, height=30, eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.3, 0.0),
                 lights=[Light((3.0, 6.0, 4.0))],
                 spheres=[Sphere((0.0, -101.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.75))),
                          Sphere((-1.0, 0.5, 0.0), 1.0, Material(color=(0.9, 0.25, 0.2), reflect=0.3)),
                          Sphere((1.4, 0.3, -0.5), 0.6, Material(color=(0.2, 0.35, 0.9)))])


def load(scene_model: Scene):
    return mi.load_string(scene_to_xml(scene_model, base_dir=None))


class Counter:
    """Counts the calls of a module's function (the scene's tables are built by them)."""

    def __init__(self, monkeypatch, module, name):
        self.calls = 0
        original = getattr(module, name)

        def counted(*args, **kwargs):
            self.calls += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, name, counted)


@pytest.fixture
def builds(monkeypatch):
    """How often the scene's materials, shape numbers and lights were read."""
    from whitted.plugins import effects, geometry, surfaces
    counters = [Counter(monkeypatch, surfaces, "_shape_materials"),
                Counter(monkeypatch, geometry, "_shape_numbers"),
                Counter(monkeypatch, effects, "_lights")]
    return lambda: tuple(c.calls for c in counters)


def test_a_second_render_reads_nothing_again(variant, builds):
    scene = load(model())
    first = whitted.render(scene).image
    assert builds() == (1, 1, 1)
    second = whitted.render(scene, max_depth=3).image   # another integrator: the same tables
    assert builds() == (1, 1, 1)
    np.testing.assert_array_equal(first, second)


def test_a_new_scene_is_read_afresh(llvm, builds):
    for n in (1, 2):
        whitted.render(load(model()))
        assert builds() == (n, n, n)


def test_changes_through_mitsuba_parameters_show_in_the_next_render(variant, builds):
    """A sphere moved and resized, a material's color and a light's position changed with
    ``mi.traverse`` + ``update()``: the next render is the reference of the changed scene."""
    original = model()
    scene = load(original)
    before = whitted.render(scene).image
    assert_matches(before, render_reference(original))

    params = mi.traverse(scene)
    center, radius, color, light = (-0.7, 0.8, 0.4), 1.2, (0.3, 0.9, 0.4), (-2.0, 5.0, 5.0)
    # Mitsuba holds the converter's frame: world coordinates minus the scene's lookat.
    frame = [tuple(a - b for a, b in zip(p, original.lookat)) for p in (center, light)]
    params["sphere_1.to_world"] = mi.ScalarTransform4f().translate(frame[0]).scale(radius)
    params["material_2.color.value"] = mi.Color3f(color)
    params["light_0.position"] = mi.Point3f(frame[1])
    # the converter's encoding of the article's light color (plugins/effects.py): I = color·π·d²
    params["light_0.intensity.value"] = mi.Color3f(math.pi * sum((a - b) ** 2 for a, b in zip(light, original.lookat)))
    params.update()
    changed = replace(original, lights=[replace(original.lights[0], position=light)], spheres=[
        original.spheres[0],
        replace(original.spheres[1], center=center, radius=radius),
        replace(original.spheres[2], material=replace(original.spheres[2].material, color=color))])

    after = whitted.render(scene).image
    assert builds() == (2, 2, 2)
    assert np.abs(after - before).mean() > 0.01
    assert_matches(after, render_reference(changed))
