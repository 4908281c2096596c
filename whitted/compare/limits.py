"""A Whitted method's limit on a scene: what the model itself draws, with every ray of its
tree and converged anti-aliasing, so that a render's error can be split in two.

Every render is scored against the path-traced reference, and that error mixes what the
user chose (the depth, the samples per pixel) with what the model cannot draw (the light
a ray tree does not transport). The limit separates them: the method at the sweep's
deepest depth, ``min_weight`` 0 (the exact tree, no ray culled), and enough samples per
pixel that its own noise is below :data:`~whitted.defaults.COMPARE_LIMIT_NOISE_SHARE` of
the smallest difference it measures to a sweep render. A render's distance to it
(``rel_mse_limit``) is what its depth and spp cost; its distance to the reference is the
model's bias.

Its noise is estimated as the reference's is, from two independent halves
(:func:`~whitted.compare.curves.reference_noise`); the halves start at
:data:`~whitted.defaults.COMPARE_LIMIT_SPP_FACTOR` times the sweep's densest spp and
double until the noise is small enough (up to :data:`~whitted.defaults.COMPARE_LIMIT_MAX_SPP`
or the budget's end).

In the article's lighting the image is affine in the ambient A (a lit point is
B·(A + (1 − A)·Σ s·light), and reflected and refracted light add linearly), so the
limit is rendered at A = 0 and A = 1 with the same seeds: the limit at the scene's A,
and at the A that fits the reference best (:func:`~whitted.compare.curves.best_ambient`),
follow exactly, with no further render. Then the article's model is fitted to the
reference, every color, the ambient and the light colors (:mod:`.fitted`), and scored as the
limit is: what the model reaches with its numbers at their best.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import metrics

from ..images import write_image
from .. import rendering  # rendering.render looked up at call time: tests count calls
from ..defaults import COMPARE_LIMIT_MAX_SPP, COMPARE_LIMIT_NOISE_SHARE, COMPARE_LIMIT_SPP_FACTOR
from .curves import best_ambient, reference_noise
from .fitted import fit_to_reference
from .results import WHITTED_LIGHTING, Limit, Measurement, SceneResult

#: The seeds of a limit's halves: this, and this plus one. Independent of the sweep's
#: (0, and its later passes 1, 2, ...) and of the reference's (0x5EED0000 and up).
LIMIT_SEED = 0x11A10000


def _halves(loaded, lighting: str, depth: int, spp: int, ambient: float | None) -> tuple[list, float]:
    """Two independent renders of ``spp`` spp each (seeds :data:`LIMIT_SEED` + 0, 1) of the
    exact tree; returns ([image, image], their render seconds)."""
    images, seconds = [], 0.0
    for half in (0, 1):
        result = rendering.render(loaded, integrator="whitted", spp=spp, max_depth=depth,
                                  lighting=lighting, seed=LIMIT_SEED + half, min_weight=0.0,
                                  ambient=ambient)
        images.append(np.asarray(result.image, dtype=np.float64))
        seconds += float(result.seconds)
    return images, seconds


def render_limit(loaded, entry: SceneResult, method: str, measured: list[tuple[Measurement, np.ndarray]],
                 reference: np.ndarray, out: Path, deadline: float = math.inf, model=None) -> Limit | None:
    """The limit of ``method`` (a Whitted method) on ``entry``'s scene (``loaded``: its
    ``mi.Scene``), scored against ``reference``; every render of ``measured`` (each with
    its image) gets its ``rel_mse_limit``. None when ``measured`` is empty or not even
    the first halves fit before ``deadline`` (a ``time.monotonic`` reading). ``model``: the
    scene's parsed model (a ``.scn`` scene's, for the fit; None: no fit)."""
    if not measured:
        return None
    lighting = WHITTED_LIGHTING[method]
    depth = max(m.setting.max_depth for m, _ in measured)
    densest = max(m.setting.spp for m, _ in measured)
    ambient = (float(rendering.whitted_settings(loaded)["ambient"]) if lighting == "article"
               else math.nan)
    per_spp = min(m.render_seconds / m.setting.spp for m, _ in measured
                  if m.setting.max_depth == depth)
    spp = max(1, COMPARE_LIMIT_SPP_FACTOR * densest // 2)  # per half
    renders = 2 if lighting == "article" else 1            # A = 0 and A = 1, or one
    seconds, limit = 0.0, None
    while True:
        if time.monotonic() + 2 * renders * spp * per_spp > deadline:
            break
        if lighting == "article":
            dark, took_dark = _halves(loaded, lighting, depth, spp, 0.0)
            lit, took_lit = _halves(loaded, lighting, depth, spp, 1.0)
            seconds += took_dark + took_lit
            halves = [d + ambient * (b - d) for d, b in zip(dark, lit)]
        else:
            halves, took = _halves(loaded, lighting, depth, spp, None)
            seconds += took
        image = (halves[0] + halves[1]) / 2
        noise = reference_noise(halves[0], halves[1], spp, spp)
        differences = [metrics.relative_mse(picture, image) for _, picture in measured]
        converged = noise < COMPARE_LIMIT_NOISE_SHARE * min(differences)
        limit = Limit(method, depth, 2 * spp, noise, converged, metrics.relative_mse(image, reference),
                      seconds, ambient)
        if lighting == "article":
            dark_mean, lit_mean = (dark[0] + dark[1]) / 2, (lit[0] + lit[1]) / 2
            limit.best_ambient, limit.rel_mse_at_best_ambient = best_ambient(dark_mean, lit_mean,
                                                                             reference)
        for (m, _), difference in zip(measured, differences):
            m.rel_mse_limit = difference
        if converged or 4 * spp > COMPARE_LIMIT_MAX_SPP:
            break
        spp *= 2
    if limit is not None and lighting == "article":
        # the article's model at its best: its colors, ambient and light colors fitted
        limit.fitted = fit_to_reference(model, reference, depth, limit.spp, LIMIT_SEED,
                                        limit.best_ambient, deadline)
    if limit is not None:
        limit.image = f"{entry.folder}/{method}-limit-d{depth}-{limit.spp}spp.exr"
        write_image(Path(out) / limit.image, image.astype(np.float32))
    return limit
