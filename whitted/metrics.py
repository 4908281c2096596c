"""How far an image is from a reference: relative MSE and FLIP, on linear RGB.

Both take linear images of shape (H, W, 3), the test image first and the
reference second, and are asymmetric: the reference sets the scale.

* **Relative MSE** weighs each squared difference by the reference's own
  brightness, so a bright highlight and a dark shadow count alike; the small
  ``EPSILON`` keeps black reference pixels (an empty background) from dividing
  by zero. It is the error measure of Monte Carlo rendering papers: for an
  unbiased renderer it falls as 1/spp.
* **FLIP** (NVIDIA's perceptual difference, the ``flip-evaluator`` package) in
  its LDR mode, on the images as displayed (:func:`whitted.images.to_display`:
  an exposure and a view, by default plain sRGB clipped to [0, 1]): what a
  viewer compares on screen, the same as comparing the PNG outputs. 0 is
  identical, 1 maximally different. Exposure and view change FLIP and nothing
  else: the relative MSE reads the linear values. HDR-FLIP was
  measured and not used: on a black background (the scene format's default)
  its exposure range, set by the reference's median luminance, runs to 2^24
  and one 640×400 evaluation takes 7 s, twenty times the LDR one; differences
  above 1 are still seen by the relative MSE.
"""

from __future__ import annotations

import numpy as np

#: Keeps black reference pixels from dividing by zero in :func:`relative_mse`.
EPSILON = 1e-2


def relative_mse(image: np.ndarray, reference: np.ndarray) -> float:
    """Mean over pixels and channels of (a − b)² / (b² + ε), with a the image, b the reference."""
    a, b = _pair(image, reference)
    return float(np.mean((a - b) ** 2 / (b * b + EPSILON)))


def flip(image: np.ndarray, reference: np.ndarray, exposure: float = 0.0, view: str = "clip") -> float:
    """Mean LDR-FLIP error of ``image`` against ``reference`` (both linear RGB), as displayed
    with ``exposure`` and ``view`` (:mod:`whitted.images`)."""
    return flip_map(image, reference, exposure, view)[1]


def flip_map(image: np.ndarray, reference: np.ndarray, exposure: float = 0.0,
             view: str = "clip") -> tuple[np.ndarray, float]:
    """LDR-FLIP's per-pixel error map (H, W) in [0, 1] and its mean (what :func:`flip`
    returns), from one evaluation: where the image differs from the reference, as seen
    (both displayed with ``exposure`` and ``view``)."""
    import flip_evaluator

    from .images import to_display

    a, b = (np.ascontiguousarray(to_display(x, exposure, view), np.float32)
            for x in _pair(image, reference))
    error_map, mean, _ = flip_evaluator.evaluate(b, a, "LDR", inputsRGB=True, applyMagma=False)
    return np.asarray(error_map, dtype=np.float32).reshape(a.shape[:2]), float(mean)


def _pair(image: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image of shape {a.shape} compared with a reference of shape {b.shape}")
    return a, b
