"""The plugins' class docstrings (Mitsuba's plugin-doc format) against what the plugins do.

Each docstring has a ``.. pluginparameters::`` table whose descriptions end in
``(Default: …)``; the integrator's XML and Python examples, a scene, show both plugins.
The defaults must be whitted.defaults' values (the one home of every default) and the
plugins' own, and the examples must load and set what they say.
"""

from __future__ import annotations

import ast
import re
from fractions import Fraction

import drjit as dr
import mitsuba as mi
import pytest

import whitted
from whitted import defaults as D

from conftest import VARIANTS


def plugin_class(name: str):
    from whitted.plugins.integrator import WhittedIntegrator
    from whitted.plugins.bsdf import ArticleBSDF
    return {"whitted": WhittedIntegrator, "article": ArticleBSDF}[name]


def parameters(doc: str) -> dict:
    """``{name: (type, description)}`` of the docstring's ``.. pluginparameters::`` table."""
    lines = doc.split(".. pluginparameters::", 1)[1].splitlines()[1:]
    entries, cells = {}, None
    for line in lines:
        text = line.strip()
        if text and not re.match(r"^ {4,}(\* )?- |^ {7,}\S", line):
            break   # the first line of prose after the table
        if text.startswith("* - "):
            cells = [text[4:]]
            entries[cells[0]] = cells
        elif text.startswith("- "):
            cells.append(text[2:])
        elif text:
            cells[-1] += " " + text
    return {name: (cells[1], cells[2]) for name, cells in entries.items()}


def documented_default(description: str):
    match = re.search(r"\(Default: (.*?)\)$", description)
    assert match, f"no '(Default: …)' at the end of {description!r}"
    text = match.group(1)
    if "," in text:
        return tuple(float(x) for x in text.split(","))
    try:
        return float(Fraction(text))
    except ValueError:
        return text


def example(doc: str, language: str) -> str:
    """The body of the docstring's ``.. code-tab:: LANGUAGE`` block, dedented."""
    block = doc.split(f".. code-tab:: {language}", 1)[1]
    body = []
    for line in block.splitlines()[1:]:
        if line.strip().startswith(":name:"):
            continue
        if line.strip() and len(line) - len(line.lstrip()) <= 8:
            break
        body.append(line)
    indent = min(len(line) - len(line.lstrip()) for line in body if line.strip())
    return "\n".join(line[indent:] for line in body).strip()


#: plugin -> parameter -> its default in whitted.defaults
DEFAULTS = {
    "whitted": {"max_depth": D.DEPTH, "ambient": D.AMBIENT, "lighting": D.LIGHTING,
                "light_reference": D.LOOKAT, "min_weight": D.MIN_WEIGHT,
                "wavefront_size": D.WAVEFRONT_SIZE, "exact_spheres": "none", "hide_emitters": "false",
                "without": "none"},
    "article": {"color": D.COLOR, "reflect": D.REFLECT, "refract": D.REFRACT, "ior": D.IOR},
}


def plugin_values(plugin) -> dict:
    """The parameters as the plugin holds them."""
    if hasattr(plugin, "light_reference"):
        return {"max_depth": plugin.max_depth, "ambient": plugin.ambient, "lighting": plugin.lighting,
                "light_reference": tuple(float(x) for x in plugin.light_reference),
                "min_weight": plugin.min_weight, "wavefront_size": plugin.wavefront_size,
                "exact_spheres": "; ".join(key for key, _, _ in plugin.exact_spheres) or "none",
                "hide_emitters": str(bool(plugin.hide_emitters)).lower(),
                "without": ",".join(plugin.without) or "none"}
    color = plugin.color.eval(dr.zeros(mi.SurfaceInteraction3f))
    return {"color": tuple(float(dr.ravel(c)[0]) for c in color), "reflect": plugin.reflect,
            "refract": plugin.refract, "ior": plugin.ior}


def assert_values(got: dict, expected: dict):
    for key, value in expected.items():
        assert got[key] == (value if isinstance(value, str) else pytest.approx(value)), key


@pytest.mark.parametrize("name", DEFAULTS)
def test_the_table_quotes_the_project_defaults(llvm, name):
    table = parameters(plugin_class(name).__doc__)
    assert set(table) == set(DEFAULTS[name])
    for parameter, (tp, description) in table.items():
        assert tp.startswith("|"), parameter
        assert documented_default(description) == pytest.approx(DEFAULTS[name][parameter]), parameter


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("name", DEFAULTS)
def test_the_plugin_has_the_documented_defaults(variant, name):
    plugin = mi.load_dict({"type": name})
    table = parameters(plugin_class(name).__doc__)
    for parameter, value in plugin_values(plugin).items():
        assert value == pytest.approx(documented_default(table[parameter][1])), parameter


def xml_value(text: str):
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        numbers = tuple(float(p) for p in parts)
    except ValueError:
        return text
    return numbers if len(numbers) > 1 else numbers[0]


@pytest.mark.parametrize("name", DEFAULTS)
def test_the_examples_load_and_set_what_they_say(llvm, name):
    doc = plugin_class("whitted").__doc__   # one scene shows both plugins
    scene_xml = example(doc, "xml")
    tag = "integrator" if name == "whitted" else "bsdf"
    xml = re.search(rf'<{tag} type="{name}">.*?</{tag}>', scene_xml, re.S).group(0)
    said = {key: xml_value(value) for key, value in re.findall(r'name="(\w+)" value="([^"]*)"', xml)}
    assert said

    def plugin(scene):
        return scene.integrator() if name == "whitted" else scene.shapes()[0].bsdf()
    from_xml = plugin(mi.load_string(scene_xml))
    from_dict = plugin(mi.load_dict(ast.literal_eval("{" + example(doc, "python") + "}")))
    assert_values(plugin_values(from_xml), said)
    assert_values(plugin_values(from_dict), plugin_values(from_xml))
