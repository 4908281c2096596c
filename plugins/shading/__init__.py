"""The article's shading and optics, and where rays hit.

:mod:`.shader` shades one level of the ray tree with the article's model;
:mod:`.optics` holds its reflection and refraction formulas; :mod:`.hits`
finds hit points, normals, UV and their error bounds, and moves rays off
surfaces by those bounds; :mod:`.giants` intersects giant spheres in float64.

The same code shades one ray (scalar variants, masks are Python ``bool``s)
and a wavefront (JIT variants, masks are Dr.Jit arrays). Two things differ.
Work a mask switches off: a wavefront does it on every lane and discards
what the mask rejects (``dr.select``), while a single ray must not start it
at all (Mitsuba's scalar ``ray_test`` ignores its ``active`` argument, and
a ray that missed has no shape: a call through it dereferences a null
pointer); :func:`off` tells the scalar case apart. And counting, which
:class:`~whitted.plugins.tree.counts.Tally` does for both. (Negation is
the other trap: ``~True`` is -2. The shading code never negates a mask; it
selects instead.)
"""

from __future__ import annotations


def off(mask) -> bool:
    """Whether ``mask`` is a single ray's ``False`` (scalar variants), so that the work it
    guards must be skipped. A wavefront's mask never is: its lanes are masked one by one."""
    return mask is False
