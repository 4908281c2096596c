"""The reference each render is scored against, and the cache that keeps it.

A converged path-traced reference costs more than the rest of a scene's sweep,
so it is rendered once and kept on disk (``DIR/references`` unless ``--cache``),
named by a hash of everything it depends on: the scene file, its converted XML,
its textures, the resolution, the reference's settings, the variant and the
versions of whitted and Mitsuba. An entry is written atomically, image first and
description second, and read only when both are whole: an interrupted run leaves
either a complete entry or none.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

from .. import rendering  # rendering.render looked up at call time: tests count calls
from .results import Options, SceneResult
from .scenes import SceneFile

#: The reference's samples must be independent of the sweep's, or its noise would
#: correlate with theirs and flatter the path tracer.
REFERENCE_SEED = 1
#: Bumped when the meaning of a cached reference changes.
CACHE_FORMAT = "whitted-compare-reference/1"


class ReferenceCache:
    """Converged path-traced references on disk, keyed by everything they depend on.

    An entry is ``NAME-KEY.exr`` (the linear image, via whitted.imageio) and
    ``NAME-KEY.json`` (the settings and render time). Both are written atomically,
    the JSON last, and an entry is used only when the JSON names the same key and
    the image reads back whole with the expected size.

    ========== ====================================================================
    ``folder`` where the entries live (made on the first store)
    ========== ====================================================================
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)

    @staticmethod
    def key(scene: SceneFile, settings: dict) -> str:
        """The SHA-256 (hex) of the scene's content and the reference's ``settings``."""
        import mitsuba as mi

        import whitted
        from ..converter import scene_to_xml

        digest = hashlib.sha256()

        def add(label: str, data: bytes) -> None:
            digest.update(f"{label}:{len(data)}:".encode())
            digest.update(data)

        add("format", CACHE_FORMAT.encode())
        add("settings", json.dumps(settings, sort_keys=True).encode())
        add("versions", f"{whitted.__version__} {mi.__version__}".encode())
        add("scene", scene.data)
        if scene.model is not None:
            # What the scene means to today's converter, independent of where the file lies:
            # texture paths relative to the scene, comments (which name the file) dropped.
            xml = scene_to_xml(scene.model, base_dir=scene.path.parent)
            add("xml", re.sub(r"<!--.*?-->", "", xml, flags=re.S).encode())
        for texture in scene.textures:
            add("texture", texture.read_bytes())
        return digest.hexdigest()

    def entry(self, name: str, key: str) -> tuple[Path, Path]:
        """The entry's image and description files."""
        stem = f"{name.replace('/', '_')}-{key[:16]}"
        return self.folder / f"{stem}.exr", self.folder / f"{stem}.json"

    def load(self, name: str, key: str, shape: tuple[int, int]) -> tuple[np.ndarray, dict] | None:
        """The cached (image, description) of ``shape`` = (height, width); None when the
        entry is missing, damaged or of another key."""
        from .. import imageio

        image_file, info_file = self.entry(name, key)
        try:
            info = json.loads(info_file.read_text(encoding="utf-8"))
            if info.get("key") != key:
                return None
            image = imageio.read_image(image_file)
        except Exception:  # missing, unreadable or foreign: render it again
            return None
        if image.shape != (shape[0], shape[1], 3) or not np.all(np.isfinite(image)):
            return None
        return image, info

    def store(self, name: str, key: str, image: np.ndarray, info: dict) -> Path:
        """Write an entry (image first, description last); returns the image file."""
        from .. import imageio
        from ..atomic import write_text

        self.folder.mkdir(parents=True, exist_ok=True)
        image_file, info_file = self.entry(name, key)
        imageio.write_image(image_file, image)
        write_text(info_file, json.dumps({**info, "key": key}, indent=2, sort_keys=True) + "\n")
        return image_file


def reference_image(scene: SceneFile, loaded, entry: SceneResult, cache: ReferenceCache,
                    options: Options, may_render: bool = True) -> np.ndarray | None:
    """The scene's reference, from the cache or rendered from ``loaded`` (its ``mi.Scene``);
    None when it is not cached and ``may_render`` is false. Records in ``entry`` where it
    lies, whether it was cached and what it cost."""
    settings = {"integrator": "path", "spp": options.reference_spp, "max_depth": entry.path_depth,
                "seed": REFERENCE_SEED, "width": entry.width, "height": entry.height,
                "variant": entry.variant}
    key = cache.key(scene, settings)
    cached = cache.load(entry.name, key, (entry.height, entry.width))
    if cached is not None:
        image, info = cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
    elif not may_render:
        return None
    else:
        if not options.quiet:
            print(f"whitted compare: {entry.name}: rendering the reference "
                  f"(path tracer, {options.reference_spp} spp)", file=sys.stderr)
        result = rendering.render(loaded, integrator="path", spp=options.reference_spp,
                                  max_depth=entry.path_depth, seed=REFERENCE_SEED,
                                  progress=not options.quiet)
        image = np.asarray(result.image, dtype=np.float32)
        entry.reference_seconds = float(result.seconds)
        cache.store(entry.name, key, image, {
            "scene": str(entry.path), "settings": settings, "seconds": result.seconds,
            "compile_seconds": result.compile_seconds,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    entry.reference_file = cache.entry(entry.name, key)[0]
    return image
