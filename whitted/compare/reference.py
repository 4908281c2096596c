"""The reference each render is scored against: planned, rendered in chunks, put together
from two independent halves (whose difference estimates its noise) and cached on disk,
since it costs more than the rest of a scene's sweep (docs/compare.md, "The reference
cache", "The reference's noise", "Budget"). The chunks and their seeds follow from one
plan alone, so a cluster makes the very image one process makes, bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import atomic  # atomic.write_text looked up at call time: tests interrupt it
from .. import metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from ..defaults import (COMPARE_MIN_REFERENCE_SPP, COMPARE_PROBE_SECONDS,
                        COMPARE_REFERENCE_NOISE_SHARE, COMPARE_REFERENCE_SHARE,
                        COMPARE_REFERENCE_START_SPP, IN_PROCESS, LIGHTING_MODES, STALE_SECONDS,
                        VERSION)
from ..images import read_image, write_image
from ..progress import progress_bar
from .budget import Budget, fit_cost, render_cost
from .curves import reference_noise
from .results import Options, SceneResult, seconds_text
from .scenes import SceneFile

#: The first seed of the reference's chunks: far from the sweep's, whose noise would
#: otherwise correlate with the reference's and flatter the path tracer.
REFERENCE_SEED = 0x5EED0000
#: Bumped when the meaning of a cached reference changes.
CACHE_FORMAT = "whitted-compare-reference/3"


def chunk_seed(half: int, index: int) -> int:
    """Interleaved: neither half's seeds depend on how many chunks the other has."""
    return REFERENCE_SEED + 2 * index + half


def reference_chunks(reference_spp: int, chunk_spp: int,
                     done: list[tuple[int, int, int]] = ()) -> list[tuple[int, int, int]]:
    """The chunks (spp, seed, half) still to render of a reference of ``reference_spp``
    after those ``done`` (the probe's): each half in chunks of at most ``chunk_spp``."""
    chunks = []
    for half, spp in enumerate((reference_spp // 2, reference_spp - reference_spp // 2)):
        had = [n for n, _, h in done if h == half]
        rest = max(0, spp - sum(had))
        sizes = [chunk_spp] * (rest // chunk_spp) + ([rest % chunk_spp] if rest % chunk_spp else [])
        chunks += [(n, chunk_seed(half, len(had) + i), half) for i, n in enumerate(sizes)]
    return chunks


@dataclass
class Chunk:
    """One chunk of a reference, rendered (plain data: it travels between processes)."""
    spp: int
    seed: int
    half: int
    image: np.ndarray
    seconds: float
    compile_seconds: float
    worker: str = IN_PROCESS

    @property
    def planned(self) -> tuple[int, int, int]:
        return self.spp, self.seed, self.half


def render_chunk(loaded, spp: int, seed: int, half: int, max_depth: int,
                 progress: bool = False) -> Chunk:
    result = rendering.render(loaded, integrator="path", spp=spp, max_depth=max_depth, seed=seed,
                              progress=progress)
    return Chunk(spp, seed, half, np.asarray(result.image, dtype=np.float32),
                 float(result.seconds), float(result.compile_seconds))


def reference_settings(entry: SceneResult, spp: int, enough: bool = False) -> dict:
    """What the cache key of an ``spp``-sample reference of ``entry``'s scene covers
    (``enough``: at most ``spp``, as many as :func:`enough_spp` finds)."""
    settings = {"integrator": "path", "spp": spp, "max_depth": entry.path_depth,
                "seed": REFERENCE_SEED, "width": entry.width, "height": entry.height,
                "variant": entry.variant}
    if enough:
        settings.update(noise_share=COMPARE_REFERENCE_NOISE_SHARE,
                        start_spp=COMPARE_REFERENCE_START_SPP)
    return settings


class ReferenceCache:
    """Converged references on disk: ``NAME-KEY.exr`` and ``NAME-KEY.json``, both written
    atomically, the JSON last; an entry is used only when it names the same key and the
    image reads back whole at the expected size."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self._cleaned = False

    def clean(self) -> None:
        """Once per cache object: remove the temporary files that killed writers left."""
        if not self._cleaned:
            atomic.remove_stale_leftovers(self.folder, STALE_SECONDS)
            self._cleaned = True

    @staticmethod
    def key(scene: SceneFile, settings: dict) -> str:
        """The SHA-256 (hex) of the scene's content and the reference's ``settings``."""
        import mitsuba as mi

        from ..converter import scene_to_xml

        digest = hashlib.sha256()

        def add(label: str, data: bytes) -> None:
            digest.update(f"{label}:{len(data)}:".encode())
            digest.update(data)

        add("format", CACHE_FORMAT.encode())
        add("settings", json.dumps(settings, sort_keys=True).encode())
        add("versions", f"{VERSION} {mi.__version__}".encode())
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
        stem = f"{name.replace('/', '_')}-{key[:16]}"
        return self.folder / f"{stem}.exr", self.folder / f"{stem}.json"

    def load(self, name: str, key: str, shape: tuple[int, int]) -> tuple[np.ndarray, dict] | None:
        """The cached (image, description); None when missing, damaged or of another key."""
        self.clean()
        image_file, info_file = self.entry(name, key)
        try:
            info = json.loads(info_file.read_text(encoding="utf-8"))
            if info.get("key") != key:
                return None
            image = read_image(image_file)
        except Exception:  # missing, unreadable or foreign: render it again
            return None
        if image.shape != (shape[0], shape[1], 3) or not np.all(np.isfinite(image)):
            return None
        return image, info

    def store(self, name: str, key: str, image: np.ndarray, info: dict) -> Path:
        self.folder.mkdir(parents=True, exist_ok=True)
        self.clean()
        image_file, info_file = self.entry(name, key)
        write_image(image_file, image)
        atomic.write_text(info_file,
                          json.dumps({**info, "key": key}, indent=2, sort_keys=True) + "\n")
        return image_file


class Halves:
    """A reference being put together: two independent halves, each the sum of its chunks."""

    def __init__(self, chunks: list[Chunk] = ()):
        self.sums: list[np.ndarray | None] = [None, None]
        self.counts = [0, 0]
        self.seconds = 0.0          # render time, compilation excluded
        self.compile_seconds = 0.0
        for chunk in chunks:
            self.add(chunk)

    def add(self, chunk: Chunk) -> None:
        """Add a chunk to its half in float64: the same chunks in the same order, the same bits."""
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
        return (sum(s for s in self.sums if s is not None) / self.spp).astype(np.float32)

    def noise(self) -> float:
        """Its relative MSE against the converged image, from its halves (NaN with one)."""
        if not all(self.counts):
            return math.nan
        return reference_noise(self.sums[0] / self.counts[0], self.sums[1] / self.counts[1],
                               *self.counts)


def probe(loaded, max_depth: int, most_spp: int, most_seconds: float,
          progress: bool = False) -> list[Chunk]:
    """Under ``--budget``, the first chunks of the first half: 1, 2, 4, ... spp until a third
    takes :data:`COMPARE_PROBE_SECONDS`, the next would pass ``most_spp`` or ``most_seconds``
    are spent; their times feed :func:`~whitted.compare.budget.fit_cost`."""
    start, chunks, spp = time.monotonic(), [], 1
    while True:
        chunks.append(render_chunk(loaded, spp, chunk_seed(0, len(chunks)), 0, max_depth, progress))
        # three renders: the cost of a sample is read between the last two (the first may
        # still pay for warm-up), once they are long enough to time
        enough = len(chunks) >= 3 and chunks[-1].seconds >= COMPARE_PROBE_SECONDS
        if enough or 2 * spp > most_spp or time.monotonic() - start >= most_seconds:
            return chunks
        spp *= 2


@dataclass
class ReferencePlan:
    """How a scene's reference is made, decided before the rest of the scene (plain data: on a
    cluster, one worker plans, any renders the chunks); ``spp`` 0: none, ``notes`` say why."""
    planned: int
    spp: int
    key: str
    cached: tuple[np.ndarray, dict] | None = None
    probes: list[Chunk] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    began: float = field(default_factory=time.time)
    enough: bool = False   # its spp: as many as its noise needs (enough_spp), not more

    def chunks(self, chunk_spp: int) -> list[tuple[int, int, int]]:
        if not self.spp or self.cached is not None:
            return []
        return reference_chunks(self.planned, chunk_spp, [c.planned for c in self.probes])


def plan_reference(scene: SceneFile, loaded, entry: SceneResult, cache: ReferenceCache,
                   options: Options, seconds: float = math.inf) -> ReferencePlan:
    """The plan of the scene's reference within ``seconds``, its share of ``--budget``
    (``math.inf``: nothing is rendered). A cached reference is used as it is; under a
    budget, one that is not is probed and planned at the spp the budget affords, or none."""
    def lookup(spp: int, enough: bool = False) -> tuple[str, tuple[np.ndarray, dict] | None]:
        key = cache.key(scene, reference_settings(entry, spp, enough))
        return key, cache.load(entry.name, key, (entry.height, entry.width))

    start, began = time.monotonic(), time.time()
    requested, chunk_spp = options.reference_spp, options.reference_chunk_spp
    # as many spp as its noise needs: always without --budget, and within it under --quick
    enough = ((not math.isfinite(seconds) or options.quick) and loaded is not None
              and requested > COMPARE_REFERENCE_START_SPP)
    key, cached = lookup(requested, enough)
    if cached is not None or not math.isfinite(seconds) and not enough:
        return ReferencePlan(requested, requested, key, cached, began=began, enough=enough)
    if enough and not math.isfinite(seconds):
        spp, probes = enough_spp(loaded, entry, requested)
        return ReferencePlan(spp, spp, key, None, probes, began=began, enough=True)
    if seconds <= 0:
        return ReferencePlan(requested, 0, key, began=began, notes=[
            "skipped whole: no time was left to render its reference"])
    pixels = entry.width * entry.height
    if enough:   # what its noise needs is asked for; its two probes time a sample (a = 0)
        requested, probes = enough_spp(loaded, entry, requested)
    else:
        pass_spp = rendering.path_passes(requested, pixels)[0]  # the most spp of one pass
        probes = probe(loaded, entry.path_depth,
                       most_spp=min(pass_spp, max(1, requested // 4), chunk_spp),
                       most_seconds=COMPARE_REFERENCE_SHARE * seconds / 4, progress=not options.quiet)
    overhead, per_spp = fit_cost([(c.spp, c.seconds) for c in probes])
    done = [c.planned for c in probes]

    def cost(spp: int) -> float:  # what the rest of an spp-sample reference costs
        return sum(render_cost(n, len(rendering.path_passes(n, pixels)), overhead, per_spp)
                   for n, _, _ in reference_chunks(spp, chunk_spp, done))

    fitted = Budget.reference_spp(requested, cost, seconds, spent=time.monotonic() - start)
    if enough and fitted == requested:
        return ReferencePlan(fitted, fitted, key, None, probes, began=began, enough=True)
    last = probes[-1]
    estimate = (f"probe renders of 1–{last.spp} spp: {seconds_text(overhead)} a render "
                f"plus {seconds_text(per_spp)} per spp" if overhead > 0 else
                f"a {last.spp}-spp probe took {seconds_text(last.seconds)}")
    if fitted is None:
        return ReferencePlan(requested, 0, key, began=began, notes=[
            f"skipped whole: its reference would take about "
            f"{seconds_text(cost(requested))} at {requested} spp ({estimate}); the scene's "
            f"{seconds_text(seconds)} share of --budget {options.budget:g} s affords less than "
            f"the {COMPARE_MIN_REFERENCE_SPP} spp a usable reference needs: raise --budget "
            f"or lower --reference-spp"])
    notes = []
    if fitted < requested:
        notes.append(
            f"reference scaled down from {requested} to {fitted} spp to fit --budget "
            f"{options.budget:g} s ({estimate}: {requested} spp would take about "
            f"{seconds_text(cost(requested))}, {fitted} spp "
            f"{'about ' + seconds_text(cost(fitted)) if cost(fitted) else 'rendered already by the probes'})")
    # a half the probe filled already may hold more than half of ``fitted``
    spp = sum(n for n, _, _ in done + reference_chunks(fitted, chunk_spp, done))
    if spp != requested:
        key, cached = lookup(spp)
    return ReferencePlan(fitted, spp, key, cached, [] if cached else probes, notes, began)


def enough_spp(loaded, entry: SceneResult, most: int) -> tuple[int, list[Chunk]]:
    """The reference's spp when its noise need only be below COMPARE_REFERENCE_NOISE_SHARE of
    the smallest Whitted error it scores: its first COMPARE_REFERENCE_START_SPP samples, in two
    halves (kept: its first chunks), give its noise per sample; each Whitted method's 1-spp
    render at the scene's depth (the reference's), scored against them less that noise, the
    error. The power of two that gets there, at most ``most``; with the chunks rendered."""
    start = COMPARE_REFERENCE_START_SPP
    probes = [render_chunk(loaded, start // 2, chunk_seed(half, 0), half, entry.path_depth)
              for half in (0, 1)]
    halves = Halves(probes)
    noise, image = halves.noise(), halves.image()
    errors = [metrics.relative_mse(np.asarray(rendering.render(
        loaded, integrator="whitted", spp=1, max_depth=entry.path_depth, lighting=lighting, seed=0,
        progress=False).image, dtype=np.float32), image) for lighting in LIGHTING_MODES]
    wanted = COMPARE_REFERENCE_NOISE_SHARE * (min(errors) - noise)
    spp = start
    while spp < most and not (wanted > 0 and noise * start / spp <= wanted):
        spp *= 2
    return min(spp, most), probes


def reference_image(scene: SceneFile, loaded, entry: SceneResult, cache: ReferenceCache,
                    options: Options, seconds: float = math.inf, plan: ReferencePlan | None = None,
                    chunks: list[Chunk] | None = None) -> np.ndarray | None:
    """The scene's reference, cached or rendered as ``plan`` (made here when None) says,
    ``chunks`` rendered elsewhere if given; None when the plan has none. Records in
    ``entry`` the notes, where it lies, its spp, noise and cost."""
    if plan is None:
        plan = plan_reference(scene, loaded, entry, cache, options, seconds)
    entry.notes.extend(plan.notes)
    if not plan.spp:
        return None
    entry.reference_enough = plan.enough
    if plan.cached is not None:
        image, info = plan.cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
        entry.reference_noise = float(info.get("noise_rel_mse", math.nan))
        entry.reference_spp = int(info.get("settings", {}).get("spp", plan.spp))
    else:
        planned = plan.chunks(options.reference_chunk_spp)
        if not options.quiet:
            print(f"whitted compare: {entry.name}: rendering the reference "
                  f"(path tracer, {plan.spp} spp in two halves)", file=sys.stderr)
        if chunks is None:   # one bar for the whole reference, not one per chunk
            with progress_bar(not options.quiet, sum(c[0] for c in planned), f"{entry.name}: reference",
                              unit="spp", unit_scale=False) as bar:
                chunks = []
                for chunk in planned:
                    chunks.append(render_chunk(loaded, *chunk, entry.path_depth))
                    bar.update(chunk[0])
        if [c.planned for c in chunks] != planned:
            raise ValueError("the reference's chunks are not those its plan makes")
        chunks = plan.probes + chunks
        halves = Halves(chunks)
        image = halves.image()
        entry.reference_spp = halves.spp
        entry.reference_seconds = halves.seconds
        entry.reference_noise = halves.noise()
        cache.store(entry.name, plan.key, image, {
            "scene": str(entry.path),
            "settings": reference_settings(entry, halves.spp, plan.enough),
            "seconds": halves.seconds, "compile_seconds": halves.compile_seconds,
            "noise_rel_mse": entry.reference_noise, "spp_per_half": halves.counts,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "chunks": [{"spp": c.spp, "seed": c.seed, "half": c.half, "seconds": c.seconds,
                        "worker": c.worker} for c in chunks]})
    entry.reference_file = cache.entry(entry.name, plan.key)[0]
    return image
