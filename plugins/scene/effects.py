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
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    lights: list[PointLight]
    max_depth: int                       # the depth asked for
    effects: tuple[str, ...] = field(init=False)
    depth: int = field(init=False)       # the depth actually needed

    def __post_init__(self):
        deep = self.max_depth > 1
        present = {
            "lights": bool(self.lights),
            "reflection": deep and self.surfaces.reflective,
            "refraction": deep and self.surfaces.refractive,
            "textures": self.surfaces.textured,
            "background": self.environment is not None,
        }
        self.effects = tuple(name for name in EFFECTS if present[name])
        # Only reflected and refracted rays make a tree deeper than its root.
        self.depth = self.max_depth if ("reflection" in self.effects
                                        or "refraction" in self.effects) else 1

    @property
    def surfaces(self) -> Materials:
        return self.tables.materials

    @property
    def environment(self):
        return self.tables.environment

    def has(self, effect: str) -> bool:
        return effect in self.effects


def analyse(tables: SceneTables, max_depth: int, light_reference) -> SceneAnalysis:
    """What a render of the scene of ``tables`` to ``max_depth`` calls for; ``light_reference``
    is where the article's light colors were measured (the integrator's property)."""
    reference = floats(light_reference)
    lights = [PointLight(position, intensity, article_color(intensity, position, reference))
              for position, intensity in tables.lights]
    return SceneAnalysis(tables, lights, max_depth)
