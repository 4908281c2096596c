"""The Whitted integrator against the float64 reference renderer (tests/float64_reference.py).

Scenes are built with the scene model and converted with the XML writer (no
parser involved), rendered at 1 spp in llvm_ad_rgb and scalar_rgb, and must
match the reference: mean absolute difference <= 0.004, at most 1% of pixels
off by more than 0.02, nothing non-finite. Both variants must also agree with
each other to float32 round-off.
"""

from __future__ import annotations

import dataclasses

import math
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
import whitted.rendering
from float64_reference import Reference, assert_matches, camera_ray, render_reference
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml

from conftest import VARIANTS
W, H = 48, 32


# -- helpers ---------------------------------------------------------------------------------------

def use_variant(variant: str) -> None:
    whitted.set_variant(variant)


def load(model: Scene, variant: str | None = None):
    if variant is not None:
        use_variant(variant)
    return mi.load_string(scene_to_xml(model, base_dir=None))


def render(model: Scene, variant: str, **options) -> np.ndarray:
    return whitted.render(load(model, variant), **options).image


def floor() -> Sphere:
    return Sphere((0.0, -101.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.75)))


def stripes(path, width=15, height=7):
    """An 8-bit sRGB PNG whose texels all differ: R from the column, G from the row."""
    rows, cols = np.mgrid[0:height, 0:width]
    pixels = np.stack([(cols + 0.5) / width, (rows + 0.5) / height, np.full(rows.shape, 0.3)], axis=-1)
    mi.Bitmap((pixels * 255).round().astype(np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
    return path


def scene(name: str, tmp_dir) -> Scene:
    """The scene suite: every effect of the article's model and their combinations."""
    base = dict(width=W, height=H, eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.3, 0.0))
    red = Material(color=(0.9, 0.25, 0.2))
    blue = Material(color=(0.2, 0.35, 0.9))
    green = Material(color=(0.25, 0.85, 0.3))
    if name == "diffuse_shadow":
        return Scene(**base, lights=[Light((3.0, 6.0, 4.0))],
                     spheres=[floor(), Sphere((0.0, 0.5, 0.0), 1.0, red)])
    if name.startswith("ambient_"):
        ambient = float(name.split("_")[1])
        return Scene(**base, ambient=ambient, lights=[Light((-3.0, 5.0, 5.0), (0.9, 0.9, 0.7))],
                     spheres=[floor(), Sphere((0.0, 0.5, 0.0), 1.0, blue)])
    if name == "colored_lights":
        return Scene(**base, ambient=0.1,
                     lights=[Light((-5.0, 4.0, 4.0), (1.0, 0.2, 0.2)), Light((5.0, 4.0, 4.0), (0.2, 1.0, 0.2)),
                             Light((0.0, 8.0, -3.0), (0.3, 0.3, 1.0))],
                     spheres=[floor(), Sphere((-1.2, 0.2, 0.0), 0.8, Material()),
                              Sphere((1.2, 0.2, 0.5), 0.8, Material(color=(0.9, 0.9, 0.5)))])
    if name.startswith("mirror"):
        depth = int(name.split("_")[1]) if "_" in name else 5
        return Scene(**base, depth=depth, ambient=0.15, background=(0.1, 0.1, 0.2),
                     lights=[Light((2.0, 6.0, 6.0))],
                     spheres=[floor(), Sphere((-1.3, 0.6, 0.0), 1.1, Material(color=(0.9, 0.9, 0.9), reflect=0.9)),
                              Sphere((1.3, 0.6, 0.0), 1.1, Material(color=(0.9, 0.8, 0.6), reflect=0.7)),
                              Sphere((0.0, 0.3, 2.0), 0.5, green)])
    if name == "glass":
        return Scene(**base, background=(0.7, 0.8, 0.9), lights=[Light((3.0, 6.0, 6.0))],
                     spheres=[floor(), Sphere((0.0, 0.7, 1.5), 1.0, Material(color=(1, 1, 1), refract=0.9, ior=1.5)),
                              Sphere((-1.5, 0.5, -3.0), 0.8, red), Sphere((1.5, 0.5, -3.0), 0.8, blue)])
    if name == "tir":
        # A glass ball with an air bubble: from inside the glass the bubble's
        # surface totally reflects rays at grazing angles.
        return Scene(**base, depth=8, background=(0.8, 0.85, 0.95), ambient=0.3,
                     lights=[Light((4.0, 8.0, 6.0)), Light((-5.0, 3.0, 5.0), (0.4, 0.4, 0.4))],
                     spheres=[floor(), Sphere((0.0, 0.9, 0.0), 1.4, Material(reflect=0.05, refract=0.9, ior=1.5)),
                              Sphere((0.25, 1.0, 0.3), 0.8, Material(refract=1.0, ior=1 / 1.5)),
                              Sphere((-1.5, 0.6, -3.0), 0.6, red), Sphere((1.5, 0.6, -3.0), 0.6, green)])
    if name == "low_ior":
        # IOR below 1 (a bubble's reading): rays arriving from outside beyond the
        # critical angle are totally reflected; inside, rays bend towards the rim.
        return Scene(**base, depth=6, background=(0.3, 0.3, 0.35),
                     lights=[Light((3.0, 6.0, 6.0))],
                     spheres=[floor(), Sphere((0.0, 0.8, 0.0), 1.3, Material(color=(1, 1, 1), reflect=0.1,
                                                                            refract=0.85, ior=0.6)),
                              Sphere((0.0, 0.5, -3.0), 0.8, red)])
    if name == "texture":
        texture = Material(texture=stripes(tmp_dir / "stripes.png"))
        return Scene(**base, lights=[Light((4.0, 5.0, 6.0))],
                     spheres=[floor(), Sphere((0.0, 0.6, 0.0), 1.3, texture,
                                              north=(0.3, 1.0, 0.4), equator=(1.0, 0.0, 0.2))])
    if name == "background":
        return Scene(**base, background=(0.3, 0.5, 0.7),
                     spheres=[Sphere((0.0, 0.3, 0.0), 1.2, green), Sphere((1.8, 0.0, -1.0), 0.6, red)])
    if name == "no_lights":
        return Scene(**base, ambient=0.6, spheres=[floor(), Sphere((0.0, 0.5, 0.0), 1.0, red)])
    if name == "everything":
        texture = Material(texture=stripes(tmp_dir / "stripes.png"), reflect=0.2)
        return Scene(**base, background=(0.2, 0.25, 0.4), depth=6,
                     lights=[Light((4.0, 6.0, 5.0)), Light((-4.0, 3.0, 6.0), (0.5, 0.3, 0.2))],
                     spheres=[floor(),
                              Sphere((-1.6, 0.6, 0.0), 0.9, texture, north=(0, 0, 1), equator=(1, 0, 0)),
                              Sphere((0.6, 0.7, 1.2), 0.8, Material(color=(0.9, 1, 0.9), reflect=0.15,
                                                                     refract=0.8, ior=1.33)),
                              Sphere((1.8, 0.8, -1.5), 0.9, Material(color=(0.8, 0.6, 0.3), reflect=0.6)),
                              Sphere((0.0, 0.3, -3.5), 0.6, blue)])
    if name == "many_materials":
        rng = np.random.default_rng(7)
        spheres = [Sphere(tuple(map(float, rng.uniform((-4, -2, -6), (4, 3, 0)))), float(rng.uniform(0.15, 0.4)),
                          Material(color=tuple(map(float, rng.uniform(0.05, 1.0, 3)))))
                   for _ in range(150)]
        return Scene(**base, lights=[Light((0.0, 8.0, 8.0))], spheres=spheres)
    raise KeyError(name)


SUITE = ("diffuse_shadow", "ambient_0", "ambient_0.5", "ambient_1", "colored_lights", "mirror",
         "mirror_1", "glass", "tir", "low_ior", "texture", "background", "no_lights", "everything",
         "many_materials")


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """Scenes, their references and renders, computed once per module."""
    tmp_dir = tmp_path_factory.mktemp("suite")
    cache = {}

    def get(name: str, what: str):
        key = (name, what)
        if key not in cache:
            model = scene(name, tmp_dir)
            if what == "model":
                cache[key] = model
            elif what == "reference":
                reference = Reference(model)
                cache[key] = reference.render()
                cache[(name, "tir_events")] = reference.tir_events
            else:
                previous = mi.variant()
                cache[key] = render(model, what)
                whitted.set_variant(previous)
        return cache[key]
    return get


# -- the scene suite ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", SUITE)
def test_matches_the_reference(suite, name, variant):
    assert_matches(suite(name, variant), suite(name, "reference"))


@pytest.mark.parametrize("name", SUITE)
def test_variants_agree(suite, name):
    llvm, scalar = suite(name, "llvm_ad_rgb"), suite(name, "scalar_rgb")
    diff = np.abs(llvm - scalar)
    assert diff.mean() <= 1e-4
    assert (diff.max(axis=2) > 1e-3).mean() <= 0.005


def test_suite_exercises_total_internal_reflection(suite):
    suite("tir", "reference")
    suite("low_ior", "reference")
    assert suite("tir", "tir_events") > 0
    assert suite("low_ior", "tir_events") > 0


def test_depth_changes_the_image(suite):
    """Max depth 1 leaves the mirrors' reflections black; depth 5 fills them in."""
    shallow, deep = suite("mirror_1", "llvm_ad_rgb"), suite("mirror", "llvm_ad_rgb")
    assert np.abs(shallow - deep).max() > 0.2
    assert (deep >= shallow - 1e-6).all()  # deeper trees only add light


def test_ambient_one_without_lights_shows_base_colors(suite):
    model = scene("ambient_1", None)
    image = suite("ambient_1", "llvm_ad_rgb")
    # With A = 1 the point color is B whatever the lights: the sphere's pixels are its color.
    sphere_pixel = image[H // 2 - 2, W // 2]
    np.testing.assert_allclose(sphere_pixel, model.spheres[1].material.color, atol=1e-6)


# -- lighting ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ("diffuse_shadow", "mirror", "colored_lights"))
def test_physical_lighting_matches_the_reference(tmp_path, name, variant):
    model = scene(name, tmp_path)
    expected = render_reference(model, lighting="physical")
    assert_matches(render(model, variant, lighting="physical"), expected)


def test_physical_lighting_has_inverse_square_falloff(tmp_path):
    """Twice the distance to the light, a quarter of the light (no ambient term)."""
    def brightness(distance):
        model = Scene(width=9, height=9, eye=(0, 0, 10), lookat=(0, 0, 0), fov=5,
                      lights=[Light((0.0, 0.0, 1.0 + distance))],
                      spheres=[Sphere((0.0, 0.0, 0.0), 1.0, Material())])
        # the light's color is measured at lookat: keep its intensity fixed instead
        loaded = load(model, "llvm_ad_rgb")
        integrator = mi.load_dict({"type": "whitted", "lighting": "physical",
                                   "light_reference": mi.ScalarPoint3f(0, 0, 0)})
        image = np.array(integrator.render(loaded))
        intensity = math.pi * (1.0 + distance) ** 2
        return image[4, 4, 0] / intensity
    assert brightness(4.0) / brightness(2.0) == pytest.approx((2.0 / 4.0) ** 2, rel=1e-3)


# -- sampling ----------------------------------------------------------------------------------------

def test_camera_is_the_spec_camera():
    """Mitsuba's perspective sensor, as the integrator drives it, gives the spec's rays."""
    from whitted.plugins.film import CameraSamples
    model = Scene(width=37, height=23, eye=(1.0, 2.0, 7.0), lookat=(-0.5, 0.3, -1.0), up=(0.2, 1.0, 0.1),
                  fov=70.0, spheres=[Sphere((0.0, 0.0, 0.0), 1.0)])
    loaded = load(model, "llvm_ad_rgb")
    y, x = np.mgrid[0:model.height, 0:model.width]
    pixel = mi.UInt32((y * model.width + x).ravel())
    camera = CameraSamples(loaded.sensors()[0], spp=1, seed=0)
    ray, _, position = camera.ray(pixel, mi.UInt32(0))
    got = np.array(ray.d).T
    expected = np.array([camera_ray(model, i + 0.5, j + 0.5)[1] for i, j in zip(x.ravel(), y.ravel())])
    np.testing.assert_allclose(got, expected, atol=2e-6)
    eye = np.subtract(model.eye, model.lookat)   # the converter's frame is centered on lookat
    np.testing.assert_allclose(np.array(ray.o).T, np.tile(eye, (x.size, 1)), atol=1e-5)
    np.testing.assert_array_equal(np.array(position).T, np.stack([x.ravel(), y.ravel()], axis=1))


def test_the_seed_moves_the_samples_and_a_render_repeats_bit_for_bit(tmp_path):
    """At several samples per pixel the seed places each sample in its stratum: the same seed
    gives the same image bit for bit, another seed another image of the same scene (at 1 spp
    the one sample sits at the pixel's center whatever the seed: see the test below)."""
    model = dataclasses.replace(scene("glass", tmp_path), samples=4)
    a = render(model, "llvm_ad_rgb", seed=1)
    np.testing.assert_array_equal(render(model, "llvm_ad_rgb", seed=1), a)
    b = render(model, "llvm_ad_rgb", seed=2)
    assert not np.array_equal(a, b)
    assert np.abs(a - b).mean() < 0.02   # other samples of the same pixels, not another scene


@pytest.mark.parametrize("spp", (1, 2, 4, 6, 7, 16))
def test_pixel_samples_are_stratified(spp):
    """Each of the spp samples lies in its own cell of an nx × ny grid covering the pixel."""
    use_variant("llvm_ad_rgb")
    from whitted.plugins.film import pixel_offset, strata
    nx, ny = strata(spp)
    assert nx * ny == spp and nx >= ny
    pixels = np.repeat(np.arange(50), spp)
    samples = np.tile(np.arange(spp), 50)
    offset = np.array(pixel_offset(mi.UInt32(pixels), mi.UInt32(samples), spp, seed=3)).T
    assert np.all((offset >= 0) & (offset < 1))
    if spp == 1:
        np.testing.assert_array_equal(offset, 0.5)
        return
    cells = np.floor(offset[:, 0] * nx) + nx * np.floor(offset[:, 1] * ny)
    for p in range(50):
        assert sorted(cells[pixels == p]) == list(range(spp))
    assert np.std(offset[:, 0] * nx % 1) > 0.2  # jittered, not centered


def test_many_samples_average_over_the_pixel(tmp_path):
    """16 spp approaches the pixel's mean color (reference: an 8 × 8 grid of rays per pixel)."""
    model = scene("everything", tmp_path)
    expected = render_reference(model, subsamples=8)
    image = render(model, "llvm_ad_rgb", spp=16)
    assert_matches(image, expected, mean_tol=0.004, outliers=0.05)
    one = render(model, "llvm_ad_rgb", spp=1)
    assert np.abs(image - expected).mean() < 0.6 * np.abs(one - expected).mean()


def test_scalar_samples_match_llvm_samples(tmp_path):
    model = scene("mirror", tmp_path)
    model.width, model.height = 16, 12
    a = render(model, "llvm_ad_rgb", spp=3, seed=5)
    b = render(model, "scalar_rgb", spp=3, seed=5)
    assert np.abs(a - b).max() < 1e-3


@pytest.mark.parametrize("min_weight", [0.0, 0.05])
def test_passes_and_split_wavefronts_give_the_same_image(tmp_path, monkeypatch, min_weight):
    """Memory is bounded by rendering in passes and splitting wide wavefronts: the image
    must not depend on either, traced exactly or with the adaptive depth control's culling.
    Passes of 63 samples split pixels (2 spp), and a level's children (up to two a ray)
    outgrow them, so the deeper levels are traced a piece at a time."""
    from whitted.plugins.recursion import Wavefronts
    model = scene("everything", tmp_path)
    loaded = load(model, "llvm_ad_rgb")
    settings = {"type": "whitted", "max_depth": 6, "ambient": model.ambient, "min_weight": min_weight,
                "light_reference": mi.ScalarPoint3f(model.lookat)}
    whole = mi.load_dict(settings)
    pieces = mi.load_dict({**settings, "wavefront_size": 63})
    split = []
    in_pieces = Wavefronts._pieces
    monkeypatch.setattr(Wavefronts, "_pieces", lambda self, front, walk: split.append(front.level)
                        or in_pieces(self, front, walk))
    one = whole.render_detailed(loaded, spp=2, seed=4)
    assert not split
    many = pieces.render_detailed(loaded, spp=2, seed=4)
    assert one.passes == 1 and many.passes == math.ceil(W * H * 2 / 63)
    assert split and min(split) == 2
    np.testing.assert_allclose(np.array(many.image), np.array(one.image), atol=1e-6)
    assert many.rays == one.rays
    assert (one.rays.culled > 0) == (min_weight > 0)


# -- Mitsuba's entry points ---------------------------------------------------------------------------

def test_mi_render_uses_the_integrator(suite):
    model = suite("mirror", "model")
    loaded = load(model, "llvm_ad_rgb")
    image = np.array(mi.render(loaded))
    np.testing.assert_array_equal(image, suite("mirror", "llvm_ad_rgb"))


def test_sample_traces_a_whole_tree(suite, variant):
    """``sample()`` (Mitsuba's per-ray entry point) gives a ray's full color."""
    model = suite("glass", "model")
    loaded = load(model, variant)
    integrator = loaded.integrator()
    expected = suite("glass", "reference")
    for i, j in ((W // 2, H // 2 - 3), (5, 5), (30, 20)):
        o, d = camera_ray(model, i + 0.5, j + 0.5)
        o = np.subtract(o, model.lookat)    # world -> the converter's frame (centered on lookat)
        color, valid, aovs = integrator.sample(loaded, None, mi.Ray3f(mi.Point3f(o), mi.Vector3f(d)))
        assert np.abs(np.array(color).ravel() - expected[j, i]).max() < 0.02


@pytest.mark.parametrize("props,message", [({"max_depth": 0}, "max_depth"), ({"ambient": 1.5}, "ambient"),
                                           ({"lighting": "sunny"}, "lighting")])
def test_bad_properties_are_rejected(props, message):
    with pytest.raises(Exception, match=message):
        mi.load_dict({"type": "whitted", **props})


# -- the project's example scenes ----------------------------------------------------------------------

EXAMPLES = sorted((Path(__file__).resolve().parent.parent / "scenes").glob("*.scn"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_scenes_match_the_reference(path, variant):
    """The scenes/ examples (parsed, at a fifth of their size) match the reference."""
    from whitted.converter import parse_file
    model = parse_file(path)
    model.width, model.height = max(1, model.width // 5), max(1, model.height // 5)
    assert_matches(render(model, variant), render_reference(model))


# -- hit geometry: Mitsuba's interaction and the integrator's sphere table -----------------------------

@pytest.mark.parametrize("name", ("everything", "tir", "texture"))
def test_mitsuba_interactions_match_the_sphere_table(suite, name, monkeypatch):
    """In llvm, all-sphere scenes skip Mitsuba's per-shape call (plugins/hits.py); the
    general path through ``scene.ray_intersect`` must give the same image."""
    from functools import partial

    import whitted.plugins.hits as hits
    monkeypatch.setattr(hits, "hit_finder", partial(hits.hit_finder, sphere_table=False))
    general = render(suite(name, "model"), "llvm_ad_rgb")
    assert_matches(general, suite(name, "reference"))
    assert np.abs(general - suite(name, "llvm_ad_rgb")).max() < 1e-3


def test_other_shapes_render_through_mitsubas_interactions(tmp_path):
    """The article's model on any shape Mitsuba knows: a mirror rectangle under a sphere."""
    model = scene("diffuse_shadow", tmp_path)
    rectangle = ('    <shape type="rectangle">\n'
                 '        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/>'
                 '<translate y="-0.6"/></transform>\n'
                 '        <bsdf type="article"><rgb name="color" value="0.3, 0.6, 0.9"/>'
                 '<float name="reflect" value="0.5"/></bsdf>\n    </shape>\n')
    xml = scene_to_xml(dataclasses.replace(model, spheres=model.spheres[1:]), base_dir=None)
    xml = xml.replace("</scene>", rectangle + "</scene>")
    images = {}
    for variant in VARIANTS:
        use_variant(variant)
        result = whitted.render(mi.load_string(xml))
        assert result.stats["rays"]["reflection"] > 0
        images[variant] = result.image
    assert np.all(np.isfinite(images["llvm_ad_rgb"]))
    assert np.abs(images["llvm_ad_rgb"] - images["scalar_rgb"]).mean() < 1e-4
