"""Which renders a comparison makes of each scene, and in which order.

The order matters to the budget: renders go cheapest first with the methods
interleaved, so that when time runs out the cheap end of every method's curve
is there rather than all of one method. Planning needs only the scene's size and
depth; it renders nothing.
"""

from __future__ import annotations

from ..defaults import DEPTH, LIGHTING_MODES
from .results import MAX_DEFAULT_DEPTH, METHODS, WHITTED_METHODS, Options, SceneResult, Setting
from .scenes import SceneFile


def plan(depths: tuple[int, ...], whitted_spp: tuple[int, ...], path_spp: tuple[int, ...],
         path_depth: int) -> list[Setting]:
    """Every render of the sweep, cheapest first, methods interleaved, so that a budget
    cut keeps the cheap end of every curve rather than all of one method."""
    settings = [Setting("whitted", lighting, spp, depth)
                for lighting in LIGHTING_MODES for spp in whitted_spp for depth in depths]
    settings += [Setting("path", "physical", spp, path_depth) for spp in path_spp]
    order = {m: i for i, m in enumerate(METHODS)}
    return sorted(settings, key=lambda s: (s.spp, s.max_depth if s.integrator == "whitted" else 0,
                                           order[s.method]))


def plan_scene(scene: SceneFile, loaded, options: Options,
               variant: str) -> tuple[SceneResult, list[Setting]]:
    """One scene's empty result (what will be swept there) and its settings in order.

    ``loaded`` is the scene's ``mi.Scene``: its film gives the size, and its
    integrator the depth when the file does not state one.
    """
    width, height = (int(v) for v in loaded.sensors()[0].film().crop_size())
    depth = scene.depth if scene.depth is not None else int(getattr(loaded.integrator(), "max_depth", DEPTH))
    depths = options.depths or tuple(range(1, min(depth, MAX_DEFAULT_DEPTH) + 1))
    path_depth = options.path_depth or depth
    result = SceneResult(scene.name, scene.path, width, height, variant, options.reference_spp,
                         path_depth, whitted_spp=options.whitted_spp, path_spp=options.path_spp,
                         depths=depths)
    return result, plan(depths, options.whitted_spp, options.path_spp, path_depth)


def limit_methods(settings: list[Setting]) -> list[str]:
    """The Whitted methods among ``settings``, each of which gets its limit rendered after
    its renders (:mod:`whitted.compare.limits`)."""
    return [m for m in WHITTED_METHODS if any(s.method == m for s in settings)]


def progress_units(settings: list[Setting]) -> int:
    """What a scene's sweep advances the progress bar by: one per render, one per limit."""
    return len(settings) + len(limit_methods(settings))
