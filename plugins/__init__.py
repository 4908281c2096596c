"""The project's Mitsuba plugins, and what the rest of the package may ask of them.

Two plugins: the ``whitted`` integrator (:mod:`.integrator`) and the
``article`` BSDF (:mod:`.bsdf`). Their classes derive from variant-specific
Mitsuba base classes, so those two modules are (re)loaded once per variant,
after ``mi.set_variant``, by :func:`register`. Behind the integrator, data
flowing one way: :mod:`.film` (where camera samples start and go),
:mod:`.recursion` (the article's recursion and its walks), which calls
:mod:`.hits` (hit finding, ray offsets, optics, the material at a hit), which
reads :mod:`.scene_tables` (what the integrator reads from a scene) and
:mod:`.primitives` (a scene's primitives as numbers); :mod:`.gradients`
serves differentiable renders only.

The rest of the package asks through the functions below, never through the
plugins' insides.
"""

from __future__ import annotations

import importlib

#: (variant, plugin name) -> the plugin's class for that variant
_classes: dict[tuple[str, str], type] = {}

# (module, registration function name, plugin name, class name)
_PLUGINS = (
    ("whitted.plugins.bsdf", "register_bsdf", "article", "ArticleBSDF"),
    ("whitted.plugins.integrator", "register_integrator", "whitted", "WhittedIntegrator"),
)


#: variants in which the plugins' names are registered to refuse with a clear error
_refused: set = set()


def register() -> None:
    """Register every plugin for Mitsuba's current variant (once per variant)."""
    import mitsuba as mi

    variant = mi.variant()
    if any(key[0] == variant for key in _classes):
        return
    for module_name, function, plugin_name, class_name in _PLUGINS:
        module = importlib.import_module(module_name)
        if _classes:  # built for another variant before: rebuild the classes
            module = importlib.reload(module)
        cls = _classes[variant, plugin_name] = getattr(module, class_name)
        getattr(mi, function)(plugin_name, lambda props, cls=cls: cls(props))


def refuse(supported) -> None:
    """In Mitsuba's current variant, which the plugins do not run in (``supported`` lists
    those they do), register their names so that a scene naming them fails with the reason
    ("runs in ... only") rather than Mitsuba's ``Plugin "whitted" not found!``."""
    import mitsuba as mi

    from whitted.errors import WhittedError
    variant = mi.variant()
    if variant in _refused:
        return
    _refused.add(variant)
    for _, function, plugin_name, _ in _PLUGINS:
        kind = "integrator" if function == "register_integrator" else "BSDF"
        message = (f"the {plugin_name!r} {kind} does not run in Mitsuba's variant {variant}; "
                   f"call mi.set_variant() with one of {', '.join(supported)} first")

        def refused(props, message=message):
            raise WhittedError(message)
        getattr(mi, function)(plugin_name, refused)


def whitted_or_none(integrator):
    """``integrator`` if it is the ``whitted`` plugin (of the current variant), else None."""
    import mitsuba as mi
    cls = _classes.get((mi.variant(), "whitted"))
    return integrator if cls is not None and isinstance(integrator, cls) else None


def check_scene(scene):
    """Raise :class:`~whitted.errors.WhittedError` unless the ``whitted`` integrator can
    render ``scene``: every shape has the ``article`` BSDF and every emitter is a point
    light or the environment. Returns what it read (the scene's tables,
    :mod:`.scene_tables`), for ``render_detailed(..., tables=)``: found once per render."""
    from .scene_tables import scene_tables
    return scene_tables(scene)


def scene_effects(scene, max_depth: int, light_reference=(0.0, 0.0, 0.0)) -> tuple[str, ...]:
    """The effects a render of ``scene`` to ``max_depth`` calls for (:func:`.scene_tables.analyse`);
    raises :class:`~whitted.errors.WhittedError` as :func:`check_scene` does."""
    from .scene_tables import analyse, scene_tables
    return analyse(scene_tables(scene), max_depth, light_reference).effects
