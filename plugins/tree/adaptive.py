"""Adaptive depth control: the branches of the ray tree that cannot change the image are not traced.

Why. A ray's color reaches its pixel multiplied by its path weight, the
product of the KR and KT factors above it (Hall and Greenberg 1983; POV-Ray's
``adc_bailout``). Inside a glass ball that traps light by total internal
reflection the weights fall by a few percent a bounce, and the tree goes on to
whatever depth is allowed; at depth 64 that is most of the render's work for
a change the 8-bit image cannot show. So by default (``min_weight`` = 1/255,
whitted.defaults.MIN_WEIGHT) branches are left untraced as long as together
they cannot change any pixel by more than ``min_weight``; 0 traces the exact
tree.

The rule. Every ray carries an *allowance* ``a``: how much path weight may
still be left untraced in its subtree. A camera ray starts with
``ε = min_weight / L``, where ``L`` is the brightest color any ray can bring
back (:func:`brightest`). Where a ray spawns children of weights ``w1 <= w2``
(a missing child has weight 0), :func:`split`:

* culls the lighter child if ``w1 <= a``, then culls the heavier one too if
  ``w2 <= a - w1``, and otherwise traces it with allowance ``a - w1``;
* otherwise (``w1 > a``) traces both, each with allowance ``a/2``.

The error bound. In each case the weights culled at a ray plus its traced
children's allowances add up to at most its own allowance, so, by induction
down the tree, the weights culled from one camera ray's tree add up to at
most ``ε``. A culled ray of weight ``w`` would have added at most ``w·L`` to
its sample's color: a ray's color is a mix of point colors and the
background, with weights ``1 - KR - KT``, ``KR`` and ``KT`` that add up to
at most 1, so it is at most ``L`` in every channel. Culling only removes
such non-negative terms, so it darkens a sample, and each pixel (the mean of
its samples), by at most ``ε·L = min_weight`` in every channel. The render
reports the bound it reached, the largest weight culled from one sample
times ``L`` (``error_bound`` in ``whitted render --stats``); it is 0 when
nothing was culled. (The bound is in linear radiance; an 8-bit sRGB pixel
of a dark color has finer steps than 1/255.)

The rule looks at one ray and its children only, so the tree it gives does
not depend on how the tree is walked (wavefronts or depth first) or how the
wavefronts are split.
"""

from __future__ import annotations

import math

import drjit as dr

#: ε is taken this much smaller than ``min_weight / L``: float32 round-off in the
#: allowances of up to 64 levels (a few ulps each) cannot then push the bound past ``min_weight``
ROUND_OFF_MARGIN = 1e-5


def allowance(min_weight: float, bright) -> float:
    """The camera rays' allowance ε for a ``min_weight`` and a brightest color ``bright``
    (:func:`brightest`): 0 (the exact tree) when either is 0 or no bound is known."""
    if min_weight <= 0 or bright is None:
        return 0.0
    return min_weight / max(bright, 1e-30) * (1 - ROUND_OFF_MARGIN)


def split(w1, w2, a):
    """The rule of the module docstring for children of weights ``w1`` and ``w2`` under
    allowance ``a``: ``(traced1, traced2, allowance, culled)``, ``allowance`` being that of
    either traced child and ``culled`` the weight left untraced."""
    first_is_lighter = w1 <= w2
    light, heavy = dr.minimum(w1, w2), dr.maximum(w1, w2)
    light_traced = light > a
    rest = dr.select(light_traced, 0.5 * a, a - light)
    heavy_traced = heavy > rest
    culled = dr.select(light_traced, 0, light) + dr.select(heavy_traced, 0, heavy)
    return (dr.select(first_is_lighter, light_traced, heavy_traced),
            dr.select(first_is_lighter, heavy_traced, light_traced), rest, culled)


# -- the brightest color ----------------------------------------------------------------------------

def brightest(analysis, lighting: str, ambient: float):
    """An upper bound on every channel of every ray's color in the scene of ``analysis``
    (:class:`~whitted.plugins.scene.effects.SceneAnalysis`), or None.

    Article lighting: a point's color is ``B·(A + (1 - A)·Σ s·light)`` with
    ``s <= 1``, so at most ``max B · (A + (1 - A)·Σ max light)``. Physical
    lighting: ``(B/π)·Σ I·cos/r²``, at most ``(max B/π)·Σ max I/d²``, d the
    distance from the light to the nearest surface (None, no bound, when a
    light sits on one). A ray that escapes gets the background. The bound is
    the largest of these, times ``(max KR + KT)^(depth-1)`` when round-off
    lets KR + KT exceed 1. None when a texture or an environment is of a kind
    whose largest value is not known here.
    """
    tables = analysis.tables
    base, gain = analysis.surfaces.largest_base(), analysis.surfaces.largest_gain()
    if base is None or tables.background is None:
        return None
    if lighting == "physical":
        lit = 0.0
        for light in analysis.lights:
            distance = tables.primitives.distance_to_surfaces(light.position)
            if distance <= 0:
                return None
            lit += max(light.intensity) / distance ** 2
        point = base * lit / math.pi
    else:
        point = base * (ambient + (1 - ambient) * sum(max(light.color) for light in analysis.lights))
    return max(point, tables.background) * max(1.0, gain) ** (analysis.depth - 1)
