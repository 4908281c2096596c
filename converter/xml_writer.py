"""Scene description -> Mitsuba 3 XML (format version 3.0.0).

Every formula is decided once in :mod:`.description`; this module only writes it as text
(docs/conversion.md, "The XML"), deterministically, each :class:`~.description.Param` as
``$name`` with a ``<default>``. A million spheres make about 150 MB of XML, so the sphere
arrays are written a batch at a time and never held whole.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import sys
import tempfile
from pathlib import Path
from xml.sax.saxutils import escape

from .description import Description, LookAt, Matrix, Mesh, Param, describe
from .portable import portable as to_portable
from .scene import Scene, Vec3

FORMAT_VERSION = "3.0.0"
INDENT = "    "

#: the XML tag of each plugin the description uses: <TAG type="PLUGIN" ...>
_OBJECT_TAGS = {
    "whitted": "integrator", "perspective": "sensor", "independent": "sampler",
    "hdrfilm": "film", "box": "rfilter", "constant": "emitter", "point": "emitter",
    "article": "bsdf", "bitmap": "texture", "sphere": "shape",
    "ply": "shape",   # giant spheres' meshes (converter/giants.py)
    "ellipsoids": "shape",   # grouped spheres of the portable form (whitted/sealed.py)
    # the portable form's stock plugins (converter/portable.py)
    "path": "integrator", "diffuse": "bsdf", "conductor": "bsdf", "dielectric": "bsdf",
    "blendbsdf": "bsdf", "twosided": "bsdf",
}


def num(x: float) -> str:
    """Shortest text that reads back as the same float64 (and never '-0.0')."""
    return repr(float(x) + 0.0)


def vec(v: Vec3, sep: str = " ") -> str:
    return sep.join(num(c) for c in v)


def attr(text: str) -> str:
    """A string made safe inside a double-quoted XML attribute."""
    return escape(str(text), {'"': "&quot;", "\n": "&#10;", "\r": "&#13;", "\t": "&#9;"})


def string_value(text: str) -> str:
    """A literal string for a Mitsuba attribute: XML-escaped, '$' as '\\$' (no substitution)."""
    return attr(str(text).replace("$", "\\$"))


def comment(text: str) -> str:
    """``text`` made safe inside an XML comment: printable, no '--', not ending in '-'."""
    text = "".join(c if c.isprintable() and not 0xD800 <= ord(c) <= 0xDFFF else "?" for c in text)
    text = re.sub(r"-(?=-)", "- ", text)
    return text + " " if text.endswith("-") else text


def _value(value, defaults: dict) -> tuple[str, str]:
    """(XML tag, attribute text) of a property value."""
    if isinstance(value, Param):
        tag, _ = _value(defaults[value.name], defaults)
        return tag, f"${value.name}"
    if isinstance(value, bool):
        return "boolean", "true" if value else "false"
    if isinstance(value, int):
        return "integer", str(value)
    if isinstance(value, float):
        return "float", num(value)
    if isinstance(value, (str, Mesh)):   # a mesh: its file's name
        return "string", string_value(value if isinstance(value, str) else value.filename)
    if isinstance(value, tuple) and len(value) == 3:
        return "point", vec(value, ", ")
    raise TypeError(f"no XML form for {value!r}")


def _transform(name: str, value, pad: str) -> list[str]:
    if isinstance(value, LookAt):
        inner = (f'<lookat origin="{vec(value.origin, ", ")}" target="{vec(value.target, ", ")}"'
                 f' up="{vec(value.up, ", ")}"/>')
    else:
        inner = f'<matrix value="{" ".join(num(v) for row in value.rows for v in row)}"/>'
    return [f'{pad}<transform name="{name}">', f"{pad}{INDENT}{inner}", f"{pad}</transform>"]


def _object(key: str, node: dict, defaults: dict, depth: int) -> list[str]:
    """One Mitsuba object: ``id`` at the top level (depth 1), ``name`` below."""
    pad = INDENT * depth
    label = "id" if depth == 1 else "name"
    kind = node["type"]
    if kind == "ref":
        return [f'{pad}<ref name="{attr(key)}" id="{attr(node["id"])}"/>']
    if kind == "rgb":
        return [f'{pad}<rgb name="{key}" value="{vec(node["value"])}"/>']
    head = f'{pad}<{_OBJECT_TAGS[kind]} type="{kind}" {label}="{attr(key)}"'
    if len(node) == 1:
        return [head + "/>"]
    lines = [head + ">"]
    for name, value in node.items():
        if name == "type":
            continue
        if isinstance(value, dict):
            lines += _object(name, value, defaults, depth + 1)
        elif isinstance(value, (LookAt, Matrix)):
            lines += _transform(name, value, pad + INDENT)
        else:
            tag, text = _value(value, defaults)
            lines.append(f'{pad}{INDENT}<{tag} name="{name}" value="{text}"/>')
    return lines + [f"{pad}</{_OBJECT_TAGS[kind]}>"]


def _with_notes(description: Description, portable: bool) -> tuple[Description, list[str]]:
    """The description as written (``portable``: its stock form) and its header comment: for
    the default XML, what renders it, and the form for stock ``mitsuba``."""
    if portable:
        return to_portable(description)
    stem = Path(description.source).stem if description.source.endswith(".scn") else "FILE"
    return description, [
        "It needs the whitted plugins (the `whitted` integrator, the `article` BSDF): render it with",
        f"`whitted render {stem}.xml -o {stem}.png`, or in Python `import whitted`, then mi.load_file.",
        'The stock `mitsuba` command stops at Plugin "whitted" not found!: give it the portable form,',
        f"{stem}.portable.xml (Mitsuba's stock plugins), which `whitted convert` writes with its",
        "portable option (docs/portable.md)."]


def _pieces(description: Description, notes: list[str]):
    o = description.origin
    out = ['<?xml version="1.0" encoding="utf-8"?>',
           f'<!-- Converted by whitted from {comment(description.source)} -->']
    if notes:
        out += [f"<!-- {comment(notes[0])}"] + [f"     {comment(n)}" for n in notes[1:]]
        out[-1] += " -->"
    out += [
        f'<!-- Positions are relative to the scene origin (its lookat), world point {vec(o, ", ")}:',
        '     world coordinates = these coordinates + that point (docs/numerics.md) -->',
        f'<scene version="{FORMAT_VERSION}">',
    ]
    for name, value in description.defaults.items():
        out.append(f'{INDENT}<default name="{name}" value="{_value(value, {})[1]}"/>')
    # each object after a blank line and its note; the block's spheres come with the block
    block = description.spheres
    later = set() if block is None else {f"sphere_{block.names[k]}" for k in block.in_scene}
    for key, node in description.scene.items():
        if key != "type" and key not in later:
            note = [f"{INDENT}<!-- {comment(description.notes[key])} -->"] if key in description.notes else []
            out += [""] + note + _object(key, node, description.defaults, 1)
    yield "\n".join(out) + "\n"
    if description.spheres is not None:
        yield from _Block(description).pieces()
    yield "</scene>\n"


#: the objects of :class:`_Block`'s spheres, from the blank line before to the line break after
_SPHERE = ('\n    <shape type="sphere" id="sphere_%s">\n'
           '        <point name="center" value="%r, %r, %r"/>\n'
           '        <float name="radius" value="%s"/>\n'
           '        <ref name="bsdf" id="%s"/>\n'
           '    </shape>\n')
#: the spheres :class:`_Block` formats at a time
_BATCH = 1 << 14
#: blocks of this many spheres on are formatted by two processes (:func:`write_xml`)
PARALLEL_FROM = 100_000


class _Block:
    """The text of a :class:`~.description.SphereBlock`'s objects as :func:`_object` writes
    them (``repr(x + 0.0)`` is :func:`num`'s text), each radius's made once when few."""

    def __init__(self, description: Description):
        import numpy as np
        self.block = block = description.spheres
        self.scene, self.defaults = description.scene, description.defaults
        self.center = block.center + 0.0
        distinct, self.which = np.unique(block.radius, return_inverse=True)
        self.radii = [num(r) for r in distinct.tolist()] if len(distinct) <= len(block) // 4 else None

    def pieces(self, lo: int = 0, hi: int | None = None):
        """The objects of spheres ``lo`` to ``hi`` (excluded), a batch at a time."""
        block, center, radii = self.block, self.center, self.radii
        hi = len(block) if hi is None else hi
        ids = block.material_ids
        special = sorted(k for k in block.in_scene if lo <= k < hi)
        for start, stop in zip([lo] + [k + 1 for k in special], special + [hi]):
            for a in range(start, stop, _BATCH):
                b = min(a + _BATCH, stop)
                x, y, z = center[a:b].T.tolist()
                texts = (map(radii.__getitem__, self.which[a:b].tolist()) if radii is not None
                         else map(repr, block.radius[a:b].tolist()))
                yield "".join(map(_SPHERE.__mod__, zip(block.names[a:b], x, y, z, texts,
                                                        map(ids.__getitem__, block.material[a:b].tolist()))))
            if stop < hi:
                key = f"sphere_{block.names[stop]}"
                yield "\n" + "\n".join(_object(key, self.scene[key], self.defaults, 1)) + "\n"


def write_xml(description: Description, file, portable: bool = False) -> None:
    """Write the XML of ``description`` (:func:`xml_of`) to the text ``file``, piece by piece.
    From :data:`PARALLEL_FROM` spheres on, a forked child formats the second half into a
    temporary file; anything amiss with it and this process does (the same bytes)."""
    description, notes = _with_notes(description, portable)
    block = description.spheres
    if block is None or len(block) < PARALLEL_FROM or not _can_fork(file):
        file.writelines(_pieces(description, notes))
        return
    file.write(next(_pieces(description, notes)))   # all but the block, which comes in two halves
    text = _Block(description)
    half = len(block) // 2
    with tempfile.TemporaryFile() as spill:
        child = _fork_writer(text, half, spill)
        try:
            file.writelines(text.pieces(0, half))
            done = child is not None and os.waitpid(child, 0)[1] == 0
            child = None
            if done:
                file.flush()
                spill.seek(0)
                shutil.copyfileobj(spill, file.buffer, 1 << 20)
            else:
                file.writelines(text.pieces(half))
        finally:
            if child is not None:   # this process failed or was interrupted: stop the child
                with contextlib.suppress(OSError):
                    os.kill(child, signal.SIGKILL)
                    os.waitpid(child, 0)
    file.write("</scene>\n")


def _can_fork(file) -> bool:
    """Whether a child may format half the block: a real file, two processors, no Dr.Jit."""
    if not hasattr(os, "fork") or not hasattr(file, "buffer") or "drjit" in sys.modules:
        return False
    try:
        return len(os.sched_getaffinity(0)) >= 2
    except (AttributeError, OSError):
        return (os.cpu_count() or 1) >= 2


def _fork_writer(text: _Block, half: int, spill) -> int | None:
    """The id of a child that writes spheres ``half`` on to ``spill`` (status 0: all), or None."""
    try:
        child = os.fork()
    except OSError:
        return None
    if child:
        return child
    status = 1
    try:   # the child: never returns, never runs the parent's clean-up or flushes its files
        with open(spill.fileno(), "w", encoding="utf-8", closefd=False) as out:
            out.writelines(text.pieces(half))
        status = 0
    except BaseException:
        pass
    finally:
        os._exit(status)


def scene_to_xml(scene: Scene, base_dir: str | os.PathLike | None, portable: bool = False) -> str:
    """The Mitsuba XML of ``scene`` (``portable``: stock plugins only), its paths relative to
    ``base_dir`` (where the caller writes the meshes), or absolute when it is None."""
    return xml_of(describe(scene, base_dir, block=True), portable)


def xml_of(description: Description, portable: bool = False) -> str:
    """The XML of ``description``, in the default or the ``portable`` form."""
    return "".join(_pieces(*_with_notes(description, portable)))
