"""Which renders a comparison makes of each scene, in order: cheapest first with the methods
interleaved, so that when the budget runs out the cheap end of every method's curve is
there rather than all of one method.
"""

from __future__ import annotations

from ..defaults import COMPARE_MAX_DEFAULT_DEPTH, COMPARE_PATH_FIT_COUNTS, DEPTH, LIGHTING_MODES
from .results import METHODS, WHITTED_METHODS, Options, SceneResult, Setting
from .scenes import SceneFile


def plan(depths: tuple[int, ...], whitted_spp: tuple[int, ...], path_spp: tuple[int, ...],
         path_depth: int, quick: bool = False) -> list[Setting]:
    """The settings in order; ``quick``: what the verdict needs first, so that a budget cuts
    the rest: the Whitted ladder's cheapest renders (the floors' candidates), the path
    tracer's that fit and check its curve (every headline is read on it), each Whitted
    method's deepest, densest render (its best error, which the floor is within 5% of), then
    the others, cheapest first, and the path tracer's counts its curve may stand for."""
    settings = [Setting("whitted", lighting, spp, depth)
                for lighting in LIGHTING_MODES for spp in whitted_spp for depth in depths]
    settings += [Setting("path", "physical", spp, path_depth) for spp in path_spp]
    order = {m: i for i, m in enumerate(METHODS)}
    settings.sort(key=lambda s: (s.spp, s.max_depth if s.integrator == "whitted" else 0,
                                 order[s.method]))
    if not quick:
        return settings
    checking = path_spp[:COMPARE_PATH_FIT_COUNTS + 1]

    def need(s: Setting) -> int:
        if s.integrator == "path":
            return 1 if s.spp in checking else 4
        if s.spp == min(whitted_spp):
            return 0
        return 2 if (s.spp, s.max_depth) == (max(whitted_spp), max(depths)) else 3
    return sorted(settings, key=need)   # stable: cheapest first within each


def plan_scene(scene: SceneFile, loaded, options: Options,
               variant: str) -> tuple[SceneResult, list[Setting]]:
    """One scene's empty result and its settings in order (``loaded``: its ``mi.Scene``, whose
    film gives the size and integrator the depth a file does not state)."""
    width, height = (int(v) for v in loaded.sensors()[0].film().crop_size())
    depth = scene.depth if scene.depth is not None else int(getattr(loaded.integrator(), "max_depth", DEPTH))
    depths = options.depths or tuple(range(1, min(depth, COMPARE_MAX_DEFAULT_DEPTH) + 1))
    path_depth = options.path_depth or depth
    result = SceneResult(scene.name, scene.path, width, height, variant, options.reference_spp,
                         path_depth, whitted_spp=options.whitted_spp, path_spp=options.path_spp,
                         depths=depths)
    return result, plan(depths, options.whitted_spp, options.path_spp, path_depth, options.quick)


def limit_methods(settings: list[Setting]) -> list[str]:
    """The Whitted methods among ``settings``: each gets its limit rendered."""
    return [m for m in WHITTED_METHODS if any(s.method == m for s in settings)]


def progress_units(settings: list[Setting]) -> int:
    return len(settings) + len(limit_methods(settings))
