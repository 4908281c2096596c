"""What the Whitted integrator reads from a scene, and what a render of it calls for.

:class:`SceneTables` holds the scene's lights, background, primitives and materials (one
table indexed by the BSDF's key: a lookup is a few gathers, no per-BSDF call in the kernels),
kept between renders and checked at each against what they were built from
(docs/CONTRACTS.md). :func:`analyse` says which effects a render calls for; their names
(also reported by ``whitted render --stats``):

``lights``      point lights: the direct term and its shadow rays
``reflection``  a surface with KR > 0, and a max depth above 1
``refraction``  a surface with KT > 0, and a max depth above 1
``textures``    a surface whose base color varies over it (a bitmap)
``background``  an environment emitter (the scene's non-black background)

Code for an effect the scene lacks is left out of the kernels. What a render leaves out on
request (``without``) is the same image, bit for bit, as a scene edited so (docs/lessons.md).
"""

from __future__ import annotations

import copy
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError

from .primitives import Primitives, as_table, bounds, bsdf_key, corners, layers, shape_rows

#: how many scenes' tables are kept (the least recently used go first)
SCENES = 8


# -- lights ---------------------------------------------------------------------------------------

def floats(value) -> tuple[float, ...]:
    """A Mitsuba vector or color (scalar or width-1 JIT array) as Python floats."""
    return tuple(float(x) for x in np.array(value, dtype=np.float64).reshape(-1))


def article_color(intensity, position, reference) -> tuple[float, float, float]:
    """The article's light color ``I / (pi d^2)`` (d = |position - reference|, 1 when 0): the
    converter writes color c as ``I = c·π·d²`` (docs/numerics.md, hazard 6b)."""
    d2 = sum((p - r) ** 2 for p, r in zip(position, reference))
    if d2 == 0.0:
        d2 = 1.0
    return tuple(i / (math.pi * d2) for i in intensity)


def point_lights(scene) -> tuple[tuple, ...]:
    """``(position, intensity)`` of every point light of ``scene``; an error for an emitter
    that is neither a point light nor the environment."""
    lights = []
    for emitter in scene.emitters():
        if emitter.is_environment():
            continue
        if emitter.class_name() != "PointLight":
            raise WhittedError(f"the whitted integrator cannot render the emitter {emitter.id()!r} "
                               f"(a {emitter.class_name()}): it renders point lights and a "
                               "background only")
        params = mi.traverse(emitter)
        if "position" not in params or "intensity.value" not in params:
            raise WhittedError(f"the whitted integrator cannot read the point light "
                               f"{emitter.id()!r}: give it a 'position' and an RGB 'intensity'")
        intensity = floats(params["intensity.value"])
        lights.append((floats(params["position"]), intensity * 3 if len(intensity) == 1
                       else intensity))
    return tuple(lights)


def largest_emission(emitter) -> float | None:
    """The largest channel of a constant environment's radiance (None: another emitter)."""
    params = mi.traverse(emitter)
    if emitter.class_name() != "ConstantBackgroundEmitter" or "radiance.value" not in params:
        return None
    return float(np.array(params["radiance.value"], np.float64).max())


# -- materials ------------------------------------------------------------------------------------

#: columns of a :func:`material_row`
KEY, TEXTURED, COLOR, REFLECT, REFRACT, IOR = 0, 1, slice(2, 5), 5, 6, 7


def uniform_color(texture) -> tuple[float, float, float]:
    """The color of a texture that does not vary over the surface, as three floats."""
    color = floats(texture.eval(dr.zeros(mi.SurfaceInteraction3f)))
    return color * 3 if len(color) == 1 else color


def material_row(bsdf) -> tuple:
    """An ``article`` BSDF as numbers: ``(key, textured, B, KR, KT, IOR)``, B being the
    constant base color (zero when textured)."""
    color = None if bsdf.color.is_spatially_varying() else uniform_color(bsdf.color)
    return (bsdf_key(bsdf), float(color is None), *(color or (0.0, 0.0, 0.0)),
            bsdf.reflect, bsdf.refract, bsdf.ior)


@dataclass
class Materials:
    """A scene's distinct ``article`` BSDFs, one :func:`material_row` each (ordered by key);
    ``textures``: key -> color texture; ``largest_texel``: their largest value (None: unknown)."""
    key: np.ndarray
    rows: np.ndarray                     # (n, 8)
    textures: dict
    largest_texel: float | None
    bsdfs: list = None                   # the BSDF objects, in the rows' order

    @classmethod
    def of(cls, bsdfs) -> tuple["Materials", np.ndarray]:
        """The distinct materials among ``bsdfs`` (one per shape), and each shape's key."""
        objects = list({id(bsdf): bsdf for bsdf in bsdfs}.values())
        rows = np.array([material_row(bsdf) for bsdf in objects], np.float64).reshape(-1, 8)
        key_of = dict(zip(map(id, objects), rows[:, KEY].astype(np.int64).tolist()))
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
        """These materials with each texture replaced by white (the format's default color)."""
        if not self.textures:
            return self
        rows = self.rows.copy()
        rows[rows[:, TEXTURED] != 0, COLOR] = 1.0
        rows[:, TEXTURED] = 0.0
        return Materials(self.key, rows, {}, 0.0, self.bsdfs)

    @property
    def reflective(self) -> bool:
        return bool((self.rows[:, REFLECT] > 0).any())

    @property
    def refractive(self) -> bool:
        return bool((self.rows[:, REFRACT] > 0).any())

    def largest_base(self) -> float | None:
        """The largest channel B can take, textures included (None when a texture's is not known)."""
        if self.largest_texel is None:
            return None
        return max(float(self.rows[self.rows[:, TEXTURED] == 0, COLOR].max(initial=0.0)),
                   self.largest_texel)

    def largest_gain(self) -> float:
        return float((self.rows[:, REFLECT] + self.rows[:, REFRACT]).max(initial=0.0))

    def table(self):
        """``(row_of, columns)``: each material's row by key, and ``(type, table)`` columns of
        color, KR, KT, IOR and texture slot (k > 0: the k-th texture). The rows are instance
        IDs (JIT: opaque arrays) or 1, 2, ... (scalar: numpy); row 0 is a miss."""
        rows = self.key if dr.is_jit_v(mi.Float) else np.arange(1, len(self.key) + 1)
        size = int(rows.max()) + 1 if len(rows) else 1
        numbers = np.zeros((size, 8))
        numbers[:, IOR] = 1.0
        numbers[rows] = self.rows
        slot = np.zeros(size, np.uint32)
        slot[rows[np.isin(self.key, list(self.textures))]] = np.arange(1, len(self.textures) + 1)
        columns = ((mi.Color3f, numbers[:, COLOR].T), (mi.Float, numbers[:, REFLECT]),
                   (mi.Float, numbers[:, REFRACT]), (mi.Float, numbers[:, IOR]), (mi.UInt32, slot))
        return (dict(zip(self.key.tolist(), rows.tolist())),
                tuple((tp, as_table(tp, values)) for tp, values in columns))


def _largest_texel(texture):
    """The largest value a bitmap texture can return (None for other textures)."""
    params = mi.traverse(texture)
    if "data" not in params:
        return None
    data = np.array(params["data"])
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(data.dtype, 1.0)
    return float(data.max(initial=0.0)) / scale


# -- the tables, kept by scene -------------------------------------------------------------------

def _changes(bsdfs) -> tuple:   # how many times each BSDF has been changed
    return tuple(bsdf.changes for bsdf in bsdfs)


def _ellipsoid_data(shape):
    """An ``ellipsoids`` shape's data array (JIT: the array itself; scalar: a copy) and extent."""
    params = mi.traverse(shape)
    data = params["data"]
    return (data if dr.is_jit_v(mi.Float) else np.array(data)), float(params["extent"])


def _same_data(a, b) -> bool:
    if dr.is_jit_v(mi.Float):
        return a[0].index == b[0].index and a[1] == b[1]
    return np.array_equal(a[0], b[0]) and a[1] == b[1]


def _to_world(shape) -> tuple:
    return tuple(np.array(mi.traverse(shape)["to_world"].matrix, np.float64).reshape(-1).tolist())


class SceneTables:
    """Everything the Whitted integrator reads from one state of a scene, built in one pass
    (a :class:`~whitted.errors.WhittedError` where a shape lacks the ``article`` BSDF)."""

    def __init__(self, scene):
        shapes = scene.shapes()
        bsdfs = [shape.bsdf() for shape in shapes]
        for shape, bsdf in zip(shapes, bsdfs):
            if not getattr(bsdf, "is_article", False):
                has = f"the BSDF {bsdf.class_name()}" if bsdf is not None else "no BSDF"
                raise WhittedError(
                    f"the whitted integrator cannot render {has} of shape {shape.id()!r} "
                    f"(a {shape.class_name()}): it renders the 'article' BSDF only")
        self.lights = point_lights(scene)
        self.environment = scene.environment()
        self.background = 0.0 if self.environment is None else largest_emission(self.environment)
        self.materials, keys = Materials.of(bsdfs)
        self.material_table = self.materials.table()
        textured = np.isin(keys, list(self.materials.textures))
        if dr.is_jit_v(mi.Float):   # each shape's mi.ShapeType, as an integer
            types = np.asarray(scene.shapes_dr().shape_type(), np.uint32).reshape(-1)
        else:
            types = np.array([int(shape.shape_type()) for shape in shapes], np.uint32)
        boxes = bounds(shapes)
        self.primitives = Primitives.read(shapes, corners(boxes), types, textured,
                                          shape_rows(scene), keys)
        self._types = types
        spheres = types == int(mi.ShapeType.Sphere)
        # whether every primitive is a sphere (the JIT variants' sphere table applies), and
        # whether a shape is a ``sphere`` shape (shadow rays must avoid its ray_test)
        self.spheres_only = bool(len(shapes)) and bool(self.primitives.sphere.all())
        self.sphere_shapes = bool(spheres.any())
        self.hit_tables = self.primitives.tables(shapes)
        # spheres traced in frames of their own, and the indices of the shapes they hold
        self.layers, self.layered = layers(shapes, types, self.primitives)
        self._rest_scenes = {}
        # what the tables were built from (:meth:`matches`)
        self._boxes, self._changes = boxes, _changes(self.materials.bsdfs)
        self._ellipsoids = {k: _ellipsoid_data(shapes[k])
                            for k in np.flatnonzero(types == int(mi.ShapeType.Ellipsoids)).tolist()}
        self._frames = {k: _to_world(shapes[k])
                        for k in np.flatnonzero(textured & spheres).tolist()}

    def matches(self, scene) -> bool:
        shapes = scene.shapes()
        return (_changes(self.materials.bsdfs) == self._changes and bounds(shapes) == self._boxes
                and all(_same_data(_ellipsoid_data(shapes[k]), data)
                        for k, data in self._ellipsoids.items())
                and all(_to_world(shapes[k]) == matrix for k, matrix in self._frames.items())
                and point_lights(scene) == self.lights
                and (scene.environment() is None) == (self.environment is None)
                and (self.environment is None or largest_emission(scene.environment()) == self.background))

    def rest(self, scene, left_out):
        """``(rest_scene, tables)``: a scene of the same shape objects but those in ``left_out``
        (None when none is left), and its tables; made once for each ``left_out``."""
        key = tuple(sorted(left_out))
        if key not in self._rest_scenes:
            # keyed by the shapes' own ids: mi.load_dict names each shape by its key
            rest = {shape.id() or f"shape_{k}": shape for k, shape in enumerate(scene.shapes())
                    if k not in left_out}
            part = copy.copy(self)   # these tables, for the scene without those shapes
            kept = np.ones(len(self._types), bool)
            kept[list(left_out)] = False
            shape_sphere = np.add.reduceat(~self.primitives.sphere, self.primitives.first) == 0
            part.spheres_only = bool(kept.any()) and bool(shape_sphere[kept].all())
            part.sphere_shapes = bool((self._types[kept] == int(mi.ShapeType.Sphere)).any())
            part.layers, part.layered, part._rest_scenes = [], [], {}
            self._rest_scenes[key] = (mi.load_dict({"type": "scene", **rest}) if rest else None,
                                      part)
        return self._rest_scenes[key]


def _witness(scene):   # what identifies ``scene`` while held, or None (nothing to keep)
    if dr.is_jit_v(mi.Float):
        arrays = (scene.shapes_dr(), scene.emitters_dr(), scene.sensors_dr())
        return arrays if any(dr.width(a) for a in arrays) else None
    for objects in (scene.shapes(), scene.emitters(), scene.sensors()):
        if objects:
            return objects[0]
    return None


class KeptByScene:
    """Values kept for at most ``size`` live scenes (least recently used first out), by the
    scene's address, recognised by a witness: JIT, its Dr.Jit arrays (an index is never
    reused); scalar, its first shape, emitter or sensor."""

    def __init__(self, size: int):
        self.size = size
        self._kept: OrderedDict = OrderedDict()   # (variant, address) -> (witness, value)

    def get(self, scene):
        """The value kept for ``scene``, or None."""
        address = (scene.variant_name(), scene.ptr)
        kept, witness = self._kept.get(address), _witness(scene)
        if kept is None or witness is None or not (
                all(a.index == b.index for a, b in zip(kept[0], witness))
                if isinstance(witness, tuple) else kept[0] is witness):
            return None
        self._kept.move_to_end(address)
        return kept[1]

    def put(self, scene, value) -> None:   # (nothing, for a scene with nothing to witness it)
        witness = _witness(scene)
        if witness is None:
            return
        address = (scene.variant_name(), scene.ptr)
        self._kept.pop(address, None)
        self._kept[address] = (witness, value)
        while len(self._kept) > self.size:
            self._kept.popitem(last=False)


_kept = KeptByScene(SCENES)


def scene_tables(scene) -> SceneTables:
    """The :class:`SceneTables` of ``scene`` as it is now: the kept ones while they still
    describe it, else new ones."""
    tables = _kept.get(scene)
    if tables is not None and tables.matches(scene):
        return tables
    tables = SceneTables(scene)
    _kept.put(scene, tables)
    return tables


# -- what a render calls for ---------------------------------------------------------------------

@dataclass(frozen=True)
class PointLight:
    """A point emitter: its radiant intensity I and the article's color (:func:`article_color`)."""
    position: tuple[float, float, float]
    intensity: tuple[float, float, float]
    color: tuple[float, float, float]


@dataclass
class SceneAnalysis:
    """The scene tables read for one render: lights, background, materials, effects and the
    depth the tree needs."""
    tables: SceneTables
    lights: list[PointLight]             # the lights simulated (none without ``diffuse``)
    max_depth: int                       # the depth asked for
    without: frozenset = frozenset()     # what the render leaves out (docs/lessons.md)
    effects: tuple[str, ...] = field(init=False)
    depth: int = field(init=False)       # the depth actually needed
    surfaces: Materials = field(init=False)   # the materials as simulated

    def __post_init__(self):
        if "diffuse" in self.without:
            self.lights = []
        self.surfaces = self.tables.materials.untextured() if "textures" in self.without \
            else self.tables.materials
        deep = self.max_depth > 1
        present = {
            "lights": bool(self.lights),
            "reflection": deep and self.surfaces.reflective and "reflection" not in self.without,
            "refraction": deep and self.surfaces.refractive and "refraction" not in self.without,
            "textures": bool(self.surfaces.textures),
            "background": self.tables.environment is not None,
        }
        self.effects = tuple(name for name, called_for in present.items() if called_for)
        # Only reflected and refracted rays make a tree deeper than its root.
        self.depth = self.max_depth if present["reflection"] or present["refraction"] else 1

    @property
    def material_table(self):
        """The table of :attr:`surfaces` (:meth:`Materials.table`)."""
        if self.surfaces is self.tables.materials:
            return self.tables.material_table
        return self.surfaces.table()

    def has(self, effect: str) -> bool:
        """Whether the render simulates ``effect``: one of :attr:`effects`, or ``shadows``
        (lights, tested for shadow) or ``ambient`` (A is taken)."""
        if effect == "shadows":
            return "lights" in self.effects and "shadows" not in self.without
        if effect == "ambient":
            return "ambient" not in self.without
        return effect in self.effects


def analyse(tables: SceneTables, max_depth: int, light_reference, without=()) -> SceneAnalysis:
    """What a render of the scene of ``tables`` to ``max_depth``, ``without`` some effects,
    calls for; ``light_reference``: where the article's light colors were measured."""
    reference = floats(light_reference)
    lights = [PointLight(position, intensity, article_color(intensity, position, reference))
              for position, intensity in tables.lights]
    return SceneAnalysis(tables, lights, max_depth, frozenset(without))
