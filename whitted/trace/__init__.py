"""The ray tree of a pixel: the article's recursion made visible (``whitted trace``,
docs/trace.md); the API is imported on first use.
"""

from __future__ import annotations

import importlib

__all__ = ["PixelTree", "Traces", "trace_pixel", "trace_pixels"]


def __getattr__(name: str):
    if name in __all__:
        return getattr(importlib.import_module("whitted.trace.pixel"), name)
    raise AttributeError(f"module 'whitted.trace' has no attribute '{name}'")
