"""The POV-Ray 3.7 scene writer of the benchmarks (benchmarks/povray.py).

The writer must make POV-Ray trace and shade what whitted does, or the
side-by-side benchmark compares different work. Where POV-Ray is installed,
the two programs render the same small scene and their images must agree;
elsewhere the written scene is checked against the mapping it promises.
"""

from __future__ import annotations

import importlib.util
import re
import shutil
import sys
from dataclasses import replace

import numpy as np
import pytest

from conftest import REPO
from whitted.converter.scene import Light, Material, Scene, Sphere


def _load(name):
    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
    module = sys.modules[name] = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


sphereflake = _load("sphereflake")
povray = _load("povray")


def test_finish_carries_the_articles_weights():
    scene = Scene(ambient=0.25, depth=7, lights=[Light((1, 2, 3), (0.5, 0.5, 0.5))],
                  spheres=[Sphere((0, 0, 0), 1, Material((1, 0.5, 0), reflect=0.4))])
    pov = povray.scene_to_pov(scene)
    # local = (1 - KR) (A + (1 - A) ...): ambient 0.6 * 0.25, diffuse 0.6 * 0.75; KR untinted
    finish = re.search(r"finish \{ ambient ([\d.]+) diffuse ([\d.]+) reflection \{ ([\d.]+) \}", pov)
    assert [float(x) for x in finish.groups()] == pytest.approx([0.15, 0.45, 0.4])
    assert "max_trace_level 7" in pov and "adc_bailout 0" in pov and "ambient_light rgb 1" in pov
    assert "light_source { <1.0, 2.0, 3.0> color rgb <0.5, 0.5, 0.5> }" in pov
    assert "fade" not in pov and "area_light" not in pov  # no fall-off, hard shadows
    assert "right -x*640/400" in pov and "angle 45.0" in pov


@pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is not installed")
def test_povray_renders_the_image_whitted_renders(tmp_path):
    import mitsuba as mi
    import whitted
    whitted.set_variant("llvm_ad_rgb")
    exe, why = povray.find()
    assert exe, why
    model = replace(sphereflake.scene(1), width=64, height=48)
    scn = tmp_path / "flake.scn"
    scn.write_text(sphereflake.to_scn(model))
    (tmp_path / "flake.pov").write_text(povray.scene_to_pov(model))
    run = povray.run(exe, tmp_path / "flake.pov", tmp_path / "pov.png", 64, 48, threads=1)
    assert run.trace_seconds >= 0 and run.wall_seconds > 0 and run.reflected_rays > 0

    result = whitted.render(whitted.load_scene(scn), min_weight=0)
    whitted.write_image(tmp_path / "whitted.png", result.image)
    ours = np.array(mi.Bitmap(str(tmp_path / "whitted.png")), dtype=float)[..., :3]
    theirs = np.array(mi.Bitmap(str(tmp_path / "pov.png")), dtype=float)[..., :3]
    assert ours.shape == theirs.shape == (48, 64, 3)
    difference = np.abs(ours - theirs)
    assert difference.mean() < 1.0                       # levels of 255
    assert (difference.max(axis=-1) <= 2).mean() > 0.97  # all but a few edge pixels
    assert run.shadow_rays == result.stats["rays"]["shadow"]
