"""What a render of a scene calls for: its lights, background, materials and effects.

The Whitted integrator builds its kernels from :func:`analyse`'s answer: a
scene without mirrors gets no reflection code and spawns no reflection rays,
a scene without lights traces no shadow rays, and a scene without reflective
or transparent surfaces is traced to depth 1 whatever its ``max_depth``.

Effect names (also reported by ``whitted render --stats``):

``lights``      point lights: the direct term and its shadow rays
``reflection``  a surface with KR > 0, and a max depth above 1
``refraction``  a surface with KT > 0, and a max depth above 1
``textures``    a surface whose base color varies over it (a bitmap)
``background``  an environment emitter (the scene's non-black background)

What a render leaves out on request (the integrator's ``without``, ``whitted render
--without``: :data:`whitted.defaults.SWITCHABLE_EFFECTS`) is decided here too, as if the
scene lacked it; each is the same image, bit for bit, as a scene edited so:

``shadows``     no shadow test: every light is seen from every point facing it (no
                shadow rays)
``reflection``  no reflected rays: a mirror keeps its diffuse share ``(1 - KR - KT)·point``
                and its share KR is dropped (black), as at the tree's last level
``refraction``  no refracted rays, likewise for KT (without both: ``max_depth`` 1)
``textures``    a textured sphere has the plain color the scene gives it: white, the
                format's default (the converter keeps no color beside a texture)
``diffuse``     no light's term: a point's color is ``B·A`` (article) or 0 (physical), as
                in a scene without lights (so no shadow rays either)
``ambient``     A = 0, as ``ambient 0`` in the file
"""

from __future__ import annotations

from dataclasses import dataclass, field

from whitted.defaults import SWITCHABLE_EFFECTS

from .lights import article_color, floats
from .materials import Materials
from .tables import SceneTables

EFFECTS = ("lights", "reflection", "refraction", "textures", "background")


@dataclass(frozen=True)
class PointLight:
    """A point emitter, with both readings of its strength: Mitsuba's radiant intensity I
    (physical lighting divides it by r^2) and the article's light color ``I / (pi d^2)``
    (:func:`.lights.article_color`, d measured to the integrator's ``light_reference``)."""
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
    without: frozenset = frozenset()     # what the render leaves out (the module docstring)
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
            "textures": self.surfaces.textured,
            "background": self.environment is not None,
        }
        self.effects = tuple(name for name in EFFECTS if present[name])
        # Only reflected and refracted rays make a tree deeper than its root.
        self.depth = self.max_depth if ("reflection" in self.effects
                                        or "refraction" in self.effects) else 1

    @property
    def environment(self):
        return self.tables.environment

    @property
    def material_table(self):
        """The table of :attr:`surfaces` (:meth:`.materials.Materials.table`)."""
        if self.surfaces is self.tables.materials:
            return self.tables.material_table
        return self.surfaces.table()

    def has(self, effect: str) -> bool:
        """Whether the render simulates ``effect``: one of :data:`EFFECTS` the scene calls
        for, or ``shadows`` (lights, tested for shadow) or ``ambient`` (A is taken)."""
        if effect == "shadows":
            return "lights" in self.effects and "shadows" not in self.without
        if effect == "ambient":
            return "ambient" not in self.without
        return effect in self.effects

    def ambient(self, ambient: float) -> float:
        """The ambient coefficient the render takes, for the integrator's ``ambient``."""
        return ambient if self.has("ambient") else 0.0


def analyse(tables: SceneTables, max_depth: int, light_reference, without=()) -> SceneAnalysis:
    """What a render of the scene of ``tables`` to ``max_depth`` calls for; ``light_reference``
    is where the article's light colors were measured (the integrator's property);
    ``without``: the effects the render leaves out (names of :data:`SWITCHABLE_EFFECTS`)."""
    unknown = set(without) - set(SWITCHABLE_EFFECTS)
    if unknown:
        raise ValueError(f"unknown effects {sorted(unknown)}")
    reference = floats(light_reference)
    lights = [PointLight(position, intensity, article_color(intensity, position, reference))
              for position, intensity in tables.lights]
    return SceneAnalysis(tables, lights, max_depth, frozenset(without))
