"""The ray tree of a pixel: the article's recursion made visible (``whitted trace``,
:func:`whitted.trace_pixel`).

:mod:`.record` keeps what the renderer computes at each level of a pixel's tree,
:mod:`.nodes` holds the tree and writes it as text and JSON, :mod:`.pixel` traces pixels
and puts the trees in the scene file's terms, :mod:`.page` draws them (an HTML page, a
notebook's view) and :mod:`.cli` is the command. Importing this package loads none of
them (the command line imports :mod:`.cli` to build its parser): the API below is
imported on first use.
"""

from __future__ import annotations

import importlib

__all__ = ["PixelTree", "Traces", "trace_pixel", "trace_pixels"]


def __getattr__(name: str):
    if name in __all__:
        return getattr(importlib.import_module("whitted.trace.pixel"), name)
    raise AttributeError(f"module 'whitted.trace' has no attribute '{name}'")
