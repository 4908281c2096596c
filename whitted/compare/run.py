"""``whitted compare``: what accuracy costs in time.

For each scene, a converged path-traced image is the reference (Mitsuba's
``path`` integrator at a high sample count, on the same converted scene). Then
three methods are swept and every render is timed and scored against it:

* ``whitted-article``: the article's model, max depth 1…D × an spp ladder;
* ``whitted-physical``: the same ray tree lit physically (inverse-square
  fall-off, albedo/π, no ambient), so the remaining gap to the reference is the
  indirect light the ray tree leaves out;
* ``path``: the path tracer itself over an spp ladder, which converges to the
  reference (its error falls as 1/spp until it meets the reference's own noise).

Timing is honest: each render is repeated and the median of the render times
is kept, kernel compilation excluded (``result.seconds`` of the rendering API)
and reported separately (``compile_seconds``). Error is measured on linear
images (:mod:`whitted.metrics`). :mod:`whitted.report` writes the CSV, the
error-against-time plot, the contact sheet and the summary table.

References are cached (``DIR/references`` unless ``--cache``), named by a hash
of everything they depend on: the scene file, its converted XML, its textures,
the resolution, the reference settings, the variant and the versions of
whitted and Mitsuba. They are written atomically, image first and description
second, and read only when both are whole: an interrupted run leaves either a
complete entry or none.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import re
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import WhittedError
from .loading import LIGHTING_MODES
from .variant import SUPPORTED_VARIANTS

WHITTED_METHODS = ("whitted-article", "whitted-physical")
METHODS = WHITTED_METHODS + ("path",)

DEFAULT_REFERENCE_SPP = 4096
DEFAULT_WHITTED_SPP = (1, 4, 16)
DEFAULT_PATH_SPP = (1, 4, 16, 64, 256, 1024)
DEFAULT_REPEATS = 3
DEFAULT_LEVELS = (0.1, 0.03, 0.01)
#: The default Whitted sweep is 1…min(scene depth, this): deeper trees rarely change a pixel.
MAX_DEFAULT_DEPTH = 8
#: The scene format's largest ``depth``.
MAX_DEPTH = 64
SWEEP_SEED = 0
#: The reference's samples must be independent of the sweep's, or its noise would
#: correlate with theirs and flatter the path tracer.
REFERENCE_SEED = 1
#: Bumped when the meaning of a cached reference changes.
CACHE_FORMAT = "whitted-compare-reference/1"


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Setting:
    """One point of the sweep."""
    integrator: str   # "whitted" or "path"
    lighting: str     # "article" or "physical" (the path tracer is always physical)
    spp: int
    max_depth: int    # the ray tree's depth, primary rays have depth 1 (both integrators)

    @property
    def method(self) -> str:
        return "path" if self.integrator == "path" else f"whitted-{self.lighting}"

    @property
    def label(self) -> str:
        if self.integrator == "path":
            return f"{self.spp} spp"
        return f"d{self.max_depth} · {self.spp} spp"


@dataclass
class Measurement:
    setting: Setting
    seconds: float          # median render time over the repeats, compilation excluded
    compile_seconds: float  # kernel compilation (the largest over the repeats)
    rel_mse: float
    flip: float
    repeats: int
    thumbnail: np.ndarray | None = field(default=None, repr=False)  # sRGB uint8


@dataclass
class SceneResult:
    """What the sweep measured on one scene."""
    name: str
    path: Path
    width: int
    height: int
    variant: str
    reference_spp: int
    path_depth: int
    reference_file: Path | None = None
    reference_seconds: float = math.nan
    reference_cached: bool = False
    reference_thumbnail: np.ndarray | None = field(default=None, repr=False)
    measurements: list[Measurement] = field(default_factory=list)
    skipped: list[Setting] = field(default_factory=list)
    whitted_spp: tuple[int, ...] = ()
    path_spp: tuple[int, ...] = ()
    depths: tuple[int, ...] = ()


@dataclass
class Options:
    out: Path
    reference_spp: int = DEFAULT_REFERENCE_SPP
    depths: tuple[int, ...] | None = None     # None: 1…the scene's depth (at most MAX_DEFAULT_DEPTH)
    whitted_spp: tuple[int, ...] = DEFAULT_WHITTED_SPP
    path_spp: tuple[int, ...] = DEFAULT_PATH_SPP
    path_depth: int | None = None             # None: the scene's depth
    repeats: int = DEFAULT_REPEATS
    budget: float | None = None               # seconds for the whole command
    levels: tuple[float, ...] = DEFAULT_LEVELS
    cache: Path | None = None                 # None: out/references
    variant: str | None = None
    quiet: bool = False


# --------------------------------------------------------------------------- input


def int_list(text: str) -> tuple[int, ...]:
    """'1,4,16' or '1-5' or '1-3,8' -> a sorted tuple of distinct positive integers (argparse type)."""
    values: set[int] = set()
    try:
        for item in text.split(","):
            item = item.strip()
            if "-" in item[1:]:
                low, high = item.split("-", 1)
                low, high = int(low), int(high)
                if high < low:
                    raise ValueError
                values.update(range(low, high + 1))
            else:
                values.add(int(item))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a list of integers like 1,4,16 or 1-5") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"'{text}': every value must be an integer >= 1")
    return tuple(sorted(values))


def float_list(text: str) -> tuple[float, ...]:
    """'0.1,0.03' -> a tuple of positive finite numbers, largest first (argparse type)."""
    try:
        values = {float(item) for item in text.split(",")}
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a list of numbers like 0.1,0.03,0.01") from None
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"'{text}': every value must be a positive number")
    return tuple(sorted(values, reverse=True))


def scene_files(arguments: list[str | os.PathLike]) -> list[Path]:
    """The scene files named on the command line; a folder stands for its ``.scn`` files
    (its ``.xml`` files when it has none, so converted copies beside the originals are not
    counted twice)."""
    files: list[Path] = []
    for argument in arguments:
        path = Path(argument)
        if path.is_dir():
            found = sorted(path.glob("*.scn")) or sorted(path.glob("*.xml"))
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


def _textures(path: Path) -> list[Path]:
    """The image files a scene reads (absolute paths)."""
    if path.suffix.lower() == ".scn":
        from .converter import parse_file
        model = parse_file(path)
        return sorted({Path(s.material.texture) for s in model.spheres if s.material.texture})
    import xml.etree.ElementTree as ET
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise WhittedError(f"{path}: not well-formed XML: {error}") from None
    found = set()
    for element in root.iter():
        if element.get("name") == "filename" and element.get("value"):
            candidate = (path.parent / element.get("value")).resolve()
            if candidate.is_file():
                found.add(candidate)
    return sorted(found)


def _scene_depth(path: Path, scene) -> int:
    """The scene's own max depth (the ``depth`` statement; 5 when it cannot be told)."""
    if path.suffix.lower() == ".scn":
        from .converter import parse_file
        return int(parse_file(path).depth)
    import xml.etree.ElementTree as ET
    for element in ET.parse(path).getroot().iter("default"):
        if element.get("name") == "max_depth":
            try:
                return int(element.get("value"))
            except (TypeError, ValueError):
                break
    return int(getattr(scene.integrator(), "max_depth", 5))


# --------------------------------------------------------------------------- plan


def plan(depths: tuple[int, ...], whitted_spp: tuple[int, ...], path_spp: tuple[int, ...],
         path_depth: int) -> list[Setting]:
    """Every render of the sweep, cheapest first, methods interleaved, so that a budget
    cut keeps the cheap end of every curve rather than all of one method."""
    settings = [Setting("whitted", lighting, spp, depth)
                for lighting in LIGHTING_MODES for spp in whitted_spp for depth in depths]
    settings += [Setting("path", "physical", spp, path_depth) for spp in path_spp]
    order = {m: i for i, m in enumerate(METHODS)}
    return sorted(settings, key=lambda s: (s.spp, s.max_depth if s.integrator == "whitted" else 0,
                                           order[s.method]))


# --------------------------------------------------------------------------- budget


class Budget:
    """Wall-clock time for the whole command, shared fairly among the scenes still to do.

    Before each render the sweep predicts its cost from what the same method has
    already cost on this scene (time grows with spp and depth) and skips it when it
    would overrun; a render that has begun is not interrupted.
    """

    def __init__(self, seconds: float | None):
        self.seconds = seconds
        self.start = time.monotonic()

    def deadline_for(self, scenes_left: int) -> float:
        """The monotonic time by which the next scene should be done."""
        if self.seconds is None:
            return math.inf
        now = time.monotonic()
        remaining = max(0.0, self.start + self.seconds - now)
        return now + remaining / max(1, scenes_left)

    @staticmethod
    def predict(setting: Setting, done: list[tuple[Setting, float, float]], repeats: int) -> float:
        """Seconds the setting will take, from ``done`` = [(setting, median seconds, wall)];
        0 when this method has not run yet (its first render is always tried)."""
        estimates = []
        for other, seconds, wall in done:
            if other.method != setting.method:
                continue
            scale = setting.spp / other.spp * max(1.0, setting.max_depth / other.max_depth)
            overhead = max(0.0, wall - repeats * seconds)  # compilation, scoring
            estimates.append(repeats * seconds * scale + overhead)
        return max(estimates, default=0.0)


# --------------------------------------------------------------------------- reference cache


class ReferenceCache:
    """Converged path-traced references on disk, keyed by everything they depend on.

    An entry is ``NAME-KEY.exr`` (the linear image, via whitted.imageio) and
    ``NAME-KEY.json`` (the settings and render time). Both are written atomically,
    the JSON last, and an entry is used only when the JSON names the same key and
    the image reads back whole with the expected size.
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)

    @staticmethod
    def key(path: Path, settings: dict) -> str:
        import mitsuba as mi

        import whitted
        from .converter import parse_file, scene_to_xml

        digest = hashlib.sha256()

        def add(label: str, data: bytes) -> None:
            digest.update(f"{label}:{len(data)}:".encode())
            digest.update(data)

        add("format", CACHE_FORMAT.encode())
        add("settings", json.dumps(settings, sort_keys=True).encode())
        add("versions", f"{whitted.__version__} {mi.__version__}".encode())
        add("scene", path.read_bytes())
        if path.suffix.lower() == ".scn":
            # What the scene means to today's converter, independent of where the file lies:
            # texture paths relative to the scene, comments (which name the file) dropped.
            xml = scene_to_xml(parse_file(path), base_dir=path.parent)
            add("xml", re.sub(r"<!--.*?-->", "", xml, flags=re.S).encode())
        for texture in _textures(path):
            add("texture", texture.read_bytes())
        return digest.hexdigest()

    def entry(self, name: str, key: str) -> tuple[Path, Path]:
        stem = f"{name.replace('/', '_')}-{key[:16]}"
        return self.folder / f"{stem}.exr", self.folder / f"{stem}.json"

    def load(self, name: str, key: str, shape: tuple[int, int]) -> tuple[np.ndarray, dict] | None:
        from . import imageio

        image_file, info_file = self.entry(name, key)
        try:
            info = json.loads(info_file.read_text(encoding="utf-8"))
            if info.get("key") != key:
                return None
            image = imageio.read_image(image_file)
        except Exception:  # missing, unreadable or foreign: render it again
            return None
        if image.shape != (shape[0], shape[1], 3) or not np.all(np.isfinite(image)):
            return None
        return image, info

    def store(self, name: str, key: str, image: np.ndarray, info: dict) -> Path:
        from . import imageio
        from .atomic import write_text

        self.folder.mkdir(parents=True, exist_ok=True)
        image_file, info_file = self.entry(name, key)
        imageio.write_image(image_file, image)
        write_text(info_file, json.dumps({**info, "key": key}, indent=2, sort_keys=True) + "\n")
        return image_file


# --------------------------------------------------------------------------- sweep


def _render(*args, **kwargs):
    """The rendering API, looked up at call time (tests count the calls)."""
    from . import render as render_module
    return render_module.render(*args, **kwargs)


def _reference(entry: SceneResult, scene, cache: ReferenceCache, options: Options,
               may_render: bool = True) -> np.ndarray | None:
    """The scene's reference, from the cache or rendered (None: not cached, may not render)."""
    settings = {"integrator": "path", "spp": options.reference_spp, "max_depth": entry.path_depth,
                "seed": REFERENCE_SEED, "width": entry.width, "height": entry.height,
                "variant": entry.variant}
    key = cache.key(entry.path, settings)
    cached = cache.load(entry.name, key, (entry.height, entry.width))
    if cached is not None:
        image, info = cached
        entry.reference_cached = True
        entry.reference_seconds = float(info.get("seconds", math.nan))
    elif not may_render:
        return None
    else:
        if not options.quiet:
            print(f"whitted compare: {entry.name}: rendering the reference "
                  f"(path tracer, {options.reference_spp} spp)", file=sys.stderr)
        result = _render(scene, integrator="path", spp=options.reference_spp,
                         max_depth=entry.path_depth, seed=REFERENCE_SEED, progress=not options.quiet)
        image = np.asarray(result.image, dtype=np.float32)
        entry.reference_seconds = float(result.seconds)
        cache.store(entry.name, key, image, {
            "scene": str(entry.path), "settings": settings, "seconds": result.seconds,
            "compile_seconds": result.compile_seconds,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    entry.reference_file = cache.entry(entry.name, key)[0]
    return image


def _measure(scene, setting: Setting, reference: np.ndarray, repeats: int) -> Measurement:
    from . import metrics, report

    seconds, compile_seconds, image = [], [], None
    for _ in range(repeats):
        result = _render(scene, integrator=setting.integrator, spp=setting.spp,
                         max_depth=setting.max_depth,
                         lighting=setting.lighting if setting.integrator == "whitted" else None,
                         seed=SWEEP_SEED, progress=False)
        seconds.append(float(result.seconds))
        compile_seconds.append(float(result.compile_seconds))
        if image is None:  # same seed, same image: score the first
            image = np.asarray(result.image, dtype=np.float32)
    return Measurement(setting, statistics.median(seconds), max(compile_seconds),
                       metrics.relative_mse(image, reference), metrics.flip(image, reference),
                       repeats, report.thumbnail(image))


def _sweep_scene(entry: SceneResult, scene, settings: list[Setting], cache: ReferenceCache,
                 options: Options, deadline: float, bar) -> None:
    from . import report

    # With no time left, a scene whose reference is not cached is skipped whole.
    reference = _reference(entry, scene, cache, options, may_render=time.monotonic() < deadline)
    if reference is None:
        entry.skipped.extend(settings)
        bar.update(len(settings))
        return
    entry.reference_thumbnail = report.thumbnail(reference)
    done: list[tuple[Setting, float, float]] = []
    for setting in settings:
        bar.set_postfix_str(f"{entry.name}: {setting.method} {setting.label}", refresh=False)
        predicted = Budget.predict(setting, done, options.repeats)
        if time.monotonic() + predicted > deadline:
            entry.skipped.append(setting)
        else:
            start = time.monotonic()
            measurement = _measure(scene, setting, reference, options.repeats)
            entry.measurements.append(measurement)
            done.append((setting, measurement.seconds, time.monotonic() - start))
        bar.update(1)


def compare(scenes: list[str | os.PathLike], options: Options) -> list[SceneResult]:
    """Run the whole comparison and write its outputs under ``options.out``."""
    from tqdm import tqdm

    from . import report
    from .loading import load_scene
    from .variant import set_variant

    budget = Budget(options.budget)
    out = Path(options.out)
    if out.exists() and not out.is_dir():
        raise WhittedError(f"{out}: exists and is not a folder")
    if options.repeats < 1 or options.reference_spp < 1:
        raise WhittedError("--repeats and --reference-spp must be >= 1")
    if options.budget is not None and not options.budget > 0:
        raise WhittedError(f"--budget must be a positive number of seconds, got {options.budget}")
    if options.depths and max(options.depths) > MAX_DEPTH:
        raise WhittedError(f"--depths: the scene format allows depths up to {MAX_DEPTH}")
    if options.path_depth is not None and not 1 <= options.path_depth <= MAX_DEPTH:
        raise WhittedError(f"--path-depth must be in 1…{MAX_DEPTH}, got {options.path_depth}")
    cache_folder = Path(options.cache) if options.cache is not None else out / "references"
    if cache_folder.exists() and not cache_folder.is_dir():
        raise WhittedError(f"{cache_folder}: the reference cache exists and is not a folder")
    variant = set_variant(options.variant)
    files = scene_files(scenes)

    # Load everything first: a bad scene fails now, not after minutes of rendering.
    entries, loaded, plans = [], [], []
    for path, name in zip(files, scene_names(files)):
        scene = load_scene(path)
        _textures(path)
        width, height = (int(v) for v in scene.sensors()[0].film().crop_size())
        depth = _scene_depth(path, scene)
        depths = options.depths or tuple(range(1, min(depth, MAX_DEFAULT_DEPTH) + 1))
        path_depth = options.path_depth or depth
        entries.append(SceneResult(name, path, width, height, variant, options.reference_spp,
                                   path_depth, whitted_spp=options.whitted_spp,
                                   path_spp=options.path_spp, depths=depths))
        loaded.append(scene)
        plans.append(plan(depths, options.whitted_spp, options.path_spp, path_depth))
    if max(options.path_spp) >= options.reference_spp and not options.quiet:
        print(f"whitted compare: warning: the path tracer's ladder reaches the reference's "
              f"{options.reference_spp} spp; its error will stop falling there", file=sys.stderr)

    out.mkdir(parents=True, exist_ok=True)
    cache = ReferenceCache(cache_folder)
    bar = tqdm(total=sum(map(len, plans)), desc="whitted compare", unit="render",
               disable=options.quiet, file=sys.stderr, dynamic_ncols=True)
    try:
        for index, (entry, scene, settings) in enumerate(zip(entries, loaded, plans)):
            deadline = budget.deadline_for(len(entries) - index)
            _sweep_scene(entry, scene, settings, cache, options, deadline, bar)
            report.write_csv(out / "results.csv", entries[:index + 1])
            loaded[index] = None  # free the scene's memory
    except KeyboardInterrupt:
        bar.close()
        if any(e.reference_thumbnail is not None for e in entries):
            report.write_all(out, _with_reference(entries))
            print(f"whitted compare: interrupted; the outputs in {out} hold what was done",
                  file=sys.stderr)
        raise
    bar.close()
    report.write_all(out, _with_reference(entries))
    return entries


def _with_reference(entries: list[SceneResult]) -> list[SceneResult]:
    """The scenes that got as far as their reference (the others have nothing to show)."""
    return [e for e in entries if e.reference_thumbnail is not None]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``compare`` subcommand's options (the CLI builds the subparser)."""
    parser.add_argument("scenes", nargs="+", metavar="SCENE",
                        help="scenes (.scn or .xml), or folders of them")
    parser.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--reference-spp", type=int, default=DEFAULT_REFERENCE_SPP, metavar="N",
                        help=f"the reference's samples per pixel (default {DEFAULT_REFERENCE_SPP})")
    parser.add_argument("--depths", type=int_list, metavar="LIST",
                        help="Whitted max depths, e.g. 1-5 or 1,2,4 (default: 1 to the scene's depth, "
                             f"at most {MAX_DEFAULT_DEPTH})")
    parser.add_argument("--spp", type=int_list, default=DEFAULT_WHITTED_SPP, metavar="LIST",
                        help="the Whitted integrator's spp ladder (default "
                             f"{','.join(map(str, DEFAULT_WHITTED_SPP))})")
    parser.add_argument("--path-spp", type=int_list, default=DEFAULT_PATH_SPP, metavar="LIST",
                        help="the path tracer's spp ladder (default "
                             f"{','.join(map(str, DEFAULT_PATH_SPP))})")
    parser.add_argument("--path-depth", type=int, metavar="N",
                        help="the path tracer's max depth, for the reference too (default: the scene's)")
    parser.add_argument("--repeats", type=int, default=DEFAULT_REPEATS, metavar="N",
                        help=f"renders per setting; the median time is kept (default {DEFAULT_REPEATS})")
    parser.add_argument("--budget", type=float, metavar="SECONDS",
                        help="bound the whole command's time: renders that would overrun are skipped")
    parser.add_argument("--levels", type=float_list, default=DEFAULT_LEVELS, metavar="LIST",
                        help="relative MSE levels of the summary table (default "
                             f"{','.join(map(str, DEFAULT_LEVELS))})")
    parser.add_argument("--cache", metavar="DIR", help="where references are cached (default DIR/references)")
    parser.add_argument("--variant", choices=SUPPORTED_VARIANTS,
                        help="Mitsuba variant (default as for render)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def compare_command(args: argparse.Namespace) -> None:
    """The CLI's ``compare`` subcommand."""
    from . import report

    options = Options(out=Path(args.out), reference_spp=args.reference_spp, depths=args.depths,
                      whitted_spp=args.spp, path_spp=args.path_spp, path_depth=args.path_depth,
                      repeats=args.repeats, budget=args.budget, levels=args.levels,
                      cache=Path(args.cache) if args.cache else None, variant=args.variant,
                      quiet=args.quiet)
    start = time.monotonic()
    entries = compare(args.scenes, options)
    skipped = sum(len(e.skipped) for e in entries)
    print(report.fastest_table(entries, options.levels))
    if skipped:
        print(f"\nbudget of {options.budget:g} s reached: skipped {skipped} of "
              f"{skipped + sum(len(e.measurements) for e in entries)} renders; "
              f"the outputs hold the renders that were done")
    for e in entries:
        if e.reference_file is None:
            print(f"{e.name}: skipped whole: no time was left to render its reference",
                  file=sys.stderr)
            continue
        how = "read from the cache" if e.reference_cached else f"rendered in {e.reference_seconds:.1f} s"
        print(f"{e.name}: reference (path tracer, {e.reference_spp} spp) {how}: {e.reference_file}",
              file=sys.stderr)
    print(f"\n{sum(len(e.measurements) for e in entries)} renders in "
          f"{time.monotonic() - start:.1f} s; wrote {report.output_files(options.out)}",
          file=sys.stderr)


__all__ = ["Budget", "Measurement", "Options", "ReferenceCache", "SceneResult", "Setting",
           "compare", "compare_command", "plan"]
