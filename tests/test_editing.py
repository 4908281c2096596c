"""Editing a scene in its ``.scn`` file's terms (whitted/editing.py): an edit made by
:class:`whitted.SceneEditor` renders the image of the edited file, bit for bit."""

from __future__ import annotations

import shutil
import time

import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted.plugins.scene_tables import article_color, floats

from conftest import REPO, VARIANTS

SCENE = """size 24 16
eye 0 1.5 6.5
lookat 0 0.5 0
background 0.1 0.1 0.15
light 5 8 4
light -4 3 2  0.4 0.4 0.4
sphere 0 -100 0 100        color 0.6 0.65 0.6
sphere -1.4 0.9 0 0.9      color 0.9 0.9 0.95  reflect 0.6
sphere 1.3 0.8 0.6 0.8     color 0.9 0.5 0.3  refract 0.8 1.5  reflect 0.1
sphere 0.1 0.5 -1.5 0.5    texture earth.png
sphere -0.6 0.3 1.6 0.3    color 0.9 0.9 0.95  reflect 0.6
"""


@pytest.fixture
def folder(tmp_path):
    shutil.copy(REPO / "scenes" / "earth.png", tmp_path / "earth.png")
    (tmp_path / "scene.scn").write_text(SCENE)
    return tmp_path


def file_image(editor, folder):
    """The image of the scene file with the editor's edits written into it."""
    (folder / "edited.scn").write_text(editor.scn(folder))
    return whitted.render(whitted.load_scene(folder / "edited.scn")).image


EDITS = {
    "light": lambda e: e.move_light(0, (2, 3, 1)),
    "sphere": lambda e: e.move_sphere(2, (0.4, 1.0, 0.2), radius=0.6),
    "far sphere": lambda e: e.move_sphere(1, (0, 3, -400)),          # the clip range grows
    "textured sphere": lambda e: e.move_sphere(3, (1.5, 0.6, -1.0)),
    "color": lambda e: e.set_color(1, (0.2, 0.4, 0.9)),                # spheres 1 and 4 share it
}


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("edit", EDITS)
def test_an_edit_renders_the_edited_file_bit_for_bit(variant, edit, folder):
    editor = whitted.SceneEditor(folder / "scene.scn", variant)
    before = whitted.render(editor.scene).image
    EDITS[edit](editor)
    image = whitted.render(editor.scene).image
    assert np.array_equal(image, file_image(editor, folder))
    assert not np.array_equal(image, before)


def test_edits_add_up_and_render_in_well_under_a_second(folder):
    editor = whitted.SceneEditor.loads(SCENE, "llvm_ad_rgb", base_dir=folder)
    whitted.render(editor.scene)
    start = time.perf_counter()
    for edit in EDITS.values():
        edit(editor)
        image = whitted.render(editor.scene).image
    assert (time.perf_counter() - start) / len(EDITS) < 0.5
    assert np.array_equal(image, file_image(editor, folder))
    assert editor.model.spheres[4].material.color == (0.2, 0.4, 0.9)


def test_a_moved_light_keeps_its_color(folder):
    """The why: Mitsuba's intensity is c·π·d², d to lookat; moving the position alone keeps
    it, and the article's color read back, I/(π d'²), scales by d²/d'² (97.25/11.25 here);
    the editor writes the intensity for the new distance."""
    whitted.set_variant("llvm_ad_rgb")
    editor = whitted.SceneEditor(folder / "scene.scn")
    params = mi.traverse(editor.scene)
    reference = floats(params["integrator.light_reference"])

    def color():
        return article_color(floats(params["light_0.intensity.value"]), floats(params["light_0.position"]),
                             reference)
    assert color() == pytest.approx((1, 1, 1), rel=1e-6)
    params["light_0.position"] = mi.Point3f(2, 2.5, 1)       # 2 3 1 in the frame of lookat 0 0.5 0
    params.update()
    assert color() == pytest.approx((97.25 / 11.25,) * 3, rel=1e-6)
    editor.move_light(0, (2, 3, 1))
    assert floats(params["light_0.position"]) == (2, 2.5, 1)
    assert color() == pytest.approx((1, 1, 1), rel=1e-6)


def test_an_edit_that_changes_how_the_scene_is_built_is_refused(folder):
    giant = SCENE.replace("sphere 0 -100 0 100", "sphere 0 -10000 0 10000")
    editor = whitted.SceneEditor.loads(giant, "llvm_ad_rgb", base_dir=folder)
    image = whitted.render(editor.scene).image
    with pytest.raises(whitted.WhittedError, match=r"changes how the scene is built \(integrator.exact_spheres\)"):
        editor.move_sphere(0, (0, -10001, 0))
    assert np.array_equal(whitted.render(editor.scene).image, image)   # left as it was
    editor.set_color(0, (0.3, 0.3, 0.3))                                  # a giant's color is a parameter
    assert np.array_equal(whitted.render(editor.scene).image, file_image(editor, folder))


@pytest.mark.parametrize("call, message", [
    (lambda e: e.move_light(2, (0, 0, 0)), "no light 2: the scene has 2 lights, numbered from 0"),
    (lambda e: e.move_sphere(0, (0, 0)), "a sphere's center must be a point"),
    (lambda e: e.move_sphere(0, (0, 0, 0), radius=0), "a sphere's radius must be > 0, got 0.0"),
    (lambda e: e.set_color(3, (1, 1, 1)), "sphere 3 is textured"),
    (lambda e: e.set_color(1, (2, 0, 0)), "color must have each component in [0, 1]"),
])
def test_bad_edits_say_what_is_wrong(call, message, folder):
    editor = whitted.SceneEditor(folder / "scene.scn", "llvm_ad_rgb")
    with pytest.raises(whitted.WhittedError) as error:
        call(editor)
    assert message in str(error.value) and "\n" not in str(error.value)
