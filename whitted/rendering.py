"""``whitted.render``: a loaded ``mi.Scene`` rendered with the article's model or Mitsuba's
``path`` integrator, timed apart from kernel compilation, with the statistics of
docs/statistics.md.
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
from . import interrupt
from .errors import WhittedError
from .progress import progress_bar

#: camera samples per ``mi.render`` call of the path tracer (bounds its memory)
PATH_SAMPLES_PER_PASS = 1 << 20


@dataclass
class RenderResult:
    image: np.ndarray        # float32 (H, W, 3), linear RGB
    seconds: float           # render time, kernel compilation excluded
    compile_seconds: float   # kernel compilation (0 when every kernel was cached)
    stats: dict              # docs/statistics.md
    cpu_seconds: float = float("nan")   # the process's CPU time (every thread's), compilation excluded


def whitted_settings(scene) -> dict:
    """The scene's own Whitted settings (its integrator's properties), else the defaults."""
    from .plugins import whitted_or_none
    own = whitted_or_none(scene.integrator())
    if own is not None:
        return own.settings()
    return {**D.WHITTED_DEFAULTS, "without": (), "exact_spheres": []}


#: how :func:`whitted_integrator` takes each setting it may change
_SETTING_TYPES = {"max_depth": int, "lighting": str, "min_weight": float,
                  "ambient": D.check_ambient, "without": D.check_without}


def whitted_integrator(scene, **changes):
    """The scene's ``whitted`` integrator (else a default one), ``changes`` not None applied."""
    import mitsuba as mi

    from .plugins import whitted_or_none
    changes = {name: _SETTING_TYPES[name](value) for name, value in changes.items()
               if value is not None}
    own = whitted_or_none(scene.integrator())
    with quiet_mitsuba():
        if own is not None:
            return own.with_settings(**changes)
        if "without" in changes:
            changes["without"] = ",".join(changes["without"])
        return mi.load_dict({"type": "whitted", **changes})


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


def check_settings(spp, max_depth, lighting, integrator, min_weight=None, without=None,
                   ambient=None) -> None:
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
    if ambient is not None:
        D.check_ambient(ambient)


class Clock:
    """Wall, CPU and kernel compilation time of a block of work, and its peak memory (without
    ``fresh_memory``: the process's so far, sparing a timed render the flush)."""

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
        if self.fresh_memory:
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
    """Render ``scene`` (a ``mi.Scene``), settings left None as the scene's."""
    check_settings(spp, max_depth, lighting, integrator, min_weight, without, ambient)
    check_loaded(scene)
    return render_checked(scene, integrator, spp, max_depth, lighting, progress, seed, min_weight, ambient,
                          without=without, fresh_memory=fresh_memory)


def render_checked(scene, integrator: str = D.INTEGRATOR, spp: int | None = None,
                   max_depth: int | None = None, lighting: str | None = None, progress: bool = False,
                   seed: int = 0, min_weight: float | None = None,
                   ambient: float | None = None, *, without=None, fresh_memory: bool = True) -> RenderResult:
    """:func:`render` for settings :func:`check_settings` has passed (the CLI checks them first)."""
    interrupt.check()   # a stop swallowed since the last render
    seed = D.check_seed(seed)
    if not scene.sensors():
        raise WhittedError("the scene has no sensor (camera) to render from")
    depth = int(max_depth) if max_depth is not None else whitted_settings(scene)["max_depth"]
    sensor = scene.sensors()[0]
    if spp is None and integrator == "path":
        spp = max(sensor.sampler().sample_count(), D.PATH_MIN_SPP)
    spp = int(spp) if spp is not None else sensor.sampler().sample_count()
    width, height = (int(c) for c in sensor.film().crop_size())

    if integrator == "whitted":
        from .plugins.film import sample_count
        spp = sample_count(sensor, spp)   # as the sampler rounds it (stratified: 8 are 9)
        tables = check_article_materials(scene)   # found once: the render takes them
        whitted = whitted_integrator(scene, max_depth=depth, lighting=lighting,
                                     min_weight=min_weight, ambient=ambient, without=without)
        with progress_bar(progress, width * height * spp, "render") as bar, Clock(fresh_memory) as clock:
            rendering = whitted.render_detailed(scene, sensor, seed=seed, spp=spp, progress=bar.update,
                                               tables=tables)
            # The developed image's own memory, not a copy (a 16384² image is 3 GiB).
            image = np.asarray(rendering.image, dtype=np.float32)
        rays = rendering.rays
        stats_rays, effects = rays.rays(), list(rendering.effects)
        adaptive = {"max_depth_reached": rays.max_depth_reached, "merged_rays": rays.merged,
                    "min_weight": whitted.min_weight, "culled_rays": rays.culled,
                    "culled_weight": rays.culled_weight, "error_bound": rendering.error_bound}
    else:
        import mitsuba as mi

        from .plugins import scene_effects
        path = scene.integrator()   # the scene's own path tracer when no depth is asked for
        if max_depth is not None or path is None or path.class_name() != "PathIntegrator":
            path = mi.load_dict({"type": "path", "max_depth": D.path_depth(depth)})
        with progress_bar(progress, width * height * spp, "path tracing") as bar, Clock(fresh_memory) as clock:
            image = _render_path(scene, path, sensor, spp, seed, bar.update)
        # Mitsuba's path tracer counts nothing: only what the caller knows is reported.
        stats_rays = {"camera": width * height * spp}
        adaptive = {}
        try:
            effects = list(scene_effects(scene, depth))
        except WhittedError:
            effects = []

    image = image[..., :3]
    stats = {"rays": stats_rays, "spp": spp, "seconds": clock.seconds, "compile_seconds": clock.compile,
             "effects": effects, "peak_memory_bytes": clock.peak_memory,
             "peak_resident_bytes": clock.peak_resident, **adaptive}
    return RenderResult(np.ascontiguousarray(image), clock.seconds, clock.compile, stats,
                        clock.cpu_seconds)


def check_loaded(scene) -> None:
    """``scene`` is a ``mi.Scene`` of the current variant, or an error saying what it is."""
    import mitsuba as mi
    if isinstance(scene, mi.Scene):
        return
    if type(scene).__name__ == "Scene" and type(scene).__module__.startswith("mitsuba"):
        raise WhittedError(f"the scene was loaded in another Mitsuba variant than the current one, "
                           f"{mi.variant()}: load it again (whitted.load_scene) after set_variant")
    raise WhittedError(f"render takes a mi.Scene (whitted.load_scene(path) loads one), "
                       f"got {type(scene).__name__}")


#: What to do about a scene of Mitsuba's stock materials, for render (``advice`` of
#: :func:`check_article_materials`).
STOCK_MATERIALS_ADVICE = ("Mitsuba's stock materials, a portable scene? use the path integrator "
                          "(--integrator path), or the default XML")


def check_article_materials(scene, name: str | None = None, advice: str = STOCK_MATERIALS_ADVICE):
    """The scene's tables (:func:`whitted.plugins.check_scene`), or an error saying what to do
    (``advice``: the calling command's, which may not have render's options)."""
    from .plugins import check_scene
    try:
        return check_scene(scene)
    except WhittedError as error:
        raise WhittedError(f"{name + ': ' if name else ''}{error} ({advice})") from None


def path_passes(spp: int, pixels: int) -> list[int]:
    """The spp of each path tracing pass (at most :data:`PATH_SAMPLES_PER_PASS` camera
    samples): powers of two, so one LLVM thread adds a pixel's samples (same bits anywhere)."""
    most = max(1, min(spp, PATH_SAMPLES_PER_PASS // pixels))
    most = 1 << (most.bit_length() - 1)
    passes = [most] * (spp // most)
    rest = spp % most
    while rest:
        passes.append(1 << (rest.bit_length() - 1))
        rest -= passes[-1]
    return passes


def _render_path(scene, integrator, sensor, spp, seed, progress) -> np.ndarray:
    import mitsuba as mi
    width, height = (int(c) for c in sensor.film().crop_size())
    total = None
    own_spp = sensor.sampler().sample_count()   # mi.render changes it: put it back after
    try:
        for k, n in enumerate(path_passes(spp, width * height)):
            pass_seed = seed if k == 0 else (seed * D.SEED_STRIDE + k) & 0xFFFFFFFF
            image = np.array(mi.render(scene, sensor=sensor, integrator=integrator, spp=n,
                                       seed=pass_seed), dtype=np.float64)
            total = image * n if total is None else total + image * n
            progress(n * width * height)
    finally:
        sensor.sampler().set_sample_count(own_spp)
    return (total / spp).astype(np.float32)


# The process's resident memory and its peak: Linux keeps the peak (``VmHWM``) and lets a
# process reset it; elsewhere it is the whole life's (``getrusage``).
def _status(key: str) -> int | None:
    with contextlib.suppress(OSError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return None


def resident_bytes() -> int | None:
    return _status("VmRSS")


def reset_peak() -> None:
    with contextlib.suppress(OSError):
        Path("/proc/self/clear_refs").write_text("5")


def peak_resident_bytes() -> int:
    """The process's peak resident set size since :func:`reset_peak` (Linux; elsewhere its life's)."""
    peak = _status("VmHWM")
    if peak is not None:
        return peak
    maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(maxrss) if sys.platform == "darwin" else int(maxrss) * 1024
