"""The rendering API: ``whitted.render`` (the ``whitted render`` command is in
:mod:`whitted.commands`).

:func:`render` renders a loaded ``mi.Scene`` with the article's model (the
``whitted`` integrator) or with Mitsuba's stock ``path`` integrator, and
reports timings and statistics.

Timing. ``seconds`` is the wall-clock time of the whole render (tracing
kernels, Python, reading the image back) minus the time Dr.Jit spent
compiling kernels, which is reported separately as ``compile_seconds``. The
compile time is measured, not estimated: Dr.Jit's kernel history records, for
every kernel launched, the time its backend (LLVM or the CUDA/OptiX JIT) took
to compile it, zero when the kernel came from the in-memory or on-disk cache.
In ``scalar_rgb`` nothing is compiled.

Statistics (``result.stats``, written by ``--stats FILE.json``)::

    {"rays": {"camera", "shadow", "reflection", "refraction"}, "merged_rays", "spp",
     "seconds", "compile_seconds", "effects": [...], "max_depth_reached",
     "peak_memory_bytes", "peak_resident_bytes", "min_weight", "culled_rays", "culled_weight",
     "error_bound"}

``merged_rays`` counts the rays that carried both a reflected and a
refracted share (total internal reflection sends the refracted share along
the mirror direction: one ray, traced once, counted in both ``reflection``
and ``refraction``); the rays traced are the sum of ``rays`` minus it.

``spp`` is the samples per pixel rendered (the path tracer's at least
``defaults.PATH_MIN_SPP`` when none is asked for).

``min_weight`` is the adaptive depth control's setting (0: off), ``culled_rays`` the
reflected and refracted rays it left untraced, ``culled_weight`` their path weights' sum
and ``error_bound`` the most it can have changed any pixel (plugins/recursion.py
derives the bound).

``peak_memory_bytes`` is, in the JIT variants, the high-water mark of Dr.Jit's
memory allocator during the render (every array Dr.Jit holds: the scene's
own arrays, the wavefronts and the image; not Embree's or OptiX's
acceleration structures, nor Python's heap); its cache is flushed before the
render so that the mark starts from what is really in use. In
``scalar_rgb``, where Dr.Jit allocates nothing, it is ``peak_resident_bytes``.
``peak_resident_bytes`` is what the operating system counts: the process's
peak resident set size during the render (on Linux; elsewhere over the
process's life; see :func:`peak_resident_bytes`), everything included. ``whitted
render`` extends it to the end of writing the image.

Mitsuba's ``path`` integrator counts none of its rays, so its stats hold what is
known without it: ``rays`` is ``{"camera": N}`` (the camera samples), with
``seconds``, ``compile_seconds``, ``effects`` (what the scene calls for) and the
memory entries; the entries that describe the Whitted ray tree
(``max_depth_reached``, ``merged_rays`` and the adaptive depth control's) are
absent.
"""

from __future__ import annotations

import contextlib
import resource
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import defaults as D
from .errors import WhittedError
from .progress import progress_bar

#: camera samples per ``mi.render`` call of the path tracer (bounds its memory)
PATH_SAMPLES_PER_PASS = 1 << 20


@dataclass
class RenderResult:
    """What :func:`render` returns (the integrator's own account of a render, which this is
    made from, is ``plugins/integrator.py``'s ``DetailedRender``).

    =================== ==============================================================
    ``image``           float32 (H, W, 3), linear RGB
    ``seconds``         render time, kernel compilation excluded
    ``compile_seconds`` kernel compilation (0 when every kernel was cached)
    ``stats``           see the module docstring
    ``cpu_seconds``     the process's CPU time (every thread's), compilation excluded
    =================== ==============================================================
    """

    image: np.ndarray        # float32 (H, W, 3), linear RGB
    seconds: float           # render time, kernel compilation excluded
    compile_seconds: float   # kernel compilation (0 when every kernel was cached)
    stats: dict              # see the module docstring
    cpu_seconds: float = float("nan")   # the process's CPU time (every thread's), compilation excluded


def integrator_of(scene):
    """The scene's own ``whitted`` integrator, else one with the default settings."""
    import mitsuba as mi

    from .plugins import whitted_or_none
    own = whitted_or_none(scene.integrator())
    if own is not None:
        return own
    with quiet_mitsuba():
        return mi.load_dict({"type": "whitted"})


def whitted_settings(scene) -> dict:
    """The scene's own Whitted settings (its integrator's properties), else the defaults."""
    return integrator_of(scene).settings()


@contextlib.contextmanager
def quiet_mitsuba():
    """Silence Mitsuba's warnings (e.g. that a Python integrator is slow in scalar mode)."""
    import mitsuba as mi
    logger = mi.logger() if hasattr(mi, "logger") else mi.Thread.thread().logger()
    level = logger.log_level()
    logger.set_log_level(mi.LogLevel.Error)
    try:
        yield
    finally:
        logger.set_log_level(level)


def check_settings(spp, max_depth, lighting, integrator, min_weight=None, without=None) -> None:
    """Every rendering option validated once (the API and the CLI call this)."""
    D.check_integrator(integrator)
    if D.check_without(without, "--without") and integrator != "whitted":
        raise WhittedError("--without applies to the whitted integrator only; the path tracer "
                           "simulates what the scene holds")
    if spp is not None:
        D.check_spp(spp)
    if max_depth is not None:
        D.check_depth(max_depth)
    if lighting is not None:
        D.check_lighting(lighting)
        if integrator != "whitted":
            raise WhittedError("--lighting applies to the whitted integrator only; "
                               "the path tracer is always physical")
    if min_weight is not None:
        D.check_min_weight(min_weight)
        if integrator != "whitted" and min_weight > 0:
            raise WhittedError("a min weight (adaptive depth control) applies to the whitted "
                               "integrator only; the path tracer ends paths by Russian roulette")


class Clock:
    """Wall time, CPU time and kernel compilation time of a block of work; with
    ``fresh_memory``, its own peak memory, from a freshly emptied allocator cache (without,
    the process's peak so far: a timed render skips the flush and the reset)."""

    def __init__(self, fresh_memory: bool = True):
        self.fresh_memory = fresh_memory

    def __enter__(self):
        import drjit as dr
        import mitsuba as mi
        self.jit = dr.is_jit_v(mi.Float)
        if self.jit:
            self.backend = dr.backend_v(mi.Float)
            self._flag = dr.scoped_set_flag(dr.JitFlag.KernelHistory, True)
            self._flag.__enter__()
            dr.eval()
            dr.sync_thread()
            dr.kernel_history_clear()
            if self.fresh_memory:
                dr.flush_malloc_cache()
            dr.detail.malloc_clear_statistics()
        if self.fresh_memory:   # else the peak stays the process's (nothing asks for it)
            reset_peak()
        self.start = time.perf_counter()
        self.cpu_start = time.process_time()
        return self

    def __exit__(self, *exc):
        import drjit as dr
        self.wall = time.perf_counter() - self.start
        self.cpu = time.process_time() - self.cpu_start
        self.compile = 0.0
        self.peak_resident = peak_resident_bytes()
        if self.jit:
            history = dr.kernel_history()
            self._flag.__exit__(*exc)
            self.compile = sum(k.get("backend_time", 0.0) for k in history) / 1000.0
            self.peak_memory = int(dr.detail.malloc_watermark(self.backend))
        else:
            self.peak_memory = self.peak_resident
        return False

    @property
    def seconds(self) -> float:
        return max(0.0, self.wall - self.compile)

    @property
    def cpu_seconds(self) -> float:
        return max(0.0, self.cpu - self.compile)   # compiling is one thread's work


def render(scene, integrator: str = D.INTEGRATOR, spp: int | None = None, max_depth: int | None = None,
           lighting: str | None = None, progress: bool = False, seed: int = 0,
           min_weight: float | None = None, ambient: float | None = None, *,
           without=None, fresh_memory: bool = True) -> RenderResult:
    """Render ``scene`` (a ``mi.Scene``); see the module docstring and docs/CONTRACTS.md.

    ``seed``: any integer from 0 to 2^64 - 1 (:func:`whitted.defaults.check_seed` folds it
    to Mitsuba's 32 bits); with one sample per pixel the whitted integrator takes none (every
    ray passes through its pixel's center: the scene format's rule).
    ``spp``, ``max_depth`` (the article's depth, primary rays being depth 1),
    ``lighting``, ``min_weight`` (the Whitted integrator's adaptive depth
    control, 0 = off) and ``ambient`` (the article's A, whitted only) default to
    the scene's own settings; but the path tracer without ``spp`` takes at least
    ``defaults.PATH_MIN_SPP`` (64) samples per pixel, not a scene's 1 (pass ``spp``
    to choose: noise falls as 1/spp). ``without`` (whitted only): the effects to leave out,
    as if the scene lacked them (``"shadows,reflection"`` or names of
    ``defaults.SWITCHABLE_EFFECTS``; plugins/scene_tables.py says what each means); None:
    the scene's own (none unless its integrator says). ``integrator="path"``
    uses Mitsuba's ``path`` integrator with ``max_depth + 1`` (one more
    segment for the connection to a light); a scene whose own integrator is
    ``path`` (a portable scene) is rendered with it unless ``max_depth`` is given.
    The whitted integrator refuses a scene without the ``article`` BSDF.
    ``fresh_memory``: hand Dr.Jit's cached memory back to the system first, so that the
    peak memory figures are this render's own (True); False keeps the cache, as a program
    rendering again and again would (``whitted compare`` times renders so), and the peak
    figures are then the process's so far.
    """
    check_settings(spp, max_depth, lighting, integrator, min_weight, without)
    return render_checked(scene, integrator, spp, max_depth, lighting, progress, seed, min_weight, ambient,
                          without=without, fresh_memory=fresh_memory)


def render_checked(scene, integrator: str = D.INTEGRATOR, spp: int | None = None,
                   max_depth: int | None = None, lighting: str | None = None, progress: bool = False,
                   seed: int = 0, min_weight: float | None = None,
                   ambient: float | None = None, *, without=None, fresh_memory: bool = True) -> RenderResult:
    """:func:`render` for settings :func:`check_settings` has passed already (the CLI checks
    them before it loads the scene): checked once."""
    seed = D.check_seed(seed)
    spp_asked = spp
    if not scene.sensors():
        raise WhittedError("the scene has no sensor (camera) to render from")
    own = integrator_of(scene)
    settings = own.settings()
    depth = int(max_depth) if max_depth is not None else settings["max_depth"]
    sensor = scene.sensors()[0]
    spp = int(spp) if spp is not None else sensor.sampler().sample_count()
    if integrator == "path" and spp_asked is None:
        spp = max(spp, D.PATH_MIN_SPP)
    width, height = (int(c) for c in sensor.film().crop_size())

    if integrator == "whitted":
        from .plugins.film import sample_count
        spp = sample_count(sensor, spp)   # as the sampler rounds it (stratified: 8 are 9)
        tables = check_article_materials(scene)   # found once: the render takes them
        min_weight = float(min_weight) if min_weight is not None else settings["min_weight"]
        ambient = D.check_ambient(ambient, "ambient") if ambient is not None else settings["ambient"]
        with quiet_mitsuba():
            whitted = own.with_settings(max_depth=depth, lighting=lighting or settings["lighting"],
                                        min_weight=min_weight, ambient=ambient,
                                        without=settings["without"] if without is None
                                        else D.check_without(without, "without"))
        with progress_bar(progress, width * height * spp, "render") as bar, Clock(fresh_memory) as clock:
            rendering = whitted.render_detailed(scene, sensor, seed=seed, spp=spp, progress=bar.update,
                                               tables=tables)
            # The developed image's own memory, not a copy (a 16384² image is 3 GiB).
            image = np.asarray(rendering.image, dtype=np.float32)
        rays = rendering.rays
        stats_rays, effects, reached = rays.rays(), list(rendering.effects), rays.max_depth_reached
        adaptive = {"max_depth_reached": reached, "merged_rays": rays.merged, "min_weight": min_weight,
                    "culled_rays": rays.culled, "culled_weight": rays.culled_weight,
                    "error_bound": rendering.error_bound}
    else:
        path = _path_integrator(scene, max_depth, depth)
        with progress_bar(progress, width * height * spp, "path tracing") as bar, Clock(fresh_memory) as clock:
            image = _render_path(scene, path, sensor, spp, seed, bar.update)
        # Mitsuba's path tracer counts nothing: only what the caller knows is reported.
        stats_rays, effects = {"camera": width * height * spp}, _effects_or_none(scene, depth)
        adaptive = {}

    image = image[..., :3]
    stats = {"rays": stats_rays, "spp": spp, "seconds": clock.seconds, "compile_seconds": clock.compile,
             "effects": effects, "peak_memory_bytes": clock.peak_memory,
             "peak_resident_bytes": clock.peak_resident, **adaptive}
    return RenderResult(np.ascontiguousarray(image), clock.seconds, clock.compile, stats, clock.cpu_seconds)


def check_article_materials(scene, name: str | None = None):
    """One clean error (naming the scene file ``name`` when given) unless the whitted
    integrator can render ``scene`` (:func:`whitted.plugins.check_scene`: the ``article``
    BSDF on every shape, point lights); this adds the file and what to do instead.
    Returns the scene's tables, for the render."""
    from .plugins import check_scene
    try:
        return check_scene(scene)
    except WhittedError as error:
        raise WhittedError(f"{name + ': ' if name else ''}{error} (Mitsuba's stock materials, a "
                           "portable scene? use the path integrator (--integrator path), or the "
                           "default XML)") from None


def _path_integrator(scene, max_depth: int | None, depth: int):
    """The path tracer for the article's ``depth``: the scene's own stock ``path``
    integrator when it has one and no depth is asked for (a portable scene's, whose
    ``max_depth`` is already the article's depth + 1), else a new one."""
    import mitsuba as mi
    own = scene.integrator()
    if max_depth is None and own is not None and own.class_name() == "PathIntegrator":
        return own
    return mi.load_dict({"type": "path", "max_depth": D.path_depth(depth)})


def path_passes(spp: int, pixels: int) -> list[int]:
    """The samples per pixel of each pass of the path tracer: powers of two, each pass
    at most :data:`PATH_SAMPLES_PER_PASS` camera samples (but at least 1 spp).

    Why powers of two: the LLVM backend runs a kernel in blocks of a power of two of
    lanes spread over its threads, and a pixel's samples are consecutive lanes. When
    a pass's spp is a power of two, every pixel's samples lie in one block and are
    added into the film by one thread in a fixed order, so the image depends only on
    the seed: bit-identical from run to run, process to process, and for any thread
    count. With 10 spp a pixel can straddle two blocks, and its sum then depends on
    which thread finishes first (a difference in the last bit), which would make two
    runs of ``whitted compare`` differ.
    """
    most = max(1, min(spp, PATH_SAMPLES_PER_PASS // pixels))
    most = 1 << (most.bit_length() - 1)
    passes = [most] * (spp // most)
    rest = spp % most
    while rest:
        passes.append(1 << (rest.bit_length() - 1))
        rest -= passes[-1]
    return passes


def _render_path(scene, integrator, sensor, spp, seed, progress) -> np.ndarray:
    """Mitsuba's path tracer in passes of whole samples per pixel (:func:`path_passes`),
    averaged."""
    import mitsuba as mi
    width, height = (int(c) for c in sensor.film().crop_size())
    total = None
    own_spp = sensor.sampler().sample_count()   # mi.render changes it: put it back after
    try:
        for k, n in enumerate(path_passes(spp, width * height)):
            # Distinct seeds per pass: passes are independent estimates (a single
            # pass is exactly mi.render with the caller's seed).
            pass_seed = seed if k == 0 else (seed * D.SEED_STRIDE + k) & 0xFFFFFFFF
            image = np.array(mi.render(scene, sensor=sensor, integrator=integrator, spp=n,
                                       seed=pass_seed), dtype=np.float64)
            total = image * n if total is None else total + image * n
            progress(n * width * height)
    finally:
        sensor.sampler().set_sample_count(own_spp)
    return (total / spp).astype(np.float32)


def _effects_or_none(scene, depth: int) -> list:
    """The effects of an article scene (for the stats of a path-traced render), else []."""
    from .plugins import scene_effects
    try:
        return list(scene_effects(scene, depth))
    except WhittedError:
        return []


# The process's resident memory and its peak. Dr.Jit's allocator high-water mark counts
# Dr.Jit's arrays only, not numpy, bitmaps, Embree, LLVM or Python (benchmarks/RESULTS.md,
# "Peak memory of a large render"). Linux keeps the peak resident set (``VmHWM``) and lets a
# process reset it (``5`` into ``/proc/self/clear_refs``); elsewhere the peak is the whole
# life's (``getrusage``). The reset also resets what ``getrusage``, ``wait4`` and GNU
# ``time`` report: each render resets it, so a ``whitted render`` process's peak is its
# render's.


_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


def _status(key: str) -> int | None:
    """A ``kB`` entry of /proc/self/status in bytes (None where there is none)."""
    with contextlib.suppress(OSError):
        for line in _STATUS.read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return None


def resident_bytes() -> int | None:
    """The process's resident set size now (Linux; None elsewhere)."""
    return _status("VmRSS")


def reset_peak() -> None:
    """Start measuring the peak resident size afresh (Linux; elsewhere nothing happens)."""
    with contextlib.suppress(OSError):
        _CLEAR_REFS.write_text("5")


def peak_resident_bytes() -> int:
    """The process's peak resident set size since :func:`reset_peak` (Linux), or over its
    whole life (elsewhere)."""
    peak = _status("VmHWM")
    if peak is not None:
        return peak
    maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(maxrss) if sys.platform == "darwin" else int(maxrss) * 1024
