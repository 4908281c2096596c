"""Where the whitted integrator's camera rays start (issue 28): a thin lens's depth of
field, the sampler's type and seed, the film's ``sample_border``: honoured where
spp > 1, checked against Mitsuba's ``path`` integrator on the same scene; one sample per
pixel keeps the pixel-centre rule of the scene format, and says what that leaves unused."""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

#: spp of the converging renders, per variant (the scalar variant is a Python loop per sample)
HIGH = {"llvm_ad_rgb": 256, "scalar_rgb": 48}
SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler")


def scene(sensor="perspective", sampler="independent", spp=4, aperture=2.0, rfilter="box",
          sample_border=False, background=False):
    """Two diffuse balls, one in focus (at 6) and one behind it, physical lighting: what
    Mitsuba's ``path`` with max_depth 2 computes too (when there is no background)."""
    camera = {"type": sensor, "fov": 40,
              "to_world": mi.ScalarTransform4f().look_at(origin=[0, 1, 6], target=[0, 0, 0], up=[0, 1, 0]),
              "film": {"type": "hdrfilm", "width": 24, "height": 16, "rfilter": {"type": rfilter},
                       "sample_border": sample_border},
              "sampler": {"type": sampler, "sample_count": spp}}
    if sensor == "thinlens":
        camera.update(aperture_radius=aperture, focus_distance=6.08)
    description = {
        "type": "scene", "integrator": {"type": "whitted", "max_depth": 1, "lighting": "physical"},
        "sensor": camera,
        "near": {"type": "sphere", "radius": 1.4,
                 "bsdf": {"type": "article", "color": {"type": "rgb", "value": [0.9, 0.3, 0.2]}}},
        "far": {"type": "sphere", "center": [1.8, 0.3, -4], "radius": 1.2, "bsdf": {"type": "article"}},
        "light": {"type": "point", "position": [2, 4, 4], "intensity": {"type": "rgb", "value": [300, 300, 300]}},
    }
    if background:
        description["background"] = {"type": "constant", "radiance": {"type": "rgb", "value": [0.1, 0.2, 0.5]}}
    return mi.load_dict(description)


def whitted(loaded, spp=None, seed=0):
    return np.array(mi.render(loaded, spp=spp or 0, seed=seed))


def path(loaded, spp, seed=0):
    return np.array(mi.render(loaded, integrator=mi.load_dict({"type": "path", "max_depth": 2}),
                              spp=spp, seed=seed))


def blocks(image, size=4):
    """The image's means over ``size``×``size`` blocks: differences of models, not of noise."""
    h, w, c = image.shape
    return image[:h // size * size, :w // size * size].reshape(h // size, size, w // size, size, c).mean(axis=(1, 3))


def test_thin_lens_depth_of_field_matches_path(variant):
    """Depth of field as ``path`` renders it: whitted's lens image is path's within the
    noise between two of path's own renders (other seeds), and the lens changes the image
    as it changes path's."""
    spp = HIGH[variant]
    pinhole, lens = scene(spp=spp), scene("thinlens", spp=spp)
    w_pin, w_lens = whitted(pinhole), whitted(lens)
    p_pin, p_lens = path(pinhole, spp), path(lens, spp)
    noise = np.abs(blocks(path(lens, spp, seed=1)) - blocks(p_lens)).mean()
    assert np.abs(blocks(w_lens) - blocks(p_lens)).mean() < 1.5 * noise
    blur_whitted = np.abs(blocks(w_lens) - blocks(w_pin)).mean()
    blur_path = np.abs(blocks(p_lens) - blocks(p_pin)).mean()
    assert blur_whitted > 3 * noise
    assert abs(blur_whitted - blur_path) < 3 * noise


def test_a_pinhole_has_no_lens_code_and_one_spp_keeps_the_centres(variant, monkeypatch):
    """A perspective camera never draws a lens sample; a thin lens at 1 spp renders through
    its center (the pinhole image, exactly), and a seed changes nothing there."""
    from whitted.plugins import film
    called = []
    original = film.lens_offset
    monkeypatch.setattr(film, "lens_offset", lambda *a: called.append(1) or original(*a))
    whitted(scene(spp=4))
    assert not called
    whitted(scene("thinlens", spp=4))
    assert called
    pinhole = whitted(scene(spp=1))
    # (the thin lens computes its rays its own way: the same to float32 rounding)
    np.testing.assert_allclose(whitted(scene("thinlens", spp=1)), pinhole, rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(whitted(scene(spp=1), seed=7), pinhole)
    np.testing.assert_array_equal(whitted(scene(sampler="stratified", spp=1), seed=9), pinhole)


def test_one_spp_says_what_it_leaves_unused(variant, capfd):
    whitted(scene("thinlens", sampler="stratified", spp=1), seed=9)
    out = capfd.readouterr()
    line = next(line for line in (out.out + out.err).splitlines() if "whitted: at 1 sample" in line)
    for word in ("pixel's center", "seed 9", "thin lens's aperture", "StratifiedSampler", "spp > 1"):
        assert word in line
    assert "StratifiedSampler change nothing" in line
    whitted(scene(spp=1), seed=5)
    out = capfd.readouterr()
    line = next(line for line in (out.out + out.err).splitlines() if "whitted: at 1 sample" in line)
    assert "the seed 5 changes nothing" in line


@pytest.mark.parametrize("sampler", SAMPLERS[1:])
def test_sampler_types_are_used_and_converge(variant, sampler):
    """Each sampler type draws its own samples (images differ at 4 spp, and with the seed)
    and converges to the image every other type converges to."""
    few_independent = whitted(scene(spp=4))
    few = whitted(scene(sampler=sampler, spp=4))
    assert not np.array_equal(few, few_independent)
    assert not np.array_equal(whitted(scene(sampler=sampler, spp=4), seed=5), few)
    spp = HIGH[variant]
    reference = blocks(path(scene(spp=spp), spp))
    noise = np.abs(blocks(path(scene(spp=spp), spp, seed=1)) - reference).mean()
    converged = blocks(whitted(scene(sampler=sampler, spp=spp)))
    assert np.abs(converged - reference).mean() < 1.5 * noise
    assert np.abs(blocks(few) - reference).mean() > np.abs(converged - reference).mean()


@pytest.mark.parametrize("sampler,asked,taken", [("stratified", 8, 9), ("orthogonal", 16, 25), ("ldsampler", 1, 4)])
def test_a_rounded_sample_count_renders_as_the_sampler_rounds_it(variant, sampler, asked, taken):
    """A sampler that takes only some sample counts (a square, a prime's square, a power of
    two, at least 4) renders the count it rounds the one asked to, as path does: the same
    image as asking for that count, and as many camera rays."""
    from whitted.rendering import render
    loaded = scene(sampler=sampler, spp=4)
    image = whitted(loaded, spp=asked)
    np.testing.assert_array_equal(image, whitted(loaded, spp=taken))
    assert not np.array_equal(image, whitted(loaded, spp=4 if taken != 4 else 9))
    assert render(loaded, spp=asked).stats["rays"]["camera"] == 24 * 16 * taken


def test_sample_border_samples_beyond_the_crop_as_path_does(variant):
    """With a wide filter and ``sample_border``, the edge pixels take samples from beyond
    the image, as path's do: closer to path's with it than without."""
    spp = HIGH[variant]
    border = scene(spp=spp, rfilter="gaussian", sample_border=True, background=True)
    plain = scene(spp=spp, rfilter="gaussian", sample_border=False, background=True)
    # the background lights path's diffuse balls too: compare where the rays see it
    expected = path(border, spp)
    w_border, w_plain = whitted(border), whitted(plain)
    edge = np.zeros(w_border.shape[:2], bool)
    edge[:2, :] = edge[-2:, :] = edge[:, :2] = edge[:, -2:] = True
    assert not np.array_equal(w_border[edge], w_plain[edge])
    np.testing.assert_array_equal(w_border.shape, w_plain.shape)
    near = np.abs(w_border - expected)[edge].mean()
    far = np.abs(w_plain - expected)[edge].mean()
    assert near < far
