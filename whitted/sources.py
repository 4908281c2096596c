"""Which ``.scn`` scene a loaded ``mi.Scene`` came from, and in what frame it was loaded.

The loader writes a scene relative to its ``lookat`` (converter/frame.py), scaled when
it groups spheres (whitted/sealed.py). What shows a scene to a user in the file's own
terms (``whitted trace``: positions in the file's coordinates, spheres named by their
line) asks :func:`recall` for the model the scene was loaded from and that frame.
Scenes take no Python attributes, so the loader (:func:`remember`) keeps them by the
scene's address, with a *witness* that tells a new scene at a dead one's address apart
(the integrator's tables' way: :class:`whitted.plugins.scene_tables.KeptByScene`). At most :data:`SCENES` are kept.
"""

from __future__ import annotations

from dataclasses import dataclass

#: how many scenes are remembered (the least recently loaded go first)
SCENES = 16


@dataclass(frozen=True)
class Source:
    """A loaded scene's model (``whitted.converter.Scene``), its frame (world = frame / scale
    + ``model.lookat``) and the text it was parsed from when it came from no file (``loads``)."""
    model: object
    scale: float = 1.0
    text: str | None = None


_kept = None


def _store():
    """The scenes remembered (:class:`whitted.plugins.scene_tables.KeptByScene`, made on first use)."""
    global _kept
    if _kept is None:
        from .plugins.scene_tables import KeptByScene
        _kept = KeptByScene(SCENES)
    return _kept


def remember(scene, source: Source) -> None:
    """``scene`` was loaded from ``source``."""
    _store().put(scene, source)


def recall(scene) -> Source | None:
    """What ``scene`` was loaded from, if :func:`remember` was told and it is still held."""
    return _store().get(scene)
