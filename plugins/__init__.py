"""The project's Mitsuba plugins, and what the rest of the package may ask of them.

The ``whitted`` integrator (:mod:`.integrator`) and the ``article`` BSDF (:mod:`.bsdf`)
derive from variant-specific Mitsuba classes, so :func:`register` (re)loads them once per
variant. The rest of the package asks through the functions below, never the plugins' insides.
"""

from __future__ import annotations

import importlib

#: (variant, plugin name) -> the plugin's class for that variant
_classes: dict[tuple[str, str], type] = {}
#: variants in which the plugins' names are registered to refuse with a clear error
_refused: set = set()

# (module, registration function name, plugin name, class name)
_PLUGINS = (
    ("whitted.plugins.bsdf", "register_bsdf", "article", "ArticleBSDF"),
    ("whitted.plugins.integrator", "register_integrator", "whitted", "WhittedIntegrator"),
)


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
    """Register the plugins' names in a variant they do not run in, to fail with the reason
    (``supported``: the variants they run in), not Mitsuba's ``Plugin not found``."""
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
    """The scene's tables (for ``render_detailed(..., tables=)``), or a
    :class:`~whitted.errors.WhittedError` if the ``whitted`` integrator cannot render it."""
    from .scene_tables import scene_tables
    return scene_tables(scene)


def scene_effects(scene, max_depth: int) -> tuple[str, ...]:
    """The effects a render of ``scene`` to ``max_depth`` calls for (:func:`.scene_tables.analyse`)."""
    from .scene_tables import analyse, scene_tables
    return analyse(scene_tables(scene), max_depth, (0.0, 0.0, 0.0)).effects
