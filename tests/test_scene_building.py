"""The two routes from a scene model to Mitsuba build the same scene: the XML text
(``scene_to_xml`` + ``mi.load_string``/``load_file``) and ``mi.load_dict`` of the same
description (``whitted.load_scene`` of a ``.scn`` file): every parameter Mitsuba exposes
is equal bit for bit, and so are the Whitted and path-traced renders (to the ulp by which
two renders of one scene may differ), in both variants."""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted.converter import Light, Material, Scene, Sphere, describe, parse_file, scene_to_xml
from whitted.errors import WhittedError
from whitted.loading import mitsuba_dict


def model(texture) -> Scene:
    """Every kind of object the converter writes: a background, two lights, shared and
    distinct materials, glass, a mirror and a textured globe, away from the origin."""
    glass = Material(color=(1.0, 1.0, 1.0), reflect=0.1, refract=0.85, ior=1.5)
    return Scene(width=24, height=16, eye=(3.0, 2.5, 9.0), lookat=(0.5, 0.7, 0.1), up=(0.1, 1.0, 0.0),
                 fov=50.0, background=(0.2, 0.3, 0.5), ambient=0.3, depth=4, samples=2, min_weight=0.05,
                 lights=[Light((4.0, 6.0, 5.0)), Light((-5.0, 3.0, 4.0), (0.4, 0.5, 0.6))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.7), reflect=0.2)),
                          Sphere((-1.2, 1.0, 0.0), 1.0, Material(color=(0.9, 0.9, 0.9), reflect=0.8)),
                          Sphere((1.3, 0.8, 0.8), 0.8, glass), Sphere((1.0, 0.3, 2.0), 0.3, glass),
                          Sphere((-0.5, 0.5, 2.5), 0.5, Material(texture=texture), north=(0.2, 1.0, 0.1))])


def parameters(scene: mi.Scene) -> dict:
    """Every parameter Mitsuba exposes, as numpy arrays (or text when it has no array form)."""
    params = mi.traverse(scene)
    values = {}
    for key in params.keys():
        value = params[key]
        if hasattr(value, "matrix"):
            value = value.matrix
        try:
            values[key] = np.array(value)
        except (TypeError, ValueError):
            values[key] = repr(value)
    return values


def assert_same_scene(a: mi.Scene, b: mi.Scene) -> None:
    pa, pb = parameters(a), parameters(b)
    assert sorted(pa) == sorted(pb)
    for key in pa:
        np.testing.assert_array_equal(pa[key], pb[key], err_msg=key)
    for getter in (lambda s: s.shapes(), lambda s: s.emitters(), lambda s: s.sensors()):
        assert [o.id() for o in getter(a)] == [o.id() for o in getter(b)]
    ia, ib = a.integrator(), b.integrator()
    for name in ("max_depth", "ambient", "lighting", "min_weight"):
        assert getattr(ia, name) == getattr(ib, name), name
    assert list(ia.light_reference) == list(ib.light_reference)
    sa, sb = a.sensors()[0], b.sensors()[0]
    assert sa.sampler().sample_count() == sb.sampler().sample_count()
    assert str(sa.world_transform()) == str(sb.world_transform())
    assert (sa.near_clip(), sa.far_clip()) == (sb.near_clip(), sb.far_clip())
    # Renders: equal but for the order in which the JIT variants' film adds a pixel's
    # samples (atomics; the same scene rendered twice differs by as much, ~1 ulp).
    for integrator in ("whitted", "path"):
        np.testing.assert_allclose(whitted.render(a, integrator=integrator).image,
                                   whitted.render(b, integrator=integrator).image, rtol=0, atol=1e-6)


def test_xml_and_load_dict_build_the_same_scene(variant, texture_png):
    scene = model(texture_png("globe.png"))
    from_xml = mi.load_string(scene_to_xml(scene, base_dir=None))
    from_dict = mi.load_dict(mitsuba_dict(describe(scene, None)))
    assert_same_scene(from_xml, from_dict)


def test_load_scene_of_a_scn_file_equals_its_converted_xml(variant, tmp_path, texture_png):
    texture_png("globe.png")
    source = tmp_path / "scene.scn"
    source.write_text("size 24 16\neye 1e6 2 9\nlookat 1e6 0.5 0\nbackground 0.2 0.3 0.5\n"
                      "depth 3\nsamples 2\nminweight 0.05\nlight 1e6 6 5\nlight 999996 3 4 0.4 0.5 0.6\n"
                      "sphere 1e6 -100 0 100 color 0.8 0.8 0.7 reflect 0.3\n"
                      "sphere 999998.8 1 0 1 reflect 0.8\n"
                      "sphere 1000001.3 0.8 0.8 0.8 refract 0.85 1.5 reflect 0.1\n"
                      'sphere 999999.5 0.5 2.5 0.5 texture "globe.png" north 0.2 1 0.1\n')
    xml = tmp_path / "scene.xml"
    xml.write_text(scene_to_xml(parse_file(source), tmp_path))
    overrides = dict(spp=3, max_depth=2, ambient=0.4, lighting="physical")
    assert_same_scene(whitted.load_scene(source), whitted.load_scene(xml))
    assert_same_scene(whitted.load_scene(source, **overrides), whitted.load_scene(xml, **overrides))


@pytest.mark.parametrize("override, message", [
    (dict(spp=0), "spp must be a positive integer"),
    (dict(max_depth=65), "max depth must be in 1…64"),
    (dict(ambient=1.5), "ambient must be in [0, 1]"),
    (dict(lighting="flat"), "lighting must be one of article, physical"),
    (dict(exposure=2), "unknown scene override(s) exposure"),
])
def test_bad_overrides_are_one_clear_error(write_scene, override, message):
    with pytest.raises(WhittedError, match=message.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
        whitted.load_scene(write_scene("sphere 0 0 0 1\n"), **override)
