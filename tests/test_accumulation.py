"""How samples become the image (plugins/film.py): per-pixel means or Mitsuba's film.

A box-filtered RGB film is developed by the integrator itself (each pixel's mean
of its samples); it must give Mitsuba's film's image, which every other film
still develops.
"""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

import whitted
from float64_reference import assert_matches, render_reference
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.plugins.film import FilmSplats, PixelMeans, image_for


def model(depth: int) -> Scene:
    """Diffuse balls (a single-level tree) or, with ``depth`` > 1, a mirror and a glass ball."""
    mirror = Material(color=(0.9, 0.9, 0.9), reflect=0.6) if depth > 1 else Material(color=(0.9, 0.4, 0.3))
    glass = Material(color=(1, 1, 1), refract=0.8, ior=1.5) if depth > 1 else Material(color=(0.3, 0.4, 0.9))
    return Scene(width=36, height=24, eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.3, 0.0), depth=depth,
                 background=(0.2, 0.3, 0.4), lights=[Light((3.0, 6.0, 4.0))],
                 spheres=[Sphere((0.0, -101.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.75))),
                          Sphere((-1.0, 0.6, 0.0), 1.0, mirror), Sphere((1.3, 0.5, 0.8), 0.7, glass)])


def film(pixel_format="rgb", rfilter="box"):
    return mi.load_dict({"type": "hdrfilm", "width": 8, "height": 4, "pixel_format": pixel_format,
                         "rfilter": {"type": rfilter}})


def test_box_filtered_rgb_films_take_the_per_pixel_means(llvm):
    assert isinstance(image_for(film(), 4), PixelMeans)
    for other in (film("rgba"), film("xyz"), film("luminance"), film(rfilter="gaussian")):
        assert isinstance(image_for(other, 4), FilmSplats), other


def test_the_scalar_variant_uses_the_film():
    whitted.set_variant("scalar_rgb")
    assert isinstance(image_for(film(), 4), FilmSplats)


@pytest.mark.parametrize("depth", [1, 4])
@pytest.mark.parametrize("spp,wavefront_size", [(1, 0), (3, 0), (4, 0), (3, 50), (4, 96)])
def test_per_pixel_means_are_the_films_image(llvm, monkeypatch, depth, spp, wavefront_size):
    """The same render through PixelMeans and through Mitsuba's film (odd spp, passes that
    split pixels, one- and many-level trees): equal up to the order of the additions."""
    scene = mi.load_string(scene_to_xml(model(depth), base_dir=None))
    integrator = mi.load_dict({"type": "whitted", "max_depth": depth, "wavefront_size": wavefront_size,
                               "light_reference": mi.ScalarPoint3f(model(depth).lookat)})
    means = integrator.render_detailed(scene, spp=spp, seed=3)
    monkeypatch.setattr(PixelMeans, "applies", staticmethod(lambda film: False))
    splats = integrator.render_detailed(scene, spp=spp, seed=3)
    assert means.image.shape == splats.image.shape == (24, 36, 3)
    np.testing.assert_allclose(np.array(means.image), np.array(splats.image), rtol=1e-6, atol=1e-7)
    assert means.rays == splats.rays
    if spp == 1:
        np.testing.assert_array_equal(np.array(means.image), np.array(splats.image))


def test_other_films_still_develop_through_mitsuba(llvm):
    """An RGBA film (no per-pixel means) gives the same colors plus an alpha of 1."""
    xml = scene_to_xml(model(1), base_dir=None)
    rgb = np.array(mi.render(mi.load_string(xml)))
    rgba = np.array(mi.render(mi.load_string(xml.replace('value="rgb"', 'value="rgba"'))))
    assert rgba.shape == rgb.shape[:2] + (4,)
    np.testing.assert_allclose(rgba[..., :3], rgb, atol=1e-6)
    np.testing.assert_array_equal(rgba[..., 3], 1.0)


def test_means_match_the_reference(llvm):
    scene_model = model(4)
    assert_matches(whitted.render(mi.load_string(scene_to_xml(scene_model, base_dir=None))).image,
                   render_reference(scene_model))


@pytest.mark.parametrize("depth", [1, 4])
@pytest.mark.parametrize("spp", [1, 4])
def test_the_image_is_cleared_in_bands_that_ctrl_c_can_stop_between(llvm, monkeypatch, depth, spp):
    """A render clears its image in kernels of at most CLEAR_BAND values, never in one
    memset of the whole image (3 GiB at 16384², seconds during which Ctrl-C waited), and
    not at all where every value is stored once; the image is the film's all the same."""
    import drjit as dr
    from whitted.plugins import film
    monkeypatch.setattr(film, "CLEAR_BAND", 89)   # 36 * 24 * 3 = 29 * 89 + 11 values
    scene = mi.load_string(scene_to_xml(model(depth), base_dir=None))
    integrator = mi.load_dict({"type": "whitted", "max_depth": depth,
                               "light_reference": mi.ScalarPoint3f(model(depth).lookat)})
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history_clear()
        means = integrator.render_detailed(scene, spp=spp, seed=3)
        history = dr.kernel_history()
    whole_image = [k for k in history if k["type"] == dr.KernelType.Memset and k["size"] == 36 * 24 * 3 * 4]
    bands = [k for k in history if k["type"] == dr.KernelType.JIT and k["size"] in (89, 11)]
    assert not whole_image
    if spp > 1:
        assert len(bands) >= 30
    else:
        assert len(bands) < 30
    monkeypatch.setattr(PixelMeans, "applies", staticmethod(lambda film: False))
    splats = integrator.render_detailed(scene, spp=spp, seed=3)
    np.testing.assert_allclose(np.array(means.image), np.array(splats.image), rtol=1e-6, atol=1e-7)
