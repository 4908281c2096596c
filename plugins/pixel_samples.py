"""Where in its pixel each camera ray starts.

With one sample per pixel the ray passes exactly through the pixel center, so
a render is deterministic (the scene format's rule). With N samples the pixel
is cut into an ``nx × ny = N`` grid of equal cells (the most nearly square
factorisation of N; a prime N gives N columns) and each sample is jittered
uniformly inside its own cell: stratified sampling, unbiased, whatever N is.

The jitter is a hash of (pixel, sample, seed) rather than a stream from a
sampler, so an image does not depend on how the render is split into passes.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from whitted.defaults import SEED_STRIDE


def strata(spp: int) -> tuple[int, int]:
    """``(nx, ny)`` with ``nx·ny = spp``, ``nx >= ny``, as square as possible."""
    ny = math.isqrt(spp)
    while spp % ny:
        ny -= 1
    return spp // ny, ny


def pixel_offset(pixel, sample, spp: int, seed: int):
    """Offset of a camera sample inside its pixel, in [0, 1)^2 (Point2f).

    ``pixel`` is the pixel's linear index and ``sample`` the sample's number
    within the pixel (UInt32, or ints in scalar variants).
    """
    if spp == 1:
        return mi.Point2f(0.5, 0.5)
    nx, ny = strata(spp)
    column = sample % nx
    row = sample // nx
    # The seed is opaque: a new seed must not compile new kernels.
    seed_offset = (seed * SEED_STRIDE) & 0xFFFFFFFF
    # (the mask wraps the sum to 32 bits where UInt32 is a Python int: scalar variants)
    salt = (mi.UInt32(sample) + dr.opaque(mi.UInt32, seed_offset)) & 0xFFFFFFFF
    bits_x, bits_y = mi.sample_tea_32(mi.UInt32(pixel), salt)
    jitter = mi.Point2f(mi.Float(bits_x >> 8), mi.Float(bits_y >> 8)) * (1.0 / (1 << 24))
    return mi.Point2f((mi.Float(column) + jitter.x) / nx, (mi.Float(row) + jitter.y) / ny)
