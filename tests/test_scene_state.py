"""What the integrator reads from a scene is built once per scene state (plugins/scene_tables.py).

A second render of an unchanged scene builds nothing again; a change made
through Mitsuba's own ``mi.traverse(scene)`` + ``params.update()`` shows in
the next render, which must match the float64 reference of the changed scene,
and no Mitsuba class is modified to notice it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mitsuba as mi
import numpy as np
import pytest

import whitted
from float64_reference import assert_matches, render_reference
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml



def model() -> Scene:
    return Scene(width=40, height=30, eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.3, 0.0),
                 lights=[Light((3.0, 6.0, 4.0))],
                 spheres=[Sphere((0.0, -101.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.75))),
                          Sphere((-1.0, 0.5, 0.0), 1.0, Material(color=(0.9, 0.25, 0.2), reflect=0.3)),
                          Sphere((1.4, 0.3, -0.5), 0.6, Material(color=(0.2, 0.35, 0.9)))])


def load(scene_model: Scene):
    return mi.load_string(scene_to_xml(scene_model, base_dir=None))


@pytest.fixture
def builds(monkeypatch):
    """How often a scene's tables were built (lights, materials, primitives: one pass)."""
    from whitted.plugins import scene_tables as tables
    calls = []

    class Counted(tables.SceneTables):
        def __init__(self, scene):
            calls.append(scene)
            super().__init__(scene)
    monkeypatch.setattr(tables, "SceneTables", Counted)
    return lambda: len(calls)


def test_a_second_render_reads_nothing_again(variant, builds):
    """Another integrator on the same scene reuses its tables, and renders what it would on a
    freshly loaded scene: what is kept is the scene's, nothing of the first integrator's (at
    depth 1 the red sphere's reflection is gone, so the images differ)."""
    scene = load(model())
    first = whitted.render(scene).image
    assert builds() == 1
    shallow = whitted.render(scene, max_depth=1).image
    assert builds() == 1
    assert not np.array_equal(first, shallow)
    np.testing.assert_array_equal(shallow, whitted.render(load(model()), max_depth=1).image)
    assert builds() == 2


def test_a_new_scene_is_read_afresh(llvm, builds):
    for n in (1, 2):
        whitted.render(load(model()))
        assert builds() == n


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
    # the converter's encoding of the article's light color (plugins/scene_tables.py): I = color·π·d²
    params["light_0.intensity.value"] = mi.Color3f(math.pi * sum((a - b) ** 2 for a, b in zip(light, original.lookat)))
    params.update()
    changed = replace(original, lights=[replace(original.lights[0], position=light)], spheres=[
        original.spheres[0],
        replace(original.spheres[1], center=center, radius=radius),
        replace(original.spheres[2], material=replace(original.spheres[2].material, color=color))])

    after = whitted.render(scene).image
    assert builds() == 2
    assert np.abs(after - before).mean() > 0.01
    assert_matches(after, render_reference(changed))


@pytest.mark.parametrize("edit", ["color", "light", "radius"])
def test_each_kind_of_edit_alone_is_noticed(llvm, builds, edit):
    """A material's color, a light's intensity or a sphere's radius (inside the scene's bounds:
    the floor's box holds it), each changed alone, rebuilds the tables; the image follows."""
    original = model()
    scene = load(original)
    before = whitted.render(scene).image
    params = mi.traverse(scene)
    if edit == "color":
        params["material_1.color.value"] = mi.Color3f(0.1, 0.9, 0.1)
        changed = replace(original, spheres=[original.spheres[0], replace(
            original.spheres[1], material=replace(original.spheres[1].material, color=(0.1, 0.9, 0.1))),
            original.spheres[2]])
    elif edit == "light":
        params["light_0.intensity.value"] = params["light_0.intensity.value"] * 0.25
        changed = replace(original, lights=[replace(original.lights[0], color=(0.25, 0.25, 0.25))])
    else:
        frame = tuple(a - b for a, b in zip(original.spheres[2].center, original.lookat))
        params["sphere_2.to_world"] = mi.ScalarTransform4f().translate(frame).scale(0.4)
        changed = replace(original, spheres=[*original.spheres[:2], replace(original.spheres[2], radius=0.4)])
    params.update()
    after = whitted.render(scene).image
    assert builds() == 2
    assert np.abs(after - before).max() > 0.05
    assert_matches(after, render_reference(changed))


def test_no_mitsuba_class_is_modified():
    """Importing whitted, rendering and editing a scene leave every attribute of Mitsuba's
    classes as Mitsuba made them (checked in a fresh process, before and after)."""
    import subprocess
    import sys
    from conftest import REPO
    script = """
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
def snapshot():
    return {(name, key): value for name in dir(mi) if isinstance(getattr(mi, name), type)
            for key, value in vars(getattr(mi, name)).items()}
before = snapshot()
import whitted
from whitted.converter import Light, Scene, Sphere, scene_to_xml
scene = mi.load_string(scene_to_xml(Scene(width=8, height=6, lights=[Light((0.0, 5.0, 5.0))],
                                          spheres=[Sphere((0.0, 0.0, 0.0), 1.0)]), base_dir=None))
whitted.render(scene)
params = mi.traverse(scene)
params["sphere_0.to_world"] = mi.ScalarTransform4f().scale(0.5)
params.update()
whitted.render(scene)
after = snapshot()
changed = sorted(k for k in set(before) | set(after) if before.get(k) is not after.get(k))
print(changed)
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]"
