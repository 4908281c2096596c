"""Same inputs, same answer: the Whitted integrator gives the same bits for the same scene,
settings and seed, run after run and at any number of Dr.Jit threads, as Mitsuba's own
integrators do.

Every example and hazard scene (giant spheres included) is rendered three times: on one
thread, then twice on two (llvm_ad_rgb at 4 and 16 spp), or twice (scalar_rgb, at 2 spp:
one thread by nature, several samples summed per pixel). The renders are small (160×100,
scalar 40×25) but wide enough for two threads to split each kernel between them (Dr.Jit hands
out blocks of 16 384 lanes: 160×100 at 1 spp would be one block, which no thread count splits).
What varied before, a sum whose order followed the threads, varies with the scene's glass
and nested trees: the hazards have them.
"""

from __future__ import annotations

import dataclasses
import hashlib

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
import whitted
from conftest import REPO
from whitted.converter import parse_file, scene_to_xml

EXAMPLES = sorted(p.stem for p in (REPO / "scenes").glob("*.scn"))
SCENES = [f"example:{name}" for name in EXAMPLES] + list(hs.HAZARDS) + [f"giant:{name}" for name in hs.GIANTS]


def _load(name: str, tmp_dir, width: int, height: int):
    """The scene ``name`` at ``width``×``height``, loaded as ``whitted render`` loads it."""
    if name.startswith("example:"):
        path = REPO / "scenes" / f"{name.split(':')[1]}.scn"
        return whitted.load_scene(path, model=dataclasses.replace(parse_file(path), width=width, height=height))
    model = hs.GIANTS[name.split(":")[1]]() if name.startswith("giant:") else hs.build(name, tmp_dir)
    return mi.load_string(scene_to_xml(dataclasses.replace(model, width=width, height=height), base_dir=None))


def _digest(result) -> str:
    image = np.ascontiguousarray(result.image, dtype=np.float32)
    assert np.isfinite(image).all()
    return hashlib.sha256(image.tobytes()).hexdigest()


@pytest.fixture
def single_then_two_threads():
    """``runs(render)``: the digests of ``render()`` on one thread, then twice on two;
    the thread count is put back afterwards."""
    before = dr.thread_count()

    def runs(render):
        digests = []
        for threads in (1, 2, 2):
            dr.set_thread_count(threads)
            digests.append(_digest(render()))
        return digests
    yield runs
    dr.set_thread_count(before)


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_llvm_renders_are_the_same_bits_at_any_thread_count(llvm, name, tmp_path, single_then_two_threads):
    scene = _load(name, tmp_path, 160, 100)
    for spp in (4, 16):
        digests = single_then_two_threads(lambda: whitted.render(scene, spp=spp, seed=7))
        assert len(set(digests)) == 1, f"{name} at {spp} spp: the renders differ ({digests})"


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_scalar_renders_are_the_same_bits_run_after_run(name, tmp_path):
    whitted.set_variant("scalar_rgb")
    scene = _load(name, tmp_path, 40, 25)
    first, second = (_digest(whitted.render(scene, spp=2, seed=7)) for _ in range(2))
    assert first == second, f"{name} at 2 spp: two renders differ"


def test_the_renders_checked_are_trees_of_several_levels(llvm, tmp_path):
    """The check above means something only where a sample's tree has several levels whose
    colors are added: most of its scenes do (their glass and mirrors)."""
    deep = 0
    for name in SCENES:
        result = whitted.render(_load(name, tmp_path, 40, 25))
        deep += result.stats["max_depth_reached"] >= 3
    assert deep >= len(SCENES) // 2
