"""One home for every default and limit: the scene format's (docs/scene-format.md), the
plugins' and the CLI's, written once so that no copy drifts; and the ``check_*`` functions
that validate a setting wherever it comes from. Plain Python: the converter imports it too.
"""

from __future__ import annotations

import math

from .errors import ParameterError, WhittedError

Vec3 = tuple[float, float, float]

#: the package's version (pyproject.toml reads it from here)
VERSION = "0.1.0"

# --- The scene format's defaults (docs/scene-format.md, "statements") -------------------------
WIDTH, HEIGHT = 640, 400
EYE: Vec3 = (0.0, 0.0, 10.0)
LOOKAT: Vec3 = (0.0, 0.0, 0.0)
UP: Vec3 = (0.0, 1.0, 0.0)
FOV = 45.0                      #: horizontal field of view, degrees
BACKGROUND: Vec3 = (0.0, 0.0, 0.0)
AMBIENT = 0.2                   #: the ambient coefficient A; the diffuse one is 1 - A
DEPTH = 5                       #: the ray tree's maximum depth; primary rays have depth 1
SAMPLES = 1                     #: samples per pixel
LIGHT_COLOR: Vec3 = (1.0, 1.0, 1.0)
COLOR: Vec3 = (1.0, 1.0, 1.0)   #: a sphere's base color
REFLECT = 0.0                   #: KR
REFRACT = 0.0                   #: KT
IOR = 1.0
NORTH: Vec3 = (0.0, 1.0, 0.0)
EQUATOR: Vec3 = (0.0, 0.0, -1.0)

# --- The scene format's limits (docs/scene-format.md, "Decided here": why) ---------------------
MAX_SIZE = 16384                #: image width and height, pixels
MAX_DEPTH = 64                  #: the deepest ray tree anything accepts (format, CLI, plugins)
MAX_SAMPLES = 65536             #: samples per pixel in a scene file
MAX_MAGNITUDE = "1e12"          #: every number's largest magnitude
MIN_POSITIVE = "1e-6"           #: the smallest radius, index of refraction and field of view
PARALLEL_SINE = 1e-9            #: two directions are parallel below this sine of their angle
#: A scene file's errors are all found; the message lists this many, then counts the rest.
MAX_REPORTED_ERRORS = 20

# --- Rendering -----------------------------------------------------------------------------------
LIGHTING_MODES = ("article", "physical")
LIGHTING = "article"
#: what a render may leave out, as if the scene lacked it (plugins/scene_tables.py)
SWITCHABLE_EFFECTS = ("shadows", "reflection", "refraction", "textures", "diffuse", "ambient")
INTEGRATORS = ("whitted", "path")
INTEGRATOR = "whitted"
IN_PROCESS = "in-process"   #: where a scene was rendered without a Dask cluster
VIEWS = ("clip", "aces")   #: how an image is displayed (whitted/images.py)
#: the path tracer's fewest spp when none are asked for (at a scene's 1 it is speckled noise)
PATH_MIN_SPP = 64


def user_cache_folder() -> "Path":
    """``$XDG_CACHE_HOME/whitted`` (if absolute), else ``~/.cache/whitted``."""
    import os
    from pathlib import Path
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "whitted"


def path_depth(depth: int) -> int:
    """Mitsuba ``path``'s ``max_depth`` for the article's depth N (docs/radiometry.md, "Depth")."""
    return depth + 1

#: the adaptive depth control's bound on a pixel's change, one step of an 8-bit image
#: (plugins/recursion.py); 0 traces the exact tree
MIN_WEIGHT = 1 / 255
WAVEFRONT_SIZE = 0   #: camera samples per pass of the whitted integrator (0: its choice)
SEED_STRIDE = 0x9E3779B9   #: spreads consecutive seeds over 32 bits (Knuth's multiplicative hash)
MAX_SPP = 2 ** 31   #: the most samples per pixel a render accepts
#: Mitsuba variants whitted runs in: the default when a libLLVM >= 16 exists, else the fallback
VARIANTS = ("scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb")
DEFAULT_VARIANT = "llvm_ad_rgb"
FALLBACK_VARIANT = "scalar_rgb"
#: the ``whitted`` integrator's checked properties and their defaults
WHITTED_DEFAULTS = {"max_depth": DEPTH, "ambient": AMBIENT, "lighting": LIGHTING,
                    "light_reference": LOOKAT, "min_weight": MIN_WEIGHT,
                    "wavefront_size": WAVEFRONT_SIZE, "without": ""}


# --- whitted compare: docs/compare.md says what each does, by name ----------------------------
COMPARE_REFERENCE_SPP = 4096              #: the path-traced reference's samples per pixel
COMPARE_WHITTED_SPP = (1, 4, 16)          #: the Whitted sweep's spp ladder
COMPARE_PATH_SPP = (1, 4, 16, 64, 256, 1024)   #: the path tracer's spp ladder
COMPARE_PATH_FIT_COUNTS = 3
COMPARE_PATH_CHECK = 0.1
COMPARE_ROUNDS = 3
COMPARE_HEADLINE_ROUNDS = 8
COMPARE_MAX_ROUNDS = 25
COMPARE_ROUNDS_SECONDS = 8.0
COMPARE_LONG_SECONDS = 0.1
COMPARE_LONG_ROUNDS = 2
COMPARE_CONFIDENCE = 0.9   #: how surely a headline's interval holds the median ratio
#: a round repeats a render back to back for COMPARE_ROUND_SECONDS (its fastest time counts), at
#: most COMPARE_ROUND_REPEATS times
COMPARE_ROUND_SECONDS = 0.05
COMPARE_ROUND_REPEATS = 8
COMPARE_SETTLED_WIDTH = 0.25
#: how far a ratio of times moves between runs of one command on a shared machine (tir's headline:
#: 2.02-2.13x over nine runs, each run's own interval ~1% wide): every ratio's interval is widened
#: by it each way, so that it holds what another run measures; the equal-quality table's fastest
#: method ties with each method whose interval then holds 1
COMPARE_RUN_SHARE = 0.05
COMPARE_TIMING_THREADS = 1   #: LLVM threads of a timed render (None: all)
COMPARE_CLOCK = "cpu"   #: the timing rounds' clock, "cpu" or "wall"
#: Dr.Jit's memory cache is handed back between settings once the process holds more than this
COMPARE_KEPT_MEMORY = 1 << 30
#: the equal-quality table's levels between the best and worst errors measured (--levels)
COMPARE_DATA_LEVELS = 2
#: the default Whitted sweep is 1…min(scene depth, this)
COMPARE_MAX_DEFAULT_DEPTH = 8
#: the reference is rendered in chunks of at most this many spp, each with its own seed
#: (the same reference on a cluster or in one process)
COMPARE_REFERENCE_CHUNK_SPP = 1024
COMPARE_CONNECT_TIMEOUT = 5.0   #: seconds to wait for a Dask scheduler (and its first worker)
COMPARE_FLOOR_TOLERANCE = 0.05
COMPARE_LIMIT_SPP_FACTOR = 8
COMPARE_LIMIT_MAX_SPP = 4096
COMPARE_LIMIT_NOISE_SHARE = 0.1
COMPARE_REFERENCE_START_SPP = 32
COMPARE_REFERENCE_NOISE_SHARE = 0.01
COMPARE_REFERENCE_SHARE = 0.5
COMPARE_MIN_REFERENCE_SPP = 8
COMPARE_PROBE_SECONDS = 0.1   #: under --budget, the render time of the reference's probe
COMPARE_REPORT_SECONDS = 3.0
COMPARE_ROUNDS_SHARE = 0.2
COMPARE_LIMITS_SHARE = 0.25
COMPARE_QUICK = {"rounds": 2, "budget": 25.0}
COMPARE_QUICK_LIMITS_SHARE = 0.0


# --- Validation, written once ----------------------------------------------------------------------

def _bounded(value, what: str, low, high, rule: str) -> int:
    if isinstance(value, bool) or (not isinstance(value, (int, float))
                                   and not hasattr(value, "__index__")):
        raise WhittedError(f"{what} must be an integer, got {value!r}")
    if isinstance(value, float) and not value.is_integer():
        raise WhittedError(f"{what} must be an integer, got {value}")
    value = int(value)
    if not low <= value <= high:
        raise WhittedError(f"{what} must be {rule}, got {value}")
    return value


def check_depth(depth, what: str = "max depth") -> int:
    return _bounded(depth, what, 1, MAX_DEPTH, f"in 1…{MAX_DEPTH} (primary rays have depth 1)")


def check_spp(spp, what: str = "spp") -> int:
    return _bounded(spp, what, 1, MAX_SPP, "a positive integer up to 2^31")


def check_size(size, what: str = "width") -> int:
    return _bounded(size, what, 1, MAX_SIZE, f"in 1…{MAX_SIZE} pixels")


def _number(value, what: str, kind: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise WhittedError(f"{what} must be {kind}, got {value!r}") from None


def _unit_interval(value, what: str) -> float:
    value = _number(value, what, "a number in [0, 1]")
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise WhittedError(f"{what} must be in [0, 1], got {value}")
    return value


def check_ambient(ambient, what: str = "ambient") -> float:
    return _unit_interval(ambient, what)


def check_min_weight(min_weight, what: str = "min weight") -> float:
    """The adaptive depth control's threshold in [0, 1] (0: the exact tree)."""
    return _unit_interval(min_weight, what)


def check_ior(ior, what: str = "ior") -> float:
    ior = _number(ior, what, "a number > 0")
    if not (math.isfinite(ior) and ior > 0.0):
        raise WhittedError(f"{what} must be > 0, got {ior}")
    return ior


def _triple(value) -> tuple:
    try:
        numbers = tuple(float(c) for c in value)
    except (TypeError, ValueError):
        return ()
    return numbers if len(numbers) == 3 else ()


def check_color(color, what: str = "color") -> Vec3:
    rgb = _triple(color)
    if not rgb:
        raise WhittedError(f"{what} must be an RGB color (three numbers in [0, 1]), got {color!r}")
    if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in rgb):
        raise WhittedError(f"{what} must have each component in [0, 1], got [{', '.join(f'{c:g}' for c in rgb)}]")
    return rgb


def check_point(point, what: str = "point") -> Vec3:
    xyz = _triple(point)
    if not xyz or not all(map(math.isfinite, xyz)):
        raise WhittedError(f"{what} must be a point (three finite numbers), got {point!r}")
    return xyz


def check_wavefront_size(size, what: str = "wavefront_size") -> int:
    """Camera samples per pass: an integer >= 0 (0: as the tracer prefers)."""
    return _bounded(size, what, 0, math.inf, ">= 0")


def check_lighting(lighting, what: str = "lighting") -> str:
    if lighting not in LIGHTING_MODES:
        raise WhittedError(f"{what} must be one of {', '.join(LIGHTING_MODES)}, got '{lighting}'")
    return lighting


def check_without(without, what: str = "without") -> tuple[str, ...]:
    """Effects to leave out of a render, comma-separated names or several (None: none): each
    once, in :data:`SWITCHABLE_EFFECTS`' order."""
    if without is None:
        return ()
    names = []
    for item in [without] if isinstance(without, str) else without:
        if not isinstance(item, str):
            raise WhittedError(f"{what} must name effects ({', '.join(SWITCHABLE_EFFECTS)}), got {item!r}")
        names += [name.strip().lower() for name in item.split(",") if name.strip()]
    for name in names:
        if name not in SWITCHABLE_EFFECTS:
            import difflib
            close = difflib.get_close_matches(name, SWITCHABLE_EFFECTS, n=1, cutoff=0.5)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise WhittedError(f"{what}: unknown effect '{name}'{hint}; choose from "
                               f"{', '.join(SWITCHABLE_EFFECTS)}")
    return tuple(name for name in SWITCHABLE_EFFECTS if name in names)


#: The plugins' parameters and their checks, one rule for a property loaded and an edit, by
#: plugin (the name that starts its messages).
PLUGIN_PARAMETERS = {
    "article BSDF": {"color": check_color, "reflect": _unit_interval, "refract": _unit_interval,
                     "ior": check_ior},
    "whitted": {"max_depth": check_depth, "ambient": check_ambient, "min_weight": check_min_weight,
                "lighting": check_lighting, "light_reference": check_point,
                "wavefront_size": check_wavefront_size, "without": check_without},
}


def check_plugin_parameters(plugin: str, values: dict) -> dict:
    """``values`` checked by :data:`PLUGIN_PARAMETERS` and together (reflect + refract <= 1),
    or a :class:`~whitted.errors.ParameterError` (``PLUGIN: NAME must ..., got VALUE``)."""
    try:
        checked = {name: PLUGIN_PARAMETERS[plugin][name](value, f"{plugin}: {name}")
                   for name, value in values.items()}
    except WhittedError as error:
        raise ParameterError(str(error)) from None
    reflect, refract = checked.get("reflect", 0.0), checked.get("refract", 0.0)
    if reflect + refract > 1.0 + 1e-6:
        raise ParameterError(f"{plugin}: reflect + refract must be <= 1, got {reflect} + {refract}")
    return checked


def check_integrator(integrator) -> str:
    if integrator not in INTEGRATORS:
        raise WhittedError(f"unknown integrator '{integrator}'; choose one of {', '.join(INTEGRATORS)}")
    return integrator


def check_seed(seed, what: str = "seed") -> int:
    """A render's seed (0 to 2^64 - 1) in Mitsuba's 32 bits, the upper half folded in."""
    seed = _bounded(seed, what, 0, 2 ** 64 - 1, "an integer from 0 to 2^64 - 1")
    return (seed ^ (seed >> 32) * SEED_STRIDE) & 0xFFFFFFFF


# --------------------------------------------------------------------------- many scenes, video

IMAGE_FORMATS = ("png", "exr")   #: what ``whitted render SCENES -o OUT/`` writes (first: default)
DEFAULT_FPS = 24.0   #: a video's frames per second unless ``--fps`` says

#: the fewest spheres of one radius grouped in an ``ellipsoids`` shape by default
#: (whitted/sealed.py): below it the load time saved is below a render's noise
SEALED_MIN_GROUP = 1000

#: the mesh cache's most bytes (converter/giants.py), the least recently used going first
MESH_CACHE_BYTES = 256 * 2 ** 20
#: a cached or temporary file untouched this long is no running process's: it may be removed
STALE_SECONDS = 600.0


# --------------------------------------------------------------------------- fitting (whitted fit)

#: the most gradient descent steps of a fit (``whitted fit``, compare's "the article's model fitted")
FIT_ITERATIONS = 150
#: a fit stops early when its best loss improved by less than FIT_MIN_GAIN (a fraction) over
#: its last FIT_PATIENCE steps and its loss is within FIT_MIN_GAIN of that best
FIT_PATIENCE = 10
FIT_MIN_GAIN = 0.005
#: the widest image a fit renders (the target is box-filtered down to it)
FIT_WIDTH = 80
#: the most samples per pixel compare's fit renders with (as many as the limit has, up to this)
FIT_SPP = 8
#: Adam's learning rate at the first and at the last step (it falls geometrically between)
FIT_RATE = (0.03, 1e-4)
