"""Errors a Mitsuba user causes with the whitted plugins say what is wrong (issue 28): an
unsupported BSDF or emitter named with its shape, an unsupported variant, a large seed."""

from __future__ import annotations

import subprocess
import sys

import mitsuba as mi
import numpy as np
import pytest

import whitted
from conftest import REPO


def scene(bsdf=None, emitter=None):
    description = {
        "type": "scene", "integrator": {"type": "whitted"},
        "sensor": {"type": "perspective",
                   "film": {"type": "hdrfilm", "width": 8, "height": 6, "rfilter": {"type": "box"}},
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])},
        "ball": {"type": "sphere", "bsdf": bsdf or {"type": "article"}},
        "light": emitter or {"type": "point", "position": [0, 3, 3]},
    }
    return mi.load_dict(description)


CASES = {
    "diffuse": (dict(bsdf={"type": "diffuse"}), ("SmoothDiffuse", "'ball'", "Sphere", "'article'")),
    "directional": (dict(emitter={"type": "directional", "direction": [0, -1, 0]}),
                    ("'light'", "DirectionalEmitter", "point lights")),
}


def first_line(error: BaseException) -> str:
    return str(error).splitlines()[0]


@pytest.mark.parametrize("case", CASES)
def test_an_unsupported_plugin_is_named_with_its_shape(variant, case):
    """The first line of the error names the plugin and the shape or emitter: from the
    integrator's own render and from whitted.render; from mi.render in the scalar variant.
    In the JIT variants mi.render runs the integrator inside ``dr.custom``, which puts a line
    of its own before any error and the integrator's as the cause: that cause's first line."""
    kwargs, words = CASES[case]
    loaded = scene(**kwargs)
    for call in (lambda: loaded.integrator().render(loaded), lambda: whitted.render(loaded),
                 lambda: mi.render(loaded)):
        with pytest.raises(Exception) as caught:
            call()
        error = caught.value
        if "drjit.custom" in first_line(error):
            assert variant != "scalar_rgb"
            error = error.__cause__
        assert isinstance(error, whitted.WhittedError)
        for word in words:
            assert word in first_line(error), (word, first_line(error))


def test_an_unsupported_variant_is_named_when_a_scene_loads():
    """After mi.set_variant("llvm_ad_spectral") (before or after import whitted), loading a
    scene that names the plugins says that the variant is not one they run in."""
    program = (
        "import mitsuba as mi{first}\n"
        "mi.set_variant('llvm_ad_spectral')\n"
        "{second}"
        "for load in (lambda: mi.load_file('scenes_xml/tir.xml'), lambda: mi.load_dict({{'type': 'article'}})):\n"
        "    try:\n"
        "        load()\n"
        "    except RuntimeError as error:\n"
        "        print(str(error).strip().splitlines()[0])\n"
        "        print(str(error).strip().splitlines()[-1])\n"
        "mi.set_variant('llvm_ad_rgb')\n"
        "print(mi.load_file('scenes_xml/tir.xml').integrator().__class__.__name__)\n")
    for first, second in (("; import whitted", ""), ("", "import whitted\n")):
        result = subprocess.run([sys.executable, "-c", program.format(first=first, second=second)],
                                cwd=REPO, capture_output=True, text=True, timeout=120)
        lines = result.stdout.splitlines()
        assert result.returncode == 0, result.stderr
        assert 'plugin of type "whitted"' in lines[0] and "tir.xml (line" in lines[0]
        assert "'whitted' integrator does not run in Mitsuba's variant llvm_ad_spectral" in lines[1]
        assert "llvm_ad_rgb" in lines[1]
        assert "'article' BSDF does not run in Mitsuba's variant llvm_ad_spectral" in lines[3]
        assert lines[4] == "WhittedIntegrator"


#: an edit of scenes_xml/tir.xml that a plugin refuses when the scene loads -> the XML object
#: it is in and the words of the plugin's message
BAD_XML = {
    "integrator": (('name="max_depth" value="10"', 'name="max_depth" value="0"'), "<integrator ", "max_depth"),
    "bsdf": (('name="reflect" value="0.05"', 'name="reflect" value="1.5"'),   # line 19: "# the glass ball"
             '<bsdf type="article" id="material_l19_the_glass_ball"', "reflect"),
}


@pytest.mark.parametrize("case", BAD_XML)
def test_a_plugin_s_load_error_is_one_clear_line(case, tmp_path, capsys):
    """Mitsuba wraps a plugin's exception as ``At FILE (line N, col M): failed to instantiate
    ...: Traceback (most recent call last):`` with the message eight lines later: whitted
    render prints that message as FILE:LINE: message, one line, and writes nothing;
    whitted.load_scene raises it as a WhittedError."""
    from whitted.cli import main
    (old, new), element, word = BAD_XML[case]
    text = (REPO / "scenes_xml" / "tir.xml").read_text(encoding="utf-8")
    assert text.count(old) == 1
    xml = tmp_path / "bad.xml"
    xml.write_text(text.replace(old, new), encoding="utf-8")
    line = next(n for n, row in enumerate(text.splitlines(), 1) if element in row)
    assert main(["render", str(xml), "-o", str(tmp_path / "out.png"), "-q"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"whitted: error: {xml}:{line}: ") and word in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.xml"]
    with pytest.raises(whitted.WhittedError) as caught:
        whitted.load_scene(xml)
    assert f"whitted: error: {caught.value}\n" == err


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_large_seeds_render(variant, integrator):
    """whitted.render takes any seed up to 2^64 - 1, folded to Mitsuba's 32 bits: seeds below
    2^32 unchanged, larger ones distinct; a negative seed is refused in one line."""
    loaded = scene()
    spp = 4
    small = whitted.render(loaded, integrator=integrator, spp=spp, seed=5).image
    # (the same seed, the same samples; Mitsuba's scalar path tracer may add in another order)
    np.testing.assert_allclose(whitted.render(loaded, integrator=integrator, spp=spp,
                                              seed=whitted_seed(5)).image, small, rtol=1e-5, atol=1e-7)
    large = whitted.render(loaded, integrator=integrator, spp=spp, seed=2 ** 33 + 5).image
    assert np.isfinite(large).all() and np.abs(large - small).max() > 1e-3
    with pytest.raises(whitted.WhittedError, match="seed must be an integer from 0 to 2"):
        whitted.render(loaded, integrator=integrator, seed=-1)


def whitted_seed(seed: int) -> int:
    from whitted.defaults import check_seed
    return check_seed(seed)


def test_the_integrator_takes_a_large_seed_itself(llvm):
    loaded = scene()
    image = loaded.integrator().render(loaded, seed=2 ** 33, spp=4)
    assert np.isfinite(np.array(image)).all()


def test_seed_folding():
    from whitted.defaults import SEED_STRIDE, check_seed
    assert [check_seed(s) for s in (0, 1, 2 ** 32 - 1)] == [0, 1, 2 ** 32 - 1]
    assert check_seed(2 ** 32) == SEED_STRIDE
    assert len({check_seed(2 ** 32 * k + 7) for k in range(100)}) == 100
    for bad in (-1, 2 ** 64, 1.5, "3"):
        with pytest.raises(whitted.WhittedError):
            check_seed(bad)


def test_render_names_what_it_got_instead_of_a_scene(llvm, tmp_path):
    """whitted.render of a path, of None or of a scene loaded in another variant is one
    WhittedError saying so, not an AttributeError or Mitsuba's TypeError from deep inside."""
    path = tmp_path / "ball.scn"
    path.write_text("size 4 3\nlight 0 5 5\nsphere 0 0 0 1\n")
    for wrong in (str(path), None):
        with pytest.raises(whitted.WhittedError, match="render takes a mi.Scene"):
            whitted.render(wrong)
    whitted.set_variant("scalar_rgb")
    loaded = whitted.load_scene(path)
    whitted.set_variant("llvm_ad_rgb")
    with pytest.raises(whitted.WhittedError, match="another Mitsuba variant"):
        whitted.render(loaded)
