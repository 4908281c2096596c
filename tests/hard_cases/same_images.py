"""Render the examples (scenes/*.scn, scenes_xml/*.xml) and the hard cases
(tests/hard_cases/hazard_scenes.py) with the whitted integrator, and save or compare
the images bit for bit.

Why: a change that is meant to leave the article's images alone (issue 28: the film,
the sensors, the refactor) is checked by rendering everything before and after it::

    python tests/hard_cases/same_images.py save BEFORE.npz     # at the branch point
    python tests/hard_cases/same_images.py compare BEFORE.npz  # at the final commit

It lives beside the hard cases it renders (run as a script, its folder is on the import
path). One Dr.Jit thread, as it was written before renders were the same bits at any
thread count (tests/hard_cases/test_determinism.py). Both variants, each scene at its own spp
through ``whitted.render`` and ``mi.render``, and the examples at 4 spp as well; every way a
scene is loaded (the XML, ``load_scene`` of the ``.scn``, as ``whitted render`` loads it, grouped
in ellipsoids), the giant spheres at every radius (floors of 10^4 to 10^7, walls, a dome).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def renders(variants, quick=False):
    import drjit as dr
    import mitsuba as mi

    import whitted
    from whitted.converter import scene_to_xml
    from whitted.converter.scn_writer import scene_to_scn
    import hazard_scenes as H

    dr.set_thread_count(1)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for variant in variants:
            whitted.set_variant(variant)
            scenes = {}
            for path in sorted((REPO / "scenes").glob("*.scn")):
                scenes[f"scn/{path.stem}"] = lambda path=path: whitted.load_scene(path)
            for path in sorted((REPO / "scenes_xml").glob("*.xml")):
                if "portable" not in path.name:
                    scenes[f"xml/{path.stem}"] = lambda path=path: mi.load_file(str(path))
            for name in H.HAZARDS:
                scenes[f"hazard/{name}"] = lambda name=name: mi.load_string(
                    scene_to_xml(H.build(name, tmp), base_dir=None))
            for path in sorted((REPO / "scenes").glob("*.scn")):   # as `whitted render` loads them
                scenes[f"render/{path.stem}"] = lambda path=path: whitted.load_scene(path, meshes=False)
            for name, builder in H.GIANTS.items():
                scenes[f"giant/{name}"] = lambda builder=builder: mi.load_string(
                    scene_to_xml(builder(), base_dir=None))
                path = tmp / f"{name}.scn"
                path.write_text(scene_to_scn(builder(), tmp))
                for way, options in (("render", {"meshes": False}), ("grouped", {"ellipsoids": True}),
                                     ("scn", {})):
                    scenes[f"giant-{way}/{name}"] = lambda path=path, options=options: whitted.load_scene(
                        path, **options)
            for name, load in scenes.items():
                scene = load()
                yield f"{variant}/{name}/render", whitted.render(scene).image
                if quick:
                    continue
                yield f"{variant}/{name}/mi.render", np.array(mi.render(scene), np.float32)
                if name.startswith(("scn/", "xml/")):
                    yield f"{variant}/{name}/spp4", whitted.render(scene, spp=4, seed=3).image


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("save", "compare"))
    parser.add_argument("file")
    parser.add_argument("--variants", default="llvm_ad_rgb,scalar_rgb")
    parser.add_argument("--quick", action="store_true", help="whitted.render at the scene's spp only")
    args = parser.parse_args()
    images = {}
    for key, image in renders(args.variants.split(","), args.quick):
        images[key] = np.ascontiguousarray(image, np.float32)
        print(key, image.shape, flush=True)
    if args.action == "save":
        np.savez_compressed(args.file, **images)
        print(f"saved {len(images)} images to {args.file}")
        return 0
    before = np.load(args.file)
    differ = [k for k in images if k not in before or before[k].shape != images[k].shape
              or before[k].tobytes() != images[k].tobytes()]
    missing = [k for k in before.files if k not in images]
    for key in differ:
        diff = np.abs(before[key] - images[key]).max() if key in before and before[key].shape == images[key].shape else "shape"
        print(f"DIFFERENT: {key} (max |diff| {diff})")
    for key in missing:
        print(f"MISSING: {key}")
    print(f"{len(images) - len(differ)} of {len(images)} images identical bit for bit"
          + (f", {len(missing)} missing" if missing else ""))
    return 1 if differ or missing else 0


if __name__ == "__main__":
    sys.exit(main())
