"""Which ``.scn`` scene a loaded ``mi.Scene`` came from, and in what frame it was loaded.

The loader writes a scene relative to its ``lookat`` (converter/frame.py), scaled when
it groups spheres (whitted/sealed.py). What shows a scene to a user in the file's own
terms (``whitted trace``: positions in the file's coordinates, spheres named by their
line) asks :func:`recall` for the model the scene was loaded from and that frame.
Scenes take no Python attributes, so the loader (:func:`remember`) keeps them by the
scene's address, with a *witness* that tells a new scene at a dead one's address apart
(as the integrator's tables do: plugins/scene/tables.py). At most :data:`SCENES` are kept.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

#: how many scenes are remembered (the least recently loaded go first)
SCENES = 16

_kept: OrderedDict = OrderedDict()


@dataclass(frozen=True)
class Source:
    """A loaded scene's model (``whitted.converter.Scene``), its frame (world = frame / scale
    + ``model.lookat``) and the text it was parsed from when it came from no file (``loads``)."""
    model: object
    scale: float = 1.0
    text: str | None = None


def _witness(scene):
    import drjit as dr
    import mitsuba as mi
    if dr.is_jit_v(mi.Float):
        shapes = scene.shapes_dr()
        return shapes if dr.width(shapes) else None
    shapes = scene.shapes()
    return shapes[0] if shapes else None


def _same(a, b) -> bool:
    import drjit as dr
    if dr.is_array_v(a):
        return dr.is_array_v(b) and a.index == b.index
    return a is b


def remember(scene, source: Source) -> None:
    """``scene`` was loaded from ``source``."""
    witness = _witness(scene)
    if witness is None:
        return
    key = (scene.variant_name(), scene.ptr)
    _kept.pop(key, None)
    _kept[key] = (witness, source)
    while len(_kept) > SCENES:
        _kept.popitem(last=False)


def recall(scene) -> Source | None:
    """What ``scene`` was loaded from, if :func:`remember` was told and it is still held."""
    kept = _kept.get((scene.variant_name(), scene.ptr))
    if kept is None:
        return None
    witness = _witness(scene)
    return kept[1] if witness is not None and _same(kept[0], witness) else None
