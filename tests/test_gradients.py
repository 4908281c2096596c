"""Gradients of the whitted integrator (issue 33): ``mi.render(scene, params)`` then
``dr.backward`` / ``dr.forward`` in llvm_ad_rgb, checked per parameter kind against central
finite differences of the same deterministic renders (plain renders, no AD), on a small
scene with shadows, glass, mirrors and a texture.

The loss is ``Σ W·image`` with a fixed random weight image W; a parameter is moved along a
fixed random direction D (its derivative along D is ``Σ D·grad`` backwards, ``Σ W·dimage``
forwards)."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import whitted
from conftest import MIRROR_AND_GLASS, REPO
from whitted.converter import parse_text, scene_to_xml
from whitted.errors import WhittedError

#: shadows (two lights, four spheres on a floor), a mirror, a glass ball, a textured globe
SCENE = "size 32 24\n" + MIRROR_AND_GLASS + "sphere 0 0.5 1 0.5        texture earth.png  reflect 0.1\n"


def line_of(fragment: str) -> int:
    """The line of SCENE that holds ``fragment``: the converter names spheres and materials by it."""
    return next(n for n, row in enumerate(SCENE.splitlines(), 1) if fragment in row)


FLOOR, MIRROR, GLASS, GLOBE = (f"l{line_of(f)}" for f in ("1000 ", "reflect 0.6", "refract 0.7", "texture"))

#: (parameter, finite-difference step): one per kind
KINDS = [
    (f"material_{MIRROR}.color.value", 1e-2),   # an article color
    (f"material_{GLOBE}.color.data", 1e-2),     # a bitmap texture's texels
    (f"material_{MIRROR}.reflect", 1e-3),       # KR (a mirror)
    (f"material_{GLASS}.refract", 1e-3),        # KT (glass)
    ("integrator.ambient", 1e-2),            # the ambient coefficient
    ("light_1.intensity.value", 1e-1),       # a light's intensity
    ("light_0.position", 2e-3),              # a light's position (shadows held fixed)
    ("background.radiance.value", 1e-2),     # the background
]


def load(without: str = "", **overrides):
    whitted.set_variant("llvm_ad_rgb")
    # Mitsuba keeps an 8-bit image's texels as 8-bit integers (format "auto"), which carry
    # no gradient: a texture to differentiate is stored as floats (format "variant").
    xml = scene_to_xml(parse_text(SCENE, REPO / "scenes" / "test.scn"), base_dir=None)
    if without:
        xml = xml.replace('<integrator type="whitted">',
                          f'<integrator type="whitted">\n<string name="without" value="{without}"/>')
    xml = xml.replace('<string name="filename" value="', '<string name="format" value="variant"/>\n'
                      '<string name="filename" value="')
    scene = mi.load_string(xml, **overrides)
    assert isinstance(mi.traverse(scene)[f"material_{GLOBE}.color.data"], mi.TensorXf)
    params = mi.traverse(scene)
    params["integrator.min_weight"] = 0.0   # the exact tree: no culling that a step could flip
    params.update()
    return scene


@pytest.fixture(scope="module")
def scene():
    return load()


@pytest.fixture(scope="module")
def physical_scene():
    """Physical lighting: the lights' intensities fall off as 1/r² from their positions."""
    return load(lighting="physical")


def as_numpy(value) -> np.ndarray:
    return np.array(value, np.float64)


def write(params, key, value: np.ndarray) -> None:
    current = params[key]
    if isinstance(current, mi.TensorXf):
        params[key] = mi.TensorXf(value.astype(np.float32))
    else:
        params[key] = type(current)(value.astype(np.float64 if isinstance(current, mi.Float64) else np.float32))
    params.update()


def loss(image, weights) -> float:
    return float(np.sum(np.array(image, np.float64) * weights))


def finite_difference(scene, key, step, direction, weights) -> float:
    params = mi.traverse(scene)
    base = as_numpy(params[key])
    try:
        write(params, key, base + step * direction)
        plus = loss(mi.render(scene), weights)
        write(params, key, base - step * direction)
        minus = loss(mi.render(scene), weights)
    finally:
        write(params, key, base)
    return (plus - minus) / (2 * step)


def setup(scene, key):
    rng = np.random.default_rng(sum(map(ord, key)))
    params = mi.traverse(scene)
    direction = rng.uniform(0.5, 1.0, as_numpy(params[key]).shape)
    weights = rng.uniform(0.0, 1.0, (24, 32, 3))
    return params, direction, weights


def moved(params, key, direction):
    """Set ``key`` to its value plus ``θ·direction``, θ a Dr.Jit Float at 0 with gradients on
    (Mitsuba's own tests' way): θ's gradient is the derivative along ``direction``."""
    current = params[key]
    base = as_numpy(current)
    theta = mi.Float(0.0)
    dr.enable_grad(theta)
    if isinstance(current, mi.TensorXf):
        value = mi.TensorXf(mi.Float(base.ravel().astype(np.float32)) + theta * mi.Float(direction.ravel().astype(np.float32)),
                            base.shape)
    elif isinstance(current, mi.Float64):
        value = mi.Float64(base) + mi.Float64(theta) * mi.Float64(direction)
    else:
        tp = type(current)
        value = tp(base.astype(np.float32)) + theta * tp(direction.astype(np.float32))
    params[key] = value
    params.update()
    return theta, base


def backward_and_finite_difference(scene, key, step) -> tuple[float, float]:
    """The derivative of a weighted sum of the image along a random direction of ``key``:
    by ``dr.backward``, and by central differences of plain renders (``step``)."""
    params, direction, weights = setup(scene, key)
    theta, base = moved(params, key, direction)
    try:
        image = mi.render(scene, params)
        dr.backward(dr.sum(image * mi.TensorXf(weights.astype(np.float32)), axis=None))
        gradient = float(dr.grad(theta)[0])
    finally:
        write(params, key, base)
    return gradient, finite_difference(scene, key, step, direction, weights)


@pytest.mark.parametrize("key,step", KINDS)
def test_backward_gradients_equal_finite_differences(scene, key, step):
    gradient, expected = backward_and_finite_difference(scene, key, step)
    assert abs(expected) > 1e-3, key   # the parameter does change the image
    assert gradient == pytest.approx(expected, rel=0.02), key


@pytest.mark.parametrize("key,step", KINDS)
def test_forward_gradients_equal_finite_differences(scene, key, step):
    params, direction, weights = setup(scene, key)
    theta, base = moved(params, key, direction)
    try:
        image = mi.render(scene, params)
        dr.forward(theta)
        derivative = loss(dr.grad(image), weights)
    finally:
        write(params, key, base)
    expected = finite_difference(scene, key, step, direction, weights)
    assert derivative == pytest.approx(expected, rel=0.02), key


def test_a_gradient_render_leaves_the_plain_render_alone(scene):
    before = np.array(mi.render(scene))
    params = mi.traverse(scene)
    dr.enable_grad(params[f"material_{MIRROR}.color.value"])
    params.update()
    image = mi.render(scene, params)
    dr.backward(image)
    dr.disable_grad(params[f"material_{MIRROR}.color.value"])
    params.update()
    np.testing.assert_array_equal(np.array(image), before)
    np.testing.assert_array_equal(np.array(mi.render(scene)), before)


def test_scalar_refuses_gradients_in_one_line():
    whitted.set_variant("scalar_rgb")
    scene = whitted.loads("size 8 6\nsphere 0 0 0 1\nlight 5 5 5")
    with pytest.raises(WhittedError) as error:
        scene.integrator().render_backward(scene, mi.traverse(scene), mi.TensorXf(np.zeros((6, 8, 3))))
    assert "\n" not in str(error.value) and "scalar_rgb" in str(error.value)
    with pytest.raises(WhittedError, match="render_forward needs gradients"):
        scene.integrator().render_forward(scene, mi.traverse(scene))


@pytest.mark.parametrize("key,step", [("light_1.intensity.value", 10.0), ("light_0.position", 2e-3),
                                      (f"material_{MIRROR}.color.value", 1e-2)])
def test_physical_lighting_gradients_equal_finite_differences(physical_scene, key, step):
    gradient, expected = backward_and_finite_difference(physical_scene, key, step)
    assert abs(expected) > 1e-4, key
    assert gradient == pytest.approx(expected, rel=0.02), key


def test_gradients_of_a_render_without_textures_equal_finite_differences():
    """A textured sphere drawn white (``without=textures``) is white in the gradient render
    too: the ambient's derivative counts its pixels."""
    gradient, expected = backward_and_finite_difference(load(without="textures"),
                                                        "integrator.ambient", 1e-2)
    assert gradient == pytest.approx(expected, rel=0.02)


def named(capfd, key) -> list[str]:
    out = capfd.readouterr()
    return [line for line in (out.out + out.err).splitlines() if f"'{key}'" in line]


def test_a_parameter_the_integrator_does_not_differentiate_is_named_once(capfd):
    """A sphere's ``to_world`` (its position, its radius) gets no gradient from the whitted
    integrator, which holds visibility fixed, nor does the IOR: a gradient render says so
    once per parameter, backward or forward, and points to Mitsuba's ``prb_projective`` for
    geometry; a parameter it differentiates is not named."""
    scene = load()
    params = mi.traverse(scene)
    thetas = [mi.Float(0.0), mi.Float(0.0)]
    for theta, key in zip(thetas, (f"sphere_{GLASS}.to_world", f"sphere_{MIRROR}.to_world")):
        dr.enable_grad(theta)
        params[key] = mi.Transform4f().translate(mi.Vector3f(theta, 0, 0)) @ params[key]
    for key in (f"material_{GLASS}.ior", *(key for key, _ in KINDS)):
        dr.enable_grad(params[key])
    params.update()
    capfd.readouterr()
    for _ in range(2):
        dr.backward(dr.sum(mi.render(scene, params), axis=None))
    assert dr.grad(thetas[0])[0] == 0   # (finite differences: about 1e-2)
    out = capfd.readouterr()
    lines = (out.out + out.err).splitlines()
    for key in (f"sphere_{GLASS}.to_world", f"sphere_{MIRROR}.to_world", f"material_{GLASS}.ior"):
        assert len([line for line in lines if f"'{key}'" in line]) == 1, (key, lines)
    geometry = next(line for line in lines if f"'sphere_{GLASS}.to_world'" in line)
    assert "prb_projective" in geometry and "not differentiated" in geometry
    assert not [line for line in lines if any(f"'{key}'" in line for key, _ in KINDS)]

    # forward: a parameter not named before is named, once
    theta = mi.Float(0.0)
    dr.enable_grad(theta)
    key = f"sphere_{FLOOR}.to_world"
    params[key] = mi.Transform4f().translate(mi.Vector3f(0, theta, 0)) @ params[key]
    params.update()
    capfd.readouterr()
    for _ in range(2):
        image = mi.render(scene, params)
        dr.forward(theta)
    assert dr.all(dr.grad(image) == 0, axis=None)
    assert len(named(capfd, key)) == 1
