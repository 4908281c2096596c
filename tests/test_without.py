"""Effects left out of a render (``whitted render --without``, the integrator's ``without``):
each render equals the render of the scene edited to lack the effect, and the kernel does
less work (plugins/scene_tables.py says what each effect's absence means).
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
from float64_reference import Reference, assert_matches
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.converter.scn_writer import scene_to_scn

from conftest import REPO

W, H = 24, 16


def model(**changes) -> Scene:
    """Shadows from two lights, a mirror, a glass ball (total internal reflection too), a
    textured ball and a background."""
    texture = REPO / "scenes" / "earth.png"
    scene = Scene(width=W, height=H, eye=(0.0, 1.5, 6.5), lookat=(0.0, 0.6, 0.0), fov=50.0,
                  background=(0.2, 0.2, 0.3), ambient=0.15, depth=5,
                  lights=[Light((3.0, 6.0, 5.0)), Light((-4.0, 3.0, 2.0), (0.4, 0.4, 0.4))],
                  spheres=[Sphere((0.0, -100.0, 0.0), 100.0, Material(color=(0.7, 0.7, 0.7))),
                           Sphere((-1.4, 0.9, 0.0), 0.9, Material(color=(0.9, 0.9, 0.9), reflect=0.6)),
                           Sphere((1.3, 0.8, 0.6), 0.8, Material(color=(0.9, 0.5, 0.3), reflect=0.1,
                                                                 refract=0.8, ior=1.5)),
                           Sphere((0.1, 0.5, -1.5), 0.5, Material(texture=texture, reflect=0.2))])
    return replace(scene, **changes)


def load(scene: Scene, variant: str):
    whitted.set_variant(variant)
    return mi.load_string(scene_to_xml(scene, base_dir=None))


def render(scene: Scene, variant: str, **options) -> whitted.RenderResult:
    return whitted.render(load(scene, variant), min_weight=0, **options)


def test_without_ambient_is_the_scene_with_ambient_0(variant):
    left_out = render(model(), variant, without="ambient")
    assert np.array_equal(left_out.image, render(model(ambient=0.0), variant).image)


def test_without_diffuse_is_the_scene_without_lights(variant):
    left_out = render(model(), variant, without=["diffuse"])
    assert np.array_equal(left_out.image, render(model(lights=[]), variant).image)
    assert left_out.stats["rays"]["shadow"] == 0 and "lights" not in left_out.stats["effects"]


def test_without_reflection_and_refraction_is_depth_1(variant):
    left_out = render(model(), variant, without="reflection,refraction")
    assert np.array_equal(left_out.image, render(model(depth=1), variant).image)
    assert left_out.stats["rays"]["reflection"] == left_out.stats["rays"]["refraction"] == 0


@pytest.mark.parametrize("effect", ["shadows", "reflection", "refraction", "textures"])
def test_without_an_effect_matches_the_reference_without_it(variant, effect):
    """Against the float64 reference renderer with the same effect left out; and the rays
    of that effect are not traced at all."""
    result = render(model(), variant, without=effect)
    reference = Reference(model(), without=(effect,))
    assert_matches(result.image, reference.render())
    full = render(model(), variant).stats["rays"]
    rays = result.stats["rays"]
    kind = {"shadows": "shadow"}.get(effect, effect)
    if kind in rays:
        assert rays[kind] == reference.rays[kind] == 0 < full[kind]
    else:
        assert "textures" not in result.stats["effects"]


def test_without_textures_is_the_scene_with_white_spheres(variant):
    """The textured ball made plain (white, the format's default color): the same image, to
    float32 round-off of the textured sphere's rotated frame (exact in scalar_rgb)."""
    plain = model()
    plain.spheres[3] = replace(plain.spheres[3], material=Material(reflect=0.2))
    left_out, edited = render(model(), variant, without="textures").image, render(plain, variant).image
    assert np.abs(left_out - edited).max() <= 1e-6


def test_without_reflection_keeps_the_diffuse_share(variant):
    """A mirror alone in the scene: without reflection its pixels are (1 - KR)·point, the
    mirror's rays cut as at the tree's last level (``max_depth`` 1)."""
    mirror_only = model(spheres=model().spheres[:2])
    assert np.array_equal(render(mirror_only, variant, without="reflection").image,
                          render(mirror_only, variant, max_depth=1).image)


def test_the_integrator_property_and_load_scene_take_it(tmp_path):
    whitted.set_variant("llvm_ad_rgb")
    integrator = mi.load_dict({"type": "whitted", "without": "Reflection, shadows"})
    assert integrator.settings()["without"] == ("shadows", "reflection")
    with pytest.raises(Exception, match=r"whitted: without: unknown effect 'shadow' \(did you mean shadows\?\)"):
        mi.load_dict({"type": "whitted", "without": "shadow"})
    path = tmp_path / "scene.scn"
    path.write_text(scene_to_scn(model(), tmp_path))
    xml = tmp_path / "scene.xml"
    xml.write_text(scene_to_xml(model(), base_dir=tmp_path))
    expected = whitted.render(whitted.load_scene(path), without="shadows").image
    for loaded in (whitted.load_scene(path, without="shadows"), whitted.load_scene(xml, without=["shadows"]),
                   whitted.loads(path.read_text(), base_dir=tmp_path, without="shadows")):
        assert np.array_equal(whitted.render(loaded).image, expected)
        assert np.array_equal(np.array(mi.render(loaded)), expected)


def test_a_scene_of_another_integrator_renders_without_the_effect_too():
    """A scene loaded with Mitsuba's path integrator, rendered with the whitted one (its
    defaults: the scene's ambient and light reference are the defaults here): ``without``
    leaves the effect out as in the scene that holds the whitted integrator, and an unknown
    effect is refused by name."""
    from whitted import defaults
    scene = model(ambient=defaults.AMBIENT, lookat=defaults.LOOKAT)
    xml = scene_to_xml(scene, base_dir=None)
    whitted.set_variant("llvm_ad_rgb")
    path_scene = mi.load_string(re.sub(r'<integrator type="whitted".*?</integrator>',
                                       '<integrator type="path"/>', xml, flags=re.S))
    assert "whitted" not in str(path_scene.integrator()).lower()
    expected = render(scene, "llvm_ad_rgb", without="shadows").image
    left_out = whitted.render(path_scene, integrator="whitted", min_weight=0, without=["shadows"])
    assert np.array_equal(left_out.image, expected)
    assert not np.array_equal(expected, render(scene, "llvm_ad_rgb").image)
    with pytest.raises(whitted.WhittedError, match="unknown effect 'nonsense'"):
        whitted.render(path_scene, integrator="whitted", without="nonsense")


def test_cli_without_is_repeatable_and_counts_no_such_rays(tmp_path, capsys):
    path = tmp_path / "scene.scn"
    path.write_text(scene_to_scn(model(), tmp_path))
    stats = tmp_path / "stats.json"
    assert main(["render", str(path), "-o", str(tmp_path / "a.exr"), "-q", "--variant", "llvm_ad_rgb",
                 "--without", "shadows", "--without", "reflection,textures", "--stats", str(stats)]) == 0
    rays = json.loads(stats.read_text())["rays"]
    assert rays["shadow"] == rays["reflection"] == 0 < rays["refraction"]
    expected = whitted.render(whitted.load_scene(path), without="textures,shadows,reflection").image
    assert np.array_equal(whitted.read_image(tmp_path / "a.exr"), expected)


@pytest.mark.parametrize("argv, message", [
    (["--without", "shadow"], "--without: unknown effect 'shadow' (did you mean shadows?); choose from "
                              "shadows, reflection, refraction, textures, diffuse, ambient"),
    (["--without", "refelction"], "(did you mean reflection?)"),
    (["--without", "ambient", "--integrator", "path"], "--without applies to the whitted integrator only"),
])
def test_bad_effects_fail_in_one_line(argv, message, tmp_path, capsys):
    path = tmp_path / "scene.scn"
    path.write_text("size 8 8\nsphere 0 0 0 1\n")
    out = tmp_path / "a.png"
    assert main(["render", str(path), "-o", str(out), "-q", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()


def test_the_lessons_page_shows_each_command_s_picture():
    """docs/lessons.md: every ``-o out/lessons/NAME.png`` of its commands has its picture in
    docs/images/lessons/ (made by docs/images/lessons.py), shown on the page; the README
    test runs the commands."""
    page = (REPO / "docs" / "lessons.md").read_text()
    names = re.findall(r"-o out/lessons/([\w-]+\.png)", page)
    assert len(names) >= 10 and len(set(names)) == len(names)
    for name in names:
        assert (REPO / "docs" / "images" / "lessons" / name).is_file(), name
        assert f"](images/lessons/{name})" in page, name
    assert "--without" in page and "--max-depth" in page
