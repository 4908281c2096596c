"""A scene model written back as legacy ``.scn`` text (what ``whitted fit`` writes).

Data still flows one way: a model (:class:`.scene.Scene`, parsed or changed by
a program) becomes text that the parser reads back into an equal model. Numbers
are written as Python's shortest round-tripping form (``repr``), so that a
fitted value survives the round trip exactly; textures are written relative to
the folder the file goes to (the format resolves them against it), quoted.
"""

from __future__ import annotations

import os
from pathlib import Path

from .. import defaults as D
from .scene import Scene, Sphere


def _num(x: float) -> str:
    x = float(x)
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def _nums(values) -> str:
    return " ".join(_num(v) for v in values)


def material_text(sphere: Sphere, folder: Path) -> str:
    """The attributes of ``sphere``'s material, as its statement writes them."""
    m = sphere.material
    parts = []
    if m.texture is not None:
        path = Path(os.path.relpath(os.path.realpath(m.texture), os.path.realpath(folder))).as_posix()
        parts.append(f'texture "{path}"')
        if sphere.north != D.NORTH:
            parts.append(f"north {_nums(sphere.north)}")
        if sphere.equator != D.EQUATOR:
            parts.append(f"equator {_nums(sphere.equator)}")
    else:
        parts.append(f"color {_nums(m.color)}")
    if m.reflect:
        parts.append(f"reflect {_num(m.reflect)}")
    if m.refract or m.ior != D.IOR:
        parts.append(f"refract {_num(m.refract)} {_num(m.ior)}")
    return "  ".join(parts)


def scene_to_scn(scene: Scene, folder: str | os.PathLike, comment: str = "") -> str:
    """``scene`` as ``.scn`` text, for a file in ``folder`` (texture paths are relative to
    it); ``comment`` opens the file, one ``#`` line per line."""
    folder = Path(folder)
    lines = [f"# {line}" for line in comment.splitlines()]
    lines += [f"size {scene.width} {scene.height}", f"eye {_nums(scene.eye)}",
              f"lookat {_nums(scene.lookat)}", f"up {_nums(scene.up)}", f"fov {_num(scene.fov)}",
              f"background {_nums(scene.background)}", f"ambient {_num(scene.ambient)}",
              f"depth {scene.depth}", f"samples {scene.samples}"]
    if scene.min_weight is not None:
        lines.append(f"minweight {_num(scene.min_weight)}")
    lines += [f"light {_nums(light.position)}  {_nums(light.color)}" for light in scene.lights]
    lines += [f"sphere {_nums(s.center)} {_num(s.radius)}  {material_text(s, folder)}" for s in scene.spheres]
    return "\n".join(lines) + "\n"
