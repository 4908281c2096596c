"""Translation and scale invariance: the article's model has no length scale and no
preferred origin, so the same scene moved by 10^4 or scaled by 10^-3 (eye, lights,
centres and radii alike) must give the same image, in both variants.

"The same" is the hazard suite's threshold (mean absolute difference <= 0.004, at most
1% of pixels off by more than 0.02) against the untransformed render of the same
variant, and against the float64 reference of the transformed scene.
"""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
from reference import assert_matches
import whitted
import whitted.rendering
from conftest import VARIANTS
from reference import render_reference
from whitted.converter import scene_to_xml

SCENES = ["mirror_and_glass", "camera_inside", "touching_and_nested", "light_on_surface", "light_on_floor",
          "texture_poles", "facing_mirrors"]
TRANSFORMS = {"moved by 1e4": dict(offset=(1e4, -1e4, 1e4)), "scaled by 1e-3": dict(scale=1e-3)}


def model(name: str, tmp_dir):
    builder = getattr(hs, name)
    return builder(tmp_dir) if name == "texture_poles" else builder()


def render(scene, variant: str) -> np.ndarray:
    previous = mi.variant()
    whitted.set_variant(variant)
    try:
        return whitted.render(mi.load_string(scene_to_xml(scene, base_dir=None))).image
    finally:
        whitted.set_variant(previous)


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    tmp_dir = tmp_path_factory.mktemp("invariance")
    cache = {}

    def get(name: str, variant: str):
        if (name, variant) not in cache:
            cache[(name, variant)] = render(model(name, tmp_dir), variant)
        return cache[(name, variant)]
    get.tmp_dir = tmp_dir
    return get


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("transform", list(TRANSFORMS))
@pytest.mark.parametrize("name", SCENES)
def test_same_image_after_moving_or_scaling(originals, name, transform, variant):
    scene = hs.transformed(model(name, originals.tmp_dir), **TRANSFORMS[transform])
    image = render(scene, variant)
    assert_matches(image, originals(name, variant).astype(np.float64))
    assert_matches(image, render_reference(scene))


@pytest.mark.parametrize("variant", VARIANTS)
def test_beyond_1e4_the_image_stays_finite_and_close(variant):
    """At 10^5 a float32 coordinate steps by 0.008 and the ray offsets grow to ~0.02 (a
    unit sphere's surface is only known that well): edges move, so single pixels may
    differ, but nothing becomes NaN, acne or noise (docs/numerics.md, "Scenes far from the
    origin")."""
    scene = hs.transformed(hs.mirror_and_glass(), offset=(1e5, 1e5, 1e5))
    image = render(scene, variant)
    assert_matches(image, render_reference(scene), outliers=0.05)
