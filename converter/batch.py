"""Converting many files: which ``.scn`` becomes which ``.xml``, and one file at a time.

``whitted convert`` must go on past a bad file and leave nothing half-written: the pairs
(source, target) are decided up front, so that a clash is reported before any file is
touched, and each is converted atomically. ``whitted render`` names its images by the same
rules, so what a user learnt of one command holds for the other.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..atomic import (atomic_path, check_folder, check_folder_creatable, names_folder,
                      writable_folder)
from ..errors import WhittedError
from .description import describe, meshes
from .frame import warn_scene
from .parser import parse_file

#: the legacy scene files a folder argument stands for
SCENE_SUFFIX = ".scn"
#: what X.scn becomes: X.xml, or X.portable.xml in the stock-plugins form (``--portable``)
XML_SUFFIX, PORTABLE_SUFFIX = ".xml", ".portable.xml"


def folder_scenes(folder: Path, accepted: tuple[str, ...] = (SCENE_SUFFIX,)) -> list[Path]:
    """The files directly in ``folder``, sorted, whose suffix (in any case) is the first of
    ``accepted`` that any has (converted copies beside their originals do not count twice)."""
    try:
        entries = [p for p in folder.iterdir() if p.suffix.lower() in accepted and p.is_file()]
    except OSError as error:
        raise WhittedError(f"{folder}: cannot list: {error.strerror or error}") from None
    for suffix in accepted:
        found = sorted(p for p in entries if p.suffix.lower() == suffix)
        if found:
            return found
    return []


def expand_folders(inputs: list[str | os.PathLike], accepted: tuple[str, ...], what: str,
                   check_file=None) -> list[Path]:
    """The files that ``inputs`` name, in order: a folder stands for its files of the
    ``accepted`` suffixes (none: an error naming ``what``), a file is checked by ``check_file``."""
    files: list[Path] = []
    for item in map(Path, inputs):
        if item.is_dir():
            found = folder_scenes(item, accepted)
            if not found:
                raise WhittedError(f"{item}: no {what} in this folder")
            files.extend(found)
        else:
            if check_file is not None:
                check_file(item)
            files.append(item)
    return files


def plan(inputs: list[str | os.PathLike], output: str | os.PathLike | None = None,
         suffix: str = XML_SUFFIX, accepted: tuple[str, ...] = (SCENE_SUFFIX,)) -> list[tuple[Path, Path]]:
    """The (source, target) pairs of a conversion (or of a render: ``suffix`` ".png"): ``X``
    + ``suffix`` beside each input, or ``output`` the file (:func:`whitted.atomic.names_folder`)
    or the folder that receives them."""
    if not inputs:
        raise WhittedError("no scene given: name scene files or folders")
    # a missing or unreadable file is reported when converted
    sources = expand_folders(inputs, accepted, f"{' or '.join(accepted)} files")
    out = None if output is None else Path(output)
    into_folder = names_folder(inputs, output)
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
                               "give them separate output folders")
        if os.path.abspath(source) == key:
            raise WhittedError(f"{source}: output would overwrite the input; choose another with -o")
        seen[key] = source
        pairs.append((source, target))
    return pairs


def prepare_folders(targets: list[Path], output: str | os.PathLike | None) -> None:
    """Check every folder the ``targets`` go to before the first is written: the one
    ``output`` names may be created, the folder of an output file must exist."""
    named_folder = Path(output) if output else None
    folders = sorted({target.parent for target in targets})
    for folder in folders:
        inside = [target for target in targets if target.parent == folder]
        named = inside[0] if len(inside) == 1 else folder
        if folder == named_folder and not folder.exists():
            check_folder_creatable(folder)
        else:
            check_folder(folder, named)
    if named_folder in folders:
        writable_folder(named_folder)


def convert_file(source: Path, target: Path, portable: bool = False) -> None:
    """Parse ``source`` and write its XML (``portable``: stock plugins only, the sealed spheres
    grouped as the path tracer's loader groups them) to ``target`` atomically, with its mesh
    files beside it; warn on stderr (:func:`.frame.warn_scene`)."""
    from ..sealed import described
    from .xml_writer import write_xml

    scene = parse_file(source)
    if target.is_dir():
        raise WhittedError(f"{target}: is a folder; give the output file's name")
    description = described(scene, target.parent) if portable else \
        describe(scene, base_dir=target.parent, block=True)
    warn_scene(scene)
    written = meshes(description)
    for mesh in written:   # giant spheres' meshes (.giants), before the XML that names them
        with atomic_path(target.parent / mesh.filename) as tmp:
            tmp.write_bytes(mesh.data)
    if written:   # files the user did not ask for, some of them large: say what and why
        names = ", ".join(m.filename for m in written[:3]) + (", …" if len(written) > 3 else "")
        what = "sphere as a closed mesh" if len(written) == 1 else "spheres as closed meshes"
        size = sum(len(m.data) for m in written) / 1e6
        print(f"whitted: note: wrote {names} ({size:.1f} MB) beside {target.name}: the scene's giant {what} "
              f"for Mitsuba's path tracer, which float32 spheres that large would speckle "
              f"(docs/numerics.md, hazard 14)", file=sys.stderr)
    # atomic, written as it is made; an OS error comes back as a one-line WhittedError
    with atomic_path(target) as tmp, open(tmp, "w", encoding="utf-8") as file:
        write_xml(description, file, portable)
