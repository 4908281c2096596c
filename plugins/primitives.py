"""A scene's primitives as numbers, and the spheres traced in frames of their own (layers).

Each primitive's bounding sphere, error bound and texture frame, and the tables the hit
finders (:mod:`.hits`) read them from (:func:`read`): a ``sphere`` shape is one primitive, an
``ellipsoids`` shape one per ellipsoid, any other shape one known by its bounding box. A
hit's slot is its shape's row (instance ID; scalar: index), plus ``prim_index`` past a
per-shape ``base`` for ellipsoids (:func:`slot_of`). Mitsuba's ``ellipsoids`` test is exact
only at radius 1 (docs/numerics.md): spheres of another radius are traced in a *layer*, a
scene of their own scaled by 1/r (:class:`.hits.LayeredHits`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.float32 import hit_error


def bsdf_key(bsdf) -> int:
    """What names ``bsdf`` in a hit: its instance ID in the JIT variants, ``id(bsdf)`` in the
    scalar one (an address: exact in a float64)."""
    if dr.is_jit_v(mi.Float):
        return int(dr.reinterpret_array(mi.UInt32, mi.BSDFPtr(bsdf))[0])
    return id(bsdf)


def bounds(shapes) -> list:
    """The shapes' bounding boxes, which compare exactly with ``==`` (a call per shape: a
    vectorized call would trace each of them)."""
    return [shape.bbox() for shape in shapes]


def corners(boxes) -> np.ndarray:
    """Bounding boxes as an N×2×3 array (read without converting each box on its own)."""
    return np.fromiter(itertools.chain.from_iterable((*box.min, *box.max) for box in boxes),
                       np.float64, 6 * len(boxes)).reshape(-1, 2, 3)


def ellipsoid_numbers(shape):
    """``(center, radius, sphere)`` of an ``ellipsoids`` shape's primitives: 3×M centers, M
    radii (the largest scale times the extent) and whether each is a sphere (equal scales,
    no rotation, no per-ellipsoid extent)."""
    params = mi.traverse(shape)
    data = np.asarray(params["data"], np.float64).reshape(-1, 10)
    scales = data[:, 3:6] * float(params["extent"])
    sphere = (scales[:, 0] == scales[:, 1]) & (scales[:, 1] == scales[:, 2]) & (data[:, 6:9] == 0).all(axis=1)
    if params["extent_adaptive_clamping"]:
        sphere[:] = False
    return data[:, :3].T.copy(), scales.max(axis=1), sphere


@dataclass
class Primitives:
    """Per primitive of ``scene.shapes()``, listed shape by shape in that order."""
    low: np.ndarray          # 3×P, bounding box
    high: np.ndarray         # 3×P
    center: np.ndarray       # 3×P
    radius: np.ndarray       # P
    error: np.ndarray        # P, :func:`whitted.float32.hit_error`
    sphere: np.ndarray       # P, whether the primitive is a sphere
    frames: dict             # {primitive index: 3×3 frame} of textured spheres
    first: np.ndarray        # N, each shape's first primitive
    rows: np.ndarray         # N, each shape's row in the tables (:func:`shape_rows`)
    bsdf: np.ndarray         # N, the key of each shape's BSDF (:func:`bsdf_key`)

    @classmethod
    def read(cls, shapes, corners, types, textured, rows, bsdf_keys) -> "Primitives":
        """The primitives of ``shapes`` (``scene.shapes()``; ``corners``: their bounding
        boxes, N×2×3; ``types``: their ``mi.ShapeType``s)."""
        low, high = corners[:, 0].T, corners[:, 1].T
        center, radius = (low + high) / 2, (high - low).max(axis=0, initial=0.0) / 2
        sphere = types == int(mi.ShapeType.Sphere)
        frames = {}
        for index in np.flatnonzero(textured & sphere).tolist():
            matrix = np.array(mi.traverse(shapes[index])["to_world"].matrix, np.float64).reshape(4, 4)
            center[:, index], radius[index] = matrix[:3, 3], np.linalg.norm(matrix[:3, 0])
            frames[index] = (matrix[:3, :3] / radius[index]).T
        first = np.arange(len(shapes))
        groups = np.flatnonzero(types == int(mi.ShapeType.Ellipsoids))
        if len(groups):   # each ellipsoids shape's one entry becomes one per primitive
            columns, parts = (low, high, center, radius, sphere), []
            counts, start = np.ones(len(shapes), np.int64), 0
            for k in groups.tolist():
                c, r, s = ellipsoid_numbers(shapes[k])
                parts += [[column[..., start:k] for column in columns], (c - r, c + r, c, r, s)]
                counts[k], start = len(r), k + 1
            parts.append([column[..., start:] for column in columns])
            low, high, center, radius, sphere = (np.concatenate(column, axis=-1)
                                                 for column in zip(*parts))
            first = np.concatenate([[0], np.cumsum(counts)[:-1]])
            frames = {int(first[k]): frame for k, frame in frames.items()}
        error = hit_error(radius, np.abs(center).max(axis=0, initial=0.0))
        return cls(low, high, center, radius, error, sphere, frames, first, rows, bsdf_keys)

    @property
    def counts(self) -> np.ndarray:   # each shape's number of primitives
        return np.diff(np.append(self.first, len(self.radius)))

    def surface_at(self, point):
        """``(error, normal)`` of the sphere that ``point`` lies on (within twice its error
        bound; the one with the largest bound if several do), ``(0, 0)`` if none."""
        point = np.asarray(point, np.float64).reshape(3, 1)
        center, radius, error = self.center[:, self.sphere], self.radius[self.sphere], self.error[self.sphere]
        offset = point - center
        distance = np.linalg.norm(offset, axis=0)
        near = np.flatnonzero(np.abs(distance - radius) <= 2 * error)
        if not len(near):
            return 0.0, (0.0, 0.0, 0.0)
        k = near[np.argmax(error[near])]
        return float(error[k]), tuple(offset[:, k] / distance[k])

    def without(self, shapes) -> "Primitives":
        """These primitives, those of ``shapes`` (giant spheres, :class:`.hits.GiantHits`)
        no longer spheres: :meth:`surface_at` passes them over."""
        sphere = self.sphere.copy()
        for k in shapes:
            sphere[self.first[k]:self.first[k] + self.counts[k]] = False
        return replace(self, sphere=sphere)

    def distance_to_surfaces(self, point) -> float:
        """A lower bound on the distance from ``point`` to every primitive (inf without one):
        a sphere's ``| |point - C| - r |`` less its error bound, any other's the distance to
        its bounding box (0 inside it)."""
        if not len(self.radius):
            return np.inf
        point = np.asarray(point, np.float64).reshape(3, 1)
        to_sphere = np.abs(np.linalg.norm(point - self.center, axis=0) - self.radius) - self.error
        to_box = np.linalg.norm(np.maximum(0.0, np.maximum(self.low - point, point - self.high)), axis=0)
        return float(np.maximum(np.where(self.sphere, to_sphere, to_box), 0.0).min())

    def tables(self, shapes) -> "PrimitiveTables":
        """The primitives' :class:`PrimitiveTables` by slot (JIT: opaque Dr.Jit arrays; scalar:
        numpy, with ``row_of``: ``id(shape)`` -> row)."""
        rows, counts = self.rows, self.counts
        size = int(rows.max(initial=0)) + 1
        many = np.flatnonzero(counts != 1)   # shapes whose primitives are listed one by one
        slots, base = rows, None
        if len(many):
            start = np.arange(size, dtype=np.int64)
            start[rows[many]] = size + np.concatenate([[0], np.cumsum(counts[many])[:-1]])
            slots = np.repeat(start[rows], counts) + (np.arange(len(self.radius)) - np.repeat(self.first, counts))
            base = (start, np.isin(np.arange(size), rows[many]))
            size += int(counts[many].sum())
        error = np.zeros(size)
        error[slots] = self.error
        mapped, frame = np.zeros(size, bool), np.zeros((3, 3, size))
        frame[0, 0] = frame[1, 1] = frame[2, 2] = 1.0
        for k, prim_frame in self.frames.items():
            mapped[slots[k]], frame[:, :, slots[k]] = True, prim_frame
        center, radius, bsdf = np.zeros((3, size)), np.ones(size), np.zeros(size, np.int64)
        center[:, slots], radius[slots], bsdf[slots] = self.center, self.radius, np.repeat(self.bsdf, counts)
        tables = PrimitiveTables(
            as_table(mi.Float, error), as_table(mi.Bool, mapped),
            [as_table(mi.Vector3f, axis) for axis in frame],
            None if base is None else (as_table(mi.UInt32, base[0]), as_table(mi.Bool, base[1])),
            as_table(mi.Point3f, center), as_table(mi.Float, radius), as_table(mi.UInt32, bsdf))
        if not dr.is_jit_v(mi.Float):
            tables.row_of = {id(shape): k for k, shape in enumerate(shapes)}
        return tables


@dataclass
class PrimitiveTables:
    """Per-slot tables: error bound, whether a texture frame applies and the frame's axes,
    where ellipsoids shapes' primitives start (``base``: start and whether a row's primitives
    are listed one by one; None when no shape has several), each primitive's (bounding)
    sphere and BSDF key."""
    error: object
    mapped: object
    frame: list
    base: tuple | None
    center: object
    radius: object
    bsdf: object
    row_of: dict | None = None   # scalar variants: ``id(shape)`` -> its row


def shape_rows(scene) -> np.ndarray:
    """Each shape's row in the primitive tables: its instance ID (JIT), its index (scalar)."""
    if dr.is_jit_v(mi.Float) and scene.shapes():
        return np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1)
    return np.arange(len(scene.shapes()))


def as_table(tp, values):
    """``values`` (numpy, by slot along the last axis) as :func:`read` reads them: an opaque
    Dr.Jit array of type ``tp`` (JIT), the numpy array itself (scalar)."""
    if not dr.is_jit_v(mi.Float):
        return values
    table = tp(values.astype(np.uint32) if tp is mi.UInt32 else values)
    dr.make_opaque(table)
    return table


def read(tp, table, index, active=True):
    """``table[index]`` as ``tp``: a gather (JIT) or, where ``active``, a numpy item (scalar)."""
    if dr.is_jit_v(mi.Float):
        return dr.gather(tp, table, index, active)
    return tp(table[..., index]) if active else dr.zeros(tp)


def slot_of(tables, shape, prim_index, active):
    """A hit's slot in ``tables`` from its shape (``si.shape``, ``pi.shape``) and ``prim_index``."""
    row = tables.row_of[id(shape)] if tables.row_of is not None \
        else dr.reinterpret_array(mi.UInt32, shape)
    if tables.base is None:
        return row
    start, expanded = tables.base
    return read(mi.UInt32, start, row, active) + \
        dr.select(read(mi.Bool, expanded, row, active), prim_index, 0)


# -- layers ----------------------------------------------------------------------------------------


@dataclass
class Layer:
    """Spheres of one radius, traced in the scene's frame scaled by 1/radius; ``tables``:
    their :class:`PrimitiveTables`, in the scene's frame."""
    radius: float
    scene: object
    tables: PrimitiveTables


def layers(shapes, types, primitives: Primitives) -> tuple[list[Layer], list[int]]:
    """The layers of ``shapes``, and the indices of the shapes they hold."""
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
    built = []
    for radius, parts in sorted(members.items()):   # each a scene scaled by 1/radius
        scale = 1.0 / radius
        scene = mi.load_dict({"type": "scene", **{
            f"part_{i}": ellipsoids_shape(centers.T * scale, shape.bsdf())
            for i, (shape, centers) in enumerate(parts)}})
        center = np.concatenate([centers for _, centers in parts], axis=1)
        own = scene.shapes()
        keys = np.array([bsdf_key(shape.bsdf()) for shape, _ in parts], np.int64)
        spheres = Primitives.read(own, corners(bounds(own)), np.full(len(own), int(mi.ShapeType.Ellipsoids)),
                                  np.zeros(len(own), bool), shape_rows(scene), keys)
        spheres.center, spheres.radius = center, np.full(center.shape[1], radius)
        spheres.error = hit_error(radius, np.abs(center).max(axis=0, initial=0.0))
        built.append(Layer(radius, scene, spheres.tables(own)))
    return built, held


def ellipsoids_shape(centers: np.ndarray, bsdf, radius: float = 1.0) -> dict:
    """The ``mi.load_dict`` entry of one ``ellipsoids`` shape of spheres of ``radius`` at
    ``centers`` (M×3): equal scales, no rotation, ``extent`` 1 (Mitsuba's 3 would triple them)."""
    count = len(centers)
    return {"type": "ellipsoids", "extent": 1.0,
            "centers": mi.TensorXf(np.ascontiguousarray(centers, np.float32).reshape(count, 3)),
            "scales": mi.TensorXf(np.full((count, 3), radius, np.float32)),
            "quaternions": mi.TensorXf(np.tile(np.array([0.0, 0.0, 0.0, 1.0], np.float32), (count, 1))),
            "bsdf": bsdf}

