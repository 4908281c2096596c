"""Shared fixtures. Keep them small and generic: every test module may use them."""

from __future__ import annotations

import functools
import os
from pathlib import Path

import mitsuba as mi
import pytest
from hypothesis import settings

import whitted  # selects the default variant and registers the plugins
from whitted.converter import giants

REPO = Path(__file__).resolve().parent.parent

# Hypothesis draws the same examples on every run: a suite that passes here passes in CI, and
# new examples come from a change to the tests, not from the luck of a run.
settings.register_profile("fixed", derandomize=True, database=None)
settings.load_profile("fixed")

# The tests load the same giant scenes again and again, in many files: keep every giant sphere's
# mesh made (a pure function's value; the package keeps the last MESH_MEMORY = 8, six walls and a
# floor or two, and the suite's 16 would make them about 120 times instead of 16).
giants._mesh_bytes = functools.lru_cache(maxsize=32)(giants._mesh_bytes.__wrapped__)

#: the variants every rendering test runs in (cuda_ad_rgb needs a GPU, which CI lacks)
VARIANTS = ("scalar_rgb", "llvm_ad_rgb")


#: the body of a small .scn scene, without its size and its last sphere: shadows (two lights,
#: spheres on a floor), a mirror and a glass ball (the fit's and the gradients' scenes)
MIRROR_AND_GLASS = """eye 0 1.5 6.5
lookat 0 0.9 0
fov 50
background 0.1 0.1 0.15
ambient 0.15
depth 5
light 0 10 6
light 5 4 -6   0.4 0.4 0.4
sphere 0 -1000 0 1000     color 0.6 0.65 0.6
sphere -1.9 1.3 0 1.3     color 0.9 0.9 0.95  reflect 0.6
sphere 1.9 1.3 0 1.3      color 0.9 0.5 0.3  refract 0.7 1.5  reflect 0.1
"""

#: ``make test``'s order (``--dist loadgroup --no-loadscope-reorder``, which :func:`group` serves):
#: the groups that take longest, slowest first, so that no worker is left with a long one at the
#: end while the other idles; then the other files in collection order, then the small groups of
#: the :data:`SPLIT` files, which fill the workers' last gaps
SLOW_FIRST = ("test_cluster.py", "test_readme.py", "test_compare.py", "test_interrupt.py",
              "test_compare_display.py", "test_path_grouped.py", "test_compare_findings.py",
              "test_fit.py", "test_trace.py")
#: files whose tests are split between the workers by the first part of their parameters' id
#: (the scene's name), each group computing only its own share of the module's renders; every
#: other file's tests are one group, run in order on one worker, sharing their module fixtures
SPLIT = ("test_giants.py", "test_invariance.py", "test_determinism.py", "test_layers.py")


def group(nodeid: str) -> str:
    """The group of the test ``nodeid``: its file's name, or for a :data:`SPLIT` file, its file's
    name and the first part of its parameters' id that is not a variant (the variants of a
    scene share its float64 reference), else the variant."""
    path, _, test = nodeid.partition("::")
    name = path.rsplit("/", 1)[-1]
    if name in SPLIT and test.endswith("]"):
        parts = test[test.index("[") + 1:-1].split("-")
        return f"{name}[{next((p for p in parts if p not in VARIANTS), parts[0])}]"
    return name


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """The tests in the order of :data:`SLOW_FIRST`, and within a file, those that select
    scalar_rgb through :func:`variant` last, so that they follow one another
    (:func:`restore_variant`); a stable sort: otherwise tests keep their order."""
    rank = {name: k for k, name in enumerate(SLOW_FIRST)}
    first = {}
    for k, item in enumerate(items):
        first.setdefault(item.path, k)

    def order(item) -> tuple[int, int, bool]:
        name = group(item.nodeid)
        return (rank.get(name, len(rank) + (item.path.name in SPLIT)), first[item.path],
                selected(item) == "scalar_rgb")
    items.sort(key=order)


def pytest_xdist_make_scheduler(config, log):
    """Under ``--dist loadgroup``, xdist's scheduling by scope with :func:`group` as the scope:
    the test files' own groups, without ``xdist_group`` marks (which pytest 9.2's node ids
    drop, so that xdist handed out the tests one by one)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Groups(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return group(nodeid)
    return Groups(config, log)


def _fresh_user_cache(tmp_path_factory):
    """$XDG_CACHE_HOME (where ``whitted compare`` keeps its references by default) set to a
    new empty folder while the caller's fixture lasts, then put back."""
    import os
    before = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg-cache"))
    yield
    if before is None:
        os.environ.pop("XDG_CACHE_HOME", None)
    else:
        os.environ["XDG_CACHE_HOME"] = before


@pytest.fixture(scope="session", autouse=True)
def user_cache(tmp_path_factory):
    """The tests' user cache folder, never the real one: a session's own, which module
    fixtures share; each test then gets one of its own (:func:`own_user_cache`)."""
    yield from _fresh_user_cache(tmp_path_factory)


@pytest.fixture(autouse=True)
def own_user_cache(tmp_path_factory):
    """Each test starts with an empty user cache, so that a reference is rendered unless the
    test itself cached it (subprocesses inherit the variable). Not through ``monkeypatch``:
    an autouse fixture that asked for it would undo a test's own patches only after the
    other autouse fixtures' teardown (restore_variant's, which must see the real libLLVM)."""
    yield from _fresh_user_cache(tmp_path_factory)


#: the test that runs after the one running now on this worker (None: the last one)
_following: dict = {}
#: the variant that the tests since the last restore found before them (:func:`restore_variant`)
_owed: list[str] = []


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_protocol(item, nextitem):
    _following["item"] = nextitem


def selected(item) -> str | None:
    """The variant that the test ``item`` selects through :func:`variant` or :func:`llvm`."""
    fixtures = getattr(item, "_fixtureinfo", None)
    for name, variant in (("variant", None), ("llvm", "llvm_ad_rgb")):
        definitions = fixtures.name2fixturedefs.get(name) if fixtures else None
        if definitions and definitions[-1].func.__module__ == __name__:
            return variant or item.callspec.params[name]
    return None


def sees_no_difference(item) -> bool:
    """Whether the test ``item`` sets up nothing that could see the variant before it selects
    its own: its fixtures of a wider scope are set up already (with its parameters), those of
    a test's scope are pytest's, its parameters or this file's (which ignore the variant)."""
    params = getattr(item, "callspec", None)
    params = params.params if params else {}
    for definitions in item._fixtureinfo.name2fixturedefs.values():
        definition = definitions[-1]
        if definition.scope == "function":
            if not getattr(definition.func, "__module__", "").startswith(("_pytest.", __name__)):
                return False
        elif definition.cached_result is None or \
                definition.cached_result[1] != params.get(definition.argname):
            return False
    return True


@pytest.fixture(autouse=True)
def restore_variant(request):
    """Every test leaves Mitsuba's variant as it found it, but where the next test, in the
    same file, selects the variant this one leaves and :func:`sees_no_difference`: that
    one then restores it, or the next. Switching to an llvm variant costs ~70 ms of CPU
    (Mitsuba re-imports its Python integrators), after every scalar_rgb test otherwise."""
    found = _owed.pop() if _owed else mi.variant()
    yield
    following = _following.get("item")
    if mi.variant() != found and following is not None and following.path == request.node.path \
            and selected(following) == mi.variant() and sees_no_difference(following):
        _owed.append(found)
    else:
        whitted.set_variant(found)


@pytest.fixture(params=VARIANTS)
def variant(request):
    """Runs the test once in each of :data:`VARIANTS`, with that variant selected."""
    whitted.set_variant(request.param)
    return request.param


@pytest.fixture
def llvm():
    """Runs the test in llvm_ad_rgb."""
    whitted.set_variant("llvm_ad_rgb")


@pytest.fixture
def write_scene(tmp_path):
    """``write_scene(text_or_bytes, name="scene.scn") -> Path``: a scene file in tmp_path."""
    def write(content: str | bytes, name: str = "scene.scn") -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, str):
            content = content.encode("utf-8")
        path.write_bytes(content)
        return path
    return write


@pytest.fixture
def texture_png(tmp_path):
    """``texture_png(name="tex.png", width=4, height=2) -> Path``: a small 8-bit RGB PNG.

    Texel (row r, column c) holds (40 c, 40 r, 200) so that tests can tell texels apart.
    """
    def make(name: str = "tex.png", width: int = 4, height: int = 2) -> Path:
        import mitsuba as mi
        import numpy as np
        rows, cols = np.mgrid[0:height, 0:width]
        pixels = np.stack([40 * cols, 40 * rows, np.full_like(rows, 200)], axis=-1).astype(np.uint8)
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
        return path
    return make


def without_report_pictures(patch: pytest.MonkeyPatch) -> None:
    """``whitted compare``'s plots and contact sheet left as empty files, through ``patch``,
    for the comparisons whose tests read neither: drawing them takes most of a small
    comparison's time. The pictures themselves are checked where they are drawn: test_compare.py's
    sweep (the contact sheet's thumbnails), test_compare_page.py's report (the page loads them)
    and test_compare_display.py's label test (the plot's figure)."""
    def empty(path, *args, **kwargs):
        Path(path).touch()
    patch.setattr("whitted.compare.report.plot_error_vs_time", empty)
    patch.setattr("whitted.compare.report.contact_sheet", empty)


def without_headline_rounds(patch: pytest.MonkeyPatch) -> None:
    """``whitted compare``'s timing rounds stopped after the rounds asked for, through ``patch``:
    no extra rounds of the headlines' renders, for the comparisons whose tests read no headline
    interval (those rounds are most of a small comparison's timing). The extra rounds themselves
    are checked in test_compare_timing.py."""
    from dask_worker_rounds import WITHOUT_HEADLINE_ROUNDS
    for name, value in WITHOUT_HEADLINE_ROUNDS.items():
        patch.setattr(f"whitted.compare.sweep.{name}", value)


def session_left(sid: int, seconds: float = 30.0) -> list[int]:
    """The processes still in session ``sid`` (a ``start_new_session`` child's pid) once
    they have all ended or ``seconds`` have passed: what a finished command left behind."""
    import time

    import psutil

    def left() -> list[int]:
        pids = []
        for process in psutil.process_iter():
            try:
                if os.getsid(process.pid) == sid:
                    pids.append(process.pid)
            except (ProcessLookupError, PermissionError):
                pass
        return pids
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and left():
        time.sleep(0.1)
    return left()


def aimed_rays(rng, centers, radius: float, impact: float, distance: float = 300.0):
    """``(origin, direction)``, float32 arrays (N, 3): a ray at each of the N ``centers``,
    from a random direction, ``distance`` radii away, passing the center at a random impact
    parameter below ``impact``·``radius`` (drawn from ``rng`` in that order)."""
    import numpy as np
    count = len(centers)
    toward = rng.normal(size=(count, 3))
    toward /= np.linalg.norm(toward, axis=1)[:, None]
    side = np.cross(toward, rng.normal(size=(count, 3)))
    side /= np.linalg.norm(side, axis=1)[:, None]
    b = rng.uniform(0.0, impact, count) * radius
    origin = (centers + side * b[:, None] - toward * distance * radius).astype(np.float32)
    return origin, toward.astype(np.float32)
