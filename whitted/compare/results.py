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

from ..defaults import (COMPARE_LEVELS as DEFAULT_LEVELS, COMPARE_MAX_DEFAULT_DEPTH as MAX_DEFAULT_DEPTH,
                        COMPARE_PATH_SPP as DEFAULT_PATH_SPP, COMPARE_REFERENCE_SPP as DEFAULT_REFERENCE_SPP,
                        COMPARE_REPEATS as DEFAULT_REPEATS, COMPARE_WHITTED_SPP as DEFAULT_WHITTED_SPP,
                        MAX_DEPTH)

if TYPE_CHECKING:
    import numpy as np

#: The Whitted integrator in its two lighting modes, then the path tracer.
WHITTED_METHODS = ("whitted-article", "whitted-physical")
METHODS = WHITTED_METHODS + ("path",)

__all__ = ["DEFAULT_LEVELS", "DEFAULT_PATH_SPP", "DEFAULT_REFERENCE_SPP", "DEFAULT_REPEATS",
           "DEFAULT_WHITTED_SPP", "MAX_DEFAULT_DEPTH", "MAX_DEPTH", "METHODS", "WHITTED_METHODS",
           "Measurement", "Options", "SceneResult", "Setting"]


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
        return "path" if self.integrator == "path" else f"whitted-{self.lighting}"

    @property
    def label(self) -> str:
        """A short caption: ``d3 · 4 spp``, or ``64 spp`` for the path tracer."""
        if self.integrator == "path":
            return f"{self.spp} spp"
        return f"d{self.max_depth} · {self.spp} spp"


@dataclass
class Measurement:
    """One setting, rendered and scored against the reference.

    =================== ===============================================================
    ``setting``         what was rendered
    ``seconds``         median render time over the repeats, compilation excluded
    ``compile_seconds`` kernel compilation (the largest over the repeats)
    ``rel_mse``         relative MSE against the reference (:mod:`whitted.metrics`)
    ``flip``            LDR-FLIP against the reference
    ``repeats``         how many times it was rendered
    ``thumbnail``       a small sRGB uint8 copy of the image (for the contact sheet)
    =================== ===============================================================
    """
    setting: Setting
    seconds: float
    compile_seconds: float
    rel_mse: float
    flip: float
    repeats: int
    thumbnail: np.ndarray | None = field(default=None, repr=False)


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


@dataclass
class Options:
    """The command's options (``whitted compare --help`` describes each).

    ================= ================================================================
    ``out``           the output folder
    ``reference_spp`` the reference's samples per pixel
    ``depths``        Whitted max depths (None: 1…the scene's depth, at most
                      :data:`MAX_DEFAULT_DEPTH`)
    ``whitted_spp``   the Whitted integrator's spp ladder
    ``path_spp``      the path tracer's spp ladder
    ``path_depth``    the path tracer's and reference's max depth (None: the scene's)
    ``repeats``       renders per setting; the median time is kept
    ``budget``        seconds for the whole command (None: unbounded)
    ``levels``        relative MSE levels of the summary table
    ``cache``         the reference cache's folder (None: ``out/references``)
    ``variant``       the Mitsuba variant (None: as for ``whitted render``)
    ``quiet``         no progress bar or messages
    ================= ================================================================
    """
    out: Path
    reference_spp: int = DEFAULT_REFERENCE_SPP
    depths: tuple[int, ...] | None = None
    whitted_spp: tuple[int, ...] = DEFAULT_WHITTED_SPP
    path_spp: tuple[int, ...] = DEFAULT_PATH_SPP
    path_depth: int | None = None
    repeats: int = DEFAULT_REPEATS
    budget: float | None = None
    levels: tuple[float, ...] = DEFAULT_LEVELS
    cache: Path | None = None
    variant: str | None = None
    quiet: bool = False

    @property
    def cache_folder(self) -> Path:
        """Where references are cached."""
        return Path(self.cache) if self.cache is not None else Path(self.out) / "references"
