"""The nodes of a pixel's ray tree, as JSON and as text (templates/trace.txt.j2). A
:class:`Node` is one ray, what the shader computed where it went, its *contribution* to the
pixel and why its branch stops: the pixel is the sum of its tree's contributions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: the kinds of rays, in the order a legend lists them
KINDS = ("camera", "reflection", "refraction", "total internal reflection")


@dataclass
class SphereRef:
    """A sphere as the scene file names it: its index, line, statement and comment."""
    index: int
    center: tuple
    radius: float
    line: int | None = None
    statement: str | None = None
    comment: str | None = None
    name: str = ""   # how the text names it: "tir.scn:17", or the shape's id

    def short(self) -> str:
        """``tir.scn:19 (the glass ball)``."""
        return f"{self.name} ({self.comment})" if self.comment else self.name

    def json(self) -> dict:
        return {"index": self.index, "line": self.line, "statement": self.statement,
                "comment": self.comment, "center": list(self.center), "radius": self.radius,
                "name": self.name}


@dataclass
class LightTerm:
    """One light's share of a hit's color: ``s = max(0, N'·L)``, 0 when behind or blocked."""
    index: int
    position: tuple
    color: tuple                 # the light's color (article) or intensity (physical)
    facing: bool                 # whether the light is in front of the surface (s > 0)
    cos: float                   # N'·L, clamped at 0
    blocked: bool = False
    shadow: dict | None = None   # the shadow ray: origin, direction, length (None: not cast)
    term: tuple = (0.0, 0.0, 0.0)   # its share of the point color: B·(1 − A)·s·color
    blocker: SphereRef | None = None
    blocker_point: tuple | None = None
    blocker_normal: tuple | None = None
    line: int | None = None
    statement: str | None = None

    def json(self) -> dict:
        return {"index": self.index, "line": self.line, "statement": self.statement,
                "position": list(self.position), "color": list(self.color), "facing": self.facing,
                "s": self.cos, "blocked": self.blocked,
                "blocker": self.blocker.json() if self.blocker else None,
                "blocker_point": list(self.blocker_point) if self.blocker_point else None,
                "shadow_ray": None if self.shadow is None else _lists(self.shadow),
                "term": list(self.term)}

    def state(self) -> tuple[str, str]:
        """What the light does at the hit, in words, and as ``off``, ``blocked`` or ``lit``."""
        if not self.facing:
            return "behind the surface (s = 0)", "off"
        if self.blocked:
            by = self.blocker.short() if self.blocker else "a surface"
            return f"s = {self.cos:.4g}, blocked by {by}", "blocked"
        return f"s = {self.cos:.4g}, adds {rgb(self.term)}", "lit"


@dataclass
class Node:
    kind: str
    level: int
    weight: float
    origin: tuple
    direction: tuple
    merged: bool = False        # a totally reflected ray that carries both KR and KT
    camera_weight: tuple = (1.0, 1.0, 1.0)
    hit: bool = False
    distance: float | None = None
    position: tuple | None = None
    normal: tuple | None = None   # the sphere's outward normal at the hit
    inside: bool | None = None    # whether the ray arrived from inside the sphere
    sphere: SphereRef | None = None
    material: dict | None = None   # color (B, the texel on a textured sphere), reflect, refract, ior
    ambient: tuple | None = None   # B·A
    lights: list = field(default_factory=list)
    local: tuple | None = None     # point = B·(A + (1 − A)·Σ s·light)
    diffuse_weight: float | None = None   # 1 − KR − KT
    background: tuple | None = None
    contribution: tuple = (0.0, 0.0, 0.0)
    children: list = field(default_factory=list)
    untraced: list = field(default_factory=list)   # {kind, weight, why} of rays left untraced
    stop: str | None = None

    def walk(self):
        """This node and every node below it, depth first (a parent before its children)."""
        yield self
        for child in self.children:
            yield from child.walk()

    def total(self) -> tuple:
        """The sum of the contributions of this node's tree (float64)."""
        return tuple(sum(node.contribution[c] for node in self.walk()) for c in range(3))

    def coefficients(self) -> str:
        """``KR 0.5, KT 0.4, IOR 1.5`` of the surface hit (the IOR where it refracts)."""
        m = self.material
        ior = f", IOR {m['ior']:.4g}" if m["refract"] > 0 else ""
        return f"KR {m['reflect']:.4g}, KT {m['refract']:.4g}{ior}"

    def count(self) -> int:
        return sum(1 for _ in self.walk())

    def json(self) -> dict:
        out = {"kind": self.kind, "level": self.level, "weight": self.weight,
               "origin": list(self.origin), "direction": list(self.direction),
               "hit": self.hit, "distance": self.distance}
        if self.merged:
            out["merged"] = True
        if self.hit:
            out.update(sphere=self.sphere.json() if self.sphere else None, point=list(self.position),
                       normal=list(self.normal), inside=self.inside, material=_lists(self.material),
                       ambient=list(self.ambient), lights=[t.json() for t in self.lights],
                       local=list(self.local), diffuse_weight=self.diffuse_weight)
        else:
            out["background"] = list(self.background)
        out.update(contribution=list(self.contribution), untraced=self.untraced, stop=self.stop,
                   children=[child.json() for child in self.children])
        return out


def _lists(d: dict) -> dict:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


# -- text ---------------------------------------------------------------------------------------------

def rgb(c) -> str:
    return f"({c[0]:.4g} {c[1]:.4g} {c[2]:.4g})"


def xyz(p) -> str:
    """A point or direction to 5 digits, a coordinate below a millionth of the largest as 0."""
    largest = max(abs(c) for c in p)
    shown = [0.0 if abs(c) < 1e-6 * largest else c for c in p]
    return f"({shown[0]:.5g}, {shown[1]:.5g}, {shown[2]:.5g})"


def text(trees) -> str:
    """Pixels' trees as indented text (templates/trace.txt.j2), a blank line between two."""
    from ..templates import environment
    return environment("whitted.trace").get_template("trace.txt.j2").render(trees=trees, xyz=xyz, rgb=rgb)
