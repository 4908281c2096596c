"""Walking the ray tree, in both kinds of variant.

:mod:`.tracer` says which rays make up a camera ray's tree and how each
level is shaded, counted (:mod:`.counts`) and pruned (:mod:`.adaptive`);
:mod:`.wavefront` walks it level by level over Dr.Jit arrays (JIT variants),
:mod:`.depth_first` one ray at a time (scalar variants).
"""

from __future__ import annotations


def tracer_for_variant(shader, epsilon: float, tally, lanes: int):
    """The walk the current variant can do: wavefronts need Dr.Jit arrays to gather a
    level's rays into (JIT variants); the scalar variants' values are one ray's plain
    numbers."""
    import drjit as dr
    import mitsuba as mi
    if dr.is_jit_v(mi.Float):
        from .wavefront import WavefrontTracer
        return WavefrontTracer(shader, epsilon, tally, lanes)
    from .depth_first import DepthFirstTracer
    return DepthFirstTracer(shader, epsilon, tally)
