"""The scenes of a comparison: which files the command line names, each read and parsed
once into plain data that every stage takes (and a worker process can receive); and which
renders each gets, in order: cheapest first with the methods interleaved, so that when the
budget runs out the cheap end of every method's curve is there rather than all of one method.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from ..converter import Scene
from ..batch import SCENE_SUFFIXES
from ..converter.batch import expand_folders
from ..converter.parser import decode, parse_text, read_scene_file
from ..defaults import COMPARE_MAX_DEFAULT_DEPTH, COMPARE_PATH_FIT_COUNTS, DEPTH, LIGHTING_MODES
from ..errors import WhittedError
from .results import METHODS, WHITTED_METHODS, Options, SceneResult, Setting


def scene_files(arguments: list[str | os.PathLike]) -> list[Path]:
    """The scene files named on the command line; a folder stands for its ``.scn`` files, or
    its ``.xml`` files when it has none (converted copies are not counted twice)."""
    files = expand_folders(arguments, SCENE_SUFFIXES, ".scn or .xml files", _check_scene_path)
    return list(dict.fromkeys(p.resolve() for p in files))


def _check_scene_path(path: Path) -> None:
    if not path.exists():
        raise WhittedError(f"{path}: no such file or folder")
    if path.suffix.lower() not in SCENE_SUFFIXES:
        raise WhittedError(f"{path}: not a scene (.scn or .xml)")


def scene_names(files: list[Path]) -> list[str]:
    """Short, distinct names: the file stem, with its folder when two stems clash."""
    stems = [f.stem for f in files]
    return [f"{f.parent.name}/{f.stem}" if stems.count(f.stem) > 1 else f.stem for f in files]


@dataclass(frozen=True)
class SceneFile:
    """One scene file, read and parsed once (``model``: a ``.scn``'s parsed scene, None for an
    ``.xml``; ``depth``: None when an ``.xml`` does not state it)."""
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
            textures = sorted({Path(m.texture) for m in model.sphere_arrays().materials if m.texture})
            return cls(path, name, data, model, tuple(textures), int(model.depth))
        return cls(path, name, data, None, *_xml_textures_and_depth(path, data))

    def load(self, variant: str | None = None):
        """The ``mi.Scene``, loaded as ``whitted render --integrator path`` loads it (sealed
        spheres grouped, :mod:`whitted.sealed`), for the Whitted renders too."""
        from ..loading import load_scene
        from ..rendering import check_article_materials
        loaded = load_scene(self.path, variant, model=self.model, integrator="path")
        check_article_materials(loaded, str(self.path), PORTABLE_ADVICE)   # before any work
        return loaded


#: compare renders every scene with both integrators: a scene of Mitsuba's stock materials
#: (``whitted convert --portable``) cannot be compared, whatever its options.
PORTABLE_ADVICE = ("Mitsuba's stock materials, a portable scene? compare renders it with the "
                   "Whitted integrator too: give it the .scn, or its XML converted without --portable")


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


def plan(depths: tuple[int, ...], whitted_spp: tuple[int, ...], path_spp: tuple[int, ...],
         path_depth: int, quick: bool = False) -> list[Setting]:
    """The settings in order; ``quick``: what the verdict needs first, so that a budget cuts
    the rest: the Whitted ladder's cheapest renders (the floors' candidates), the path
    tracer's that fit and check its curve (every headline is read on it), each Whitted
    method's deepest, densest render (its best error, which the floor is within 5% of), then
    the others, cheapest first, and the path tracer's counts its curve may stand for."""
    settings = [Setting("whitted", lighting, spp, depth)
                for lighting in LIGHTING_MODES for spp in whitted_spp for depth in depths]
    settings += [Setting("path", "physical", spp, path_depth) for spp in path_spp]
    settings.sort(key=lambda s: (s.spp, s.max_depth if s.integrator == "whitted" else 0,
                                 METHODS.index(s.method)))
    if not quick:
        return settings
    checking = path_spp[:COMPARE_PATH_FIT_COUNTS + 1]

    def need(s: Setting) -> int:
        if s.integrator == "path":
            return 1 if s.spp in checking else 4
        if s.spp == min(whitted_spp):
            return 0
        return 2 if (s.spp, s.max_depth) == (max(whitted_spp), max(depths)) else 3
    return sorted(settings, key=need)   # stable: cheapest first within each


def plan_scene(scene: SceneFile, loaded, options: Options,
               variant: str) -> tuple[SceneResult, list[Setting]]:
    """One scene's empty result and its settings in order (``loaded``: its ``mi.Scene``, whose
    film gives the size and integrator the depth a file does not state)."""
    width, height = (int(v) for v in loaded.sensors()[0].film().crop_size())
    depth = scene.depth if scene.depth is not None else int(getattr(loaded.integrator(), "max_depth", DEPTH))
    depths = options.depths or tuple(range(1, min(depth, COMPARE_MAX_DEFAULT_DEPTH) + 1))
    path_depth = options.path_depth or depth
    result = SceneResult(scene.name, scene.path, width, height, variant, options.reference_spp,
                         path_depth, whitted_spp=options.whitted_spp, path_spp=options.path_spp,
                         depths=depths)
    return result, plan(depths, options.whitted_spp, options.path_spp, path_depth, options.quick)


def limit_methods(settings: list[Setting]) -> list[str]:
    """The Whitted methods among ``settings``: each gets its limit rendered."""
    return [m for m in WHITTED_METHODS if any(s.method == m for s in settings)]


def progress_units(settings: list[Setting]) -> int:
    return len(settings) + len(limit_methods(settings))
