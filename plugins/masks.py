"""Masks, written once for a wavefront of rays and for a single ray.

The shading code runs unchanged in every variant: in the JIT variants a mask
is a Dr.Jit array with one lane per ray of a wavefront, in the scalar
variants a plain Python ``bool`` for the one ray being traced. Two things
differ, and are handled here rather than where masks are used:

* Work a mask switches off. A wavefront does it on every lane and discards
  what the mask rejects (``dr.select``); that is how SIMD code runs. A single
  ray must not start it at all: Mitsuba's scalar ``ray_test`` ignores its
  ``active`` argument (it traces the ray anyway), and a ray that missed has no
  shape, so a call through it dereferences a null pointer. :func:`off` tells
  the scalar case apart.
* Counting. A wavefront's counts are added up inside the kernel that
  computes the mask (an atomic add, deferred like any scatter: nothing is
  evaluated early, nothing is read back per level); a single ray's are
  Python numbers. :class:`.counts.Tally` does both.

(Negation is the other trap: ``~True`` is -2. The shading code never negates
a mask; it selects instead.)
"""

from __future__ import annotations


def off(mask) -> bool:
    """Whether ``mask`` is a single ray's ``False`` (scalar variants), so that the work it
    guards must be skipped. A wavefront's mask never is: its lanes are masked one by one."""
    return mask is False

