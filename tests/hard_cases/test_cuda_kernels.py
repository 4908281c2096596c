"""Spheres grouped in layers are traced in scenes of their own (plugins/hits.py,
``LayeredHits``). OptiX traces one scene per kernel and silently drops the rays of a second
one, so on CUDA each layer's query is evaluated in a kernel of its own. CI has no GPU: here
the same bracketing is forced in llvm, where it must change no bit of the image (run on a GPU,
the CUDA image then matches llvm's within float32 rounding: checked on an H200)."""

from __future__ import annotations

import numpy as np
import pytest

import hazard_scenes as hs
import whitted
from whitted.converter.scn_writer import scene_to_scn
from whitted.plugins import hits


@pytest.mark.parametrize("name", ["floor_1e5", "sky_dome"])
def test_a_layer_traced_in_a_kernel_of_its_own_gives_the_same_image(name, tmp_path, monkeypatch):
    whitted.set_variant("llvm_ad_rgb")
    path = tmp_path / f"{name}.scn"
    path.write_text(scene_to_scn(hs.GIANTS[name](), tmp_path))
    shared = whitted.render(whitted.load_scene(path, ellipsoids=True)).image

    built = hits.LayeredHits.__init__

    def own_kernels(self, *args, **kwargs):
        built(self, *args, **kwargs)
        self.own_kernels = True
        own_kernels.layers = len(self.layers)

    monkeypatch.setattr(hits.LayeredHits, "__init__", own_kernels)
    separate = whitted.render(whitted.load_scene(path, ellipsoids=True)).image
    assert own_kernels.layers >= 1   # the scene was traced in layers
    assert np.array_equal(np.asarray(separate), np.asarray(shared))
