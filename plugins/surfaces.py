"""Looking up a hit's material: base color B, KR, KT and IOR.

In the JIT variants a per-instance method call for every material would make
Dr.Jit trace one Python function per BSDF, which does not scale to scenes of
thousands of spheres. Instead the materials' numbers sit in a table indexed by
the BSDF's instance ID (a ``BSDFPtr`` reinterpreted as an integer), so a lookup
is a handful of gathers whatever the number of materials. Textures are the
exception: each textured material evaluates its own texture, only on the lanes
that hit it. The scalar variant reads the same table, by the hit BSDF's row.

Reading a scene's materials costs one pass over its shapes, and no more:
every ``article`` BSDF keeps its numbers as one :func:`material_row`, read
at the first render (about 10 µs: the color is read back from Dr.Jit) and
again only when its color changes (``parameters_changed``), so
:func:`shape_materials` only collects each shape's row (the rows of 66 000
spheres in about 0.1 s; Mitsuba's vectorized ``shapes_dr().bsdf()`` took as
long, and 2 s after a ``params.update()``). The integrator asks once per
scene state (see :mod:`.scene_state`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError

from .masks import off
from .scene_state import memo

#: columns of a :func:`material_row`
_KEY, _TEXTURED, _COLOR, _REFLECT, _REFRACT, _IOR = 0, 1, slice(2, 5), 5, 6, 7


def uniform_color(texture) -> tuple[float, float, float]:
    """The color of a texture that does not vary over the surface, as three floats.

    Read by indexing rather than through numpy: numpy's conversion, at 8 µs a
    call, was most of the time spent on a scene of 10 000 materials.
    """
    value = texture.eval(dr.zeros(mi.SurfaceInteraction3f))
    color = tuple(float(c[0]) if dr.is_jit_v(c) else float(c) for c in value)
    return color * 3 if len(color) == 1 else color


def material_row(bsdf) -> tuple:
    """An ``article`` BSDF as numbers: ``(key, textured, B, KR, KT, IOR)``.

    ``key`` is the BSDF's instance ID in the JIT variants (what a hit reports)
    and ``id(bsdf)`` in the scalar one (an address: exact in a float64); B is
    the constant base color, zero when textured.
    """
    if dr.is_jit_v(mi.Float):
        key = int(dr.reinterpret_array(mi.UInt32, mi.BSDFPtr(bsdf))[0])
    else:
        key = id(bsdf)
    color = None if bsdf.color.is_spatially_varying() else uniform_color(bsdf.color)
    return (key, float(color is None), *(color or (0.0, 0.0, 0.0)), bsdf.reflect, bsdf.refract, bsdf.ior)


@dataclass
class ShapeMaterials:
    """The material of every shape of ``scene.shapes()``, in that order."""
    rows: np.ndarray    # (N, 8) float64: each shape's :func:`material_row`
    textures: dict      # key -> the color texture of a textured material

    @property
    def key(self) -> np.ndarray:
        return self.rows[:, _KEY].astype(np.int64)

    @property
    def textured(self) -> np.ndarray:
        return self.rows[:, _TEXTURED] > 0


def shape_materials(scene) -> ShapeMaterials:
    """Each shape's material, computed once per scene state; every shape must have an
    ``article`` BSDF."""
    return memo(scene, "shape materials", lambda: _shape_materials(scene))


def _shape_materials(scene) -> ShapeMaterials:
    shapes = scene.shapes()
    bsdfs = [shape.bsdf() for shape in shapes]
    rows = [getattr(bsdf, "material_row", None) for bsdf in bsdfs]
    if None in rows:
        index = rows.index(None)
        bsdf = bsdfs[index]
        raise WhittedError(
            f"the whitted integrator needs the 'article' BSDF on every shape; shape "
            f"{shapes[index].id()!r} has {bsdf.class_name() if bsdf is not None else 'none'}")
    rows = np.array(rows, np.float64).reshape(-1, 8)
    textures = {int(rows[k, _KEY]): bsdfs[k].color for k in np.flatnonzero(rows[:, _TEXTURED]).tolist()}
    return ShapeMaterials(rows, textures)


@dataclass
class Materials:
    """A scene's distinct ``article`` BSDFs, one row each (ordered by key).

    ``key`` is a row's BSDF instance ID (JIT variants) or ``id()`` of the BSDF
    object (scalar); ``textures`` maps the keys of textured materials to their
    color textures, in order.
    """
    key: np.ndarray
    rows: np.ndarray                     # (n, 8): their :func:`material_row`
    textures: dict
    _memos: dict = field(default_factory=dict, repr=False)

    @property
    def reflective(self) -> bool:
        return bool((self.rows[:, _REFLECT] > 0).any())

    @property
    def refractive(self) -> bool:
        return bool((self.rows[:, _REFRACT] > 0).any())

    @property
    def textured(self) -> bool:
        return bool(self.textures)

    def largest_color(self) -> float:
        """The largest channel of the constant base colors (textures not included)."""
        return float(self.rows[self.rows[:, _TEXTURED] == 0, _COLOR].max(initial=0.0))

    def largest_gain(self) -> float:
        """The largest KR + KT."""
        return float((self.rows[:, _REFLECT] + self.rows[:, _REFRACT]).max(initial=0.0))

    def memo(self, key, build):
        """``build()``, computed once for these materials (they last one scene state)."""
        if key not in self._memos:
            self._memos[key] = build()
        return self._memos[key]

    def table(self):
        """``(row_of, columns)``, built once: the materials' numbers by row, and each
        material's row by key. ``columns`` are ``(type, table)`` pairs of color, KR, KT,
        IOR and texture slot (0 untextured, k: the k-th of ``textures``).

        A hit names its BSDF by instance ID in the JIT variants: the rows are the
        instance IDs and the tables opaque Dr.Jit arrays, read by gathers. In the
        scalar variant a hit hands over the BSDF itself, and ``dr.gather`` takes no
        plain numbers: the rows are 1, 2, ... and the tables numpy arrays. Row 0 is no
        material (a miss).
        """
        return self.memo("table", self._table)

    def _table(self):
        jit = dr.is_jit_v(mi.Float)
        rows = self.key if jit else np.arange(1, len(self.key) + 1)
        size = int(rows.max()) + 1 if len(rows) else 1
        numbers = np.zeros((size, 8))
        numbers[:, _IOR] = 1.0
        numbers[rows] = self.rows
        slot = np.zeros(size, np.uint32)
        slot[rows[np.isin(self.key, list(self.textures))]] = np.arange(1, len(self.textures) + 1)
        columns = ((mi.Color3f, numbers[:, _COLOR].T), (mi.Float, numbers[:, _REFLECT]),
                   (mi.Float, numbers[:, _REFRACT]), (mi.Float, numbers[:, _IOR]), (mi.UInt32, slot))
        if jit:
            columns = tuple((tp, tp(values)) for tp, values in columns)
            dr.make_opaque(*(table for _, table in columns))
        return (dict(zip(self.key.tolist(), rows.tolist())), columns)


def scene_materials(scene) -> Materials:
    """The distinct materials of ``scene``, computed once per scene state."""
    def build():
        shapes = shape_materials(scene)
        rows = shapes.rows[np.argsort(shapes.rows[:, _KEY], kind="stable")]
        distinct = rows[np.r_[True, rows[1:, _KEY] != rows[:-1, _KEY]]] if len(rows) else rows
        key = distinct[:, _KEY].astype(np.int64)
        return Materials(key, distinct, {k: shapes.textures[k] for k in key.tolist() if k in shapes.textures})
    return memo(scene, "materials", build)


@dataclass
class SurfaceSample:
    """The material at a hit point."""
    base: object      # mi.Color3f, B (texel or color)
    reflect: object   # mi.Float, KR
    refract: object   # mi.Float, KT
    ior: object       # mi.Float


class SurfaceTable:
    """Material lookups for the :class:`Materials` of a :class:`~.effects.SceneAnalysis`.

    ``need_ior`` leaves the IOR out of the kernels of scenes without refraction.
    """

    def __init__(self, materials: Materials, need_ior: bool):
        self.need_ior = need_ior
        # KR and KT that are 0 on every material are constants, not lookups
        self.reflective, self.refractive = materials.reflective, materials.refractive
        self.textured = list(materials.textures.values())   # slot k is textured[k - 1]
        row_of, columns = materials.table()
        if dr.is_jit_v(mi.Float):
            self._row = lambda bsdf: bsdf
            self._read = lambda tp, table, row, active: dr.gather(tp, table, row, active)
        else:
            self._row = lambda bsdf: row_of[id(bsdf)]
            self._read = lambda tp, table, row, active: tp(table[..., row].tolist())
        self._color, self._reflect, self._refract, self._ior, self._slot = columns

    def lookup(self, si, bsdf, active) -> SurfaceSample:
        """The material at ``si`` on the lanes ``active`` (hits only).

        ``bsdf`` is the hit BSDF's instance ID (JIT variants) or the BSDF itself (scalar).
        """
        row = self._row(bsdf)
        base = self._read(*self._color, row, active)
        if self.textured:
            slot = self._read(*self._slot, row, active)
            for k, texture in enumerate(self.textured, start=1):
                on_texture = active & (slot == k)
                if not off(on_texture):
                    base = dr.select(on_texture, mi.Color3f(texture.eval(si, on_texture)), base)
        ior = self._read(*self._ior, row, active) if self.need_ior else mi.Float(1)
        reflect = self._read(*self._reflect, row, active) if self.reflective else mi.Float(0)
        refract = self._read(*self._refract, row, active) if self.refractive else mi.Float(0)
        return SurfaceSample(base, reflect, refract, ior)
