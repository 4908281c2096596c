"""A scene model written back as legacy ``.scn`` text (what ``whitted fit`` writes).

The parser reads it back into an equal model: numbers are written in their shortest
round-tripping form, so a fitted value survives exactly. :func:`edited_scn` writes a model
into the text it was read from instead, keeping the file's comments and layout.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from .. import defaults as D
from .parser import ATTRIBUTES, token_spans
from .scene import Scene, Sphere, relative_path


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
        parts.append(f'texture "{relative_path(m.texture, folder)}"')
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


def edited_scn(text: str, scene: Scene, folder: str | os.PathLike, note: str = "") -> str | None:
    """``text``, the ``.scn`` file ``scene`` was read from, with the ambient, light and sphere
    colors ``scene`` has changed put in place, textures relative to ``folder``, and ``note``
    as comment lines at the end; None when a statement is not on the line ``scene`` gives it."""
    folder = Path(folder)
    bom = "\ufeff" if text.startswith("\ufeff") else ""
    parts = re.split(r"(\r\n|\r|\n)", text[len(bom):])
    lines, edits, tail = parts[0::2], [], []

    def word(token) -> str:
        return lines[token[0]][token[1]:token[2]]

    def put(tokens, at: int, values, default, name: str = "") -> None:
        """``values`` for the numbers from token ``at`` on, or added (with ``name``) when the
        statement has none and they are not the ``default``."""
        if len(tokens) > at:
            edits.extend((*t, _num(v)) for t, v in zip(tokens[at:], values) if float(word(t)) != v)
        elif tuple(values) != tuple(default):
            k, _, z = tokens[-1]
            edits.append((k, z, z, f"{'  ' + name if name else ''} {_nums(values)}"))

    def statement(line: int, keyword: str):
        """The tokens ``(line index, start, end)`` of the ``keyword`` statement that starts on
        ``line`` (1-based), or None."""
        k = line - 1
        if not 0 <= k < len(lines) or k and token_spans(lines[k - 1])[1]:
            return None
        tokens = []
        for k in range(k, len(lines)):
            spans, continued, _ = token_spans(lines[k])
            tokens += [(k, a, z) for a, z in spans]
            if not continued:
                break
        return tokens if tokens and word(tokens[0]).lower() == keyword else None

    ambient = next(filter(None, (statement(k + 1, "ambient") for k, line in enumerate(lines)
                                 if line.lstrip(" \t\f\v")[:7].lower() == "ambient")), None)
    if ambient:
        put(ambient, 1, [scene.ambient], ())
    elif scene.ambient != D.AMBIENT:
        tail.append(f"ambient {_num(scene.ambient)}")
    for light in scene.lights:
        tokens = statement(light.line, "light")
        if tokens is None:
            return None
        put(tokens, 4, light.color, D.LIGHT_COLOR)
    for sphere in scene.spheres:
        tokens = statement(sphere.line, "sphere")
        if tokens is None:
            return None
        at, found = 5, {}
        while at < len(tokens):   # the attributes: name -> the index of its first value
            name = word(tokens[at]).lower()
            found[name] = at + 1
            at += 1 + len(ATTRIBUTES.get(name, ()))
        texture = sphere.material.texture
        if texture is None:
            put(tokens, found.get("color", len(tokens)), sphere.material.color, D.COLOR, "color")
        elif Path(os.path.abspath(folder / word(tokens[found["texture"]]).strip('"'))) != texture:
            edits.append((*tokens[found["texture"]], f'"{relative_path(texture, folder)}"'))
    for k, start, end, new in sorted(edits, reverse=True):
        lines[k] = lines[k][:start] + new + lines[k][end:]
    parts[0::2] = lines
    tail += [f"# {line}" for line in note.splitlines()]
    if tail:
        newline = parts[1] if len(parts) > 1 else "\n"
        parts += ([newline] if parts[-1] else []) + [newline.join(tail) + newline]
    return bom + "".join(parts)
