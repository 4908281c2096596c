"""What a Mitsuba user touches around the whitted integrator (issue 28): the film holds the
render, ``hide_emitters`` hides the background as Mitsuba's own integrators do.

The expectations are Mitsuba's: the image ``mi.render`` returned, and the ``path``
integrator's alpha channel on the same scene.
"""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

BACKGROUND = [0.2, 0.3, 0.4]


def scene(pixel_format="rgb", rfilter="box", spp=1, hide=None, background=True, crop=False):
    """A reflective ball in front of the background (or none), seen by a 16×12 film."""
    integrator = {"type": "whitted", "max_depth": 3}
    if hide is not None:
        integrator["hide_emitters"] = hide
    film = {"type": "hdrfilm", "width": 16, "height": 12, "pixel_format": pixel_format,
            "rfilter": {"type": rfilter}, "component_format": "float32"}
    if crop:
        film.update(crop_offset_x=3, crop_offset_y=2, crop_width=9, crop_height=7)
    description = {
        "type": "scene", "integrator": integrator,
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": film, "sampler": {"type": "independent", "sample_count": spp}},
        "ball": {"type": "sphere", "bsdf": {"type": "article", "color": {"type": "rgb", "value": [0.9, 0.5, 0.3]},
                                            "reflect": 0.4}},
        "floor": {"type": "sphere", "center": [0, -101.2, 0], "radius": 100,
                  "bsdf": {"type": "article", "reflect": 0.3}},
        "light": {"type": "point", "position": [2, 4, 4], "intensity": {"type": "rgb", "value": [40, 40, 40]}},
    }
    if background:
        description["background"] = {"type": "constant", "radiance": {"type": "rgb", "value": BACKGROUND}}
    return mi.load_dict(description)


# -- the film holds the render ------------------------------------------------------------------

@pytest.mark.parametrize("pixel_format,rfilter,crop", [("rgb", "box", False), ("rgb", "box", True),
                                                       ("rgba", "box", False), ("rgb", "gaussian", False)])
@pytest.mark.parametrize("spp", [1, 4])
def test_the_film_develops_to_the_rendered_image(variant, tmp_path, pixel_format, rfilter, crop, spp):
    """After ``mi.render`` the film's bitmap, develop() and written file are the image the
    render returned, even when another integrator rendered on that film just before."""
    loaded = scene(pixel_format, rfilter, spp, crop=crop)
    film = loaded.sensors()[0].film()
    mi.render(loaded, integrator=mi.load_dict({"type": "path"}))   # leaves its own image on the film
    image = np.array(mi.render(loaded))
    assert image.shape[:2] == tuple(int(c) for c in film.crop_size())[::-1]
    np.testing.assert_array_equal(np.array(film.develop()), image)
    # Mitsuba's bitmap() divides by the weights its own way (on the CPU): exact where every
    # weight is 1 (a box filter), within an ulp elsewhere, for every integrator alike.
    exact = rfilter == "box"
    same = np.testing.assert_array_equal if exact else \
        (lambda a, b: np.testing.assert_allclose(a, b, rtol=3e-7, atol=1e-7))
    same(np.array(film.bitmap()), image)
    film.write(str(tmp_path / "film.exr"))
    same(np.array(mi.Bitmap(str(tmp_path / "film.exr"))), image)


def test_the_film_is_not_read_unless_asked(llvm):
    """Handing the image to the film costs no kernel unless the film is read: no kernel of
    the render is as wide as the film's storage (4 values a pixel), reading it runs one."""
    import drjit as dr
    loaded = scene(spp=2)
    storage = 4 * 16 * 12   # (the render's kernels are 2 * 16 * 12 samples wide)
    mi.render(loaded)   # compiles
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history_clear()
        mi.render(loaded)
        rendered = [k.get("size") for k in dr.kernel_history()]
        dr.kernel_history_clear()
        loaded.sensors()[0].film().bitmap()
        read = [k.get("size") for k in dr.kernel_history()]
    assert storage not in rendered
    assert storage in read


# -- hide_emitters -------------------------------------------------------------------------------

def test_hide_emitters_hides_the_background_and_keeps_its_reflections(variant):
    shown = np.array(mi.render(scene("rgba", hide=False)))
    hidden = np.array(mi.render(scene("rgba", hide=True)))
    corner = (0, 0)   # a pixel that sees the background
    np.testing.assert_allclose(shown[corner], BACKGROUND + [1.0], rtol=1e-6)
    np.testing.assert_array_equal(hidden[corner], [0, 0, 0, 0])
    on_surface = hidden[..., 3] == 1
    assert on_surface.sum() > 20
    # the ball and the floor still reflect the background
    np.testing.assert_array_equal(hidden[on_surface], shown[on_surface])
    np.testing.assert_array_equal(hidden[~on_surface][:, :3], 0.0)


@pytest.mark.parametrize("hide", [False, True])
@pytest.mark.parametrize("background", [False, True])
def test_alpha_is_paths_alpha(variant, hide, background):
    """Alpha is 1 where a camera ray hits a surface or sees the background, as ``path``
    computes it; only silhouette pixels differ, by the noise of where samples fall."""
    spp = 64
    loaded = scene("rgba", spp=spp, hide=hide, background=background)
    whitted_alpha = np.array(mi.render(loaded))[..., 3]
    path = mi.load_dict({"type": "path", "hide_emitters": hide})
    path_alpha = np.array(mi.render(loaded, integrator=path, spp=spp))[..., 3]
    edge = ((path_alpha > 0) & (path_alpha < 1)) | ((whitted_alpha > 0) & (whitted_alpha < 1))
    np.testing.assert_array_equal(whitted_alpha[~edge], path_alpha[~edge])
    assert np.abs(whitted_alpha - path_alpha).max() < 0.25
    if background and not hide:
        assert (whitted_alpha == 1).all()
    else:
        assert (whitted_alpha == 0).sum() > 20 and edge.sum() < 40


# -- the aov integrator ----------------------------------------------------------------------------

@pytest.mark.parametrize("spp", [1, 4])
def test_aov_color_and_aovs_come_from_the_same_rays(variant, spp):
    """Under Mitsuba's ``aov`` integrator the color is of the rays the AOVs describe (not of
    the pixel centres a whitted render takes at 1 spp): with no background and an ambient
    term, a pixel has a color exactly where its depth says a ray hit, silhouettes included."""
    whitted = {"type": "whitted", "max_depth": 3}
    description = {
        "type": "scene", "integrator": {"type": "aov", "aovs": "dd.y:depth", "color": whitted},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 24, "height": 16, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "ball": {"type": "sphere", "bsdf": {"type": "article", "reflect": 0.4}},
        "small": {"type": "sphere", "center": [1.6, 0.5, -1], "radius": 0.5, "bsdf": {"type": "article"}},
        "light": {"type": "point", "position": [2, 4, 4], "intensity": {"type": "rgb", "value": [40, 40, 40]}},
    }
    image = np.array(mi.render(mi.load_dict(description)))
    color, depth = image[..., :3], image[..., 3]
    assert 20 < (depth > 0).sum() < depth.size - 20
    np.testing.assert_array_equal(color.max(axis=-1) > 0, depth > 0)
    # and it is the whitted integrator's color (the scene's lights and materials, as shaded)
    description["integrator"] = whitted
    plain = np.array(mi.render(mi.load_dict(description)))
    assert np.abs(color.mean() - plain.mean()) < 0.05 * plain.mean()
