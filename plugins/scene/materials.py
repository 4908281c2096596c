"""A scene's materials as one table: base color B, KR, KT, IOR and texture slot per BSDF.

Why a table. In the JIT variants a per-instance method call for every
material would make Dr.Jit trace one Python function per BSDF, which does not
scale to scenes of thousands of spheres. Instead the materials' numbers sit in
a table indexed by the BSDF's instance ID (a ``BSDFPtr`` reinterpreted as an
integer), so a lookup is a handful of gathers whatever the number of
materials (:class:`~whitted.plugins.shading.shader.SurfaceLookup`). Textures are the
exception: each textured material evaluates its own texture, only on the lanes
that hit it. The scalar variant reads the same numbers, by the hit BSDF's row.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

#: columns of a :func:`material_row`
KEY, TEXTURED, COLOR, REFLECT, REFRACT, IOR = 0, 1, slice(2, 5), 5, 6, 7


def uniform_color(texture) -> tuple[float, float, float]:
    """The color of a texture that does not vary over the surface, as three floats
    (read by indexing, which is much cheaper than numpy's conversion)."""
    value = texture.eval(dr.zeros(mi.SurfaceInteraction3f))
    color = tuple(float(c[0]) if dr.is_jit_v(c) else float(c) for c in value)
    return color * 3 if len(color) == 1 else color


def bsdf_key(bsdf) -> int:
    """What names ``bsdf`` in a hit: its instance ID in the JIT variants, ``id(bsdf)`` in the
    scalar one (an address: exact in a float64)."""
    if dr.is_jit_v(mi.Float):
        return int(dr.reinterpret_array(mi.UInt32, mi.BSDFPtr(bsdf))[0])
    return id(bsdf)


def material_row(bsdf) -> tuple:
    """An ``article`` BSDF as numbers: ``(key, textured, B, KR, KT, IOR)``, B being the
    constant base color (zero when textured)."""
    color = None if bsdf.color.is_spatially_varying() else uniform_color(bsdf.color)
    return (bsdf_key(bsdf), float(color is None), *(color or (0.0, 0.0, 0.0)),
            bsdf.reflect, bsdf.refract, bsdf.ior)


@dataclass
class Materials:
    """A scene's distinct ``article`` BSDFs, one :func:`material_row` each (ordered by key).

    ``textures`` maps the keys of textured materials to their color textures, in
    order; ``largest_texel`` is the largest value any of them can return (None
    when that is not known: a texture other than a bitmap).
    """
    key: np.ndarray
    rows: np.ndarray                     # (n, 8)
    textures: dict
    largest_texel: float | None
    bsdfs: list = None                   # the BSDF objects, in the rows' order

    @classmethod
    def of(cls, bsdfs) -> tuple["Materials", np.ndarray]:
        """The distinct materials among ``bsdfs`` (``article`` BSDF objects, one per shape),
        and each shape's material key. A material is read once, however many shapes share it."""
        distinct = {}
        for bsdf in bsdfs:
            distinct.setdefault(id(bsdf), bsdf)
        objects = list(distinct.values())
        rows = np.array([material_row(bsdf) for bsdf in objects], np.float64).reshape(-1, 8)
        key_of = dict(zip(distinct, rows[:, KEY].astype(np.int64).tolist()))
        shape_keys = np.fromiter((key_of[id(bsdf)] for bsdf in bsdfs), np.int64, len(bsdfs))
        order = np.argsort(rows[:, KEY], kind="stable")
        rows = rows[order]
        objects = [objects[k] for k in order.tolist()]
        textures = {int(row[KEY]): bsdf.color for row, bsdf in zip(rows, objects) if row[TEXTURED]}
        texels = [_largest_texel(texture) for texture in textures.values()]
        materials = cls(rows[:, KEY].astype(np.int64), rows, textures,
                        None if None in texels else max(texels, default=0.0), objects)
        return materials, shape_keys

    def untextured(self) -> "Materials":
        """These materials with each texture replaced by the plain color white (the format's
        default color: a textured sphere's ``color`` is not kept beside its texture)."""
        if not self.textures:
            return self
        rows = self.rows.copy()
        textured = rows[:, TEXTURED] != 0
        rows[textured, COLOR] = 1.0
        rows[:, TEXTURED] = 0.0
        return Materials(self.key, rows, {}, 0.0, self.bsdfs)

    @property
    def reflective(self) -> bool:
        return bool((self.rows[:, REFLECT] > 0).any())

    @property
    def refractive(self) -> bool:
        return bool((self.rows[:, REFRACT] > 0).any())

    @property
    def textured(self) -> bool:
        return bool(self.textures)

    def largest_base(self) -> float | None:
        """The largest channel B can take, textures included (None when a texture's is not known)."""
        if self.largest_texel is None:
            return None
        return max(float(self.rows[self.rows[:, TEXTURED] == 0, COLOR].max(initial=0.0)), self.largest_texel)

    def largest_gain(self) -> float:
        """The largest KR + KT."""
        return float((self.rows[:, REFLECT] + self.rows[:, REFRACT]).max(initial=0.0))

    def table(self):
        """``(row_of, columns)``: the materials' numbers by row, and each material's row by
        key. ``columns`` are ``(type, table)`` pairs of color, KR, KT, IOR and texture slot
        (0 untextured, k: the k-th of ``textures``).

        A hit names its BSDF by instance ID in the JIT variants: the rows are the
        instance IDs and the tables opaque Dr.Jit arrays, read by gathers. In the
        scalar variant a hit hands over the BSDF itself, and ``dr.gather`` takes no
        plain numbers: the rows are 1, 2, ... and the tables numpy arrays. Row 0 is no
        material (a miss).
        """
        jit = dr.is_jit_v(mi.Float)
        rows = self.key if jit else np.arange(1, len(self.key) + 1)
        size = int(rows.max()) + 1 if len(rows) else 1
        numbers = np.zeros((size, 8))
        numbers[:, IOR] = 1.0
        numbers[rows] = self.rows
        slot = np.zeros(size, np.uint32)
        slot[rows[np.isin(self.key, list(self.textures))]] = np.arange(1, len(self.textures) + 1)
        columns = ((mi.Color3f, numbers[:, COLOR].T), (mi.Float, numbers[:, REFLECT]),
                   (mi.Float, numbers[:, REFRACT]), (mi.Float, numbers[:, IOR]), (mi.UInt32, slot))
        if jit:
            columns = tuple((tp, tp(values)) for tp, values in columns)
            dr.make_opaque(*(table for _, table in columns))
        return (dict(zip(self.key.tolist(), rows.tolist())), columns)


def _largest_texel(texture):
    """The largest value a bitmap texture can return: its largest stored value (8- and 16-bit
    ones read as v/255 and v/65535, which is at least their sRGB-decoded value); None for
    other textures."""
    params = mi.traverse(texture)
    if "data" not in params:
        return None
    data = np.array(params["data"])
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(data.dtype, 1.0)
    return float(data.max(initial=0.0)) / scale
