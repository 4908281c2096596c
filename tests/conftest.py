"""Shared fixtures. Keep them small and generic: every test module may use them."""

from __future__ import annotations

from pathlib import Path

import pytest

import whitted  # noqa: F401  (selects the default variant and registers the plugins)

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def write_scene(tmp_path):
    """``write_scene(text_or_bytes, name="scene.scn") -> Path``: a scene file in tmp_path."""
    def write(content: str | bytes, name: str = "scene.scn") -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, str):
            content = content.encode("utf-8")
        path.write_bytes(content)
        return path
    return write


@pytest.fixture
def texture_png(tmp_path):
    """``texture_png(name="tex.png", width=4, height=2) -> Path``: a small 8-bit RGB PNG.

    Texel (row r, column c) holds (40 c, 40 r, 200) so that tests can tell texels apart.
    """
    def make(name: str = "tex.png", width: int = 4, height: int = 2) -> Path:
        import mitsuba as mi
        import numpy as np
        rows, cols = np.mgrid[0:height, 0:width]
        pixels = np.stack([40 * cols, 40 * rows, np.full_like(rows, 200)], axis=-1).astype(np.uint8)
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
        return path
    return make
