"""How far an image is from a reference: relative MSE and FLIP, on linear RGB.

Both take linear images of shape (H, W, 3), the test image first and the
reference second, and are asymmetric: the reference sets the scale.

* **Relative MSE** weighs each squared difference by the reference's own
  brightness, so a bright highlight and a dark shadow count alike; the small
  ``EPSILON`` keeps black reference pixels (an empty background) from dividing
  by zero. It is the error measure of Monte Carlo rendering papers: for an
  unbiased renderer it falls as 1/spp.
* **FLIP** (NVIDIA's perceptual difference, the ``flip-evaluator`` package) in
  its HDR mode, which takes linear images and tone-maps them over the range of
  exposures the reference needs; 0 is identical, 1 maximally different.
"""

from __future__ import annotations

import numpy as np

#: Keeps black reference pixels from dividing by zero in :func:`relative_mse`.
EPSILON = 1e-2


def relative_mse(image: np.ndarray, reference: np.ndarray) -> float:
    """Mean over pixels and channels of (a − b)² / (b² + ε), with a the image, b the reference."""
    a, b = _pair(image, reference)
    return float(np.mean((a - b) ** 2 / (b * b + EPSILON)))


def flip(image: np.ndarray, reference: np.ndarray) -> float:
    """Mean HDR-FLIP error of ``image`` against ``reference`` (both linear RGB)."""
    import flip_evaluator

    a, b = _pair(image, reference)
    # FLIP needs non-negative, finite float32 input; a NaN stays visible in relative_mse.
    a = np.ascontiguousarray(np.clip(np.nan_to_num(a, nan=0.0, posinf=0.0), 0.0, None), np.float32)
    b = np.ascontiguousarray(np.clip(np.nan_to_num(b, nan=0.0, posinf=0.0), 0.0, None), np.float32)
    parameters = {}
    if not b.any():
        # HDR-FLIP picks its exposures from the reference's luminance and aborts the
        # whole process on a black reference: judge at exposure 1 (one ACES tone map).
        parameters = {"startExposure": 0.0, "stopExposure": 0.0}
    _, mean, _ = flip_evaluator.evaluate(b, a, "HDR", applyMagma=False, parameters=parameters)
    return float(mean)


def _pair(image: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image of shape {a.shape} compared with a reference of shape {b.shape}")
    return a, b
