"""The scenes of a comparison: which files the command line names, and each one
read once.

Several stages need something of a scene file: the planner its depth, the
reference cache its bytes, its converted XML and its textures, the sweep the
loaded ``mi.Scene``. :class:`SceneFile` reads and parses the file once and
carries all of it; the stages take it, not the path. It is plain data (bytes,
paths and the converter's scene model: it pickles), so a worker process can
receive it and load its own ``mi.Scene`` with :meth:`SceneFile.load`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from ..converter import Scene
from ..converter.batch import folder_scenes
from ..converter.parser import decode, parse_text, read_scene_file
from ..errors import WhittedError


def scene_files(arguments: list[str | os.PathLike]) -> list[Path]:
    """The scene files named on the command line; a folder stands for its ``.scn`` files
    (its ``.xml`` files when it has none, so converted copies beside the originals are not
    counted twice)."""
    files: list[Path] = []
    for argument in arguments:
        path = Path(argument)
        if path.is_dir():
            found = folder_scenes(path, (".scn", ".xml"))
            if not found:
                raise WhittedError(f"{path}: folder holds no .scn or .xml scene")
            files.extend(found)
        elif path.exists():
            if path.suffix.lower() not in (".scn", ".xml"):
                raise WhittedError(f"{path}: not a scene (.scn or .xml)")
            files.append(path)
        else:
            raise WhittedError(f"{path}: no such file or folder")
    unique = list(dict.fromkeys(p.resolve() for p in files))
    return [Path(p) for p in unique]


def scene_names(files: list[Path]) -> list[str]:
    """Short, distinct names: the file stem, with its folder when two stems clash."""
    stems = [f.stem for f in files]
    return [f"{f.parent.name}/{f.stem}" if stems.count(f.stem) > 1 else f.stem for f in files]


@dataclass(frozen=True)
class SceneFile:
    """One scene file, read and parsed once.

    ============ =====================================================================
    ``path``     the file (``.scn`` or ``.xml``)
    ``name``     its short name in the outputs (:func:`scene_names`)
    ``data``     the file's bytes
    ``model``    the parsed scene (``whitted.converter.Scene``) of a ``.scn``; None
                 for an ``.xml``, which Mitsuba reads itself (its relative paths are
                 relative to the file)
    ``textures`` the image files the scene reads (absolute paths, sorted)
    ``depth``    the scene's max depth as the file states it; None when an ``.xml``
                 does not say (the loaded scene's integrator then tells)
    ============ =====================================================================
    """
    path: Path
    name: str
    data: bytes = field(repr=False)
    model: Scene | None = field(repr=False)
    textures: tuple[Path, ...]
    depth: int | None

    @classmethod
    def read(cls, path: str | os.PathLike, name: str | None = None) -> SceneFile:
        """Read and parse ``path``; a bad scene raises :class:`~whitted.errors.WhittedError`."""
        path = Path(path)
        data = read_scene_file(path)
        name = path.stem if name is None else name
        if path.suffix.lower() == ".scn":
            model = parse_text(decode(data, path), path)
            textures = sorted({Path(s.material.texture) for s in model.spheres if s.material.texture})
            return cls(path, name, data, model, tuple(textures), int(model.depth))
        return cls(path, name, data, None, *_xml_textures_and_depth(path, data))

    def load(self, variant: str | None = None):
        """The ``mi.Scene`` (``variant`` as for :func:`whitted.load_scene`).

        Loaded as ``whitted render --integrator path`` loads it (the sealed spheres
        of the commonest radius and of larger ones grouped in ``ellipsoids`` shapes,
        where Mitsuba's own test finds every hit: :mod:`whitted.sealed`): the reference and the path renders are those of that
        command, and a scene of a million spheres loads in seconds and a few hundred
        MB instead of minutes and gigabytes. The Whitted renders see the same scene
        (its layers trace every grouped radius exactly).
        """
        from ..loading import load_scene
        from ..rendering import check_article_materials
        loaded = load_scene(self.path, variant, model=self.model, integrator="path")
        check_article_materials(loaded, str(self.path))   # before any work: compare renders both
        return loaded


def _xml_textures_and_depth(path: Path, data: bytes) -> tuple[tuple[Path, ...], int | None]:
    """The image files a Mitsuba XML scene reads, and its ``max_depth`` default if it has one."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(data)
    except ET.ParseError as error:
        raise WhittedError(f"{path}: not well-formed XML: {error}") from None
    textures = set()
    for element in root.iter():
        if element.get("name") == "filename" and element.get("value"):
            candidate = (path.parent / element.get("value")).resolve()
            if candidate.is_file():
                textures.add(candidate)
    depths = [e.get("value") for e in root.iter("default") if e.get("name") == "max_depth"]
    try:
        depth = int(depths[0])
    except (IndexError, TypeError, ValueError):  # none, or one Mitsuba's $-syntax must resolve
        depth = None
    return tuple(sorted(textures)), depth
