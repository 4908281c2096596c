"""What the Whitted integrator derives from a scene, in one place: :class:`SceneTables`.

Why. A render needs the scene's lights, background, materials and primitives,
as numbers and as Dr.Jit tables (:mod:`.lights`, :mod:`.materials`,
:mod:`.primitives`). Building them takes a pass over the shapes, which a scene
of tens of thousands of spheres feels, while they only change when the scene
does. So they are kept from one render to the next, and checked at the start
of each one.

The one way they are invalidated. :func:`scene_tables`, which every render
calls first, reads what the tables were built from and what costs little to
read: each shape's bounding box (a sphere's center and radius), each ``ellipsoids`` shape's data array, each textured
sphere's ``to_world``, the lights and the background, and how many times each
``article`` BSDF has changed (its ``changes``, which Mitsuba's own
``parameters_changed`` counts: no BSDF knows of the tables). Anything else the tables hold follows from
these. When one differs, the tables are built afresh. So an edit made the
Mitsuba way (``params = mi.traverse(scene)``, ``params[...] = ...``,
``params.update()``) shows in the next render without the integrator being
told, and no Mitsuba class is touched. (A shape edited through its own
``mi.traverse(shape)`` reaches no scene: Mitsuba's own ray tracing of it is
then stale as well, and so are the tables.)

Which scene. Scenes take neither Python attributes nor weak references, so
tables are kept by the scene's address, and a scene is recognised by a
*witness* held with them: in the JIT variants the Dr.Jit arrays of its
shapes, emitters and sensors (a held variable's index is never reused, so a
new scene at the address of a dead one has other ones), in ``scalar_rgb`` its
first shape, emitter or sensor object. At most :data:`SCENES` scenes' tables
are kept.
"""

from __future__ import annotations

import copy
from collections import OrderedDict

import drjit as dr
import mitsuba as mi
import numpy as np

from whitted.errors import WhittedError

from .layers import layers
from .lights import largest_emission, point_lights
from .materials import Materials
from .primitives import Primitives, bounds, corners

#: how many scenes' tables are kept (the least recently used go first)
SCENES = 8



def _changes(bsdfs) -> tuple:
    """How many times each ``article`` BSDF has been changed (``ArticleBSDF.changes``)."""
    return tuple(bsdf.changes for bsdf in bsdfs)


def _shape_types(scene, shapes) -> np.ndarray:
    """Each shape's ``mi.ShapeType`` as an integer (one gather in the JIT variants)."""
    if dr.is_jit_v(mi.Float):
        return np.asarray(scene.shapes_dr().shape_type(), np.uint32).reshape(-1)
    return np.array([int(shape.shape_type()) for shape in shapes], np.uint32)


def _ellipsoid_data(shape):
    """What an ``ellipsoids`` shape's primitives are read from: its data array (the Dr.Jit
    array itself in the JIT variants, compared by variable index; a copy in scalar) and extent."""
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
    """Everything the Whitted integrator reads from one state of a scene, built in one pass.

    ============== =======================================================================
    lights         ``(position, intensity)`` of each point light
    environment    the environment emitter (the background) or None
    background     the largest channel of its radiance (0 without one; None: not known)
    materials      the distinct ``article`` BSDFs (:class:`.materials.Materials`)
    material_table their numbers as lookup tables (:meth:`.materials.Materials.table`)
    primitives     each primitive's bounding sphere and error bound (:class:`.primitives.Primitives`)
    spheres_only   whether every primitive is a sphere (the JIT variants' sphere table applies)
    sphere_shapes  whether a shape is a ``sphere`` shape (shadow rays must avoid its ray_test)
    hit_tables     the primitives' Dr.Jit tables (JIT variants) or ``id(shape)`` table (scalar)
    layers         spheres traced in frames of their own (:mod:`.layers`)
    layered        the indices of the shapes the layers hold
    ============== =======================================================================

    Raises :class:`~whitted.errors.WhittedError` when a shape lacks the ``article`` BSDF or
    an emitter is neither a point light nor the environment.
    """

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
        types = _shape_types(scene, shapes)
        boxes = bounds(shapes)
        jit = dr.is_jit_v(mi.Float)
        rows = np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), np.int64).reshape(-1) \
            if jit and shapes else None
        self.primitives = Primitives.read(shapes, corners(boxes), types, textured, rows, keys if jit else None)
        self._types = types
        self.spheres_only = bool(len(shapes)) and bool(self.primitives.sphere.all())
        self.sphere_shapes = bool((types == int(mi.ShapeType.Sphere)).any())
        if jit:   # with every primitive's sphere (a mesh's is its bounding sphere): see :meth:`_part`
            self.hit_tables = self.primitives.tables(spheres=True)
        else:
            self.hit_tables = self.primitives.scalar_tables(shapes)
        self.layers, self.layered = layers(shapes, types, self.primitives)
        self._rest_scenes = {}
        # what the tables were built from (:meth:`matches`)
        self._boxes, self._changes = boxes, _changes(self.materials.bsdfs)
        ellipsoids = types == int(mi.ShapeType.Ellipsoids)
        self._ellipsoids = {k: _ellipsoid_data(shapes[k]) for k in np.flatnonzero(ellipsoids).tolist()}
        spheres = types == int(mi.ShapeType.Sphere)
        self._frames = {k: _to_world(shapes[k]) for k in np.flatnonzero(textured & spheres).tolist()}

    def matches(self, scene) -> bool:
        """Whether these tables are still those of ``scene`` (see the module docstring)."""
        shapes = scene.shapes()
        return (_changes(self.materials.bsdfs) == self._changes and bounds(shapes) == self._boxes
                and all(_same_data(_ellipsoid_data(shapes[k]), data) for k, data in self._ellipsoids.items())
                and all(_to_world(shapes[k]) == matrix for k, matrix in self._frames.items())
                and point_lights(scene) == self.lights
                and (scene.environment() is None) == (self.environment is None)
                and (self.environment is None or largest_emission(scene.environment()) == self.background))

    def rest(self, scene, left_out):
        """``(rest_scene, tables)``: a scene of ``scene``'s shapes but those whose index is in
        ``left_out`` (the same objects: the same instance IDs and BSDFs; None when no shape is
        left), and its tables (:meth:`_part`); made once for each ``left_out``."""
        key = tuple(sorted(left_out))
        if key not in self._rest_scenes:
            # keyed by the shapes' own ids: mi.load_dict names each shape by its key
            rest = {shape.id() or f"shape_{k}": shape for k, shape in enumerate(scene.shapes()) if k not in left_out}
            self._rest_scenes[key] = (mi.load_dict({"type": "scene", **rest}) if rest else None,
                                      self._part(left_out))
        return self._rest_scenes[key]

    def _part(self, left_out) -> "SceneTables":
        """These tables, for the scene of :meth:`rest` (its shape objects keep their instance
        IDs, rows and primitives): only what depends on which shapes there are changes."""
        part = copy.copy(self)
        kept = np.ones(len(self._types), bool)
        kept[list(left_out)] = False
        shape_sphere = np.add.reduceat(~self.primitives.sphere, self.primitives.first) == 0 \
            if len(self._types) else np.zeros(0, bool)
        part.spheres_only = bool(kept.any()) and bool(shape_sphere[kept].all())
        part.sphere_shapes = bool((self._types[kept] == int(mi.ShapeType.Sphere)).any())
        part.layers, part.layered, part._rest_scenes = [], [], {}
        return part


def _witness(scene):
    """Something that identifies ``scene`` while held, or None (nothing to keep)."""
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


class KeptByScene:
    """Values kept for live scenes, by the scene's address and recognised by its witness
    (see the module docstring); at most ``size``, the least recently used going first."""

    def __init__(self, size: int):
        self.size = size
        self._kept: OrderedDict = OrderedDict()   # (variant, address) -> (witness, value)

    def get(self, scene):
        """The value kept for ``scene``, or None."""
        kept = self._kept.get((scene.variant_name(), scene.ptr))
        witness = _witness(scene)
        if kept is None or witness is None or not _same(kept[0], witness):
            return None
        self._kept.move_to_end((scene.variant_name(), scene.ptr))
        return kept[1]

    def put(self, scene, value) -> None:
        """Keep ``value`` for ``scene`` (nothing, for a scene with nothing to witness it)."""
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
