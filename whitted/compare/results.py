"""What a comparison is asked to do and what it measured: plain data only.

Every other part of ``whitted compare`` speaks in these types: the planner makes
:class:`Setting` lists, the sweep fills :class:`SceneResult` with
:class:`Measurement` s, and the reports (CSV, plot, contact sheet, table, and
any later one) read them. They import nothing of the rest of the command, so a
report never imports the sweep, and they hold no Mitsuba object, so they pickle:
a worker process can receive the settings and :class:`Options` and send a
:class:`SceneResult` back. The defaults of the command live here, once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..defaults import IN_PROCESS
from ..defaults import (COMPARE_MAX_DEFAULT_DEPTH as MAX_DEFAULT_DEPTH,
                        COMPARE_PATH_SPP as DEFAULT_PATH_SPP,
                        COMPARE_REFERENCE_CHUNK_SPP as DEFAULT_REFERENCE_CHUNK_SPP,
                        COMPARE_REFERENCE_SPP as DEFAULT_REFERENCE_SPP,
                        COMPARE_ROUNDS as DEFAULT_ROUNDS, COMPARE_WHITTED_SPP as DEFAULT_WHITTED_SPP,
                        LIGHTING_MODES, MAX_DEPTH, user_cache_folder)

if TYPE_CHECKING:
    import numpy as np



def method_of(integrator: str, lighting: str) -> str:
    """The name of the method that renders with ``integrator`` in ``lighting``:
    ``whitted-article``, ``whitted-physical`` or ``path`` (the path tracer has one
    lighting). Names are made here only; their parts are read from
    :data:`WHITTED_LIGHTING`, never parsed back out of the name."""
    return "path" if integrator == "path" else f"whitted-{lighting}"


#: Each Whitted method (the Whitted integrator in one lighting mode) -> its lighting mode.
WHITTED_LIGHTING = {method_of("whitted", lighting): lighting for lighting in LIGHTING_MODES}
#: The Whitted integrator in its two lighting modes, then the path tracer.
WHITTED_METHODS = tuple(WHITTED_LIGHTING)
METHODS = WHITTED_METHODS + ("path",)

__all__ = ["DEFAULT_PATH_SPP", "DEFAULT_REFERENCE_CHUNK_SPP", "DEFAULT_REFERENCE_SPP",
           "DEFAULT_ROUNDS", "DEFAULT_WHITTED_SPP", "IN_PROCESS", "MAX_DEFAULT_DEPTH", "MAX_DEPTH",
           "METHODS", "WHITTED_LIGHTING", "WHITTED_METHODS", "Comparison", "Limit", "Measurement",
           "Options", "SceneResult", "Setting", "method_of", "seconds_text"]


@dataclass(frozen=True)
class Setting:
    """One point of the sweep: one render's parameters.

    ============== ===================================================================
    ``integrator`` ``"whitted"`` or ``"path"``
    ``lighting``   ``"article"`` or ``"physical"`` (the path tracer is always physical)
    ``spp``        samples per pixel
    ``max_depth``  the ray tree's depth, primary rays have depth 1 (both integrators)
    ============== ===================================================================
    """
    integrator: str
    lighting: str
    spp: int
    max_depth: int

    @property
    def method(self) -> str:
        """One of :data:`METHODS`."""
        return method_of(self.integrator, self.lighting)

    @property
    def label(self) -> str:
        """A short caption: ``d3 · 4 spp``, or ``64 spp`` for the path tracer."""
        return f"{self.spp} spp" if self.integrator == "path" else f"d{self.max_depth} · {self.spp} spp"

    @property
    def short_label(self) -> str:
        """The plot's label: ``d3·4`` (depth · spp) for Whitted, ``64`` (spp) for the path tracer."""
        return f"{self.spp}" if self.integrator == "path" else f"d{self.max_depth}·{self.spp}"

    @property
    def slug(self) -> str:
        """A file name stem: ``whitted-article-d3-4spp``, ``path-64spp``."""
        return f"path-{self.spp}spp" if self.integrator == "path" else f"{self.method}-d{self.max_depth}-{self.spp}spp"


@dataclass
class Measurement:
    """One setting, rendered and scored against the reference, then timed in rounds.

    =================== ===============================================================
    ``setting``         what was rendered
    ``seconds``         its render time, compilation excluded: the median of its timed
                        rounds on the timing clock (:mod:`~whitted.compare.timing`), or
                        :attr:`render_seconds` where the scene got no round
    ``compile_seconds`` kernel compilation (its scored render's: the first)
    ``rel_mse``         relative MSE against the reference (:mod:`whitted.metrics`)
    ``flip``            LDR-FLIP against the reference
    ``work``            what the render does, independent of timing: the rays traced
                        (Whitted: camera, shadow, reflected and refracted, merged rays
                        once) or, for the path tracer, its camera samples
    ``thumbnail``       a small sRGB uint8 copy of the image (for the contact sheet)
    ``times``           its time in each timed round, in round order (the rounds of a
                        scene are the same moments for all its settings)
    ``image``           the render, linear EXR, relative to the output folder (None:
                        not kept)
    ``image_png``       the same as an sRGB PNG (for the report page)
    ``error_map``       FLIP's per-pixel error against the reference, colored (PNG)
    ``rel_mse_limit``   relative MSE against the method's limit (:class:`Limit`): what
                        the render's depth and spp cost (NaN: no limit, or the path tracer)
    ``render_seconds``  its scored render's wall time on all threads, compilation
                        excluded: what the time of other renders is predicted from
    =================== ===============================================================
    """
    setting: Setting
    seconds: float
    compile_seconds: float
    rel_mse: float
    flip: float
    work: int = 0
    thumbnail: np.ndarray | None = field(default=None, repr=False)
    times: tuple[float, ...] = ()
    image: str | None = None
    image_png: str | None = None
    error_map: str | None = None
    rel_mse_limit: float = math.nan
    render_seconds: float = math.nan

    @property
    def rounds(self) -> int:
        """How many timed rounds it has."""
        return len(self.times)

    def seconds_in(self, timed_round: int) -> float:
        """Its time in round ``timed_round`` (its :attr:`seconds` when it has no rounds; NaN
        when it missed that round)."""
        if not self.times:
            return self.seconds
        return self.times[timed_round] if timed_round < len(self.times) else math.nan

    @property
    def seconds_min(self) -> float:
        return min(self.times, default=self.seconds)

    @property
    def seconds_max(self) -> float:
        return max(self.times, default=self.seconds)


@dataclass
class Limit:
    """A Whitted method's limit on one scene: what it converges to with every ray of its
    tree (``min_weight`` 0) at the sweep's deepest depth and enough samples per pixel that
    anti-aliasing has converged. Against it, a render's error is what its depth and spp
    cost; its own error against the reference is the model's bias.

    =========================== =====================================================
    ``method``                  the Whitted method
    ``max_depth``, ``spp``      how it was rendered (``spp``: both halves together)
    ``noise``                   its own relative MSE against the converged limit,
                                estimated from its two halves (as for the reference)
    ``converged``               whether ``noise`` is below the share of the smallest
                                difference it measured (``COMPARE_LIMIT_NOISE_SHARE``)
    ``rel_mse``                 its relative MSE against the reference: the bias
    ``seconds``                 the render time of all its renders
    ``ambient``                 the scene's ambient A (article lighting; NaN otherwise)
    ``best_ambient``            the A in [0, 1] whose limit is closest to the reference
                                (article lighting; NaN otherwise)
    ``rel_mse_at_best_ambient`` that limit's relative MSE against the reference
    ``image``                   the limit, linear EXR, relative to the output folder
    ``fitted``                  the article's model fitted to the reference (colors,
                                ambient, light colors: :class:`.fitted.Fitted`; None:
                                not fitted)
    =========================== =====================================================
    """
    method: str
    max_depth: int
    spp: int
    noise: float
    converged: bool
    rel_mse: float
    seconds: float
    ambient: float = math.nan
    best_ambient: float = math.nan
    rel_mse_at_best_ambient: float = math.nan
    image: str | None = None
    fitted: object = None


@dataclass
class SceneResult:
    """What the sweep measured on one scene, and what it was asked to sweep there.

    ======================= ===========================================================
    ``name``                the scene's short, distinct name (its file stem)
    ``path``                the scene file
    ``width``, ``height``   the image size
    ``variant``             the Mitsuba variant of every render
    ``reference_spp``       the reference's samples per pixel
    ``path_depth``          the path tracer's (and the reference's) max depth
    ``reference_file``      the cached reference image (None: no time was left for it)
    ``reference_seconds``   its render time (NaN when unknown)
    ``reference_cached``    whether it was read from the cache
    ``reference_thumbnail`` a small sRGB copy (None: the scene got no reference)
    ``measurements``        the renders that were done, in the order done
    ``skipped``             the settings the budget left out
    ``whitted_spp``, ``path_spp``, ``depths``: the ladders that were planned
    ``reference_requested`` the reference spp asked for (``reference_spp`` is less when
                            ``--budget`` scaled it down)
    ``reference_noise``     the reference's own relative MSE against the converged
                            image, estimated from its two independent halves (NaN:
                            unknown); no render can score much below it
    ``reference_png``       the reference as an sRGB PNG, relative to the output folder
    ``notes``               one line each on what the budget did to this scene and why
    ``worker``              who rendered the sweep: a Dask worker's address, or
                            :data:`IN_PROCESS` (every setting of a scene is rendered
                            by one worker, so its times compare)
    ``limits``              Whitted method -> its :class:`Limit` (absent: not rendered)
    ``view``, ``exposure``  how every image of the scene is displayed (PNGs, page,
                            contact sheet) and what FLIP scores (:mod:`whitted.images`)
    ``reference_clipped``   the share of the reference's pixels plain sRGB would clip
    ======================= ===========================================================
    """
    name: str
    path: Path
    width: int
    height: int
    variant: str
    reference_spp: int
    path_depth: int
    reference_file: Path | None = None
    reference_seconds: float = math.nan
    reference_cached: bool = False
    reference_thumbnail: np.ndarray | None = field(default=None, repr=False)
    measurements: list[Measurement] = field(default_factory=list)
    skipped: list[Setting] = field(default_factory=list)
    whitted_spp: tuple[int, ...] = ()
    path_spp: tuple[int, ...] = ()
    depths: tuple[int, ...] = ()
    reference_requested: int = 0
    reference_noise: float = math.nan
    reference_png: str | None = None
    notes: list[str] = field(default_factory=list)
    worker: str = IN_PROCESS
    limits: dict[str, Limit] = field(default_factory=dict)
    view: str = "clip"
    exposure: float = 0.0
    reference_clipped: float = math.nan

    def __post_init__(self):
        if not self.reference_requested:
            self.reference_requested = self.reference_spp

    @property
    def folder(self) -> str:
        """Where this scene's renders lie, relative to the output folder."""
        return f"renders/{self.name.replace('/', '_')}"


@dataclass
class Options:
    """The command's options (``whitted compare --help`` describes each).

    ======================= ==========================================================
    ``out``                 the output folder
    ``reference_spp``       the reference's samples per pixel
    ``depths``              Whitted max depths (None: 1…the scene's depth, at most
                            :data:`MAX_DEFAULT_DEPTH`)
    ``whitted_spp``         the Whitted integrator's spp ladder
    ``path_spp``            the path tracer's spp ladder
    ``path_depth``          the path tracer's and reference's max depth (None: the
                            scene's)
    ``rounds``              timed rounds over a scene's settings, at least
                            (:mod:`~whitted.compare.timing`; more while a headline
                            is unsettled)
    ``budget``              seconds for the whole command (None: unbounded)
    ``levels``              relative MSE levels of the equal-quality table (None: from
                            the data, :func:`~whitted.compare.analysis.data_levels`)
    ``cache``               the reference cache's folder (None: the user's cache,
                            ``~/.cache/whitted/references``: shared by every run)
    ``variant``             the Mitsuba variant (None: as for ``whitted render``)
    ``quiet``               no progress bar or messages
    ``reference_chunk_spp`` the reference is rendered in chunks of at most this many
                            spp, each with its own seed, and averaged: the same chunks
                            in this process and on a cluster
    ``workers``             sweep on a local Dask cluster of this many worker
                            processes (None: in this process)
    ``scheduler``           sweep on the Dask cluster of this scheduler
                            (``tcp://host:port``; None: in this process)
    ``view``                how every image is displayed and FLIP scores it ("clip" or
                            "aces"; None: per scene, :func:`whitted.images.fitting_view`
                            of its reference)
    ``exposure``            the displayed images' exposure, in stops
    ``started``             when ``budget``'s clock started (``time.monotonic``; None:
                            when :func:`~whitted.compare.compare` is called)
    ======================= ==========================================================
    """
    out: Path
    reference_spp: int = DEFAULT_REFERENCE_SPP
    depths: tuple[int, ...] | None = None
    whitted_spp: tuple[int, ...] = DEFAULT_WHITTED_SPP
    path_spp: tuple[int, ...] = DEFAULT_PATH_SPP
    path_depth: int | None = None
    rounds: int = DEFAULT_ROUNDS
    budget: float | None = None
    levels: tuple[float, ...] | None = None
    cache: Path | None = None
    variant: str | None = None
    quiet: bool = False
    reference_chunk_spp: int = DEFAULT_REFERENCE_CHUNK_SPP
    workers: int | None = None
    scheduler: str | None = None
    view: str | None = None
    exposure: float = 0.0
    started: float | None = None

    @property
    def cache_folder(self) -> Path:
        """Where references are cached: ``cache``, or the user's cache folder
        (:func:`whitted.defaults.user_cache_folder`), so that a second run of the same scene
        into another output folder renders no reference again."""
        return Path(self.cache) if self.cache is not None else user_cache_folder() / "references"


class Comparison(list):
    """What :func:`whitted.compare.compare` returns: the scenes' results (a list of
    :class:`SceneResult`, in the order given), with ``analyses`` (one
    :class:`~whitted.compare.analysis.Analysis` per scene that got a reference) and
    ``findings`` (the run's conclusions, the content of ``findings.json``)."""

    def __init__(self, entries: list[SceneResult], analyses: list, findings: dict):
        super().__init__(entries)
        self.analyses = analyses
        self.findings = findings


def seconds_text(value: float) -> str:
    """A duration for people, three significant digits: ``0.104 ms``, ``12.3 ms``,
    ``1.25 s``, ``4 min 10 s``, ``3 h 21 min``."""
    if not math.isfinite(value):
        return "time unknown"
    if value < 1:
        return f"{value * 1000:.3g} ms"
    if value < 60:
        return f"{value:.3g} s"
    if value < 3600:
        return f"{int(value // 60)} min {int(value % 60)} s"
    return f"{int(value // 3600)} h {int(value % 3600 // 60)} min"
