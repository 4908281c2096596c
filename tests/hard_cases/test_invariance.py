"""Translation and scale invariance: the article's model has no length scale and no
preferred origin, so the same scene moved (up to 10^7) or scaled (eye, lights, centers
and radii alike) must give the same image, in both variants.

"The same" is the hazard suite's threshold (mean absolute difference <= 0.004, at most
1% of pixels off by more than 0.02) against the untransformed render of the same
variant, and against the float64 reference of the transformed scene. Mitsuba stores
the scene in float32: translations beyond 10^4 hold only because the converter writes
positions relative to the scene's lookat (converter/frame.py; docs/numerics.md,
"Scenes far from the origin"). Every hazard scene stays meaningful under every
transform here (the smallest radius, 0.02·10^-4, is above the format's 10^-6).
"""

from __future__ import annotations

import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
import whitted
import whitted.rendering
from float64_reference import assert_matches, render_reference
from whitted.converter import scene_to_xml

SCENES = list(hs.HAZARDS) + ["mirror_and_glass"]
TRANSFORMS = {
    "moved by 1e4": dict(offset=(1e4, -1e4, 1e4)),
    "moved by 1e5": dict(offset=(1e5, -1e5, 1e5)),
    "moved by 1e6": dict(offset=(1e6, -1e6, 1e6)),
    "moved by 1e7": dict(offset=(1e7, -1e7, 1e7)),
    "scaled by 1e-3": dict(scale=1e-3),
    "scaled by 1e-4, moved by 1e2": dict(scale=1e-4, offset=(1e2, -1e2, 1e2)),
}


def model(name: str, tmp_dir):
    return hs.build(name, tmp_dir) if name in hs.HAZARDS else getattr(hs, name)()


def load(scene) -> mi.Scene:
    return mi.load_string(scene_to_xml(scene, base_dir=None))


def render(scene, variant: str, **options) -> np.ndarray:
    previous = mi.variant()
    whitted.set_variant(variant)
    try:
        return whitted.render(load(scene), **options).image
    finally:
        whitted.set_variant(previous)


@pytest.fixture(scope="module")
def cached(tmp_path_factory):
    """``cached(name, transform, what)``: the (transformed) model, its float64 reference
    ("reference") or its render in a variant, each computed once for the module."""
    tmp_dir = tmp_path_factory.mktemp("invariance")
    cache = {}

    def get(name: str, transform: str | None, what: str = "model"):
        key = (name, transform, what)
        if key not in cache:
            if what == "model":
                base = model(name, tmp_dir)
                cache[key] = base if transform is None else hs.transformed(base, **TRANSFORMS[transform])
            elif what == "reference":
                cache[key] = render_reference(get(name, transform))
            else:
                cache[key] = render(get(name, transform), what)
        return cache[key]
    return get


@pytest.mark.parametrize("transform", list(TRANSFORMS))
@pytest.mark.parametrize("name", SCENES)
def test_same_image_after_moving_or_scaling(cached, name, transform, variant):
    image = cached(name, transform, variant)
    assert_matches(image, cached(name, None, variant).astype(np.float64))
    assert_matches(image, cached(name, transform, "reference"))


def test_path_tracer_far_from_the_origin_is_the_same_render(cached, variant):
    """Mitsuba's own ``path`` integrator, same seed, at the origin and moved by 10^6: in the
    converter's frame both are the same float32 scene, so the two renders agree to float
    round-off, not merely within noise (without the frame: 18 % of the Whitted pixels
    are off at 10^6, and the paths diverge)."""
    options = dict(integrator="path", spp=4, seed=7)
    here = render(cached("mirror_and_glass", None), variant, **options)
    far = render(cached("mirror_and_glass", "moved by 1e6"), variant, **options)
    assert np.abs(here.astype(np.float64) - far).max() <= 1e-5
