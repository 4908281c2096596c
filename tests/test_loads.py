"""``whitted.loads``: a scene from its text, as a notebook writes one."""

from __future__ import annotations

import numpy as np
import pytest

import whitted

TEXT = "size 24 16\nlight 5 5 10\nsphere 0 0 0 1 color 0.9 0.2 0.2 reflect 0.3 texture tex.png\n"


def test_text_loads_the_scene_its_file_would(tmp_path, texture_png):
    texture_png("tex.png")
    (tmp_path / "s.scn").write_text(TEXT)
    from_file = whitted.render(whitted.load_scene(tmp_path / "s.scn", spp=2)).image
    from_text = whitted.render(whitted.loads(TEXT, base_dir=tmp_path, spp=2)).image
    np.testing.assert_allclose(from_text, from_file, rtol=0, atol=1e-6)
    assert from_text.shape == (16, 24, 3) and from_text.max() > 0.1


def test_errors_name_the_text_and_its_lines(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)   # no tex.png here
    with pytest.raises(whitted.SceneError) as error:
        whitted.loads("size 24 16\nsphere 0 0 0 -1 color 2 0 0\nsphere 0 0 0 1 texture tex.png\n")
    lines = str(error.value).splitlines()
    assert lines[0] == "<text>:2: sphere radius must be > 0, got -1"
    assert lines[1] == "<text>:2: sphere color must be >= 0 and <= 1, got 2"
    assert lines[2].startswith("<text>:3:") and "tex.png" in lines[2]
    with pytest.raises(whitted.WhittedError, match="as a str"):
        whitted.loads(b"sphere 0 0 0 1")


def test_an_unknown_integrator_is_refused_as_render_refuses_it(tmp_path):
    """load_scene and loads check ``integrator`` as whitted.render does: a typo is one
    WhittedError, not a scene silently built for neither integrator."""
    (tmp_path / "s.scn").write_text("size 4 3\nlight 5 5 10\nsphere 0 0 0 1\n")
    for load in (lambda: whitted.load_scene(tmp_path / "s.scn", integrator="paht"),
                 lambda: whitted.loads("sphere 0 0 0 1", integrator="paht")):
        with pytest.raises(whitted.WhittedError, match="unknown integrator 'paht'"):
            load()
