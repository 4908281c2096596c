"""How far an image is from a reference, both linear RGB, the reference second (it sets the
scale): relative MSE, and LDR-FLIP of the images as displayed (docs/compare.md, "Error
measures").
"""

from __future__ import annotations

import os

import numpy as np

#: Keeps black reference pixels from dividing by zero in :func:`relative_mse`.
EPSILON = 1e-2


def relative_mse(image: np.ndarray, reference: np.ndarray) -> float:
    """Mean over pixels and channels of (a − b)² / (b² + ε), with a the image, b the reference."""
    a, b = _pair(image, reference)
    return float(np.mean((a - b) ** 2 / (b * b + EPSILON)))


def flip(image: np.ndarray, reference: np.ndarray, exposure: float = 0.0, view: str = "clip") -> float:
    """Mean LDR-FLIP error of ``image`` against ``reference``, as displayed."""
    return flip_map(image, reference, exposure, view)[1]


def flip_map(image: np.ndarray, reference: np.ndarray, exposure: float = 0.0,
             view: str = "clip") -> tuple[np.ndarray, float]:
    """LDR-FLIP's per-pixel error map (H, W) in [0, 1] and its mean, both images displayed
    with ``exposure`` and ``view``."""
    from .images import to_display

    return displayed_flip_map(*(to_display(x, exposure, view) for x in _pair(image, reference)))


def displayed_flip_map(shown: np.ndarray, shown_reference: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`flip_map` of two images already displayed (:func:`~whitted.images.to_display`),
    so that a reference scored against many renders is displayed once."""
    # FLIP's OpenMP threads sleep between evaluations: spinning, they took 40% of its CPU
    # time on 2 cores, and cores from the renders in between
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    import flip_evaluator

    a, b = (np.ascontiguousarray(x, np.float32) for x in (shown, shown_reference))
    if a.shape != b.shape:
        raise ValueError(f"image of shape {a.shape} compared with a reference of shape {b.shape}")
    error_map, mean, _ = flip_evaluator.evaluate(b, a, "LDR", inputsRGB=True, applyMagma=False)
    return np.asarray(error_map, dtype=np.float32).reshape(a.shape[:2]), float(mean)


def _pair(image: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image of shape {a.shape} compared with a reference of shape {b.shape}")
    return a, b
