"""A Whitted method's limit on a scene: its full ray tree, anti-aliasing converged, which
splits a render's error into what its depth and spp cost and the model's bias
(docs/compare.md, "What the error is made of"); and the article's model fitted to the
reference (:func:`whitted.fitting.fit`), which splits the bias into numbers that are off (a
guessed ambient, colors chosen by eye) and light the model does not transport.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import metrics
from .. import rendering  # rendering.render looked up at call time: tests count calls
from ..converter.description import line_label, material_labels
from ..defaults import (COMPARE_LIMIT_MAX_SPP, COMPARE_LIMIT_NOISE_SHARE,
                        COMPARE_LIMIT_SPP_FACTOR, FIT_ITERATIONS, FIT_SPP)
from ..fitting import fit
from ..images import read_image, write_image
from ..loading import _load_model
from .curves import best_ambient, reference_noise
from .results import WHITTED_LIGHTING, Limit, Measurement, SceneResult, Setting
from .scenes import limit_methods

#: The seeds of a limit's halves: this and the next, apart from the sweep's and the reference's.
LIMIT_SEED = 0x11A10000


def _halves(loaded, lighting: str, depth: int, spp: int, ambient: float | None) -> tuple[list, float]:
    images, seconds = [], 0.0
    for half in (0, 1):
        result = rendering.render(loaded, integrator="whitted", spp=spp, max_depth=depth,
                                  lighting=lighting, seed=LIMIT_SEED + half, min_weight=0.0,
                                  ambient=ambient, fresh_memory=False)
        images.append(np.asarray(result.image, dtype=np.float64))
        seconds += float(result.seconds)
    return images, seconds


def render_limits(loaded, entry: SceneResult, settings: list[Setting], reference: np.ndarray, out: Path,
                  deadline: float, progress, model=None) -> None:
    """Each Whitted method's limit, its renders read back from their EXRs and scored against it."""
    methods = limit_methods(settings)
    weights = [2 if WHITTED_LIGHTING[m] == "article" else 1 for m in methods]  # its renders
    for k, method in enumerate(methods):   # each its share of the time left
        until = time.monotonic() + (deadline - time.monotonic()) * weights[k] / sum(weights[k:])
        progress.set_postfix_str(f"{entry.name}: {method} limit", refresh=False)
        measured = [(m, read_image(out / m.image)) for m in entry.measurements
                    if m.setting.method == method and m.image]
        limit = render_limit(loaded, entry, method, measured, reference, out, until, model)
        if limit is not None:
            entry.limits[method] = limit
        elif measured:
            entry.notes.append(f"{method}: its limit was not rendered: it would have overrun the "
                               f"scene's share of --budget")
        progress.update(1)


def render_limit(loaded, entry: SceneResult, method: str, measured: list[tuple[Measurement, np.ndarray]],
                 reference: np.ndarray, out: Path, deadline: float = math.inf, model=None) -> Limit | None:
    """The limit of a Whitted method on the scene, scored against ``reference``; sets each
    measured render's ``rel_mse_limit``. None when nothing fits before ``deadline``;
    ``model``: the parsed ``.scn`` scene, for the fit (None: no fit)."""
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
    # the article's limit leaves half of its time to the fit
    halves_until = deadline if model is None or lighting != "article" else \
        (time.monotonic() + deadline) / 2
    while True:
        until = deadline if limit is None else halves_until   # the first halves: any time left
        if time.monotonic() + 2 * renders * spp * per_spp > until:
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
                                        limit.best_ambient, deadline, seconds / 4)
        fitted = limit.fitted
        if fitted is None and model is not None and time.monotonic() + seconds / 2 > deadline:
            entry.notes.append(f"{method}: not fitted: the fit would have overrun the scene's "
                               f"share of --budget")
        elif fitted is not None and fitted.stopped:
            entry.notes.append(f"{method}: the fit stopped at the scene's share of --budget after "
                               f"{fitted.stopped} steps: its numbers are its last step's")
    if limit is not None:
        limit.image = f"{entry.folder}/{method}-limit-d{depth}-{limit.spp}spp.exr"
        write_image(Path(out) / limit.image, image.astype(np.float32))
    return limit


@dataclass
class Fitted:
    """The fit of one scene: its relative MSE against the reference at full resolution, the
    fitted ambient, colors (material id -> RGB) and light colors, and what it took; ``names``:
    how the scene file names each material id and ``light_K`` (``line 14 (the floor)``)."""
    rel_mse: float
    ambient: float
    colors: dict
    lights: list
    seconds: float
    fit_rel_mse: float      # at the fit's resolution
    size: tuple
    names: dict = field(default_factory=dict)
    stopped: int = 0        # the steps done when the deadline stopped the fit (0: it was not)


def fit_to_reference(model, reference: np.ndarray, depth: int, spp: int, seed: int,
                     start_ambient: float = math.nan, deadline: float = math.inf,
                     score_seconds: float = 0.0) -> Fitted | None:
    """Fit the article's model of the parsed ``.scn`` ``model`` to ``reference`` and score it
    there as the limit is; None without a model, or when its scoring does not fit before
    ``deadline``. A fit whose next step would overrun stops (:attr:`Fitted.stopped`)."""
    import drjit as dr
    import mitsuba as mi
    if model is None or not dr.is_diff_v(mi.Float):
        return None   # (gradients need an AD variant: the sweep's is kept)
    start = time.monotonic()
    if start + 2 * score_seconds > deadline:
        return None
    model = replace(model, depth=depth)
    if math.isfinite(start_ambient):
        model = replace(model, ambient=start_ambient)
    steps, stopped = [start], []

    def on_step(k, loss):   # stop when the next step and the scoring render would overrun
        steps.append(time.monotonic())
        next_step = steps[-1] - steps[-2]
        if steps[-1] + next_step + score_seconds > deadline and k + 1 < FIT_ITERATIONS:
            stopped.append(k + 1)
            return True
        return False
    # anti-aliased as the limit is (its samples, up to FIT_SPP): the reference is
    result = fit(model, reference, on_step=on_step, spp=min(spp, FIT_SPP))
    loaded = _load_model(result.model, {}, None, "whitted", False)   # grouped, as the sweep's scene
    image = rendering.render(loaded, integrator="whitted", spp=spp, max_depth=depth, lighting="article",
                             seed=seed, min_weight=0.0, ambient=result.ambient,
                             fresh_memory=False).image
    error = metrics.relative_mse(np.asarray(image, np.float64), reference)
    names = {**material_labels(model), **{f"light_{k}": line_label(model, light.line)
                                          for k, light in enumerate(model.lights) if light.line}}
    return Fitted(error, result.ambient, result.colors, list(result.lights), time.monotonic() - start,
                  result.error, result.size, names, sum(stopped))


def fitted_text(fitted: Fitted) -> str:
    """``ambient 0.31; colors line 14 (the floor): 0.52 0.6 0.55, …; lights …``."""
    def rgb(c):
        return " ".join(f"{v:.2g}" for v in c)
    names = fitted.names
    parts = [f"ambient {fitted.ambient:.2g}"]
    if fitted.colors:
        parts.append("colors " + ", ".join(f"{names.get(mid, mid)}: {rgb(c)}" for mid, c in fitted.colors.items()))
    if fitted.lights:
        parts.append("lights " + ", ".join(f"{names.get(f'light_{k}', f'light {k}')}: {rgb(c)}"
                                           for k, c in enumerate(fitted.lights)))
    return "; ".join(parts)
