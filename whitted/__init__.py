"""whitted: the classic sphere ray tracer of "Ray Tracing: Graphics for the Masses", inside
Mitsuba 3. Importing it loads neither Mitsuba nor Dr.Jit (the converter runs without them);
the API is loaded on first use. Once ``mitsuba`` is imported, before or after, a variant is
chosen if none is set and the plugins are registered for every variant (:mod:`whitted.variant`).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys

from .defaults import VERSION as __version__
from .errors import SceneError, WhittedError
from .variant import prepare_llvm as _prepare_llvm

_prepare_llvm()  # only sets an environment variable: Dr.Jit reads it when it starts

#: module -> the public names it holds: the API, imported on first use
_API = {"loading": ("load_scene", "loads"), "rendering": ("render", "RenderResult"),
        "batch": ("render_scenes",), "images": ("write_image", "read_image", "to_srgb"),
        "variant": ("set_variant",), "fitting": ("fit",), "editing": ("SceneEditor",),
        "trace": ("trace_pixel",)}
_LAZY = {name: f"whitted.{module}" for module, names in _API.items() for name in names}

__all__ = ["SceneError", "WhittedError", "__version__", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'whitted' has no attribute '{name}'")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


def _mitsuba_ready(mi) -> None:
    """Mitsuba has just been imported: choose a variant if none is set, register the plugins."""
    from .variant import on_variant_changed, set_variant
    mi.detail.add_variant_callback(on_variant_changed)
    try:
        set_variant(None)
    except WhittedError as error:   # e.g. a bad $WHITTED_VARIANT: the user's to fix, not a crash
        print(f"whitted: warning: {error}; no variant selected", file=sys.stderr)
        on_variant_changed(None, mi.variant())   # a variant the plugins refuse to run in


class _MitsubaHook:
    """A ``sys.meta_path`` finder that runs :func:`_mitsuba_ready` right after ``import mitsuba``."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "mitsuba":
            return None
        sys.meta_path.remove(self)   # once; and let the real finders find it
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def exec_then_register(module):
            from .interrupt import deferred
            with deferred():   # a Ctrl-C is not to cut Mitsuba's and Dr.Jit's set-up in half
                exec_module(module)
                _mitsuba_ready(sys.modules.get(fullname, module))

        spec.loader.exec_module = exec_then_register
        return spec


if "mitsuba" in sys.modules:
    _mitsuba_ready(sys.modules["mitsuba"])
elif not any(isinstance(f, _MitsubaHook) for f in sys.meta_path):
    sys.meta_path.insert(0, _MitsubaHook())
