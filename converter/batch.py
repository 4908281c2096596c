"""Converting many files: which ``.scn`` becomes which ``.xml``, and one file at a time.

``whitted convert a.scn b.scn DIR/ [-o OUT]`` must go on past a bad file, say
what failed, and leave nothing half-written. This module decides the pairs
(source, target) up front, so that a clash (two inputs that would write the
same XML, an output that would overwrite its input) is reported before any
file is touched, and converts each pair atomically. It imports neither
Mitsuba nor Dr.Jit: conversion is text in, text out.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..atomic import atomic_path
from ..defaults import SEALED_MIN_GROUP
from ..errors import WhittedError
from .description import describe, meshes
from .frame import warn_precision
from .parser import parse_file
from .xml_writer import write_xml

#: the legacy scene files a folder argument stands for
SCENE_SUFFIX = ".scn"
#: what X.scn becomes: X.xml, or X.portable.xml in the stock-plugins form (``--portable``)
XML_SUFFIX, PORTABLE_SUFFIX = ".xml", ".portable.xml"


def folder_scenes(folder: Path, accepted: tuple[str, ...] = (SCENE_SUFFIX,)) -> list[Path]:
    """The scene files a folder argument stands for: the files directly in ``folder``, sorted
    by name, whose suffix (in any case) is the first of ``accepted`` that any of them has.
    ``whitted convert`` takes ``.scn`` files; ``whitted compare`` takes ``.scn`` files, else
    ``.xml`` ones, so that converted copies beside their originals do not count twice."""
    try:
        entries = [p for p in folder.iterdir() if p.suffix.lower() in accepted and p.is_file()]
    except OSError as error:
        raise WhittedError(f"{folder}: cannot list: {error.strerror or error}") from None
    for suffix in accepted:
        found = sorted(p for p in entries if p.suffix.lower() == suffix)
        if found:
            return found
    return []


def plan(inputs: list[str | os.PathLike], output: str | os.PathLike | None = None,
         suffix: str = XML_SUFFIX) -> list[tuple[Path, Path]]:
    """The (source, target) pairs of a conversion.

    Each input is a ``.scn`` file or a folder (its ``.scn`` files). Without
    ``output`` every ``X.scn`` becomes ``X.xml`` (``X`` + ``suffix``) beside it.
    With one input file, ``output`` names the XML file, unless it is an existing
    folder or ends with a path separator; otherwise it is the folder that
    receives every ``X.xml``.
    """
    if not inputs:
        raise WhittedError("no scene given: name .scn files or folders")
    sources: list[Path] = []
    single_file = len(inputs) == 1
    for item in map(Path, inputs):
        if item.is_dir():
            found = folder_scenes(item)
            if not found:
                raise WhittedError(f"{item}: no {SCENE_SUFFIX} files in this folder")
            sources.extend(found)
            single_file = False
        else:
            sources.append(item)   # a missing or unreadable file is reported when converted
    out = None if output is None else Path(output)
    into_folder = out is not None and (not single_file or out.is_dir() or str(output).endswith(("/", os.sep)))
    pairs, seen = [], {}
    for source in sources:
        if out is None:
            target = source.with_suffix(suffix)
        elif into_folder:
            target = out / source.with_suffix(suffix).name
        else:
            target = out
        key = os.path.abspath(target)
        if key in seen and os.path.abspath(seen[key]) != os.path.abspath(source):
            raise WhittedError(f"{target}: both {seen[key]} and {source} would be written here; "
                               "convert them into separate folders")
        if os.path.abspath(source) == key:
            raise WhittedError(f"{source}: output would overwrite the input; choose another with -o")
        seen[key] = source
        pairs.append((source, target))
    return pairs


def convert_file(source: Path, target: Path, portable: bool = False) -> None:
    """Parse ``source`` and write its XML (``portable``: in stock plugins only, its sealed
    spheres grouped in ``ellipsoids`` shapes as for the path tracer, :func:`_portable_description`)
    to ``target`` atomically (nothing for an invalid scene), with the mesh files of its giant
    spheres (:mod:`.giants`) and the PLY files of its groups beside it; warn on stderr when
    float32 cannot hold the scene's detail (:mod:`.frame`)."""
    scene = parse_file(source)
    if target.is_dir():
        raise WhittedError(f"{target}: is a folder; give the output file's name")
    description = _portable_description(scene, target.parent) if portable else \
        describe(scene, base_dir=target.parent, block=True)
    warn_precision(scene)
    for mesh in meshes(description):   # giant spheres' meshes (.giants), before the XML that names them
        with atomic_path(target.parent / mesh.filename) as tmp:
            tmp.write_bytes(mesh.data)
    # atomic, written as it is made (a scene of a million spheres makes 150 MB of XML);
    # an OS error comes back as a one-line WhittedError
    with atomic_path(target) as tmp, open(tmp, "w", encoding="utf-8") as file:
        write_xml(description, file, portable)


def _portable_description(scene, folder: Path):
    """The description the portable XML is written from: the sealed spheres grouped as the path
    tracer's loader groups them (:func:`whitted.sealed.described`) when the scene has enough
    spheres for a group; a smaller scene is described without numpy."""
    arrays = scene.held_sphere_arrays()
    count = len(scene.spheres) if arrays is None else len(arrays)
    if count < SEALED_MIN_GROUP:
        return describe(scene, base_dir=folder, block=True)
    from ..sealed import described
    return described(scene, folder)
