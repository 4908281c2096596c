"""The renderer's own trees, recorded: the recursion shows each level it shades to a
:class:`Recorder`, which links each ray to the pending child of its parent with the same
origin, direction and weight, bit for bit.
"""

from __future__ import annotations

from collections import defaultdict, deque

import drjit as dr
import mitsuba as mi
import numpy as np

from .nodes import LightTerm, Node

_VECTORS = {"o", "d", "color", "p", "n", "base", "point", "position", "strength",
            "ray_o", "ray_d", "value", "child_o", "child_d"}


def _t(values) -> tuple:
    return tuple(float(c) for c in values)


def _lanes(value, n: int, vector: bool) -> np.ndarray:
    """A recorded value as numpy: (n, 3) for a vector, (n,) else, broadcast from one lane."""
    array = np.asarray(value)
    if array.dtype != bool:
        array = array.astype(np.float64)
    if vector:
        array = array.reshape(3, -1).T if array.ndim else np.full((1, 3), float(array))
    else:
        array = array.reshape(-1)
    return np.broadcast_to(array, (n, *array.shape[1:]))


class Recorder:
    """Collects the levels a tracer shades and makes them trees."""

    def __init__(self):
        self.levels: list[dict] = []
        self.weights: list[np.ndarray] = []   # each batch's camera ray weights (n, 3)
        self.recursion = None   # the render's recursion (whitted.plugins.recursion.Recursion)

    def attach(self, recursion) -> None:
        self.recursion = recursion
        recursion.recorder = self
        recursion.record = {}

    def camera(self, weight) -> None:
        self._pending_weight = weight

    def level(self, branch, color, hit, children) -> None:
        record = self.recursion.record
        si = record["si"]
        values = {"o": branch.ray.o, "d": branch.ray.d, "weight": branch.weight,
                  "color": color, "hit": hit, "t": si.t, "p": si.p, "n": si.n}
        if "surface" in record:   # (a scalar ray that missed has no surface)
            surface = record["surface"]
            values.update(inside=record["inside"], base=surface.base, reflect=surface.reflect,
                          refract=surface.refract, ior=surface.ior, point=record["point"])
            if "tir" in record:
                values["tir"] = record["tir"]
        lights = []
        for terms in record["lights"]:
            light = {key: value for key, value in terms.items() if key != "ray"}
            if "ray" in terms:   # (none when the render leaves shadows out)
                light.update(ray_o=terms["ray"].o, ray_d=terms["ray"].d, maxt=terms["ray"].maxt)
            lights.append(light)
        children = [(child.kind, {"child_o": child.branch.ray.o, "child_d": child.branch.ray.d,
                                  "weight": child.branch.weight, "traced": child.traced,
                                  **({} if child.merged is None else {"merged": child.merged})})
                    for child in children]
        jit = dr.is_jit_v(mi.Float)
        if jit:
            flat = [*values.values(), *(v for light in lights for v in light.values()),
                    *(v for _, entry in children for v in entry.values())]
            dr.eval(*[v for v in flat if dr.is_jit_v(v)])
        n = dr.width(branch.ray.d) if jit else 1

        def convert(group: dict) -> dict:
            return {key: _lanes(value, n, key in _VECTORS) for key, value in group.items()}
        self.levels.append({"level": branch.level, "n": n, "spawn": branch.level < self.recursion.depth,
                            "values": convert(values), "lights": [convert(light) for light in lights],
                            "children": [(kind, convert(entry)) for kind, entry in children],
                            "batch": len(self.weights) - 1 if branch.level > 1 else len(self.weights)})
        if branch.level == 1:
            self.weights.append(_lanes(self._pending_weight, n, True))

    def trees(self) -> list[Node]:
        """The recorded trees, one per camera ray in the order traced (frame coordinates)."""
        ambient = float(np.asarray(self.recursion.ambient).reshape(-1)[0])
        roots: list[Node] = []
        pending: dict = defaultdict(deque)   # (level, o, d, weight) -> (parent, kind, merged)
        for level in self.levels:
            v = level["values"]
            for lane in range(level["n"]):
                o, d, weight = _t(v["o"][lane]), _t(v["d"][lane]), float(v["weight"][lane])
                if level["level"] == 1:
                    parent, kind, merged = None, "camera", False
                    camera_weight = _t(self.weights[level["batch"]][lane])
                else:
                    waiting = pending.get((level["level"], o, d, weight))
                    if not waiting:
                        raise RuntimeError(f"a ray of level {level['level']} that no parent spawned")
                    parent, kind, merged = waiting.popleft()
                    camera_weight = parent.camera_weight
                node = Node(kind=kind, level=level["level"], weight=weight, origin=o, direction=d,
                            merged=merged, camera_weight=camera_weight)
                (roots if parent is None else parent.children).append(node)
                self._shade(node, level, lane, ambient)
                for kind, entry in level["children"]:
                    w = float(entry["weight"][lane])
                    merged = bool(entry["merged"][lane]) if "merged" in entry else False
                    tir = merged if kind == "reflection" else (
                        kind == "refraction" and "tir" in v and bool(v["tir"][lane]))
                    named = "total internal reflection" if tir else kind
                    if bool(entry["traced"][lane]):
                        key = (level["level"] + 1, _t(entry["child_o"][lane]), _t(entry["child_d"][lane]), w)
                        pending[key].append((node, named, merged))
                    elif w > 0:
                        node.untraced.append({"kind": named, "weight": w, "why": "cut by weight"})
                if node.hit and not level["spawn"]:
                    for kind, share in (("reflection", node.material["reflect"]),
                                        ("refraction", node.material["refract"])):
                        if share > 0:
                            node.untraced.append({"kind": kind, "weight": weight * share, "why": "max depth"})
        left = sum(len(q) for q in pending.values())
        if left:
            raise RuntimeError(f"{left} traced rays were never shaded")
        for root in roots:
            for node in root.walk():
                node.stop = _stop(node)
        return roots

    def _shade(self, node: Node, level: dict, lane: int, ambient: float) -> None:
        v = level["values"]
        node.contribution = _t(v["color"][lane] * np.asarray(node.camera_weight))
        node.hit = bool(v["hit"][lane])
        if not node.hit:
            node.background = node.contribution
            return
        node.distance = float(v["t"][lane])
        node.position = _t(v["p"][lane])
        node.normal = _t(v["n"][lane])
        node.inside = bool(v["inside"][lane])
        base = v["base"][lane]
        node.material = {"color": _t(base), "reflect": float(v["reflect"][lane]),
                         "refract": float(v["refract"][lane]), "ior": float(v["ior"][lane])}
        node.local = _t(v["point"][lane])
        node.diffuse_weight = 1 - node.material["reflect"] - node.material["refract"]
        physical = self.recursion.physical
        node.ambient = (0.0, 0.0, 0.0) if physical else _t(base * ambient)
        for k, light in enumerate(level["lights"]):
            facing = bool(light["facing"][lane])
            term = LightTerm(index=k, position=_t(light["position"][lane]),
                             color=_t(light["strength"][lane]), facing=facing,
                             cos=max(0.0, float(light["cos"][lane])))
            if facing and "value" in light:
                if "ray_o" in light:
                    term.blocked = bool(light["shadowed"][lane])
                    term.shadow = {"origin": _t(light["ray_o"][lane]), "direction": _t(light["ray_d"][lane]),
                                   "length": float(light["maxt"][lane])}
                value = light["value"][lane]
                term.term = _t(base * value / np.pi if physical else base * (1 - ambient) * value)
            node.lights.append(term)

    def blockers(self, roots: list[Node]) -> None:
        """Where each blocked shadow ray meets its blocker (the render's own hit finder)."""
        terms = [term for root in roots for node in root.walk() for term in node.lights
                 if term.blocked and term.shadow is not None]
        if not terms:
            return
        origins = np.array([t.shadow["origin"] for t in terms])
        directions = np.array([t.shadow["direction"] for t in terms])
        lengths = np.array([t.shadow["length"] for t in terms])
        # one batch of every ray where the variant is vectorized, one ray at a time in a scalar one
        batches = ([(origins.T, directions.T, lengths)] if dr.is_jit_v(mi.Float)
                   else zip(origins, directions, lengths))
        found, points, normals = [], [], []
        for o, d, maxt in batches:
            ray = mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*d))
            ray.maxt = mi.Float(maxt)
            hit, si, _, _ = self.recursion.hits.intersect(ray, False)
            found.extend(np.asarray(hit, bool).reshape(-1))
            points.extend(np.asarray(si.p, np.float64).reshape(3, -1).T)
            normals.extend(np.asarray(si.n, np.float64).reshape(3, -1).T)
        for term, ok, p, n in zip(terms, found, points, normals):
            if ok:
                term.blocker_point, term.blocker_normal = tuple(map(float, p)), tuple(map(float, n))


def _stop(node: Node) -> str | None:
    """Why the tree ends below ``node`` (None while a child goes on)."""
    if not node.hit:
        return "missed: background"
    if node.children:
        return None
    whys = [u["why"] for u in node.untraced]
    return next((why for why in ("max depth", "cut by weight") if why in whys), "no reflection or refraction")
