"""whitted: the classic sphere ray tracer of "Ray Tracing: Graphics for the Masses",
inside Mitsuba 3.

``import whitted`` chooses a variant (llvm_ad_rgb when a libLLVM >= 16 exists,
else scalar_rgb; a variant already set through Mitsuba is kept) and registers
the project's plugins: the ``whitted`` integrator and the ``article`` BSDF.
"""

from __future__ import annotations

from .errors import SceneError, WhittedError
from .variant import prepare_llvm as _prepare_llvm

_prepare_llvm()  # before Dr.Jit starts: a bad libLLVM aborts the process

from .variant import set_variant  # noqa: E402

set_variant()

from .loading import load_scene  # noqa: E402

__all__ = ["SceneError", "WhittedError", "load_scene", "set_variant"]
__version__ = "0.1.0"
