"""``whitted render SCENE|FOLDER... -o OUT/``, ``whitted video`` and ``whitted.render_scenes``:
many scenes in one process.

The expectation for every image is independent of the batch code: the scene loaded
and rendered on its own (``whitted.load_scene`` + ``whitted.render``), bit for bit
(EXR output). A frame sequence of small scenes stands for an animation; a Ctrl-C and
a killed Dask worker are sent to real processes, as a user's would be.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
from whitted.cli import main
from whitted.images import read_image

from conftest import session_left
from test_interrupt import start  # noqa: E402  (signals are sent once the process handles them)

W, H = 40, 26


def frame_text(k: int, frames: int, width: int = W, height: int = H) -> str:
    """Frame ``k`` of an animation: two balls orbiting a glass one above a floor, a mirror."""
    a = 2 * math.pi * k / frames
    return (f"size {width} {height}\neye 0 2 9\nlookat 0 0.5 0\ndepth 5\nbackground 0.2 0.3 0.5\n"
            "light 5 8 6\nsphere 0 -100 0 100 color 0.8 0.8 0.7\n"
            "sphere 0 1 0 1 color 1 1 1 refract 0.9 1.5\n"
            "sphere -3 1.5 -3 1.5 color 0.9 0.9 0.9 reflect 0.8\n"
            f"sphere {2.5 * math.cos(a):.5f} 0.5 {2.5 * math.sin(a):.5f} 0.5 color 0.9 0.2 0.2\n"
            f"sphere {2.5 * math.cos(a + math.pi):.5f} 0.6 {2.5 * math.sin(a + math.pi):.5f} 0.4 "
            "color 0.2 0.8 0.3 reflect 0.3\n")


def write_frames(folder: Path, frames: int, **size) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k in range(frames):
        path = folder / f"frame{k:03d}.scn"
        path.write_text(frame_text(k, frames, **size))
        paths.append(path)
    return paths


def alone(scene: Path) -> np.ndarray:
    """The expectation: the scene loaded and rendered on its own."""
    return whitted.render(whitted.load_scene(scene)).image


def images(folder: Path) -> list[Path]:
    """The EXR images in ``folder`` (not the hidden temporary file of one being written)."""
    return sorted(p for p in folder.glob("*.exr") if not p.name.startswith(".")) if folder.is_dir() else []


def hidden(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if p.name.startswith(".")]


# --------------------------------------------------------------------------- in one process


def test_a_bad_scene_among_good_ones(tmp_path, capsys):
    """Every good frame is written and equals its render alone; the bad one is named
    FILE:LINE; the exit status is 2 and one line sums it up."""
    scenes = write_frames(tmp_path / "frames", 4)
    bad = tmp_path / "frames" / "frame001b.scn"
    bad.write_text("size 8 8\nsphere 0 0 0 1 colr 1 0 0\n")
    out = tmp_path / "out"
    assert main(["render", str(tmp_path / "frames"), "-o", f"{out}/", "--format", "exr", "-q"]) == 2
    err = capsys.readouterr().err
    assert f"whitted: error: {bad}:2: unknown sphere attribute 'colr'" in err
    assert err.strip().splitlines()[-1].startswith(f"whitted: rendered 4 of 5 scenes, 1 failed in ")
    assert sorted(p.name for p in out.iterdir()) == [f"{s.stem}.exr" for s in scenes]
    for scene in scenes:
        np.testing.assert_array_equal(read_image(out / f"{scene.stem}.exr"), alone(scene))


@pytest.mark.parametrize("integrator, spp", [("path", 2), ("whitted", 3)])
def test_a_folder_is_rendered_with_the_options_one_file_is(tmp_path, integrator, spp):
    """``-o out/`` renders each scene as ``-o one.exr`` does, the spp asked included (the path
    tracer's least of 64 is for renders that ask for none)."""
    (scene,) = write_frames(tmp_path / "scenes", 1)
    assert main(["render", str(scene), "-o", str(tmp_path / "one.exr"), "--integrator", integrator,
                 "--spp", str(spp), "-q"]) == 0
    assert main(["render", str(scene), "-o", f"{tmp_path / 'out'}/", "--format", "exr",
                 "--integrator", integrator, "--spp", str(spp), "-q"]) == 0
    one, batch = read_image(tmp_path / "one.exr"), read_image(tmp_path / "out" / f"{scene.stem}.exr")
    assert one.tobytes() == batch.tobytes()
    expected = whitted.render(whitted.load_scene(scene), integrator=integrator, spp=spp).image
    assert np.array_equal(one, expected)


def test_files_and_folders_name_their_images_as_convert_does(tmp_path, capsys):
    """Several inputs: OUT/NAME.png and .exr per scene (the folder created); two scenes of
    one name clash before anything is rendered; --format needs a folder."""
    a = write_frames(tmp_path / "a", 2)
    b = tmp_path / "b" / "other.scn"
    b.parent.mkdir()
    b.write_text(frame_text(1, 3))
    out = tmp_path / "made" / "here"
    assert main(["render", str(tmp_path / "a"), str(b), "-o", str(out), "--format", "png",
                 "--format", "exr", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"{s.stem}.{x}" for s in [*a, b] for x in ("png", "exr")])
    capsys.readouterr()
    clash = tmp_path / "c" / "frame000.scn"
    clash.parent.mkdir()
    clash.write_text(frame_text(0, 3))
    assert main(["render", str(tmp_path / "a"), str(clash), "-o", str(tmp_path / "x"), "-q"]) == 2
    assert "both" in capsys.readouterr().err and not (tmp_path / "x").exists()
    assert main(["render", str(b), "-o", str(tmp_path / "y.png"), "--format", "exr", "-q"]) == 2
    assert "--format renders scenes into a folder" in capsys.readouterr().err
    assert not (tmp_path / "y.png").exists()
    # --fps without --video was accepted and did nothing
    for output in (tmp_path / "y.png", f"{tmp_path / 'z'}/"):
        assert main(["render", str(b), "-o", str(output), "--fps", "12", "-q"]) == 2
        assert capsys.readouterr().err == ("whitted: error: --fps is the rate of a video: "
                                           "give --video OUT.mp4 too\n")
    assert not (tmp_path / "y.png").exists() and not (tmp_path / "z").exists()


def test_resume_skips_what_is_up_to_date(tmp_path, capsys, texture_png):
    """A second run renders nothing; a scene edited since, or whose texture changed, is
    rendered again, and only it; --force renders all."""
    scenes = write_frames(tmp_path / "frames", 3)
    texture = texture_png("frames/tex.png")
    textured = tmp_path / "frames" / "globe.scn"
    textured.write_text(f"size {W} {H}\nlight 3 3 5\nsphere 0 0 0 2 texture tex.png\n")
    out = tmp_path / "out"
    args = ["render", str(tmp_path / "frames"), "-o", f"{out}/", "--stats", str(tmp_path / "s.json"), "-q"]
    assert main(args) == 0
    capsys.readouterr()

    def stamps():
        return {p.name: p.stat().st_mtime_ns for p in out.iterdir()}

    first = stamps()
    assert len(first) == 4
    assert main(args) == 0
    assert "rendered 0 of 4 scenes, 4 up to date" in capsys.readouterr().err
    assert stamps() == first
    totals = json.loads((tmp_path / "s.json").read_text())["totals"]
    assert (totals["rendered"], totals["skipped"], totals["failed"]) == (0, 4, 0)

    later = time.time() + 5   # newer than the images, whatever the file system's clock step
    os.utime(scenes[1], (later, later))
    os.utime(texture, (later, later))
    assert main(args) == 0
    assert "rendered 2 of 4 scenes, 2 up to date" in capsys.readouterr().err
    again = stamps()
    assert {name for name in first if again[name] != first[name]} == {"frame001.png", "globe.png"}
    stats = json.loads((tmp_path / "s.json").read_text())
    assert [e["status"] for e in stats["scenes"]].count("rendered") == 2
    assert stats["totals"]["rays"]["camera"] == 2 * W * H

    assert main([*args, "--force"]) == 0
    assert "rendered 4 of 4 scenes in" in capsys.readouterr().err


def test_render_scenes_yields_each_scene(tmp_path):
    """The Python API: images in memory, equal to each scene rendered alone; a bad scene is
    a failed result, not an exception."""
    scenes = write_frames(tmp_path / "frames", 3)
    (tmp_path / "frames" / "zz.scn").write_text("sphere 0 0 0 -1\n")
    done = list(whitted.render_scenes([tmp_path / "frames"], spp=1))
    assert [d.scene.name for d in done] == [*(s.name for s in scenes), "zz.scn"]
    assert [d.status for d in done] == ["rendered"] * 3 + ["failed"]
    assert done[-1].error.startswith(f"{tmp_path / 'frames' / 'zz.scn'}:1: ") and done[-1].image is None
    for d, scene in zip(done, scenes):
        np.testing.assert_array_equal(d.image, alone(scene))
        assert d.stats["rays"]["camera"] == W * H and not d.outputs
    written = list(whitted.render_scenes(scenes[:1], tmp_path / "api", formats=["exr"]))
    assert written[0].outputs == (tmp_path / "api" / "frame000.exr",) and written[0].image is None
    np.testing.assert_array_equal(read_image(tmp_path / "api" / "frame000.exr"), alone(scenes[0]))


# --------------------------------------------------------------------------- video


def decoded(path: Path) -> tuple[int, tuple[int, int], np.ndarray]:
    """(frames, (width, height), the frames) of a video, read back by imageio's FFmpeg."""
    import imageio.v3 as iio
    frames = iio.imread(path, plugin="FFMPEG", index=None)
    return frames.shape[0], (frames.shape[2], frames.shape[1]), frames


def test_video_decodes_to_the_frames(tmp_path, capsys):
    """--video after a render that resumed (frames up to date and rendered mixed), and
    whitted video from the images: the file decodes to as many frames as scenes, of the
    frames' size (odd sizes padded by one), each showing its frame, in the scenes' order
    (H.264 is lossy: the nearest of the images, not equal to it)."""
    write_frames(tmp_path / "frames", 5, width=41, height=27)
    out, video = tmp_path / "out", tmp_path / "film.mp4"
    assert main(["render", str(tmp_path / "frames"), "-o", f"{out}/", "-q"]) == 0
    (out / "frame002.png").unlink()
    assert main(["render", str(tmp_path / "frames"), "-o", f"{out}/", "--video", str(video),
                 "--fps", "5", "-q"]) == 0
    err = capsys.readouterr().err
    assert "rendered 1 of 5 scenes, 4 up to date" in err and f"wrote {video} (5 frames at 5 fps)" in err
    count, size, frames = decoded(video)
    assert (count, size) == (5, (42, 28))
    pngs = [np.array(mi.Bitmap(str(out / f"frame{k:03d}.png")), dtype=np.float64) for k in range(5)]
    for k, frame in enumerate(frames):
        errors = [np.abs(frame[:27, :41].astype(np.float64) - png).mean() for png in pngs]
        assert errors[k] < 6 and int(np.argmin(errors)) == k, errors   # of 255

    again = tmp_path / "again.mkv"
    assert main(["video", str(out), "-o", str(again), "--fps", "12", "-q"]) == 0
    assert decoded(again)[:2] == (5, (42, 28))
    assert not hidden(tmp_path)
    # a clean error before any work: nothing written
    assert main(["video", str(out), "-o", str(tmp_path / "film.gif"), "-q"]) == 2
    assert main(["render", str(tmp_path / "frames"), "-o", f"{tmp_path / 'o2'}/", "--video",
                 str(tmp_path / "no" / "f.mp4"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "film.gif: unsupported video format '.gif'" in err and "output folder" in err
    assert not (tmp_path / "o2").exists() and not (tmp_path / "film.gif").exists()


@pytest.mark.parametrize("frames, options, message", [
    (["a.png", "b.png", "short.png"], [], "short.png: a 8x4 frame among 8x6 ones; a video's frames share one size"),
    (["a.png", "broken.png"], [], "broken.png: could not read the frame"),
    (["a.png", "notes.txt"], [], "notes.txt: not a frame (.png or .exr)"),
    (["a.png", "gone.png"], [], "gone.png: no such frame"),
    (["a.png", "gone"], [], "gone: no such frame or folder"),
    (["a.png", "b.png"], ["--fps", "0"], "--fps must be a number of frames per second in [0.001, 1000], got 0"),
    (["a.png", "b.png"], ["--fps", "1e-9"], "in [0.001, 1000], got 1e-09")])
def test_a_bad_frame_or_rate_is_one_line_and_no_video(tmp_path, capsys, frames, options, message):
    """A frame of another size (found while encoding), one that cannot be read, a file that is
    no frame, a missing one (or folder: it was called no frame), a rate of 0 or one too low for FFmpeg (it ended with status 0 and
    an empty file): status 2, one line naming it, and no video, not even a partial one, nor a
    temporary file."""
    for name, height in (("a.png", 6), ("b.png", 6), ("short.png", 4)):
        mi.Bitmap(np.full((height, 8, 3), 0.5, np.float32)).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(tmp_path / name))
    (tmp_path / "broken.png").write_bytes(b"not a png")
    (tmp_path / "notes.txt").write_text("frame list")
    capsys.readouterr()
    video = tmp_path / "film.mp4"
    assert main(["video", *(str(tmp_path / f) for f in frames), "-o", str(video), *options, "-q"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("whitted: error: ") and message in err[0], err
    assert not video.exists() and not hidden(tmp_path)


# --------------------------------------------------------------------------- Ctrl-C


def test_ctrl_c_mid_sequence_leaves_whole_frames(tmp_path):
    """SIGINT while a real process renders a sequence: status 130, one line, every image
    in the folder whole (each reads back at its size), no temporary file; a rerun renders
    only what was left and the sequence is complete."""
    frames = 60
    write_frames(tmp_path / "frames", frames, width=160, height=100)
    out = tmp_path / "out"
    process = start(["render", "frames", "-o", "out/", "--format", "exr", "-q"], tmp_path)
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline and process.poll() is None:
            if len(images(out)) >= 3:
                break
            time.sleep(0.02)
        assert process.poll() is None, "the sequence finished before the signal: make it longer"
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode in (130, -signal.SIGINT), err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("whitted: interrupted; "), err
    assert not hidden(out)
    written = images(out)
    assert 3 <= len(written) < frames
    for image in written:
        assert read_image(image).shape == (100, 160, 3)
    assert err.strip().splitlines()[-1] == (f"whitted: interrupted; the images of {len(written)} of "
                                            f"{frames} scenes are in out/; run it again to render the rest")
    stamps = {p.name: p.stat().st_mtime_ns for p in written}
    assert main(["render", str(tmp_path / "frames"), "-o", f"{out}/", "--format", "exr", "-q"]) == 0
    assert len(images(out)) == frames
    assert all(p.stat().st_mtime_ns == stamps[p.name] for p in written)   # not rendered again


# --------------------------------------------------------------------------- a Dask cluster


def test_workers_with_one_killed_mid_run_give_the_plain_images(tmp_path):
    """--workers 2 in a real process, one of its worker processes killed (SIGKILL) as the
    first frames come out: the run succeeds and every image equals the plain run's, bit
    for bit; no process of the run is left."""
    psutil = pytest.importorskip("psutil")
    pytest.importorskip("distributed")
    frames = 48   # long enough that a loaded machine still kills a worker mid-run
    scenes = write_frames(tmp_path / "frames", frames, width=200, height=130)
    out = tmp_path / "out"
    run = subprocess.Popen([sys.executable, "-m", "whitted", "render", str(tmp_path / "frames"), "-o",
                            f"{out}/", "--format", "exr", "--workers", "2", "-q", "--stats",
                            str(tmp_path / "stats.json")],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    killed = done_then = None
    try:
        deadline = time.monotonic() + 240
        while killed is None and time.monotonic() < deadline and run.poll() is None:
            done = images(out)
            workers = [p for p in psutil.Process(run.pid).children(recursive=True)
                       if "spawn_main" in " ".join(p.cmdline())
                       and "resource_tracker" not in " ".join(p.cmdline())] if done else []
            if workers:
                done_then = len(done)
                workers[0].kill()
                killed = workers[0].pid
            time.sleep(0.02)
        _, err = run.communicate(timeout=240)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert killed is not None, "no worker process was seen rendering"
    assert done_then < frames, "every frame was done before the kill"
    assert run.returncode == 0, err
    for scene in scenes:
        np.testing.assert_array_equal(read_image(out / f"{scene.stem}.exr"), alone(scene))
    assert not hidden(out)
    entries = json.loads((tmp_path / "stats.json").read_text())["scenes"]
    assert len(entries) == frames and all(e["status"] == "rendered" for e in entries)
    assert all(e["worker"].startswith("tcp://127.0.0.1:") for e in entries)   # on the cluster
    assert not session_left(run.pid)



# --------------------------------------------------------------------------- giants, once per frame


@pytest.mark.parametrize("name", ["floor", "wall"])
def test_giants_stay_spheres_for_the_whitted_integrator_alone(variant, write_scene, name):
    """A floor of radius 10^4 is a fine mesh for Mitsuba's own integrators (converter/giants.py):
    its acceleration structure takes far longer to build than a small frame to render. The
    whitted integrator intersects it in float64 and never traces its shape, so loading it
    as a sphere (``meshes=False``, what ``whitted render`` does) gives the same image, bit
    for bit, with no mesh in the scene."""
    text = frame_text(1, 4).replace("sphere 0 -100 0 100", "sphere 0 -10000 0 10000")
    if name == "wall":   # a giant that is not below the eye, and seen through glass
        text += "sphere 0 0 -10010 10000 color 0.3 0.3 0.9 reflect 0.2\n"
    scene = write_scene(text)
    meshed, plain = whitted.load_scene(scene), whitted.load_scene(scene, meshes=False)
    assert any(shape.is_mesh() for shape in meshed.shapes())   # the floor at least
    assert not any(shape.is_mesh() for shape in plain.shapes())
    assert len(plain.shapes()) == len(meshed.shapes())
    np.testing.assert_array_equal(whitted.render(plain).image, whitted.render(meshed).image)
