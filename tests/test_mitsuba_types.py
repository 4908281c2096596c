"""Every sensor, film and sampler type Mitsuba ships, under the whitted integrator: each
renders as Mitsuba's ``path`` renders it, or is refused with one clear line, and none takes
the process down.

The renders run in one child process (this file, run as a script), which reports each case
as it starts and as it ends: a crash fails these tests, naming the case, not the suite.

The scene is opaque (a partly reflecting ball on a diffuse floor), lit by a point light,
with physical lighting and no background. Its direct light (whitted at max_depth 1) is what
``path`` with max_depth 2 computes, noisy only where the camera samples fall; its trees 3
deep walk more than one level of the wavefront tracer, and must be the same in the scalar
variant, which walks them one ray at a time.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
#: samples per pixel of the renders compared with path's (orthogonal rounds it to 17²)
SPP = 256

#: name -> (sensor type, film, sampler type, spp); the film is (width, height, hdrfilm's extras)
CASES = {
    "perspective": ("perspective", (12, 8, {}), "independent", SPP),
    "thinlens": ("thinlens", (12, 8, {}), "independent", SPP),
    "orthographic": ("orthographic", (12, 8, {}), "independent", SPP),
    "radiancemeter": ("radiancemeter", (1, 1, {}), "independent", SPP),
    "irradiancemeter": ("irradiancemeter", (1, 1, {}), "independent", SPP),
    "distant": ("distant", (1, 1, {}), "independent", SPP),
    "batch": ("batch", (24, 8, {}), "independent", SPP),
    **{f"sampler {sampler}": ("orthographic", (12, 8, {}), sampler, SPP)
       for sampler in ("stratified", "multijitter", "orthogonal", "ldsampler")},
    **{f"sampler {sampler} at 1 spp": ("orthographic", (12, 8, {}), sampler, 1)
       for sampler in ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")},
    **{f"hdrfilm {fmt}": ("orthographic", (12, 8, {"pixel_format": fmt}), "independent", SPP)
       for fmt in ("rgba", "luminance", "luminance_alpha", "xyz", "xyza")},
    "hdrfilm gaussian, border, crop": ("orthographic", (12, 8, {
        "rfilter": {"type": "gaussian"}, "sample_border": True, "crop_offset_x": 2, "crop_offset_y": 1,
        "crop_width": 8, "crop_height": 6}), "independent", SPP),
    "specfilm": ("perspective", (12, 8, {"type": "specfilm"}), "independent", SPP),
}
#: what Mitsuba itself refuses in an RGB variant, for every integrator
REFUSED = {"specfilm": "spectral"}


def description(sensor_type, film, sampler, spp, integrator):
    import mitsuba as mi
    width, height, extras = film
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, **extras}
    if film["type"] == "specfilm":
        film = {"type": "specfilm", "width": width, "height": height,
                "band": {"type": "spectrum", "value": [(400.0, 1.0), (700.0, 1.0)]}}
    to_world = mi.ScalarTransform4f().look_at(origin=[0, 1, 6], target=[0, 0, 0], up=[0, 1, 0])
    sensor = {"type": sensor_type, "film": film, "sampler": {"type": sampler, "sample_count": spp}}
    if sensor_type in ("perspective", "thinlens", "orthographic", "radiancemeter"):
        sensor["to_world"] = to_world
    if sensor_type == "orthographic":   # the view a perspective camera at fov 40 has of the ball
        sensor["to_world"] = to_world @ mi.ScalarTransform4f().scale([2.2, 2.2, 1])
    if sensor_type == "thinlens":
        sensor.update(aperture_radius=0.3, focus_distance=6)
    if sensor_type == "distant":
        sensor.update(direction=[0, -0.3, -1], target=[0.3, 0.2, 0])
    if sensor_type == "batch":
        sensor.update(left={"type": "perspective", "to_world": to_world},
                      right={"type": "orthographic", "to_world": to_world})
    article = {"type": "article", "color": {"type": "rgb", "value": [0.9, 0.3, 0.2]}}
    scene = {
        "type": "scene", "integrator": integrator,
        "ball": {"type": "sphere", "radius": 1.4, "bsdf": {**article, "reflect": 0.4}},
        "floor": {"type": "sphere", "center": [0, -11.4, 0], "radius": 10, "bsdf": {"type": "article"}},
        "light": {"type": "point", "position": [2, 4, 4], "intensity": {"type": "rgb", "value": [300, 300, 300]}},
    }
    if sensor_type == "irradiancemeter":   # a small square facing the ball, beside it
        scene["meter"] = {"type": "rectangle", "bsdf": {"type": "article"}, "sensor": sensor,
                          "to_world": mi.ScalarTransform4f().translate([3, 0, 0]).rotate([0, 1, 0], -90)
                          @ mi.ScalarTransform4f().scale(0.2)}
    else:
        scene["sensor"] = sensor
    return scene


def run_cases(names) -> None:
    """The child: per case, one JSON line as it starts and one as it ends, with the whitted
    render at max_depth 1 and two of path's at max_depth 2 (seeds 0 and 1), at the sampler's
    spp; and whitted's at max_depth 3 and 1 spp in both variants."""
    import mitsuba as mi

    import whitted

    def load(name, variant, depth):
        whitted.set_variant(variant)
        return mi.load_dict(description(*CASES[name], {"type": "whitted", "max_depth": depth,
                                                        "lighting": "physical"}))
    for name in names:
        print(json.dumps({"case": name}), flush=True)
        try:
            scene = load(name, "llvm_ad_rgb", 1)
        except Exception as error:   # noqa: BLE001  (what Mitsuba refuses, for every integrator)
            print(json.dumps({"case": name, "load_refused": str(error)}), flush=True)
            continue
        try:
            report = {"case": name, "whitted": np.array(mi.render(scene)).tolist()}
            path = mi.load_dict({"type": "path", "max_depth": 2})
            report["path"] = [np.array(mi.render(scene, integrator=path, seed=seed)).tolist() for seed in (0, 1)]
            report["deep"] = [np.array(mi.render(load(name, variant, 3), spp=1)).tolist()
                              for variant in ("llvm_ad_rgb", "scalar_rgb")]
        except Exception as error:   # noqa: BLE001
            cause = error.__cause__ or error
            report = {"case": name, "refused": f"{type(cause).__name__}: {cause}"}
        print(json.dumps(report), flush=True)


@pytest.fixture(scope="module")
def reports():
    """Each case's last report (None: it never ended), and the child's exit status and stderr."""
    done = subprocess.run([sys.executable, __file__, *CASES], capture_output=True, text=True, cwd=REPO,
                          timeout=600)
    found = {name: None for name in CASES}
    for line in done.stdout.splitlines():
        if '{"case": ' in line:   # (after any warning Mitsuba left unfinished on the line)
            report = json.loads(line[line.index('{"case": '):])
            found[report["case"]] = report
    return found, done.returncode, done.stderr


def blocks(image, size=4):
    """Means over size×size blocks (the whole image when smaller): where path's samples fell
    matters less than how bright each region is."""
    h, w = image.shape[:2]
    size = min(size, h, w)
    return image[:h // size * size, :w // size * size].reshape(h // size, size, w // size, size, -1).mean(axis=(1, 3))


def test_no_type_takes_the_process_down(reports):
    found, returncode, stderr = reports
    unfinished = [name for name, report in found.items() if report is None or len(report) == 1]
    assert returncode == 0 and not unfinished, \
        f"exit status {returncode}, cases not finished: {unfinished}\n{stderr[-2000:]}"


@pytest.mark.parametrize("name", list(CASES))
def test_each_type_renders_as_path_does_or_is_refused_in_one_line(reports, name):
    """Direct light (whitted at max_depth 1) as path renders it (max_depth 2): the same within
    path's own noise; and a deeper tree (max_depth 3) the same in both variants."""
    report = reports[0][name]
    assert report is not None, f"{name}: the child process died before this case"
    assert len(report) > 1, f"{name}: the child process died in this case"
    if name in REFUSED:
        message = report.get("load_refused") or report.get("refused")
        assert message and REFUSED[name] in message and len(message.strip().splitlines()) == 1
        return
    assert "refused" not in report, report.get("refused") or report["load_refused"]
    image, (path, path_again) = np.array(report["whitted"]), [np.array(p) for p in report["path"]]
    assert image.shape == path.shape
    assert np.isfinite(image).all() and image.max() > 0
    if CASES[name][3] == 1:   # whitted's rays pass through the pixel centres, path's do not
        assert np.abs(image.mean() - path.mean()) < 0.1 * path.mean()
    else:
        noise = np.abs(blocks(path_again) - blocks(path)).mean()
        assert np.abs(blocks(image) - blocks(path)).mean() <= 1.5 * noise + 1e-4 * path.mean()
    llvm, scalar = (np.array(deep) for deep in report["deep"])
    assert llvm.shape == image.shape
    if image.size > 3:   # the ball reflects
        assert not np.allclose(llvm, image, rtol=0.01)
    if CASES[name][2] in ("orthogonal", "ldsampler") or "rfilter" in CASES[name][1][2]:
        # at least 4 spp, drawn otherwise in each variant; a Gaussian filter looked up in a
        # table in the scalar variant (Mitsuba's own ImageBlock)
        assert np.abs(llvm.mean() - scalar.mean()) < 0.05 * scalar.mean()
    else:
        assert np.abs(llvm - scalar).mean() <= 1e-4 * scalar.mean()


if __name__ == "__main__":
    run_cases(sys.argv[1:])
