"""The reference each render is scored against, and the cache that keeps it.

A converged path-traced reference costs more than the rest of a scene's sweep,
so it is rendered once and kept on disk (``DIR/references`` unless ``--cache``),
named by a hash of everything it depends on: the scene file, its converted XML,
its textures, the resolution, the reference's settings, the variant and the
versions of whitted and Mitsuba. An entry is written atomically, image first and
description second, and read only when both are whole: an interrupted run leaves
either a complete entry or none.

A reference is rendered as two independent halves (:class:`Halves`: half the
samples each, their own seeds) and averaged: the two halves disagree by exactly the
noise the reference carries, so their difference estimates it
(:func:`~whitted.compare.curves.reference_noise`), and the report draws it as the
floor no render can measurably go below. Under ``--budget`` short probe renders
(1, 2, 4, ... spp, kept as part of the first half) measure what a render and a
sample cost first, and the reference is scaled down to what the scene's share
affords (:meth:`~whitted.compare.budget.Budget.reference_spp`) or refused.

Without a budget, each half is rendered in chunks (:func:`reference_chunks`) of at
most ``--reference-chunk-spp`` samples per pixel, each from its own seed. The chunks
follow from the options alone, never from who renders them, so a cluster can spread
them over its workers (:mod:`.cluster`) and still make the very image a run in one
process makes, bit for bit (a path-traced image depends only on its seed:
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
from ..defaults import COMPARE_MIN_REFERENCE_SPP, COMPARE_PROBE_SECONDS, COMPARE_REFERENCE_SHARE
from .budget import Budget, fit_cost, render_cost
from .curves import reference_noise
from .results import IN_PROCESS, Options, SceneResult, seconds_text
from .scenes import SceneFile

#: The seeds of the reference's renders are this plus a running count (even: the first
#: half, odd: the second). Its samples must be independent of the sweep's (seed 0, whose
#: later passes use seeds 1, 2, ...), or its noise would correlate with theirs and
#: flatter the path tracer; and the halves must be independent of each other, or their
#: difference would understate the noise.
REFERENCE_SEED = 0x5EED0000
#: Bumped when the meaning of a cached reference changes (2: two halves, noise estimated).
CACHE_FORMAT = "whitted-compare-reference/2"


def reference_chunks(reference_spp: int, chunk_spp: int) -> list[tuple[int, int, int]]:
    """The chunks of a reference rendered without a budget, as (spp, seed, half), in
    order: each half (``reference_spp // 2`` samples per pixel, then the rest) cut into
    chunks of at most ``chunk_spp``; chunk ``i`` of half ``h`` has the seed
    ``REFERENCE_SEED + 2 i + h``."""
    chunks = []
    for half, spp in enumerate((reference_spp // 2, reference_spp - reference_spp // 2)):
        sizes = [chunk_spp] * (spp // chunk_spp) + ([spp % chunk_spp] if spp % chunk_spp else [])
        chunks += [(n, REFERENCE_SEED + 2 * i + half, half) for i, n in enumerate(sizes)]
    return chunks


@dataclass
class Chunk:
    """One chunk of a reference, rendered (plain data: it travels between processes).

    =================== ===============================================================
    ``spp``, ``seed``,  what was rendered, for which half (one entry of
    ``half``            :func:`reference_chunks`)
    ``image``           the linear image, float32 (H, W, 3)
    ``seconds``         its render time, compilation excluded
    ``compile_seconds`` kernel compilation
    ``worker``          who rendered it (a Dask worker's address, or ``in-process``)
    =================== ===============================================================
    """
    spp: int
    seed: int
    half: int
    image: np.ndarray
    seconds: float
    compile_seconds: float
    worker: str = IN_PROCESS


def render_chunk(loaded, spp: int, seed: int, half: int, max_depth: int,
                 progress: bool = False) -> Chunk:
    """Render one chunk of a reference with Mitsuba's path tracer (``loaded``: the
    ``mi.Scene``)."""
    result = rendering.render(loaded, integrator="path", spp=spp, max_depth=max_depth, seed=seed,
                              progress=progress)
    return Chunk(spp, seed, half, np.asarray(result.image, dtype=np.float32),
                 float(result.seconds), float(result.compile_seconds))


def reference_settings(entry: SceneResult, spp: int) -> dict:
    """What the cache key of an ``spp``-sample reference of ``entry``'s scene covers."""
    return {"integrator": "path", "spp": spp, "max_depth": entry.path_depth,
            "seed": REFERENCE_SEED, "width": entry.width, "height": entry.height,
            "variant": entry.variant}


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


class Halves:
    """A reference being rendered: two independent halves, each the sum of path-traced
    renders of its own seeds, averaged at the end (and differenced for its noise).

    ============= ====================================================================
    ``loaded``    the scene's ``mi.Scene``
    ``max_depth`` the path tracer's max depth
    ``progress``  whether each render shows a progress bar
    ============= ====================================================================
    """

    def __init__(self, loaded, max_depth: int, progress: bool = False):
        self.loaded, self.max_depth, self.progress = loaded, max_depth, progress
        self.sums: list[np.ndarray | None] = [None, None]
        self.counts = [0, 0]
        self.renders = 0
        self.seconds = 0.0          # render time, compilation excluded
        self.compile_seconds = 0.0

    def render(self, half: int, spp: int) -> float:
        """Add ``spp`` samples per pixel to ``half`` (0 or 1); returns the render's seconds."""
        if spp <= 0:
            return 0.0
        chunk = render_chunk(self.loaded, spp, REFERENCE_SEED + 2 * self.renders + half, half,
                             self.max_depth, self.progress)
        self.add(chunk)
        return chunk.seconds

    def add(self, chunk: Chunk) -> None:
        """Add a rendered chunk to its half (in float64: the same chunks in the same
        order give the same bits)."""
        self.renders += 1
        image = chunk.image.astype(np.float64) * chunk.spp
        half = chunk.half
        self.sums[half] = image if self.sums[half] is None else self.sums[half] + image
        self.counts[half] += chunk.spp
        self.seconds += chunk.seconds
        self.compile_seconds += chunk.compile_seconds

    @property
    def spp(self) -> int:
        return sum(self.counts)

    def image(self) -> np.ndarray:
        """The reference: every sample of both halves, averaged."""
        return (sum(s for s in self.sums if s is not None) / self.spp).astype(np.float32)

    def noise(self) -> float:
        """The reference's relative MSE against the converged image, estimated from its
        halves (:func:`~whitted.compare.curves.reference_noise`); NaN with one half."""
        if not all(self.counts):
            return math.nan
        return reference_noise(self.sums[0] / self.counts[0], self.sums[1] / self.counts[1],
                               *self.counts)


def probe(halves: Halves, most_spp: int, most_seconds: float) -> list[tuple[int, float]]:
    """Renders of 1, 2, 4, ... spp into the first half (kept: they are part of the
    reference) until a third one takes :data:`COMPARE_PROBE_SECONDS` (several, to tell
    the cost of a render call from that of a sample), the next would pass ``most_spp``
    or the probe has taken ``most_seconds``; returns [(spp, seconds)] for
    :func:`~whitted.compare.budget.fit_cost`."""
    start, points, spp = time.monotonic(), [], 1
    while True:
        points.append((spp, halves.render(0, spp)))
        # three renders: the cost of a sample is read between the last two (the first may
        # still pay for warm-up), once they are long enough to time
        enough = len(points) >= 3 and points[-1][1] >= COMPARE_PROBE_SECONDS
        if enough or 2 * spp > most_spp or time.monotonic() - start >= most_seconds:
            return points
        spp *= 2


def reference_image(scene: SceneFile, loaded, entry: SceneResult, cache: ReferenceCache,
                    options: Options, seconds: float = math.inf,
                    chunks: list[Chunk] | None = None) -> np.ndarray | None:
    """The scene's reference, from the cache or rendered from ``loaded`` (its ``mi.Scene``)
    within ``seconds`` (the scene's share of ``--budget``; ``math.inf``: no budget).

    Under a budget, a reference that is not cached is first probed (:func:`probe`: its
    first renders, kept) and completed at the spp :meth:`Budget.reference_spp` allows:
    fewer than asked (a reference of that spp is looked up in the cache first; a line of
    ``entry.notes`` says so), or none, when not even the minimum fits (the note says why
    and the result is None). Without a budget it is rendered in :func:`reference_chunks`,
    or made of ``chunks`` rendered elsewhere (a cluster's workers). Records in ``entry``
    where the reference lies, its spp and noise, whether it was cached and what it cost.
    """
    def settings(spp: int) -> dict:
        return reference_settings(entry, spp)

    def lookup(spp: int) -> tuple[str, tuple[np.ndarray, dict] | None]:
        key = cache.key(scene, settings(spp))
        return key, cache.load(entry.name, key, (entry.height, entry.width))

    start = time.monotonic()
    requested = options.reference_spp
    key, cached = lookup(requested)
    halves = Halves(loaded, entry.path_depth, progress=not options.quiet)
    if cached is None and math.isfinite(seconds):
        if seconds <= 0:
            entry.notes.append("skipped whole: no time was left to render its reference")
            return None
        pixels = entry.width * entry.height
        pass_spp = rendering.path_passes(requested, pixels)[0]  # the most spp of one pass
        points = probe(halves, most_spp=min(pass_spp, max(1, requested // 4)),
                       most_seconds=COMPARE_REFERENCE_SHARE * seconds / 4)
        overhead, per_spp = fit_cost(points)

        def cost(spp: int) -> float:  # what the rest of an spp-sample reference costs
            rest = (max(0, spp // 2 - halves.counts[0]), spp - spp // 2)
            return sum(render_cost(n, len(rendering.path_passes(n, pixels)),
                                   overhead, per_spp) for n in rest)

        fitted = Budget.reference_spp(requested, cost, seconds, spent=time.monotonic() - start)
        estimate = (f"probe renders of 1–{points[-1][0]} spp: {seconds_text(overhead)} a render "
                    f"plus {seconds_text(per_spp)} per spp" if overhead > 0 else
                    f"a {points[-1][0]}-spp probe took {seconds_text(points[-1][1])}")
        if fitted is None:
            entry.notes.append(
                f"skipped whole: its reference would take about "
                f"{seconds_text(cost(requested))} at {requested} spp ({estimate}); the scene's "
                f"{seconds_text(seconds)} share of --budget {options.budget:g} s affords less than "
                f"the {COMPARE_MIN_REFERENCE_SPP} spp a usable reference needs: raise --budget "
                f"or lower --reference-spp")
            return None
        if fitted < requested:
            entry.notes.append(
                f"reference scaled down from {requested} to {fitted} spp to fit --budget "
                f"{options.budget:g} s ({estimate}: {requested} spp would take about "
                f"{seconds_text(cost(requested))}, {fitted} spp about {seconds_text(cost(fitted))})")
        target = fitted
        key, cached = lookup(max(halves.counts[0], target // 2) + target - target // 2)
    else:
        target = requested
    if cached is not None:
        image, info = cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
        entry.reference_noise = float(info.get("noise_rel_mse", math.nan))
        entry.reference_spp = int(info.get("settings", {}).get("spp", target))
    else:
        if not options.quiet:
            print(f"whitted compare: {entry.name}: rendering the reference "
                  f"(path tracer, {target} spp in two halves)", file=sys.stderr)
        if math.isfinite(seconds):  # the probe's renders are part of the first half
            halves.render(0, target // 2 - halves.counts[0])
            halves.render(1, target - target // 2)
        else:
            planned = reference_chunks(target, options.reference_chunk_spp)
            if chunks is None:
                chunks = [render_chunk(loaded, *chunk, entry.path_depth, progress=not options.quiet)
                          for chunk in planned]
            if [(c.spp, c.seed, c.half) for c in chunks] != planned:
                raise ValueError("the reference's chunks are not those its options make")
            for chunk in chunks:
                halves.add(chunk)
        image = halves.image()
        entry.reference_spp = halves.spp
        entry.reference_seconds = halves.seconds
        entry.reference_noise = halves.noise()
        cache.store(entry.name, key, image, {
            "scene": str(entry.path), "settings": settings(halves.spp), "seconds": halves.seconds,
            "compile_seconds": halves.compile_seconds, "noise_rel_mse": entry.reference_noise,
            "spp_per_half": halves.counts, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "chunks": [{"spp": c.spp, "seed": c.seed, "half": c.half, "seconds": c.seconds,
                        "worker": c.worker} for c in chunks or ()]})
    entry.reference_file = cache.entry(entry.name, key)[0]
    return image
