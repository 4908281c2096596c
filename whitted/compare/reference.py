"""The reference each render is scored against, and the cache that keeps it.

A converged path-traced reference costs more than the rest of a scene's sweep,
so it is rendered once and kept on disk (``DIR/references`` unless ``--cache``),
named by a hash of everything it depends on: the scene file, its converted XML,
its textures, the resolution, the reference's settings, the variant and the
versions of whitted and Mitsuba. An entry is written atomically, image first and
description second, and read only when both are whole: an interrupted run leaves
either a complete entry or none.

The reference is rendered in chunks (:func:`reference_chunks`): independent
path-traced images of at most ``--reference-chunk-spp`` samples per pixel, each
from its own seed, averaged with their spp as weights. The chunks depend on the
options alone, never on who renders them, so a cluster can spread them over its
workers (:mod:`.cluster`) and still make the very image a run in one process
makes, bit for bit (a path-traced image depends only on its seed:
:func:`whitted.rendering.path_passes`).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import rendering  # rendering.render looked up at call time: tests count calls
from .results import IN_PROCESS, Options, SceneResult
from .scenes import SceneFile

#: The reference's samples must be independent of the sweep's, or its noise would
#: correlate with theirs and flatter the path tracer: each chunk's seed is drawn
#: from this one by a hash (:func:`chunk_seed`), far from the sweep's seed 0 and the
#: small seeds of its passes.
REFERENCE_SEED = 1
#: Bumped when the meaning of a cached reference changes (2: rendered in chunks).
CACHE_FORMAT = "whitted-compare-reference/2"


def chunk_seed(index: int) -> int:
    """The seed of the reference's chunk ``index``: 32 bits of a SHA-256, so that no
    two chunks, and no chunk and the sweep, share their samples."""
    digest = hashlib.sha256(f"whitted-compare reference {REFERENCE_SEED} chunk {index}".encode())
    return int.from_bytes(digest.digest()[:4], "little")


def reference_chunks(reference_spp: int, chunk_spp: int) -> list[tuple[int, int]]:
    """The reference's chunks as (spp, seed), in order: ``reference_spp`` samples per
    pixel cut into chunks of ``chunk_spp`` (the last one takes the rest)."""
    sizes = [chunk_spp] * (reference_spp // chunk_spp)
    if reference_spp % chunk_spp:
        sizes.append(reference_spp % chunk_spp)
    return [(spp, chunk_seed(index)) for index, spp in enumerate(sizes)]


@dataclass
class Chunk:
    """One chunk of the reference, rendered (plain data: it travels between processes).

    =================== ===============================================================
    ``spp``, ``seed``   what was rendered (one entry of :func:`reference_chunks`)
    ``image``           the linear image, float32 (H, W, 3); None when the budget left
                        no time to render it
    ``seconds``         its render time, compilation excluded
    ``compile_seconds`` kernel compilation
    ``worker``          who rendered it (a Dask worker's address, or ``in-process``)
    =================== ===============================================================
    """
    spp: int
    seed: int
    image: np.ndarray | None
    seconds: float = math.nan
    compile_seconds: float = math.nan
    worker: str = IN_PROCESS


def render_chunk(loaded, spp: int, seed: int, max_depth: int, progress: bool = False) -> Chunk:
    """Render one chunk of the reference with Mitsuba's path tracer (``loaded``: the
    ``mi.Scene``)."""
    result = rendering.render(loaded, integrator="path", spp=spp, max_depth=max_depth, seed=seed,
                              progress=progress)
    return Chunk(spp, seed, np.asarray(result.image, dtype=np.float32), float(result.seconds),
                 float(result.compile_seconds))


def combine(chunks: list[Chunk]) -> np.ndarray:
    """The average of the chunks' images, weighted by their spp, summed in float64 in
    the chunks' order (so the same chunks always give the same bits)."""
    total = None
    for chunk in chunks:
        weighted = chunk.image.astype(np.float64) * chunk.spp
        total = weighted if total is None else total + weighted
    return (total / sum(c.spp for c in chunks)).astype(np.float32)


def reference_settings(entry: SceneResult, options: Options) -> dict:
    """Everything about how the reference is rendered that its cache key must cover."""
    return {"integrator": "path", "spp": options.reference_spp, "max_depth": entry.path_depth,
            "chunks": reference_chunks(options.reference_spp, options.reference_chunk_spp),
            "width": entry.width, "height": entry.height, "variant": entry.variant}


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
                    options: Options, may_render: bool = True,
                    chunks: list[Chunk] | None = None) -> np.ndarray | None:
    """The scene's reference, from the cache, else from ``chunks`` (already rendered,
    in the order of :func:`reference_chunks`), else rendered here chunk by chunk from
    ``loaded`` (its ``mi.Scene``); None when it is not cached and ``may_render`` is
    false. Records in ``entry`` where it lies, whether it was cached and what it cost."""
    if chunks is not None and any(c.image is None for c in chunks):
        chunks, may_render = None, False   # the budget ran out before every chunk was made
    settings = reference_settings(entry, options)
    key = cache.key(scene, settings)
    cached = cache.load(entry.name, key, (entry.height, entry.width))
    if cached is not None:
        image, info = cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
    elif chunks is None and not may_render:
        return None
    else:
        if chunks is None:
            if not options.quiet:
                print(f"whitted compare: {entry.name}: rendering the reference "
                      f"(path tracer, {options.reference_spp} spp)", file=sys.stderr)
            chunks = [render_chunk(loaded, spp, seed, entry.path_depth, progress=not options.quiet)
                      for spp, seed in settings["chunks"]]
        if [(c.spp, c.seed) for c in chunks] != settings["chunks"]:
            raise ValueError("the reference's chunks are not those its settings describe")
        image = combine(chunks)
        entry.reference_seconds = sum(c.seconds for c in chunks)
        cache.store(entry.name, key, image, {
            "scene": str(entry.path), "settings": settings, "seconds": entry.reference_seconds,
            "compile_seconds": sum(c.compile_seconds for c in chunks),
            "chunks": [{"spp": c.spp, "seed": c.seed, "seconds": c.seconds, "worker": c.worker}
                       for c in chunks],
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    entry.reference_file = cache.entry(entry.name, key)[0]
    return image
