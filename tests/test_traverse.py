"""``mi.traverse`` and ``params.update()`` on the project's plugins (issue 28): every
parameter of the ``article`` BSDF and of the ``whitted`` integrator that a scene sets is
exposed, and an edit renders exactly what a freshly loaded file with that edit renders."""

from __future__ import annotations

import re
import sys

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from conftest import REPO
from whitted.converter import scene_to_xml

sys.path.insert(0, str(REPO / "tests" / "hard_cases"))
import hazard_scenes as hs  # noqa: E402


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    """One Dr.Jit thread for the file's tests: multi-level renders are then bit-identical run to
    run."""
    threads = dr.thread_count()
    dr.set_thread_count(1)
    yield
    dr.set_thread_count(threads)


def glass_xml() -> str:
    return scene_to_xml(hs.total_internal_reflection(), base_dir=None)   # glass, a bubble, depth 8


def render(scene) -> np.ndarray:
    return np.array(mi.render(scene))


def edited(xml: str, element: str, name: str, value: str) -> str:
    """``xml`` with property ``name`` of the object ``id="element"`` set to ``value``."""
    start = xml.index(f'id="{element}"')
    end = xml.index("</", start)
    block = xml[start:end]
    new, count = re.subn(rf'(name="{name}" value=")[^"]*(")', rf"\g<1>{value}\g<2>", block)
    assert count == 1, (element, name)
    return xml[:start] + new + xml[end:]


@pytest.mark.parametrize("name,value,text", [
    ("reflect", 0.08, "0.08"), ("refract", 0.6, "0.6"), ("ior", 1.33, "1.33"),
    ("color.value", [0.2, 0.6, 0.4], "0.2 0.6 0.4")])
def test_a_bsdf_edit_renders_as_the_edited_file(variant, name, value, text):
    xml = glass_xml()
    scene = mi.load_string(xml)
    params = mi.traverse(scene)
    for key in ("reflect", "refract", "ior", "color.value"):
        assert f"material_1.{key}" in params
    params[f"material_1.{name}"] = value
    params.update()
    expected = mi.load_string(edited(xml, "material_1", name.split(".")[0], text))
    np.testing.assert_array_equal(render(scene), render(expected))
    assert not np.array_equal(render(scene), render(mi.load_string(xml)))


def test_a_textures_edit_renders_as_the_edited_file(variant, tmp_path):
    """The texels of a textured sphere (``color.data``, 8-bit as loaded), against a file
    naming a PNG of the edited texels."""
    xml = scene_to_xml(hs.texture_poles(tmp_path), base_dir=None)
    scene = mi.load_string(xml)
    params = mi.traverse(scene)
    key = next(k for k in params.keys() if k.endswith("color.data"))
    texels = np.array(params[key])
    assert texels.dtype == np.uint8
    texels = (texels[..., ::-1] // 2).copy()   # channels swapped, halved
    params[key] = type(params[key])(texels)
    params.update()
    mi.Bitmap(texels, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(tmp_path / "edited.png"))
    expected = xml.replace(str(tmp_path / "stripes.png"), str(tmp_path / "edited.png"))
    assert expected != xml
    np.testing.assert_array_equal(render(scene), render(mi.load_string(expected)))


def test_an_invalid_bsdf_edit_is_refused_and_undone(variant):
    scene = mi.load_string(glass_xml())
    before = render(scene)
    params = mi.traverse(scene)
    params["material_1.reflect"] = 0.5   # 0.5 + 0.9 > 1
    with pytest.raises(ValueError, match="reflect \\+ refract must be <= 1"):
        params.update()
    assert params["material_1.reflect"][0] == 0.05
    np.testing.assert_array_equal(render(scene), before)


@pytest.mark.parametrize("name,value", [("max_depth", 3), ("ambient", 0.55), ("min_weight", 0.1),
                                        ("light_reference", [0.5, 1.0, -2.0])])
def test_an_integrator_edit_renders_as_the_edited_file(variant, name, value):
    xml = glass_xml()
    scene = mi.load_string(xml)
    params = mi.traverse(scene.integrator())
    assert set(params.keys()) >= {"max_depth", "ambient", "min_weight", "light_reference"}
    params[name] = value
    params.update()
    if name in ("max_depth", "ambient"):   # the file's own parameters
        expected = mi.load_string(xml, **{name: str(value)})
    elif name == "min_weight":
        expected = mi.load_string(xml.replace('<point name="light_reference"',
                                              f'<float name="min_weight" value="{value}"/>\n'
                                              '        <point name="light_reference"'))
    else:
        expected = mi.load_string(edited(xml, "integrator", name, ", ".join(map(str, value))))
    np.testing.assert_array_equal(render(scene), render(expected))
    assert not np.array_equal(render(scene), render(mi.load_string(xml)))


def test_an_invalid_integrator_edit_is_refused_and_undone(variant):
    from whitted.errors import WhittedError
    scene = mi.load_string(glass_xml())
    params = mi.traverse(scene.integrator())
    params["ambient"] = 0.6
    params["max_depth"] = 0
    with pytest.raises(WhittedError, match="max_depth must be in 1"):
        params.update()
    assert scene.integrator().max_depth == 8 and scene.integrator().ambient == 0.3
    assert params["ambient"][0] == 0.3 and params["max_depth"][0] == 8


# -- the converted XML's parameters ----------------------------------------------------------------

@pytest.mark.parametrize("name", ["tir", "globe"])
def test_the_xml_declares_every_override_the_portable_xml_has(llvm, name):
    """``width`` and ``height`` (and ``spp``, ``max_depth``) are defaults of both XML forms;
    ``world_origin`` is no parameter (no property could use it: overriding it would be
    silently ignored)."""
    import xml.etree.ElementTree as ET

    def declared(path):
        return {d.get("name") for d in ET.parse(path).getroot().iter("default")}
    default, portable = REPO / "scenes_xml" / f"{name}.xml", REPO / "scenes_xml" / f"{name}.portable.xml"
    assert declared(portable) <= declared(default)
    assert {"width", "height", "spp", "max_depth", "ambient", "lighting"} <= declared(default)
    assert "world_origin" not in declared(default) | declared(portable)
    for path in (default, portable):
        scene = mi.load_file(str(path), width="40", height="25", spp="2")
        film = scene.sensors()[0].film()
        assert tuple(film.size()) == (40, 25)
        assert scene.sensors()[0].sampler().sample_count() == 2
        with pytest.raises(RuntimeError, match="unused parameters"):
            mi.load_file(str(path), world_origin="1, 2, 3")


def test_load_scene_overrides_the_size(variant):
    import whitted
    for path in (REPO / "scenes" / "tir.scn", REPO / "scenes_xml" / "tir.xml"):
        scene = whitted.load_scene(path, width=32, height=20)
        assert tuple(scene.sensors()[0].film().size()) == (32, 20)
    with pytest.raises(whitted.WhittedError, match="width must be in 1…16384"):
        whitted.load_scene(REPO / "scenes_xml" / "tir.xml", width=0)


# -- one rule for a parameter, loaded or edited ----------------------------------------------------

def load_message(**properties) -> str:
    """The message a plugin raised while Mitsuba loaded it from ``properties`` (Mitsuba puts
    its own words and the traceback first: the plugin's error is the last line)."""
    with pytest.raises(RuntimeError) as error:
        mi.load_dict(properties)
    return str(error.value).splitlines()[-1].split(": ", 1)[1]


@pytest.mark.parametrize("name,value,loaded,message", [
    ("reflect", 1.5, 1.5, "article BSDF: reflect must be in [0, 1], got 1.5"),
    ("refract", -0.5, -0.5, "article BSDF: refract must be in [0, 1], got -0.5"),
    ("ior", 0.0, 0.0, "article BSDF: ior must be > 0, got 0.0"),
    ("color.value", [-0.5, 0.25, 0.25], {"type": "rgb", "value": [-0.5, 0.25, 0.25]},
     "article BSDF: color must have each component in [0, 1], got [-0.5, 0.25, 0.25]"),
    ("color.value", [0.5, 1.5, 0.5], {"type": "rgb", "value": [0.5, 1.5, 0.5]},
     "article BSDF: color must have each component in [0, 1], got [0.5, 1.5, 0.5]")])
def test_a_bsdf_parameter_is_checked_alike_at_load_and_at_update(variant, name, value, loaded, message):
    """An edit that loading would refuse is refused by ``params.update()`` with loading's
    message, and undone."""
    from whitted.errors import WhittedError
    assert load_message(type="article", **{name.split(".")[0]: loaded}) == message
    scene = mi.load_string(glass_xml())
    before = render(scene)
    params = mi.traverse(scene)
    params[f"material_0.{name}"] = value
    with pytest.raises(WhittedError) as error:
        params.update()
    assert str(error.value) == message
    np.testing.assert_array_equal(render(scene), before)


@pytest.mark.parametrize("name,value,message", [
    ("max_depth", 2.5, "whitted: max_depth must be an integer, got 2.5"),
    ("max_depth", 65, "whitted: max_depth must be in 1…64 (primary rays have depth 1), got 65"),
    ("ambient", -0.25, "whitted: ambient must be in [0, 1], got -0.25"),
    ("min_weight", 1.5, "whitted: min_weight must be in [0, 1], got 1.5")])
def test_an_integrator_parameter_is_checked_alike_at_load_and_at_update(variant, name, value, message):
    """A non-integral max_depth is refused, not truncated, when loaded and when edited."""
    from whitted.errors import WhittedError
    assert load_message(type="whitted", **{name: value}) == message
    scene = mi.load_string(glass_xml())
    integrator = scene.integrator()
    params = mi.traverse(integrator)
    params[name] = value
    with pytest.raises(WhittedError) as error:
        params.update()
    assert str(error.value) == message
    assert (integrator.max_depth, integrator.ambient) == (8, 0.3)
    assert params["max_depth"][0] == 8 and params["ambient"][0] == 0.3


@pytest.mark.parametrize("plugin,name", [("article", "reflect"), ("article", "refract"),
                                         ("article", "ior"), ("whitted", "ambient"),
                                         ("whitted", "max_depth"), ("whitted", "min_weight")])
def test_an_rgb_where_a_number_belongs_is_named(variant, plugin, name):
    kind = "bsdf" if plugin == "article" else "integrator"
    with pytest.raises(RuntimeError) as error:
        mi.load_string(f'<{kind} version="3.0.0" type="{plugin}"><rgb name="{name}" value="0.5 0.5 0.5"/></{kind}>')
    line = str(error.value).splitlines()[-1]
    owner = "article BSDF" if plugin == "article" else "whitted"
    assert f"{owner}: {name} must be a" in line and "[0.5, 0.5, 0.5]" in line, line
    assert "float()" not in line


def test_load_scene_names_the_bad_parameter_in_one_line(llvm, tmp_path):
    import whitted
    path = tmp_path / "bad.xml"
    path.write_text(edited(glass_xml(), "material_1", "reflect", "1.5"))
    with pytest.raises(whitted.WhittedError) as error:
        whitted.load_scene(path)
    # FILE:LINE, the line of the XML object (whitted.loading.load_error)
    assert re.fullmatch(rf"{re.escape(str(path))}:\d+: article BSDF: reflect must be in \[0, 1\], got 1\.5",
                        str(error.value)), str(error.value)
