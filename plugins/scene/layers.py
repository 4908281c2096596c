"""Spheres Mitsuba cannot intersect exactly in the scene's frame, and frames in which it can.

Why. Mitsuba 3.9's ``ellipsoids`` test is exact only at radius 1
(docs/numerics.md, "Spheres as Mitsuba ellipsoids"): for another radius it
loses hits and misplaces the rest. The loader gives the commonest radius of
a scene 1 by scaling the whole scene; spheres of other radii that it groups
as well (whitted/sealed.py, ``classes``), and any ``ellipsoids`` shape of
spheres whose radius is not 1, are traced in a *layer*: a scene of their own
holding the same spheres in the frame scaled by 1/r about the origin, where
their radius is 1. The Whitted integrator casts each ray into every layer,
scaled the same way (plugins/shading/layers.py), and keeps the nearest hit.

A layer's tables hold its primitives' centers, radii, error bounds and BSDFs
in the *scene's* frame, taken from the scene's own ``ellipsoids`` data, so a
hit found in a layer is the same point, normal and bound as if Mitsuba had
found it exactly in the scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.float32 import hit_error

from .materials import bsdf_key
from .primitives import Primitives, bounds, corners


@dataclass
class Layer:
    """Spheres of one radius, traced in the scene's frame scaled by ``scale`` (= 1/radius).

    ``tables`` are, in the JIT variants, the layer's
    :class:`~.primitives.PrimitiveTables` by slot of its own scene, with the scene-frame
    center, radius, error bound and BSDF instance ID; in the scalar variant a dict
    ``id(shape) -> (first primitive, BSDF)`` beside the lists ``center``, ``error``.
    """
    scale: float
    radius: float
    scene: object
    tables: object
    center: list | None = None
    error: list | None = None


def layers(shapes, types, primitives: Primitives) -> tuple[list[Layer], list[int]]:
    """The layers of ``shapes`` (``scene.shapes()``, their ``mi.ShapeType``s and
    :class:`~.primitives.Primitives`), and the indices of the shapes they hold (which the
    scene's own ray tracing must then leave out)."""
    members: dict[float, list] = {}
    held = []
    counts = primitives.counts
    for k in np.flatnonzero(types == int(mi.ShapeType.Ellipsoids)).tolist():
        span = slice(primitives.first[k], primitives.first[k] + counts[k])
        center, radius, sphere = primitives.center[:, span], primitives.radius[span], primitives.sphere[span]
        if not len(radius) or not sphere.all() or (radius == 1.0).all():
            continue
        held.append(k)
        for value in np.unique(radius).tolist():
            members.setdefault(value, []).append((shapes[k], center[:, radius == value]))
    return [_layer(radius, parts) for radius, parts in sorted(members.items())], held


def ellipsoids_shape(centers: np.ndarray, bsdf, radius: float = 1.0) -> dict:
    """The ``mi.load_dict`` entry of one ``ellipsoids`` shape of spheres of ``radius`` at
    ``centers`` (M×3): equal scales, no rotation, and ``extent`` 1 (Mitsuba's default, 3,
    would triple them). The loader's sealed spheres are made the same way (whitted/sealed.py)."""
    count = len(centers)
    return {"type": "ellipsoids", "extent": 1.0,
            "centers": mi.TensorXf(np.ascontiguousarray(centers, np.float32).reshape(count, 3)),
            "scales": mi.TensorXf(np.full((count, 3), radius, np.float32)),
            "quaternions": mi.TensorXf(np.tile(np.array([0.0, 0.0, 0.0, 1.0], np.float32), (count, 1))),
            "bsdf": bsdf}


def _layer(radius: float, parts) -> Layer:
    """The layer of the spheres of ``radius`` in ``parts``: (shape, 3×M scene-frame centers)."""
    scale = 1.0 / radius
    scene = mi.load_dict({"type": "scene", **{f"part_{i}": ellipsoids_shape(centers.T * scale, shape.bsdf())
                                               for i, (shape, centers) in enumerate(parts)}})
    center = np.concatenate([centers for _, centers in parts], axis=1)
    error = hit_error(radius, np.abs(center).max(axis=0, initial=0.0))
    own = scene.shapes()
    if not dr.is_jit_v(mi.Float):
        first = np.cumsum([0] + [c.shape[1] for _, c in parts])[:-1].tolist()
        tables = {id(shape): (start, parts[i][0].bsdf()) for i, (shape, start) in enumerate(zip(own, first))}
        return Layer(scale, radius, scene, tables, [mi.Point3f(c) for c in center.T.tolist()], error.tolist())
    rows = np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1)
    keys = np.array([bsdf_key(shape.bsdf()) for shape, _ in parts], np.int64)
    primitives = Primitives.read(own, corners(bounds(own)), np.full(len(own), int(mi.ShapeType.Ellipsoids)),
                                 np.zeros(len(own), bool), rows, keys)
    primitives.center, primitives.radius, primitives.error = center, np.full(center.shape[1], radius), error
    return Layer(scale, radius, scene, primitives.tables(spheres=True))
