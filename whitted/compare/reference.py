"""The reference each render is scored against, and the cache that keeps it.

A converged path-traced reference costs more than the rest of a scene's sweep,
so it is rendered once and kept on disk (``DIR/references`` unless ``--cache``),
named by a hash of everything it depends on: the scene file, its converted XML,
its textures, the resolution, the reference's settings, the variant and the
versions of whitted and Mitsuba. An entry is written atomically, image first and
description second, and read only when both are whole: an interrupted run leaves
either a complete entry or none.

A reference is rendered as two independent halves (half the samples each, their
own seeds) and averaged: the two halves disagree by exactly the noise the
reference carries, so their difference estimates it
(:func:`~whitted.compare.curves.reference_noise`), and the report draws it as the
floor no render can measurably go below. Under ``--budget`` a short probe render
measures the cost of a sample first, and the reference is scaled down to what the
scene's share affords (:meth:`~whitted.compare.budget.Budget.reference_spp`) or
refused.
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
from ..defaults import COMPARE_PROBE_SECONDS
from .budget import Budget
from .curves import reference_noise
from .results import Options, SceneResult
from .scenes import SceneFile

#: The seeds of the reference's two halves. Its samples must be independent of the
#: sweep's (seed 0, whose later passes use seeds 1, 2, ...), or its noise would correlate
#: with theirs and flatter the path tracer; and the halves must be independent of each
#: other, or their difference would understate the noise.
REFERENCE_SEEDS = (0x5EED0001, 0x5EED0002)
#: The seed of the probe render that measures a sample's cost (its image is not kept).
PROBE_SEED = 0x5EED0003
#: Bumped when the meaning of a cached reference changes (2: two halves, noise estimated).
CACHE_FORMAT = "whitted-compare-reference/2"


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


def render_reference(loaded, spp: int, max_depth: int, progress: bool = False) -> tuple[np.ndarray, float, float, float]:
    """A path-traced reference of ``spp`` samples as two independent halves, averaged:
    (image, its estimated relative MSE against the converged image (NaN at 1 spp), render
    seconds, compile seconds)."""
    counts = [spp // 2, spp - spp // 2] if spp >= 2 else [spp]
    halves, seconds, compile_seconds = [], 0.0, 0.0
    for count, seed in zip(counts, REFERENCE_SEEDS):
        result = rendering.render(loaded, integrator="path", spp=count, max_depth=max_depth,
                                  seed=seed, progress=progress)
        halves.append(np.asarray(result.image, dtype=np.float64))
        seconds += float(result.seconds)
        compile_seconds += float(result.compile_seconds)
    image = sum(h * n for h, n in zip(halves, counts)) / spp
    noise = reference_noise(*halves, *counts) if len(halves) == 2 else math.nan
    return image.astype(np.float32), noise, seconds, compile_seconds


def probe_cost(loaded, max_depth: int, most_spp: int) -> tuple[float, float, int]:
    """The path tracer's seconds per sample per pixel on ``loaded``, measured on renders of
    1, 2, 4, ... spp until one takes :data:`COMPARE_PROBE_SECONDS` or reaches ``most_spp``:
    (seconds per spp, wall seconds the probe took, the last probe's spp). The last render's
    time over its spp includes the fixed cost of a render, so it errs on the high side."""
    start = time.monotonic()
    spp = 1
    while True:
        result = rendering.render(loaded, integrator="path", spp=spp, max_depth=max_depth,
                                  seed=PROBE_SEED, progress=False)
        if result.seconds >= COMPARE_PROBE_SECONDS or 2 * spp > most_spp:
            return float(result.seconds) / spp, time.monotonic() - start, spp
        spp *= 2


def reference_image(scene: SceneFile, loaded, entry: SceneResult, cache: ReferenceCache,
                    options: Options, seconds: float = math.inf) -> np.ndarray | None:
    """The scene's reference, from the cache or rendered from ``loaded`` (its ``mi.Scene``)
    within ``seconds`` (the scene's share of ``--budget``; ``math.inf``: no budget).

    Under a budget, a reference that is not cached is first probed (:func:`probe_cost`)
    and rendered at the spp :meth:`Budget.reference_spp` allows: fewer than asked (a
    reference of that spp is looked up in the cache first), or none, when not even the
    minimum fits; the reason is then a line of ``entry.notes`` and the result None.
    Records in ``entry`` where the reference lies, its spp and noise, whether it was
    cached and what it cost.
    """
    def settings(spp: int) -> dict:
        return {"integrator": "path", "spp": spp, "max_depth": entry.path_depth,
                "seeds": list(REFERENCE_SEEDS), "width": entry.width, "height": entry.height,
                "variant": entry.variant}

    def lookup(spp: int) -> tuple[str, tuple[np.ndarray, dict] | None]:
        key = cache.key(scene, settings(spp))
        return key, cache.load(entry.name, key, (entry.height, entry.width))

    start = time.monotonic()
    spp = options.reference_spp
    key, cached = lookup(spp)
    if cached is None and math.isfinite(seconds):
        if seconds <= 0:
            entry.notes.append("skipped whole: no time was left to render its reference")
            return None
        per_spp, spent, probe_spp = probe_cost(loaded, entry.path_depth, max(1, spp // 8))
        fitted = Budget.reference_spp(spp, per_spp, seconds, spent=time.monotonic() - start)
        estimate = f"a {probe_spp}-spp probe measured {_duration(per_spp)} per spp"
        if fitted is None:
            entry.notes.append(
                f"skipped whole: its reference would take about {_duration(per_spp * spp)} at "
                f"{spp} spp ({estimate}); the scene's {_duration(seconds)} share of --budget "
                f"{options.budget:g} s affords less than the {Budget.minimum_reference_spp} spp a "
                f"usable reference needs: raise --budget or lower --reference-spp")
            return None
        if fitted < spp:
            entry.notes.append(
                f"reference scaled down from {spp} to {fitted} spp to fit --budget "
                f"{options.budget:g} s ({estimate}: {spp} spp would take about "
                f"{_duration(per_spp * spp)}, {fitted} spp about {_duration(per_spp * fitted)})")
            spp = fitted
            key, cached = lookup(spp)
    entry.reference_spp = spp
    if cached is not None:
        image, info = cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
        entry.reference_noise = float(info.get("noise_rel_mse", math.nan))
    else:
        if not options.quiet:
            print(f"whitted compare: {entry.name}: rendering the reference "
                  f"(path tracer, {spp} spp in two halves)", file=sys.stderr)
        image, noise, render_seconds, compile_seconds = render_reference(
            loaded, spp, entry.path_depth, progress=not options.quiet)
        entry.reference_seconds = render_seconds
        entry.reference_noise = noise
        cache.store(entry.name, key, image, {
            "scene": str(entry.path), "settings": settings(spp), "seconds": render_seconds,
            "compile_seconds": compile_seconds, "noise_rel_mse": noise,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    entry.reference_file = cache.entry(entry.name, key)[0]
    return image


def _duration(seconds: float) -> str:
    """``850 ms``, ``12.3 s``, ``4 min 10 s``, ``3 h 21 min``."""
    if seconds < 1:
        return f"{seconds * 1000:.0f} ms"
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min {int(seconds % 60)} s"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60)} min"
