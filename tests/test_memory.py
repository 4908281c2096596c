"""Memory of a large render: what a pixel costs, measured as the operating system sees it.

A render and the writing of its PNG and EXR run in a fresh process; its peak
resident set size (``VmHWM``, reset after the scene is loaded) less its
resident size at that moment, over the pixel count, must stay within
:data:`BYTES_PER_PIXEL`. The image is 2048² at 4 spp (the same code serves a
16384² one, where the fixed costs fade and only the per-pixel ones count:
a float32 RGB image is 12 bytes a pixel). ``--stats`` reports the same peak
(``peak_resident_bytes``).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml

#: the budget: resident bytes per pixel of a render written to PNG and to EXR
BYTES_PER_PIXEL = 40
SIZE, SPP = 2048, 4

pytestmark = pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(),
                                reason="needs Linux's per-process peak resident size")

DRIVER = """
import json, sys
from pathlib import Path
import whitted
from whitted.rendering import peak_resident_bytes, reset_peak, resident_bytes

scene = whitted.load_scene(sys.argv[1])
baseline = resident_bytes()
reset_peak()
result = whitted.render(scene)
rendered = peak_resident_bytes()
whitted.write_image(Path(sys.argv[2]) / "image.png", result.image)
whitted.write_image(Path(sys.argv[2]) / "image.exr", result.image)
print(json.dumps({"baseline": baseline, "rendered": rendered, "peak": peak_resident_bytes(),
                  "stats": result.stats["peak_resident_bytes"], "shape": list(result.image.shape)}))
"""


def scene() -> Scene:
    return Scene(width=SIZE, height=SIZE, samples=SPP, eye=(0.0, 1.0, 8.0), lookat=(0.0, 0.5, 0.0),
                 lights=[Light((4.0, 6.0, 5.0))],
                 spheres=[Sphere((0.0, -100.0, 0.0), 100.0, Material(color=(0.8, 0.8, 0.7))),
                          Sphere((0.0, 1.0, 0.0), 1.0, Material(color=(0.9, 0.3, 0.2))),
                          Sphere((-2.0, 0.7, 1.0), 0.7, Material(color=(0.2, 0.4, 0.9)))])


def test_a_large_render_costs_at_most_40_bytes_a_pixel(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(scene_to_xml(scene(), base_dir=None))
    run = subprocess.run([sys.executable, "-c", DRIVER, str(path), str(tmp_path)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    m = json.loads(run.stdout.strip().splitlines()[-1])
    assert m["shape"] == [SIZE, SIZE, 3]
    pixels = SIZE * SIZE
    per_pixel = (m["peak"] - m["baseline"]) / pixels
    assert per_pixel <= BYTES_PER_PIXEL, f"{per_pixel:.1f} bytes a pixel (render alone: " \
        f"{(m['rendered'] - m['baseline']) / pixels:.1f})"
    # The statistics report the render's true peak: at least the image (float32 RGB) was resident.
    assert m["baseline"] + 12 * pixels <= m["stats"] <= m["rendered"]
    assert (tmp_path / "image.png").stat().st_size > 0 and (tmp_path / "image.exr").stat().st_size > 0


def test_stats_report_the_peak_resident_size(tmp_path):
    """``whitted render --stats``: the process's peak resident size (to the end of writing the
    image) beside Dr.Jit's allocator mark; the process holds far more than the image."""
    from whitted.cli import main
    path, stats = tmp_path / "scene.xml", tmp_path / "stats.json"
    small = scene()
    small.width, small.height = 64, 48
    path.write_text(scene_to_xml(small, base_dir=None))
    assert main(["render", str(path), "-o", str(tmp_path / "out.png"), "--stats", str(stats), "-q"]) == 0
    data = json.loads(stats.read_text())
    assert isinstance(data["peak_resident_bytes"], int) and isinstance(data["peak_memory_bytes"], int)
    assert data["peak_resident_bytes"] > 12 * 64 * 48 and data["peak_resident_bytes"] > data["peak_memory_bytes"]
