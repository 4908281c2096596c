"""The project's Mitsuba plugins, registered for the current variant.

Plugin classes derive from variant-specific Mitsuba base classes, so their
modules are (re)loaded once per variant, after ``mi.set_variant``.
"""

from __future__ import annotations

import importlib

_registered: set[str] = set()

# (module, registration function name, plugin name, class name)
_PLUGINS = (
    ("whitted.plugins.material", "register_bsdf", "article", "ArticleBSDF"),
    ("whitted.plugins.integrator", "register_integrator", "whitted", "WhittedIntegrator"),
)


def register() -> None:
    """Register every plugin for Mitsuba's current variant (once per variant)."""
    import mitsuba as mi

    variant = mi.variant()
    if variant in _registered:
        return
    from .scene_state import watch
    watch(mi.Scene)   # scene changes drop what the integrator derived from the scene
    for module_name, function, plugin_name, class_name in _PLUGINS:
        module = importlib.import_module(module_name)
        if _registered:  # built for another variant before: rebuild the classes
            module = importlib.reload(module)
        cls = getattr(module, class_name)
        getattr(mi, function)(plugin_name, lambda props, cls=cls: cls(props))
    _registered.add(variant)
