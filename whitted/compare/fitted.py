"""The article's model fitted to the reference (:func:`whitted.fitting.fit`), so that the
limit's error splits into numbers that are off (a guessed ambient, colors chosen by eye)
and light the model does not transport.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .. import metrics
from .. import rendering


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
    from ..converter.description import line_label, material_labels
    from ..defaults import FIT_ITERATIONS, FIT_SPP
    from ..fitting import fit
    from ..loading import _load_model

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
                             seed=seed, min_weight=0.0, ambient=result.ambient).image
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
