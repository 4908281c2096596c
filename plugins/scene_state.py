"""Memos of what the Whitted integrator derives from a scene, kept until the scene changes.

Why. A render needs the scene's sphere table, material table, lights and
effects (:mod:`.geometry`, :mod:`.surfaces`, :mod:`.effects`). Reading them
takes a pass over the scene's shapes (a scene of 66 000 spheres: most of a
second), while they only change when the scene does. So each is computed once
per *scene state* and kept here.

When the state changes. Mitsuba tells a scene that something in it changed
by calling its ``parameters_changed``: ``mi.SceneParameters.update()`` does so
for every scene whose shapes, materials, lights or sensors were written
(``params = mi.traverse(scene); params[...] = ...; params.update()``), and
the scene then rebuilds its own acceleration structure. :func:`watch` wraps
that method (once per variant) so that it also drops the scene's memos. A
material that changes drops every scene's memos itself (a material's
``mi.traverse(bsdf)`` reaches no scene). A shape changed through its own
``mi.traverse(shape)`` reaches no scene either, which leaves Mitsuba's ray
tracing stale as well as these memos.

Which scene. Scenes take neither Python attributes nor weak references, so
memos are keyed by the scene's address, and a scene is recognised by a
*witness* that the memo holds on to: in the JIT variants the Dr.Jit array of
its shapes (a held variable's index is never reused, so a new scene at the
address of a dead one has another), in ``scalar_rgb`` its first shape, emitter
or sensor object. Memos hold no reference to the scene itself, and at most
:data:`SCENES` scenes are remembered.
"""

from __future__ import annotations

from collections import OrderedDict

import drjit as dr
import mitsuba as mi

#: how many scenes' memos are kept (the least recently used go first)
SCENES = 8

#: (variant, scene address) -> (witness, {key: value})
_memos: OrderedDict = OrderedDict()


def _key(scene):
    return scene.variant_name(), scene.ptr


def _witness(scene):
    """Something that identifies ``scene`` while held, or None (nothing to remember)."""
    if dr.is_jit_v(mi.Float):
        arrays = (scene.shapes_dr(), scene.emitters_dr(), scene.sensors_dr())
        return arrays if any(dr.width(a) for a in arrays) else None
    for objects in (scene.shapes(), scene.emitters(), scene.sensors()):
        if objects:
            return objects[0]
    return None


def _same(witness, current) -> bool:
    if isinstance(witness, tuple):
        return all(a.index == b.index for a, b in zip(witness, current))
    return witness is current


def memo(scene, key, build):
    """``build()``, computed once per state of ``scene`` and ``key``."""
    witness = _witness(scene)
    if witness is None:
        return build()
    address = _key(scene)
    entry = _memos.get(address)
    if entry is None or not _same(entry[0], witness):
        entry = _memos[address] = (witness, {})
        while len(_memos) > SCENES:
            _memos.popitem(last=False)
    _memos.move_to_end(address)
    values = entry[1]
    if key not in values:
        values[key] = build()
    return values[key]


def forget(scene=None) -> None:
    """Drop the memos of ``scene`` (all memos when None)."""
    if scene is None:
        _memos.clear()
    else:
        _memos.pop(_key(scene), None)


def watch(scene_class) -> None:
    """Make ``scene_class.parameters_changed`` (a variant's ``mi.Scene``) drop the scene's memos."""
    original = scene_class.parameters_changed
    if getattr(original, "drops_memos", False):
        return

    def parameters_changed(self, keys=[]):  # noqa: B006  (Mitsuba's own default)
        forget(self)
        return original(self, keys)

    parameters_changed.drops_memos = True
    parameters_changed.__doc__ = original.__doc__
    scene_class.parameters_changed = parameters_changed
