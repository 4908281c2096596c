"""A frame sequence three ways: what one process for many scenes saves (``make bench``).

Legacy ray tracers rendered an animation as a scene file per frame, a process each. This
times such a sequence as a user waits for it, in rounds after a warm-up frame: POV-Ray 3.7
and ``whitted render`` a process per frame, and one ``whitted render FRAMES/ -o OUT/``,
whose frames must equal those rendered alone, bit for bit (else the exit status is 1).

``--quick``: 6 frames of 160×100, for a check that it works. Options of run.py that
``make bench BENCHFLAGS=...`` passes along are ignored.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

from whitted.compare.timing import median
from whitted.defaults import check_size
from whitted.errors import WhittedError

from . import povray, process, run_main
from .report import Table, ratio, seconds

#: the targets: the folder run's time over POV-Ray's, and over the per-frame loop's
TARGET_POVRAY, TARGET_LOOP = 0.5, 0.25
COLORS = [(0.9, 0.2, 0.2), (0.2, 0.8, 0.3), (0.2, 0.3, 0.9), (0.9, 0.8, 0.2), (0.8, 0.3, 0.8),
          (0.2, 0.8, 0.8)]


def frame_scene(k: int, frames: int, width: int = 320, height: int = 200) -> str:
    """Frame ``k`` of ``frames``: six balls orbit a glass ball, bobbing, above a floor sphere
    of radius 10⁴, beside a mirror."""
    lines = [f"# frame {k + 1} of {frames} (benchmarks/frames.py)", f"size {width} {height}",
             "eye 0 3.5 12", "lookat 0 0.8 0", "fov 50", "depth 6", "background 0.25 0.35 0.55",
             "light 8 14 10", "light -10 9 4 0.4 0.4 0.5",
             "sphere 0 -10000 0 10000 color 0.75 0.75 0.7",
             "sphere 0 1.3 0 1.3 color 1 1 1 refract 0.9 1.5",
             "sphere -4 2.2 -5 2.2 color 0.9 0.9 0.9 reflect 0.85"]
    for j, (r, g, b) in enumerate(COLORS):
        a = 2 * math.pi * (k / frames + j / len(COLORS))
        x, z, y = 3.2 * math.cos(a), 3.2 * math.sin(a), 0.5 + 0.35 * (1 + math.sin(2 * a))
        lines.append(f"sphere {x:.6f} {y:.6f} {z:.6f} 0.5 color {r} {g} {b} reflect 0.2")
    return "\n".join(lines) + "\n"


def write_sequence(folder: Path, frames: int, width: int, height: int) -> list[Path]:
    from whitted.converter import parse_file
    folder.mkdir(parents=True, exist_ok=True)
    scenes = []
    for k in range(frames):
        scene = folder / f"frame{k + 1:03d}.scn"
        scene.write_text(frame_scene(k, frames, width, height))
        scenes.append(scene)
        (folder.parent / "pov").mkdir(exist_ok=True)
        (folder.parent / "pov" / f"{scene.stem}.pov").write_text(povray.scene_to_pov(parse_file(scene)))
    return scenes


def povray_loop(exe: str, root: Path, scenes: list[Path], width: int, height: int) -> float:
    out = root / "povray"
    out.mkdir(exist_ok=True)
    start = time.perf_counter()
    for scene in scenes:
        povray.run(exe, root / "pov" / f"{scene.stem}.pov", out / f"{scene.stem}.png", width, height,
                   threads=len(os.sched_getaffinity(0)))
    return time.perf_counter() - start


def whitted_loop(root: Path, scenes: list[Path]) -> float:
    out = root / "single"
    out.mkdir(exist_ok=True)
    start = time.perf_counter()
    for scene in scenes:
        run = process.whitted("render", scene, "-o", out / f"{scene.stem}.exr", "--min-weight", "0", "-q")
        process.succeeded(run, "whitted render", scene.name)
    return time.perf_counter() - start


def whitted_folder(root: Path) -> float:
    start = time.perf_counter()
    run = process.whitted("render", root / "frames", "-o", f"{root / 'folder'}/", "--format", "exr",
                          "--min-weight", "0", "--force", "-q", "--stats", root / "folder-stats.json")
    process.succeeded(run, "whitted render", "FRAMES/")
    return time.perf_counter() - start


def differing(root: Path, scenes: list[Path]) -> list[str]:
    """The frames whose folder-run image differs from the frame rendered alone."""
    import numpy as np

    from whitted.images import read_image
    return [scene.stem for scene in scenes
            if not np.array_equal(read_image(root / "folder" / f"{scene.stem}.exr"),
                                  read_image(root / "single" / f"{scene.stem}.exr"))]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="6 frames of 160x100")
    parser.add_argument("--frames", type=int, metavar="N", help="frames in the sequence (default 48)")
    parser.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), help="frame size (default 320 200)")
    parser.add_argument("--rounds", type=int, default=1, metavar="N", help="rounds of the three (default 1)")
    args, _ = parser.parse_known_args(argv)
    if args.frames is not None and args.frames < 1:   # 0 ran the default count
        parser.error(f"--frames must be >= 1, got {args.frames}")
    if args.rounds < 1:
        parser.error(f"--rounds must be >= 1, got {args.rounds}")
    frames = args.frames or (6 if args.quick else 48)
    width, height = args.size or ((160, 100) if args.quick else (320, 200))
    try:   # the size a scene file may give
        check_size(width, "--size width")
        check_size(height, "--size height")
    except WhittedError as error:
        parser.error(str(error))
    exe, why = povray.find()
    times: dict[str, list[float]] = {"povray": [], "loop": [], "folder": []}
    with tempfile.TemporaryDirectory(prefix="whitted-frames-") as folder:
        root = Path(folder)
        scenes = write_sequence(root / "frames", frames, width, height)
        print(f"{frames} frames of {width}x{height}, depth 6, a floor sphere of radius 1e4; "
              f"{len(os.sched_getaffinity(0))} cores; POV-Ray: {exe or why}", flush=True)
        # warm-up, untimed: a frame each (kernel cache on disk, page cache)
        whitted_loop(root, scenes[:1])
        if exe:
            povray_loop(exe, root, scenes[:1], width, height)
        for k in range(args.rounds):
            if exe:
                times["povray"].append(povray_loop(exe, root, scenes, width, height))
            times["loop"].append(whitted_loop(root, scenes))
            times["folder"].append(whitted_folder(root))
            print(f"round {k + 1}: " + ", ".join(f"{name} {t[-1]:.1f} s" for name, t in times.items() if t),
                  flush=True)
        wrong = differing(root, scenes)
        totals = json.loads((root / "folder-stats.json").read_text())["totals"]
    folder_time = median(times["folder"])
    table = Table(f"{frames} frames of {width}x{height}", ["how", "s", "s per frame", "folder run / this", "target"])
    for name, key, target in [("POV-Ray 3.7, a process per frame", "povray", TARGET_POVRAY),
                              ("whitted render, a process per frame", "loop", TARGET_LOOP),
                              ("whitted render FRAMES/ -o OUT/, one process", "folder", None)]:
        t = median(times[key])
        met = "" if target is None or math.isnan(t) else "met" if folder_time / t <= target else "MISSED"
        table.add(name, seconds(t), seconds(t / frames), ratio(folder_time, t), f"≤ {target}: {met}" if met else "")
    print(table.text())
    print(f"folder run, last round: {totals['wall_seconds']:.1f} s in its loop over the scenes, of "
          f"which {totals['render_seconds']:.1f} s rendering and {totals['compile_seconds']:.1f} s "
          f"compiling kernels; the rest loading scenes and writing images; start-up "
          f"{times['folder'][-1] - totals['wall_seconds']:.1f} s")
    if wrong:
        print(f"FRAMES DIFFER between the folder run and the single renders: {', '.join(wrong)}")
        return 1
    print(f"every frame of the folder run equals its single render ({frames} EXR files, bit for bit)")
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main))
