"""One home for every default and limit: the scene format's, the plugins' and the CLI's.

Why one module: the same number (the format's depth cap of 64, the ambient
coefficient 0.2, ...) is needed by the parser, the scene model, the
integrator's constructor, the rendering API and ``compare``; written once, no
copy can drift from another. Everything here is plain Python (no Mitsuba, no
Dr.Jit), so the standalone converter can import it as cheaply as the plugins do.

The scene format's defaults and limits restate ``docs/scene-format.md`` (the
project's copy of the format contract); the ``check_*`` functions validate a
setting once, wherever it comes from (API, CLI, XML), and raise
:class:`~whitted.errors.WhittedError`, which the CLI prints as one line.
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

# --- The scene format's limits -----------------------------------------------------------------
MAX_SIZE = 16384                #: image width and height, pixels
MAX_DEPTH = 64                  #: the deepest ray tree anything accepts (format, CLI, plugins)
MAX_SAMPLES = 65536             #: samples per pixel in a scene file
#: Every number's magnitude is at most this: light intensities (color * pi * d^2)
#: and squared distances then stay far inside 32-bit float range.
MAX_MAGNITUDE = "1e12"
#: Radius, index of refraction and field of view are at least this, so that
#: their squares and reciprocals stay normal 32-bit floats.
MIN_POSITIVE = "1e-6"
#: Two directions count as parallel when the sine of their angle is below this.
PARALLEL_SINE = 1e-9
#: A scene file's errors are all found; the message lists this many, then counts the rest.
MAX_REPORTED_ERRORS = 20

# --- Rendering -----------------------------------------------------------------------------------
#: how the Whitted integrator lights a scene: the article's model, or physically
LIGHTING_MODES = ("article", "physical")
LIGHTING = "article"
#: what a render of the article's model may leave out, as if the scene lacked it
#: (``whitted render --without``, the integrator's ``without``; plugins/scene_tables.py
#: decides what each means)
SWITCHABLE_EFFECTS = ("shadows", "reflection", "refraction", "textures", "diffuse", "ambient")
#: the article's model, or Mitsuba's stock path tracer
INTEGRATORS = ("whitted", "path")
INTEGRATOR = "whitted"
#: How an image is displayed (PNG, the compare page, notebooks; whitted/images.py): plain
#: sRGB clipped to [0, 1], or OpenColorIO's ACES 2.0 SDR view (highlights rolled off)
VIEWS = ("clip", "aces")
#: The path tracer's samples per pixel when none are asked for and the scene asks for fewer:
#: a scene's ``samples`` (1 by default) is anti-aliasing for the article's deterministic model;
#: the path tracer at 1 spp is speckled noise.
PATH_MIN_SPP = 64


def user_cache_folder() -> "Path":
    """Where whitted keeps what it may compute again but would rather not (the compare
    command's path-traced references): ``$XDG_CACHE_HOME/whitted``, or
    ``~/.cache/whitted`` where that variable is unset, empty or not an absolute path (as
    the XDG base directory specification says to treat it). Deleting it is always safe."""
    import os
    from pathlib import Path
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "whitted"


def path_depth(depth: int) -> int:
    """Mitsuba ``path``'s ``max_depth`` for the article's depth N: N + 1 (docs/radiometry.md,
    "Depth": N surface interactions, each connected to the lights by one more segment)."""
    return depth + 1

#: The adaptive depth control (Hall and Greenberg; POV-Ray's adc_bailout): branches of the
#: ray tree are left untraced as long as together they cannot change a pixel by more than
#: this, one step of an 8-bit image (plugins/recursion.py); 0 traces the exact tree
MIN_WEIGHT = 1 / 255
#: camera samples per pass of the whitted integrator (0: as its tracer prefers; see plugins/recursion.py)
WAVEFRONT_SIZE = 0
#: the multiplier that spreads consecutive seeds over 32 bits (the golden ratio's, Knuth's
#: multiplicative hash): a render's seed and its passes' seeds are far apart
SEED_STRIDE = 0x9E3779B9
#: the most samples per pixel a render accepts (API and CLI; Mitsuba's samplers count in 32 bits)
MAX_SPP = 2 ** 31
#: Mitsuba variants whitted runs in: the default when a libLLVM >= 16 exists, else the fallback
VARIANTS = ("scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb")
DEFAULT_VARIANT = "llvm_ad_rgb"
FALLBACK_VARIANT = "scalar_rgb"


# --- whitted compare ------------------------------------------------------------------------------
COMPARE_REFERENCE_SPP = 4096              #: the path-traced reference's samples per pixel
COMPARE_WHITTED_SPP = (1, 4, 16)          #: the Whitted sweep's spp ladder
COMPARE_PATH_SPP = (1, 4, 16, 64, 256, 1024)   #: the path tracer's spp ladder
#: Timing on a busy machine (whitted/compare/timing.py): once every setting of a scene is
#: rendered and scored, each is timed once per round, the rounds interleaved, at least
#: COMPARE_ROUNDS rounds; more while a headline ratio's interval (COMPARE_CONFIDENCE, for
#: the median of its paired per-round ratios) is wider than 1 + COMPARE_SETTLED_WIDTH, up to
#: COMPARE_MAX_ROUNDS rounds and COMPARE_ROUNDS_SECONDS of extra rounds per scene.
#: The extra rounds time only the headlines' renders (their floor renders and the path
#: renders their ratios are read between), back to back: COMPARE_HEADLINE_ROUNDS of them,
#: then more while a headline is unsettled, all within COMPARE_ROUNDS_SECONDS (fewer where a
#: headline round takes longer than COMPARE_ROUNDS_SECONDS / COMPARE_HEADLINE_ROUNDS).
COMPARE_ROUNDS = 3
COMPARE_HEADLINE_ROUNDS = 8
COMPARE_MAX_ROUNDS = 25
COMPARE_ROUNDS_SECONDS = 20.0
COMPARE_CONFIDENCE = 0.9
#: Within a round, a render faster than COMPARE_ROUND_SECONDS is repeated back to back until
#: its renders add up to that (at most COMPARE_ROUND_REPEATS), the fastest kept: a render of a
#: few milliseconds is at the mercy of one scheduler tick.
COMPARE_ROUND_SECONDS = 0.05
COMPARE_ROUND_REPEATS = 8
COMPARE_SETTLED_WIDTH = 0.25
#: The timed rounds run Dr.Jit's LLVM backend on this many threads (None: as many as the
#: process has), and read a render's time on COMPARE_CLOCK: "cpu" (the process's CPU time)
#: or "wall". One thread and CPU time is the cost of a render's work on one core, which a
#: busy machine hardly changes: on a quiet machine it equals the one-thread wall time;
#: two threads beside two CPU-bound programs made a Whitted render 5x slower and a path
#: render 3.5x (docs/compare.md, "Timing", has the measurements). CUDA variants read the
#: wall clock whatever this says (the CPU only waits for the GPU).
COMPARE_TIMING_THREADS = 1
COMPARE_CLOCK = "cpu"
#: Timed renders keep Dr.Jit's memory cache (a program rendering again and again keeps it),
#: but after a setting's renders in a round the cache is handed back once the process holds
#: more than this many bytes: it keeps blocks of every size the scene's settings used (a
#: sphereflake of 66 431 spheres at 512x512 reached 1.9 GB without this bound).
COMPARE_KEPT_MEMORY = 1 << 30
#: The equal-quality table's levels, from the data: each method's floor times (1 + this
#: tolerance), and this many levels spaced evenly on log axes between the best and worst
#: errors measured (--levels replaces them all).
COMPARE_DATA_LEVELS = 2
#: The default Whitted sweep is 1…min(scene depth, this): deeper trees rarely change a pixel.
COMPARE_MAX_DEFAULT_DEPTH = 8
#: The reference is rendered in independent chunks of at most this many spp, each with its
#: own seed, and averaged: a cluster renders the chunks on different workers, and a run
#: in one process renders the same chunks, so both make the same reference.
COMPARE_REFERENCE_CHUNK_SPP = 1024
#: Seconds to wait for a Dask scheduler to answer (and for its first worker) before
#: ``whitted compare --scheduler`` gives up.
COMPARE_CONNECT_TIMEOUT = 5.0
#: A Whitted method's floor is its cheapest render whose error is within this fraction of the
#: method's best: more depth or samples past it buy less than that.
COMPARE_FLOOR_TOLERANCE = 0.05
#: The model's limit (a Whitted method at the sweep's deepest depth, exact tree) is rendered
#: in two halves of at least this many times the sweep's densest spp, doubled (up to
#: COMPARE_LIMIT_MAX_SPP) until its own noise, estimated from the halves, is below
#: COMPARE_LIMIT_NOISE_SHARE of the smallest difference it measures to a sweep render.
COMPARE_LIMIT_SPP_FACTOR = 16
COMPARE_LIMIT_MAX_SPP = 4096
COMPARE_LIMIT_NOISE_SHARE = 0.1
#: Under --budget, the most of a scene's share its reference may take (the sweep gets the rest).
COMPARE_REFERENCE_SHARE = 0.5
#: Under --budget, a reference is scaled down to fit its share but not below this many spp
#: (below it, its own noise would swamp the errors it is meant to measure): the scene is refused.
COMPARE_MIN_REFERENCE_SPP = 8
#: The probe that estimates a reference's cost doubles its spp until one render takes this long.
COMPARE_PROBE_SECONDS = 0.1
#: Seconds of --budget kept back per scene for writing its outputs (plots, report page).
COMPARE_REPORT_SECONDS = 3.0


# --- Validation, written once ----------------------------------------------------------------------

def _integer(value, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__index__"):
        raise WhittedError(f"{what} must be an integer, got {value!r}")
    if isinstance(value, float) and not value.is_integer():
        raise WhittedError(f"{what} must be an integer, got {value}")
    return int(value)


def check_depth(depth, what: str = "max depth") -> int:
    """The ray tree's maximum depth, 1 ... :data:`MAX_DEPTH` (primary rays have depth 1)."""
    depth = _integer(depth, what)
    if not 1 <= depth <= MAX_DEPTH:
        raise WhittedError(f"{what} must be in 1…{MAX_DEPTH} (primary rays have depth 1), got {depth}")
    return depth


def check_spp(spp, what: str = "spp") -> int:
    """Samples per pixel, 1 ... :data:`MAX_SPP`."""
    spp = _integer(spp, what)
    if not 1 <= spp <= MAX_SPP:
        raise WhittedError(f"{what} must be a positive integer up to 2^31, got {spp}")
    return spp


def check_size(size, what: str = "width") -> int:
    """An image's width or height, 1 ... :data:`MAX_SIZE` pixels (the scene format's range)."""
    size = _integer(size, what)
    if not 1 <= size <= MAX_SIZE:
        raise WhittedError(f"{what} must be in 1…{MAX_SIZE} pixels, got {size}")
    return size


def _number(value, what: str, kind: str) -> float:
    """``value`` as a float, or an error saying it must be ``kind`` (an RGB value is no number)."""
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
    """The article's ambient coefficient A in [0, 1]."""
    return _unit_interval(ambient, what)


def check_min_weight(min_weight, what: str = "min weight") -> float:
    """The adaptive depth control's threshold in [0, 1] (0: the exact tree)."""
    return _unit_interval(min_weight, what)


def check_ior(ior, what: str = "ior") -> float:
    """An index of refraction: a finite number > 0."""
    ior = _number(ior, what, "a number > 0")
    if not (math.isfinite(ior) and ior > 0.0):
        raise WhittedError(f"{what} must be > 0, got {ior}")
    return ior


def check_color(color, what: str = "color") -> Vec3:
    """A base color: three numbers, each in [0, 1] (the scene format's range, and what Mitsuba
    loads as an RGB reflectance)."""
    try:
        rgb = tuple(float(c) for c in color)
    except (TypeError, ValueError):
        rgb = ()
    if len(rgb) != 3:
        raise WhittedError(f"{what} must be an RGB color (three numbers in [0, 1]), got {color!r}")
    if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in rgb):
        raise WhittedError(f"{what} must have each component in [0, 1], got [{', '.join(f'{c:g}' for c in rgb)}]")
    return rgb


def check_point(point, what: str = "point") -> Vec3:
    """A point: three finite numbers."""
    try:
        xyz = tuple(float(c) for c in point)
    except (TypeError, ValueError):
        xyz = ()
    if len(xyz) != 3 or not all(map(math.isfinite, xyz)):
        raise WhittedError(f"{what} must be a point (three finite numbers), got {point!r}")
    return xyz


def check_wavefront_size(size, what: str = "wavefront_size") -> int:
    """Camera samples per pass: an integer >= 0 (0: as the tracer prefers)."""
    size = _integer(size, what)
    if size < 0:
        raise WhittedError(f"{what} must be >= 0, got {size}")
    return size


def check_lighting(lighting, what: str = "lighting") -> str:
    """One of :data:`LIGHTING_MODES`."""
    if lighting not in LIGHTING_MODES:
        raise WhittedError(f"{what} must be one of {', '.join(LIGHTING_MODES)}, got '{lighting}'")
    return lighting


def check_without(without, what: str = "without") -> tuple[str, ...]:
    """Effects to leave out of a render: names of :data:`SWITCHABLE_EFFECTS`, given as a
    string (comma-separated) or several; each once, in that tuple's order (None: none)."""
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


#: The plugins' parameters and their checks: one rule for a property loaded (XML, a dict) and
#: for an edit (``params.update()``, the plugins' ``parameters_changed``), by plugin (the name
#: that starts its messages). ``color`` is a uniform base color (a texture's texels are not
#: checked).
PLUGIN_PARAMETERS = {
    "article BSDF": {"color": check_color, "reflect": _unit_interval, "refract": _unit_interval,
                     "ior": check_ior},
    "whitted": {"max_depth": check_depth, "ambient": check_ambient, "min_weight": check_min_weight,
                "lighting": check_lighting, "light_reference": check_point,
                "wavefront_size": check_wavefront_size, "without": check_without},
}


def check_plugin_parameters(plugin: str, values: dict) -> dict:
    """``values`` (name -> value as given) checked by :data:`PLUGIN_PARAMETERS`, and together
    (an ``article`` BSDF's reflect + refract <= 1): the values to use, or a
    :class:`~whitted.errors.ParameterError` (``PLUGIN: NAME must ..., got VALUE``)."""
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
    """One of :data:`INTEGRATORS`."""
    if integrator not in INTEGRATORS:
        raise WhittedError(f"unknown integrator '{integrator}'; choose one of {', '.join(INTEGRATORS)}")
    return integrator


def check_seed(seed, what: str = "seed") -> int:
    """A render's seed as Mitsuba takes it (32 bits): any integer from 0 to 2^64 - 1. Seeds
    below 2^32 are themselves; a larger one folds its upper half into the lower (times
    :data:`SEED_STRIDE`), so that seeds that differ above bit 32 still give other samples."""
    seed = _integer(seed, what)
    if not 0 <= seed < 2 ** 64:
        raise WhittedError(f"{what} must be an integer from 0 to 2^64 - 1, got {seed}")
    return (seed ^ (seed >> 32) * SEED_STRIDE) & 0xFFFFFFFF


# --------------------------------------------------------------------------- many scenes, video

#: the image formats ``whitted render SCENES... -o OUT/`` writes per scene (``--format``; the first
#: is the default)
IMAGE_FORMATS = ("png", "exr")
#: a video's frames per second unless ``--fps`` says (``whitted render --video``, ``whitted video``)
DEFAULT_FPS = 24.0

#: the fewest spheres of one radius that the loader and the portable XML group in an
#: ``ellipsoids`` shape by default (whitted/sealed.py, ``MIN_GROUP``): below this the load time
#: saved (~0.1 ms a sphere) is below a render's noise, and the scene is left as written.
SEALED_MIN_GROUP = 1000


#: The mesh cache (converter/giants.py: the meshes of giant spheres in scenes loaded without
#: an XML file, in the temporary folder) keeps at most this many bytes: beyond it, the meshes
#: used least recently go first (smallpt's box alone is 40 MB).
MESH_CACHE_BYTES = 256 * 2 ** 20
#: A cached file or a writer's temporary file untouched for this many seconds is in use by no
#: running process (a mesh is written and loaded in seconds, a cache entry written in
#: seconds): only such files are removed from a cache.
STALE_SECONDS = 600.0


# --------------------------------------------------------------------------- fitting (whitted fit)

#: gradient descent steps of a fit (``whitted fit``, compare's "the article's model fitted")
FIT_ITERATIONS = 150
#: the widest image a fit renders (the target is box-filtered down to it)
FIT_WIDTH = 80
#: the most samples per pixel compare's fit renders with (as many as the limit has, up to this)
FIT_SPP = 16
#: Adam's learning rate at the first and at the last step (it falls geometrically between)
FIT_RATE = (0.03, 1e-4)
