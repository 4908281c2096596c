"""What a comparison is asked to do and what it measured: plain data that every part of
``whitted compare`` speaks in. It imports nothing else of the command and holds no Mitsuba
object, so reports never import the sweep and a worker process can pickle it both ways."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..defaults import (COMPARE_PATH_SPP, COMPARE_REFERENCE_CHUNK_SPP, COMPARE_REFERENCE_SPP,
                        COMPARE_ROUNDS, COMPARE_WHITTED_SPP, IN_PROCESS, LIGHTING_MODES,
                        user_cache_folder)

if TYPE_CHECKING:
    import numpy as np


def method_of(integrator: str, lighting: str) -> str:
    """``whitted-article``, ``whitted-physical`` or ``path``: made here only, never parsed."""
    return "path" if integrator == "path" else f"whitted-{lighting}"


#: Each Whitted method (the Whitted integrator in one lighting mode) -> its lighting mode.
WHITTED_LIGHTING = {method_of("whitted", lighting): lighting for lighting in LIGHTING_MODES}
#: The Whitted integrator in its two lighting modes, then the path tracer.
WHITTED_METHODS = tuple(WHITTED_LIGHTING)
METHODS = WHITTED_METHODS + ("path",)


@dataclass(frozen=True)
class Setting:
    """One render's parameters (``max_depth``: primary rays have depth 1)."""
    integrator: str
    lighting: str
    spp: int
    max_depth: int

    @property
    def method(self) -> str:
        return method_of(self.integrator, self.lighting)

    @property
    def label(self) -> str:
        return f"{self.spp} spp" if self.integrator == "path" else f"d{self.max_depth} · {self.spp} spp"

    @property
    def short_label(self) -> str:
        return f"{self.spp}" if self.integrator == "path" else f"d{self.max_depth}·{self.spp}"

    @property
    def slug(self) -> str:
        return f"path-{self.spp}spp" if self.integrator == "path" else f"{self.method}-d{self.max_depth}-{self.spp}spp"


@dataclass
class Measurement:
    """One setting, rendered, scored against the reference and timed in rounds (its fields:
    docs/compare.md, "Outputs", results.csv)."""
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
    modelled: bool = False   # not rendered: read from the path tracer's fitted curve

    @property
    def rounds(self) -> int:
        """The rounds it was timed in (a long render sits out the later ones, NaN there)."""
        return sum(1 for t in self.times if math.isfinite(t))

    def seconds_in(self, timed_round: int | None) -> float:
        """Its time in a round (NaN: it missed it); its :attr:`seconds` for None or untimed."""
        if timed_round is None or not self.times:
            return self.seconds
        return self.times[timed_round] if timed_round < len(self.times) else math.nan

    @property
    def seconds_min(self) -> float:
        return min((t for t in self.times if math.isfinite(t)), default=self.seconds)

    @property
    def seconds_max(self) -> float:
        return max((t for t in self.times if math.isfinite(t)), default=self.seconds)


@dataclass
class Limit:
    """A Whitted method's limit on one scene: its full ray tree (``min_weight`` 0) at the
    sweep's deepest depth, anti-aliasing converged; its error against the reference is
    the model's bias (docs/compare.md, "What the error is made of")."""
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
    """What the sweep measured on one scene, and what it was asked to sweep there."""
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
    reference_enough: bool = False   # rendered at the spp its noise needs, below the requested
    reference_png: str | None = None
    notes: list[str] = field(default_factory=list)
    worker: str = IN_PROCESS
    limits: dict[str, Limit] = field(default_factory=dict)
    view: str = "clip"
    exposure: float = 0.0
    reference_clipped: float = math.nan
    path_model: object = None   # the path tracer's fitted curve (curves.PathModel), once checked
    reference_black: bool = False   # black everywhere: an error against it compares nothing

    def __post_init__(self):
        if not self.reference_requested:
            self.reference_requested = self.reference_spp

    @property
    def folder(self) -> str:
        return f"renders/{self.name.replace('/', '_')}"


@dataclass
class Options:
    """The command's options (``whitted compare --help`` describes each)."""
    out: Path
    reference_spp: int = COMPARE_REFERENCE_SPP
    depths: tuple[int, ...] | None = None
    whitted_spp: tuple[int, ...] = COMPARE_WHITTED_SPP
    path_spp: tuple[int, ...] = COMPARE_PATH_SPP
    path_depth: int | None = None
    rounds: int = COMPARE_ROUNDS
    budget: float | None = None
    quick: bool = False   # --quick's rules under its budget (docs/compare.md, "--quick")
    levels: tuple[float, ...] | None = None
    cache: Path | None = None
    variant: str | None = None
    quiet: bool = False
    reference_chunk_spp: int = COMPARE_REFERENCE_CHUNK_SPP
    workers: int | None = None
    scheduler: str | None = None
    view: str | None = None
    exposure: float = 0.0
    started: float | None = None

    @property
    def cache_folder(self) -> Path:
        """``cache``, or the user's: shared by every run, whatever its output folder."""
        return Path(self.cache) if self.cache is not None else user_cache_folder() / "references"


class Comparison(list):
    """What :func:`whitted.compare.compare` returns: the scenes' results, with ``analyses`` and
    ``findings`` (the content of ``findings.json``)."""

    def __init__(self, entries: list[SceneResult], analyses: list, findings: dict):
        super().__init__(entries)
        self.analyses = analyses
        self.findings = findings


def seconds_text(value: float) -> str:
    """A duration for people: ``12.3 ms``, ``1.25 s``, ``4 min 10 s``, ``3 h 21 min``."""
    if not math.isfinite(value):
        return "time unknown"
    if value < 1:
        return f"{value * 1000:.3g} ms"
    if value < 60:
        return f"{value:.3g} s"
    if value < 3600:
        return f"{int(value // 60)} min {int(value % 60)} s"
    return f"{int(value // 3600)} h {int(value % 3600 // 60)} min"
