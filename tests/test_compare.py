"""``whitted compare``: the sweep's outputs, its error trends, the reference cache,
the time budget and bad input.

The scenes are tiny (32×24) and the ladders short so the whole file runs in
seconds. Expectations come from outside the code under test: the 1/spp variance
law of Monte Carlo estimators, the fact that each extra level of a physically lit
ray tree adds light the reference also has, and the formula of relative MSE.
"""

from __future__ import annotations

import csv
from collections import Counter
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import without_headline_rounds, without_report_pictures
from whitted import compare as cmp
from whitted import metrics
from whitted.cli import main

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# A mirror sphere facing a red, slightly glossy sphere: every extra depth adds a
# visible inter-reflection.
MIRROR_SCENE = """\
size 32 24
eye 0 0 6
fov 50
light 4 5 6
light -5 3 4 0.5 0.5 0.5
depth 3
sphere -0.9 0 0 0.8  color 0.9 0.9 0.9  reflect 0.8
sphere 0.9 0 0 0.8   color 0.9 0.2 0.2  reflect 0.3
"""

DIFFUSE_SCENE = """\
size 32 24
eye 0 0 6
light 3 4 5
background 0.1 0.1 0.2
sphere 0 0 0 1.2 color 0.3 0.8 0.3
"""

REFERENCE_SPP = 1024
DEPTHS = (1, 2, 3)
WHITTED_SPP = (1, 4)
PATH_SPP = (1, 4, 16, 64)
REQUIRED_COLUMNS = {"scene", "integrator", "lighting", "spp", "max_depth", "seconds",
                    "compile_seconds", "rel_mse", "flip"}


def read_rows(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def mirror_scene(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("scenes") / "mirror.scn"
    path.write_text(MIRROR_SCENE)
    return path


@pytest.fixture(scope="module")
def sweep(mirror_scene, tmp_path_factory):
    """One full (small) comparison of the mirror scene, shared by the tests below (none reads
    a headline's interval: no rounds beyond the two asked for)."""
    out = tmp_path_factory.mktemp("compare")
    options = cmp.Options(out=out, reference_spp=REFERENCE_SPP, depths=DEPTHS,
                          whitted_spp=WHITTED_SPP, path_spp=PATH_SPP, rounds=2,
                          cache=out / "references", quiet=True)
    with pytest.MonkeyPatch.context() as patch:
        without_headline_rounds(patch)
        entries = cmp.compare([mirror_scene], options)
    return out, entries


def by_method(rows: list[dict], method: str) -> list[dict]:
    return [r for r in rows if r["method"] == method]


# --------------------------------------------------------------------------- outputs


def test_csv_has_one_row_per_render_with_the_schema(sweep):
    out, entries = sweep
    rows = read_rows(out / "results.csv")
    assert REQUIRED_COLUMNS <= set(rows[0])
    assert len(rows) == 2 * len(DEPTHS) * len(WHITTED_SPP) + len(PATH_SPP)
    assert {r["method"] for r in rows} == {"whitted-article", "whitted-physical", "path"}
    for r in rows:
        assert r["scene"] == "mirror"
        assert r["integrator"] in ("whitted", "path")
        assert r["lighting"] in ("article", "physical")
        assert float(r["seconds"]) > 0 and float(r["compile_seconds"]) >= 0
        assert math.isfinite(float(r["rel_mse"])) and float(r["rel_mse"]) >= 0
        assert 0 <= float(r["flip"]) <= 1
        assert (int(r["width"]), int(r["height"])) == (32, 24)
    whitted_rows = [r for r in rows if r["integrator"] == "whitted"]
    assert {(r["lighting"], int(r["max_depth"]), int(r["spp"])) for r in whitted_rows} == {
        (lighting, d, s) for lighting in ("article", "physical") for d in DEPTHS for s in WHITTED_SPP}
    assert sorted(int(r["spp"]) for r in by_method(rows, "path")) == list(PATH_SPP)
    assert not entries[0].skipped


def test_path_tracer_error_falls_as_one_over_spp(sweep):
    rows = sorted(by_method(read_rows(sweep[0] / "results.csv"), "path"), key=lambda r: int(r["spp"]))
    errors = [float(r["rel_mse"]) for r in rows]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    # Variance of an N-sample estimate is σ²/N, and the reference adds its own σ²/1024:
    # from 1 to 64 spp the error shrinks by (1 + 1/1024) / (1/64 + 1/1024) ≈ 60.
    assert errors[0] / errors[-1] > 15, errors
    assert float(rows[-1]["flip"]) < float(rows[0]["flip"])


@pytest.mark.parametrize("spp", WHITTED_SPP)
def test_physical_whitted_error_does_not_grow_with_depth(sweep, spp):
    """Each level of a physically lit ray tree adds reflected light the reference has too."""
    rows = [r for r in by_method(read_rows(sweep[0] / "results.csv"), "whitted-physical")
            if int(r["spp"]) == spp]
    errors = [float(r["rel_mse"]) for r in sorted(rows, key=lambda r: int(r["max_depth"]))]
    assert errors[1] < 0.95 * errors[0], errors  # the mirror's first reflection matters
    assert all(b <= a * 1.001 for a, b in zip(errors, errors[1:])), errors


def _colors(pixels: np.ndarray) -> np.ndarray:
    """The distinct 8-bit RGB colors of an image, each as one integer."""
    rgb = np.asarray(pixels)[..., :3].astype(np.uint32).reshape(-1, 3)
    return np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])


def test_the_contact_sheet_shows_every_render(sweep):
    """Each render's thumbnail (and the reference's) is drawn on the sheet: nearly all of its
    colors, exact to the 8-bit level, are among the sheet's (thumbnails are drawn by nearest
    neighbor; a missing, blank or wrong image shows few of them)."""
    import mitsuba as mi
    out, entries = sweep
    for name in ("error_vs_time.png", "contact_sheet.png"):
        assert (out / name).read_bytes()[:8] == PNG_SIGNATURE
    sheet = _colors(np.array(mi.Bitmap(str(out / "contact_sheet.png"))))
    thumbnails = [e.reference_thumbnail for e in entries] + [m.thumbnail for e in entries
                                                             for m in e.measurements]
    assert len(thumbnails) == 1 + len(PATH_SPP) + 2 * len(DEPTHS) * len(WHITTED_SPP)
    for thumbnail in thumbnails:
        colors = _colors(thumbnail)
        assert np.isin(colors, sheet).mean() > 0.9, len(colors)
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no leftover temporaries


def test_reference_is_the_path_tracer_at_high_spp(sweep):
    """The cached reference is a linear image of the scene's size, brighter than black."""
    from whitted.images import read_image
    _, entries = sweep
    reference = read_image(entries[0].reference_file)
    assert reference.shape == (24, 32, 3) and np.all(np.isfinite(reference))
    assert reference.mean() > 0.01
    assert not entries[0].reference_cached


def test_quick_draws_the_defaults_floors_and_levels_from_the_same_renders(sweep, mirror_scene,
                                                                          tmp_path):
    """Under a budget that cuts nothing, --quick's rules change what is cut first and how long
    the timing takes, not what is measured: its reference, its renders' errors, its floors and
    its equal-quality levels are the default's (its times, and so its ratios, are its own)."""
    out, entries = sweep
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=DEPTHS,
                          whitted_spp=WHITTED_SPP, path_spp=PATH_SPP, rounds=2, budget=600.0,
                          quick=True, cache=tmp_path / "references", quiet=True)
    quick = cmp.compare([mirror_scene], options)
    assert not quick[0].skipped and quick[0].reference_enough
    assert quick[0].reference_spp == entries[0].reference_spp
    errors = [{m.setting: m.rel_mse for m in e.measurements} for e in (entries[0], quick[0])]
    assert errors[0] == errors[1]
    default, mine = (result.findings["scenes"]["mirror"] for result in (entries, quick))
    assert mine["levels"] == default["levels"]
    for method in ("whitted-article", "whitted-physical"):
        same = ("max_depth", "spp", "rel_mse")
        floors = [f["methods"][method]["floor"] for f in (default, mine)]
        assert {k: floors[1][k] for k in same} == {k: floors[0][k] for k in same}


# --------------------------------------------------------------------------- cache


def test_references_are_shared_between_runs_in_the_user_cache(mirror_scene, tmp_path, monkeypatch):
    """Without --cache, references live in the user's cache folder ($XDG_CACHE_HOME/whitted/
    references): a second run of the same scene into another folder renders none; a
    relative $XDG_CACHE_HOME is not a cache folder (the XDG specification), ~/.cache is."""
    without_report_pictures(monkeypatch)
    import os

    from whitted.defaults import user_cache_folder
    cache = Path(os.environ["XDG_CACHE_HOME"]) / "whitted" / "references"
    assert user_cache_folder() / "references" == cache
    options = dict(reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,), path_spp=(1,),
                   rounds=1, quiet=True)
    first = cmp.compare([mirror_scene], cmp.Options(out=tmp_path / "one", **options))
    assert not first[0].reference_cached and first[0].reference_file.parent == cache
    second = cmp.compare([mirror_scene], cmp.Options(out=tmp_path / "two", **options))
    assert second[0].reference_cached and second[0].reference_file == first[0].reference_file
    assert not (tmp_path / "two" / "references").exists()
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/folder")
    assert user_cache_folder() == Path.home() / ".cache" / "whitted"


def test_second_run_reuses_the_cached_reference(sweep, mirror_scene, tmp_path, monkeypatch):
    without_report_pictures(monkeypatch)
    out, first = sweep
    reference_file = first[0].reference_file
    stamp = reference_file.stat().st_mtime_ns
    import whitted.rendering as render_module
    calls = []
    real = render_module.render

    def counting(scene, **kwargs):
        calls.append(kwargs)
        return real(scene, **kwargs)

    monkeypatch.setattr(render_module, "render", counting)
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=(1,), rounds=1, cache=out / "references", quiet=True)
    entries = cmp.compare([mirror_scene], options)
    assert entries[0].reference_cached
    assert entries[0].reference_file == reference_file
    assert reference_file.stat().st_mtime_ns == stamp
    assert not [c for c in calls if c.get("integrator") == "path" and c.get("spp") == REFERENCE_SPP]
    sweep_calls = [c for c in calls if c.get("min_weight") is None]
    limit_calls = [c for c in calls if c.get("min_weight") == 0]
    # the sweep's three renders, each scored then timed in one round (repeated there when fast)
    settings = {tuple(sorted((k, v) for k, v in c.items() if k != "fresh_memory")) for c in sweep_calls}
    assert len(settings) == 3 and len(sweep_calls) >= 3 * 2
    # the article's model fitted to the reference (issue 33), scored as the limit is: one render
    # of the last halves' samples (twice a half's: more than any other article render)
    most = max(c["spp"] for c in limit_calls if c["lighting"] == "article")
    fitted = [c for c in limit_calls if c["lighting"] == "article" and c["spp"] == most]
    limit_calls = [c for c in limit_calls if c not in fitted]
    half = max(c["spp"] for c in limit_calls if c["lighting"] == "article")
    assert len(fitted) == 1 and most == 2 * half
    # each Whitted method's limit: two halves a pass (doubled until converged), at A = 0 and
    # A = 1 in the article's lighting
    passes = Counter((c["lighting"], c["ambient"]) for c in limit_calls)
    assert set(passes) == {("article", 0.0), ("article", 1.0), ("physical", None)}
    assert passes[("article", 0.0)] == passes[("article", 1.0)]
    assert all(n % 2 == 0 for n in passes.values())


def test_the_reference_stops_once_its_noise_is_small_beside_the_whitted_errors(mirror_scene,
                                                                               tmp_path):
    """Without --budget the reference is rendered at the power of two whose noise is
    COMPARE_REFERENCE_NOISE_SHARE of the smallest Whitted error it scores (its 1-spp render at
    the scene's depth, less that noise), at most --reference-spp."""
    import whitted.rendering as rendering
    from whitted.compare.scenes import plan_scene
    from whitted.compare.reference import ReferenceCache, reference_image
    from whitted.defaults import COMPARE_REFERENCE_NOISE_SHARE, COMPARE_REFERENCE_START_SPP
    from whitted.metrics import relative_mse

    scene = cmp.SceneFile.read(mirror_scene)
    loaded = scene.load()
    options = cmp.Options(out=tmp_path, reference_spp=1 << 16, depths=DEPTHS, quiet=True)
    entry, _ = plan_scene(scene, loaded, options, "llvm_ad_rgb")
    image = reference_image(scene, loaded, entry, ReferenceCache(tmp_path / "cache"), options)
    spp, noise = entry.reference_spp, entry.reference_noise
    assert entry.reference_enough and COMPARE_REFERENCE_START_SPP < spp < 1 << 16
    whitted = min(relative_mse(np.asarray(rendering.render(
        loaded, integrator="whitted", spp=1, max_depth=entry.path_depth, lighting=lighting).image),
        image) for lighting in ("article", "physical"))
    wanted = COMPARE_REFERENCE_NOISE_SHARE * (whitted - noise)
    # the rule's noise came from its first samples: within a factor 2 of the final one's
    assert noise < 2 * wanted and 2 * noise > wanted / 2


@pytest.mark.parametrize("affordable", [True, False])
def test_quick_renders_the_reference_its_noise_needs_when_its_budget_affords_it(
        mirror_scene, tmp_path, monkeypatch, affordable):
    """Under --quick's budget the reference stops by its noise as the default's does: the same
    spp, the same image bit for bit and the same cache entry; one the budget cannot afford is
    scaled down from what its noise needs, and says so."""
    from whitted.compare.scenes import plan_scene
    from whitted.compare.reference import ReferenceCache, reference_image

    scene = cmp.SceneFile.read(mirror_scene)
    loaded = scene.load()
    made, seconds = {}, 60.0
    for quick in (False, True):
        if quick and not affordable:   # a sample costs so much that all of it would take 2 budgets
            spp = made[False][0].reference_spp
            monkeypatch.setattr("whitted.compare.reference.fit_cost",
                                lambda points: (0.0, 2 * seconds / spp))
        options = cmp.Options(out=tmp_path, reference_spp=1 << 16, depths=DEPTHS, quiet=True,
                              quick=quick, budget=seconds if quick else None)
        entry, _ = plan_scene(scene, loaded, options, "llvm_ad_rgb")
        image = reference_image(scene, loaded, entry, ReferenceCache(tmp_path / f"cache-{quick}"),
                                options, seconds=seconds if quick else math.inf)
        made[quick] = entry, image
    (default, image), (quick, quick_image) = made[False], made[True]
    assert default.reference_enough and default.reference_spp < 1 << 16
    if affordable:
        assert quick.reference_enough and quick.reference_spp == default.reference_spp
        assert quick.reference_file.name == default.reference_file.name
        assert np.array_equal(quick_image, image)
    else:
        assert not quick.reference_enough and quick.reference_spp <= default.reference_spp // 2
        assert f"from {default.reference_spp} to {quick.reference_spp} spp" in quick.notes[0]


def test_cache_key_follows_scene_content_and_settings(mirror_scene, tmp_path):
    settings = {"spp": 64, "width": 32, "height": 24}
    copy = tmp_path / "copy.scn"
    copy.write_text(MIRROR_SCENE)

    def key(path, settings):
        return cmp.ReferenceCache.key(cmp.SceneFile.read(path), settings)

    assert key(copy, settings) == key(mirror_scene, settings)  # content, not location
    assert key(mirror_scene, {**settings, "spp": 128}) != key(mirror_scene, settings)
    copy.write_text(MIRROR_SCENE.replace("light 4 5 6", "light 4 5 7"))
    assert key(copy, settings) != key(mirror_scene, settings)


def test_damaged_cache_entry_is_rendered_again(tmp_path):
    cache = cmp.ReferenceCache(tmp_path)
    image = np.full((24, 32, 3), 0.5, np.float32)
    cache.store("scene", "k" * 64, image, {"seconds": 1.0})
    loaded, info = cache.load("scene", "k" * 64, (24, 32))
    np.testing.assert_array_equal(loaded, image)
    exr, description = cache.entry("scene", "k" * 64)
    exr.write_bytes(exr.read_bytes()[:100])  # an image cut short
    assert cache.load("scene", "k" * 64, (24, 32)) is None
    cache.store("scene", "k" * 64, image, {"seconds": 1.0})
    description.write_text('{"key": "another"}')  # a description of something else
    assert cache.load("scene", "k" * 64, (24, 32)) is None
    cache.store("scene", "k" * 64, image, {"seconds": 1.0})
    assert cache.load("scene", "k" * 64, (48, 64)) is None


def test_interrupted_store_leaves_no_usable_entry(tmp_path, monkeypatch):
    """Interrupted between the image and its description: the entry is not trusted."""
    import whitted.atomic
    cache = cmp.ReferenceCache(tmp_path)
    image = np.full((24, 32, 3), 0.5, np.float32)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(whitted.atomic, "write_text", interrupted)
    with pytest.raises(KeyboardInterrupt):
        cache.store("scene", "k" * 64, image, {"seconds": 1.0})
    monkeypatch.undo()
    assert cache.load("scene", "k" * 64, (24, 32)) is None
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_interrupted_sweep_writes_what_was_done(sweep, mirror_scene, tmp_path, monkeypatch):
    import whitted.rendering as render_module
    out, _ = sweep
    real, calls = render_module.render, []

    def interrupted_on_the_third(scene, **kwargs):
        calls.append(kwargs)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(scene, **kwargs)

    monkeypatch.setattr(render_module, "render", interrupted_on_the_third)
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=DEPTHS,
                          whitted_spp=WHITTED_SPP, path_spp=PATH_SPP, rounds=1,
                          cache=out / "references", quiet=True)
    with pytest.raises(KeyboardInterrupt):
        cmp.compare([mirror_scene], options)
    assert len(read_rows(tmp_path / "results.csv")) == 2
    for name in ("error_vs_time.png", "contact_sheet.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG_SIGNATURE
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_each_scene_file_is_read_once_per_run(sweep, mirror_scene, tmp_path, monkeypatch):
    """Planning, loading, the cache key and the sweep share one reading of the scene."""
    without_report_pictures(monkeypatch)
    import builtins
    import io

    out, _ = sweep
    opened = []
    real_open, real_io_open = builtins.open, io.open

    def counting(open_function):
        def counted(file, *args, **kwargs):
            if isinstance(file, (str, Path)) and Path(file).resolve() == mirror_scene.resolve():
                opened.append(file)
            return open_function(file, *args, **kwargs)
        return counted

    monkeypatch.setattr(builtins, "open", counting(real_open))
    monkeypatch.setattr(io, "open", counting(real_io_open))  # pathlib reads through io.open
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=(1,), rounds=1, cache=out / "references", quiet=True)
    entries = cmp.compare([mirror_scene], options)
    assert entries[0].reference_cached and len(entries[0].measurements) == 3
    assert len(opened) == 1


def test_one_scene_sweeps_from_plain_data_alone(sweep, mirror_scene, tmp_path, monkeypatch):
    """What a worker process gets: everything pickles, no mi.Scene is handed over, and the
    result comes back as plain data, measured as the whole command measures it."""
    without_report_pictures(monkeypatch)
    import pickle

    out, _ = sweep
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1, 2), whitted_spp=(1,),
                          path_spp=(1, 4), rounds=1, cache=out / "references", quiet=True)
    scene = cmp.SceneFile.read(mirror_scene, "mirror")
    import mitsuba as mi
    entry, settings = cmp.plan_scene(scene, scene.load(), options, mi.variant())
    work = pickle.dumps((scene, entry, settings, options))
    result = cmp.sweep_scene(*pickle.loads(work))
    result = pickle.loads(pickle.dumps(result))
    assert result.reference_cached and not result.skipped
    assert [m.setting for m in result.measurements] == settings
    whole = cmp.compare([mirror_scene], options)[0]
    for alone, together in zip(result.measurements, whole.measurements):
        assert alone.setting == together.setting
        assert alone.rel_mse == pytest.approx(together.rel_mse, rel=1e-6)  # same seed, same image
        assert alone.thumbnail.shape == together.thumbnail.shape


# --------------------------------------------------------------------------- budget


def test_exhausted_budget_skips_every_render_but_still_writes_outputs(sweep, mirror_scene,
                                                                       tmp_path, capsys):
    out, _ = sweep
    target = tmp_path / "out"
    status = main(["compare", str(mirror_scene), "--out", str(target), "--cache", str(target / "references"), "--budget", "1e-9",
                   "--reference-spp", str(REFERENCE_SPP), "--depths", "1-3", "--spp", "1",
                   "--path-spp", "1,4", "--rounds", "1", "--cache", str(out / "references"), "-q"])
    assert status == 0
    assert read_rows(target / "results.csv") == []
    for name in ("error_vs_time.png", "contact_sheet.png"):
        assert (target / name).read_bytes()[:8] == PNG_SIGNATURE
    assert "skipped 8 of 8 renders" in capsys.readouterr().out


def test_budget_bounds_the_sweep(sweep, mirror_scene, tmp_path):
    """A ladder far too long for the budget: the cheap end is done, the rest skipped, in time."""
    out, _ = sweep
    budget = 3.0
    ladder = tuple(4 ** k for k in range(10))  # up to 262144 spp: minutes if all were done
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=ladder, rounds=1, budget=budget, cache=out / "references",
                          quiet=True)
    start = time.monotonic()
    entries = cmp.compare([mirror_scene], options)
    elapsed = time.monotonic() - start
    done = {m.setting.spp for m in entries[0].measurements if m.setting.integrator == "path"}
    assert 1 in done and ladder[-1] not in done
    assert {s.spp for s in entries[0].skipped} >= {ladder[-1]}
    # the plotting after the sweep and one misjudged render; all of the ladder would take minutes.
    # (The margin is for a loaded 2-core machine: 9–11 s were measured at load 10, old code and new.)
    assert elapsed < budget + 10.0
    assert len(read_rows(tmp_path / "results.csv")) == len(entries[0].measurements)


def test_no_reference_is_rendered_once_the_budget_is_spent(tmp_path, monkeypatch, capsys):
    """Budget gone (here: by the time the scenes are loaded): uncached references are not rendered."""
    import whitted.rendering as render_module
    scene = tmp_path / "diffuse.scn"
    scene.write_text(DIFFUSE_SCENE)
    calls = []
    monkeypatch.setattr(render_module, "render", lambda *a, **k: calls.append(k))
    target = tmp_path / "out"
    status = main(["compare", str(scene), "--out", str(target), "--cache", str(target / "references"), "--budget", "1e-9", "--depths", "1",
                   "--spp", "1", "--path-spp", "1", "-q"])
    assert status == 0 and calls == []
    assert read_rows(target / "results.csv") == []
    assert (target / "contact_sheet.png").read_bytes()[:8] == PNG_SIGNATURE
    references = target / "references"
    assert not references.exists() or not any(references.iterdir())
    captured = capsys.readouterr()
    assert "no time was left" in captured.err and "skipped 3 of 3 renders" in captured.out
    # not "the outputs hold the renders that were done" beside "no render was done"
    assert "renders that were done" not in captured.out and "nothing was rendered" in captured.out


def test_budget_scales_an_unaffordable_reference_down_and_says_so(mirror_scene, tmp_path, capsys):
    """A reference asked at 4M spp (an hour or more even at 32×24) under a 6 s budget: a probe
    measures its cost, a power of two that fits is rendered, and the run ends on time with
    renders done; the summary, stderr and the page say what happened."""
    budget, asked = 6.0, 1 << 22
    start = time.monotonic()
    status = main(["compare", str(mirror_scene), "--out", str(tmp_path), "--budget", str(budget),
                   "--reference-spp", str(asked), "--depths", "1,2", "--spp", "1", "--path-spp",
                   "1,4,16", "--rounds", "1", "-q"])
    elapsed = time.monotonic() - start
    assert status == 0
    # loading Mitsuba and one misjudged render (the margin for a loaded 2-core machine); the whole
    # reference would take an hour
    assert elapsed < budget + 10.0
    (info,) = [line for line in capsys.readouterr().err.splitlines() if "scaled down" in line]
    assert f"from {asked} to " in info and "--budget 6 s" in info
    rows = read_rows(tmp_path / "results.csv")
    assert rows  # the sweep got the time the reference left
    spp = int(rows[0]["reference_spp"])
    assert 8 <= spp < asked and spp & (spp - 1) == 0  # a power of two
    assert f"scaled down from {asked} to {spp} spp" in (tmp_path / "report.html").read_text(encoding="utf-8")


def test_budget_refuses_a_reference_it_cannot_afford_and_says_why(mirror_scene, tmp_path,
                                                                    monkeypatch, capsys):
    """When not even the fewest spp of a usable reference fit (here: probes that find a
    sample costs 100 s), the scene is skipped with the reason, not left to overrun."""
    import whitted.compare.reference as reference_module
    monkeypatch.setattr(reference_module, "fit_cost", lambda points: (0.0, 100.0))
    status = main(["compare", str(mirror_scene), "--out", str(tmp_path), "--budget", "10",
                   "--depths", "1", "--spp", "1", "--path-spp", "1", "--rounds", "1", "-q"])
    assert status == 0
    err = capsys.readouterr().err
    assert "raise --budget or lower --reference-spp" in err and "no render was done" in err
    assert read_rows(tmp_path / "results.csv") == []
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "raise --budget or lower --reference-spp" in page


# --------------------------------------------------------------------------- several scenes, CLI


def test_folder_of_scenes_through_the_cli(tmp_path, capsys, monkeypatch):
    without_report_pictures(monkeypatch)
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "mirror.scn").write_text(MIRROR_SCENE)
    (folder / "diffuse.scn").write_text(DIFFUSE_SCENE)
    target = tmp_path / "out"
    status = main(["compare", str(folder), "--out", str(target), "--cache", str(target / "references"), "--reference-spp", "64",
                   "--depths", "1,2", "--spp", "1", "--path-spp", "1,4", "--rounds", "1",
                   "--levels", "1,0.1", "-q"])
    assert status == 0
    rows = read_rows(target / "results.csv")
    assert {r["scene"] for r in rows} == {"mirror", "diffuse"}
    assert len(rows) == 2 * (2 * 2 + 2)
    printed = capsys.readouterr().out
    assert "mirror" in printed and "diffuse" in printed and "rel_mse ≤" in printed
    assert len(list((target / "references").glob("*.exr"))) == 2


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("arguments, message", [
    (["missing.scn"], "missing.scn: no such file or folder"),
    (["bad.scn"], "bad.scn:2:"),
    (["empty"], "empty: no .scn or .xml files in this folder"),
    (["notes.txt"], "notes.txt: not a scene"),
])
def test_bad_input_is_one_clean_error_and_no_output(tmp_path, capsys, monkeypatch, arguments, message):
    monkeypatch.chdir(tmp_path)
    Path("bad.scn").write_text("size 32 24\nsphere 0 0 0 -1\n")
    Path("empty").mkdir()
    Path("notes.txt").write_text("hello")
    status = main(["compare", *arguments, "--out", "out", "-q"])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and "Traceback" not in err
    assert err.startswith("whitted: error:")
    assert not Path("out").exists()


@pytest.mark.parametrize("option", [["--spp", "0"], ["--depths", "3-1"], ["--levels", "-1"],
                                    ["--spp", "x"]])
def test_bad_options_are_rejected(tmp_path, option, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["compare", "scene.scn", "--out", str(tmp_path / "out"), *option])
    assert exit_info.value.code == 2
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("option, message", [
    (["--depths", "1-65"], "--depths"), (["--path-depth", "0"], "--path-depth"),
    (["--rounds", "0"], "--rounds"), (["--budget", "0"], "--budget"),
    (["--cache", "taken.txt"], "taken.txt: the reference cache exists and is not a folder"),
])
def test_bad_settings_are_one_clean_error_and_no_output(mirror_scene, tmp_path, monkeypatch, capsys,
                                                          option, message):
    monkeypatch.chdir(tmp_path)
    Path("taken.txt").write_text("mine")
    assert main(["compare", str(mirror_scene), "--out", "out", "-q", *option]) == 2
    err = capsys.readouterr().err
    assert err.startswith("whitted: error:") and message in err
    assert not Path("out").exists()


def test_output_that_is_a_file_is_refused(mirror_scene, tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("mine")
    assert main(["compare", str(mirror_scene), "--out", str(target), "--cache", str(target / "references"), "-q"]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert target.read_text() == "mine"


# --------------------------------------------------------------------------- pieces


def test_relative_mse_is_the_documented_formula():
    rng = np.random.default_rng(3)
    b = rng.random((5, 7, 3))
    a = b + rng.normal(0, 0.1, b.shape)
    expected = sum((a.flat[i] - b.flat[i]) ** 2 / (b.flat[i] ** 2 + 0.01) for i in range(b.size)) / b.size
    assert metrics.relative_mse(a, b) == pytest.approx(expected, rel=1e-12)
    assert metrics.relative_mse(b, b) == 0


def test_durations_read_as_their_docstring_says():
    """The plots' axes, the page and the budget's notes write times through seconds_text."""
    from whitted.compare.results import seconds_text
    assert [seconds_text(s) for s in (0.0123, 1.25, 250.0, 12060.0, math.inf)] == [
        "12.3 ms", "1.25 s", "4 min 10 s", "3 h 21 min", "time unknown"]


def test_flip_is_zero_for_equal_images_and_grows_with_the_difference():
    rng = np.random.default_rng(4)
    image = rng.random((24, 32, 3)).astype(np.float32) * 0.25
    assert metrics.flip(image, image) == 0
    assert 0 < metrics.flip(image * 1.5, image) < metrics.flip(image * 4, image) <= 1
    black = np.zeros_like(image)
    assert metrics.flip(black, black) == 0
    assert 0 < metrics.flip(image, black) <= 1


def test_flip_judges_the_displayed_srgb_images():
    """FLIP of linear images equals LDR-FLIP of their sRGB encodings (Mitsuba's), clipped."""
    import flip_evaluator
    import mitsuba as mi

    def srgb(x):
        bitmap = mi.Bitmap(np.ascontiguousarray(np.clip(x, 0, 1), dtype=np.float32))
        return np.array(bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32,
                                       srgb_gamma=True))

    rng = np.random.default_rng(5)
    reference = rng.random((24, 32, 3)).astype(np.float32) * 1.5  # some values above 1
    image = np.clip(reference + rng.normal(0, 0.1, reference.shape), 0, None).astype(np.float32)
    _, expected, _ = flip_evaluator.evaluate(srgb(reference), srgb(image), "LDR", inputsRGB=True,
                                             applyMagma=False)
    assert metrics.flip(image, reference) == pytest.approx(expected, abs=1e-5)


def test_lists_of_the_command_line():
    assert cmp.int_list("1-3,8") == (1, 2, 3, 8)
    assert cmp.int_list("16,1,4,4") == (1, 4, 16)
    assert cmp.float_list("0.01,0.1") == (0.1, 0.01)
    assert len(cmp.int_list("1-1000")) == 1000


@pytest.mark.parametrize("text", ["1-2000000", "1-600,601-1200"])
def test_a_list_of_too_many_values_is_refused(text):
    """A range of millions of renders is a typo: refused at once (1-99999999999 was a
    MemoryError traceback after seconds of filling the memory)."""
    import argparse
    with pytest.raises(argparse.ArgumentTypeError, match="a list holds at most 1000 values"):
        cmp.int_list(text)


def test_plan_puts_cheap_renders_of_every_method_first():
    settings = cmp.plan((1, 2), (1, 4), (1, 4, 16), 5)
    assert len(settings) == 2 * 2 * 2 + 3
    first = settings[:5]
    assert {s.method for s in first} == {"whitted-article", "whitted-physical", "path"}
    assert [s.spp for s in settings] == sorted(s.spp for s in settings)


def test_quick_renders_what_its_verdict_needs_first():
    """Under --quick a budget cuts last what the verdict needs: the Whitted ladder's cheapest
    renders (the floors' candidates), the path renders its curve is fitted to and checked by
    (every headline is read on it), then each Whitted method's deepest, densest render (its
    best error); without --quick the order is the default's."""
    from whitted.defaults import COMPARE_PATH_FIT_COUNTS
    ladder = (1, 4, 16, 64, 256, 1024)
    settings = cmp.plan((1, 2), (1, 4, 16), ladder, 5, quick=True)
    default = cmp.plan((1, 2), (1, 4, 16), ladder, 5)
    assert sorted(settings, key=str) == sorted(default, key=str) and settings != default
    assert [(s.integrator, s.spp, s.max_depth) for s in settings[:10]] == [
        ("whitted", 1, 1)] * 2 + [("whitted", 1, 2)] * 2 + [
        ("path", n, 5) for n in ladder[:COMPARE_PATH_FIT_COUNTS + 1]] + [("whitted", 16, 2)] * 2
    rest = settings[10:]
    assert [s.spp for s in rest] == [4] * 4 + [16] * 2 + [256, 1024]
    assert {s.method for s in settings[8:10]} == {"whitted-article", "whitted-physical"}


def test_a_floor_among_renders_of_equal_work_does_not_follow_the_clock():
    """A deeper tree that finds nothing more to trace draws the same image with the same work:
    the floor is the shallower one, however the timing rounds fell."""
    from whitted.compare.analysis import analyse
    from whitted.compare.results import Measurement, SceneResult, Setting

    entry = SceneResult("s", Path("s.scn"), 32, 24, "llvm_ad_rgb", 256, 5)
    for depth, seconds in ((1, 0.02), (2, 0.031), (3, 0.030), (4, 0.029)):
        error, work = (0.2, 100) if depth == 1 else (0.1, 150)
        entry.measurements.append(Measurement(Setting("whitted", "physical", 4, depth), seconds,
                                              0.0, error, 0.1, work, times=(seconds,)))
    floor, = [f for f in analyse(entry).floors if f.method == "whitted-physical"]
    assert (floor.render.setting.max_depth, floor.render.seconds) == (2, 0.031)


def test_pareto_front_keeps_only_unbeaten_points():
    from whitted.compare.curves import pareto_front
    points = [(1.0, 0.5), (2.0, 0.6), (3.0, 0.2), (0.5, 0.9), (4.0, 0.2)]
    assert pareto_front(points) == [(0.5, 0.9), (1.0, 0.5), (3.0, 0.2)]


# --------------------------------------------------------------------------- timing


def _fake_render(times: list[float], calls: list):
    """A stand-in for whitted.rendering.render whose renders take ``times`` in turn."""
    from whitted.rendering import RenderResult

    def render(scene, **kwargs):
        calls.append(kwargs)
        return RenderResult(np.zeros((24, 32, 3), np.float32), times[len(calls) - 1], 0.0, {})
    return render


def test_progress_estimate_comes_from_the_renders_not_the_reference(sweep, mirror_scene, tmp_path,
                                                                     monkeypatch):
    """A reference that takes 100 s (on a fake clock) and renders of 1 s each: the bar's
    elapsed time, and so its rate and estimate of the time left, counts the renders only."""
    import io

    import mitsuba as mi
    import tqdm.std

    import whitted.compare.sweep as sweep_module

    class Clock:
        now = 1000.0

        def __call__(self):
            return self.now

    clock = Clock()
    monkeypatch.setattr(tqdm.std, "time", clock)
    real_reference, real_measure = sweep_module.reference_image, sweep_module.measure

    def slow_reference(*args, **kwargs):
        clock.now += 100.0
        return real_reference(*args, **kwargs)

    def timed_measure(*args, **kwargs):
        clock.now += 1.0
        return real_measure(*args, **kwargs)

    monkeypatch.setattr(sweep_module, "reference_image", slow_reference)
    monkeypatch.setattr(sweep_module, "measure", timed_measure)
    out, _ = sweep
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=(1, 4), rounds=1, cache=out / "references", quiet=True)
    scene = cmp.SceneFile.read(mirror_scene, "mirror")
    entry, settings = cmp.plan_scene(scene, scene.load(), options, mi.variant())
    from whitted.compare.scenes import progress_units
    bar = tqdm.std.tqdm(total=progress_units(settings), file=io.StringIO(), mininterval=0, miniters=1)
    cmp.sweep_scene(scene, entry, settings, options, progress=bar)
    assert bar.n == bar.total == len(settings) + 2  # the renders and the two limits
    assert bar.format_dict["elapsed"] == pytest.approx(len(settings) * 1.0)  # not 100 s more
    bar.close()


def test_a_budgeted_run_ends_within_its_budget_and_says_what_it_cut(mirror_scene, tmp_path):
    """--budget bounds the whole command, the report included, and every output names the cuts."""
    import html
    import json
    budget, out = 12.0, tmp_path / "out"
    start = time.monotonic()
    status = main(["compare", str(mirror_scene), "--out", str(out),
                   "--cache", str(tmp_path / "refs"), "--budget", str(budget),
                   "--reference-spp", str(1 << 22), "-q",
                   "--path-spp", ",".join(str(4 ** k) for k in range(9))])
    elapsed = time.monotonic() - start
    # unbounded, its reference alone takes an hour, so the budget cuts on any machine; the margin is a loaded 2-core machine's, where the
    # report's plots alone can take tens of seconds (the wall-time target itself is measured,
    # not asserted: docs/compare.md, Budget)
    assert status == 0 and elapsed < budget + 60.0
    notes = json.loads((out / "findings.json").read_text())["scenes"]["mirror"]["notes"]
    assert any("--budget" in note for note in notes)
    summary = (out / "summary.txt").read_text()
    assert all(note in summary for note in notes)
    page = html.unescape(" ".join((out / "report.html").read_text().split()))
    assert all(note in page for note in notes)


@pytest.mark.parametrize("given, wins", [
    ([], {}), (["--budget", "60", "--spp", "2", "--depths", "3"],
               {"budget": 60.0, "whitted_spp": (2,), "depths": (3,)})])
def test_quick_sets_what_the_docs_say_and_options_beside_it_win(mirror_scene, tmp_path,
                                                                 monkeypatch, given, wins):
    from whitted.compare.cli import quick_text
    from whitted.errors import WhittedError
    seen = []

    def fake_compare(scenes, options):
        seen.append(options)
        raise WhittedError("enough")
    monkeypatch.setattr("whitted.compare.run.compare", fake_compare)
    assert main(["compare", str(mirror_scene), "--out", str(tmp_path), "--quick", *given]) == 2
    # the default's depths (None: the scene's) and Whitted ladder: its floors are the default's
    # the default's reference (as many spp as its noise needs, within the budget)
    from whitted.defaults import COMPARE_PATH_SPP, COMPARE_REFERENCE_SPP
    expected = {"reference_spp": COMPARE_REFERENCE_SPP, "depths": None, "whitted_spp": (1, 4, 16),
                "path_spp": COMPARE_PATH_SPP, "rounds": 2, "budget": 25.0, "quick": True, **wins}
    assert {name: getattr(seen[0], name) for name in expected} == expected
    docs = " ".join((Path(__file__).parents[1] / "docs" / "compare.md").read_text().split())
    assert f"`--quick` stands for `{quick_text()}`" in docs


def test_a_limit_past_the_deadline_is_not_rendered_and_the_notes_say_so(tmp_path):
    """A Whitted method whose limit would overrun the scene's share of --budget gets none,
    and the scene's notes (which every report prints) say that it was cut."""
    from tqdm import tqdm
    from whitted.compare.limits import render_limits
    from whitted.compare.results import Measurement, SceneResult, Setting
    from whitted.images import write_image
    entry = SceneResult("cut", None, 4, 3, "llvm_ad_rgb", 16, 2)
    image = np.full((3, 4, 3), 0.5, np.float32)
    measured = Measurement(Setting("whitted", "physical", 1, 2), 0.01, 0.0, 0.1, 0.1,
                           image=f"{entry.folder}/d2-1spp.exr", render_seconds=0.01)
    (tmp_path / entry.folder).mkdir(parents=True)
    write_image(tmp_path / measured.image, image)
    entry.measurements.append(measured)
    with tqdm(disable=True) as progress:
        render_limits(None, entry, [measured.setting], image, tmp_path, time.monotonic(), progress)
    assert entry.limits == {}
    assert entry.notes == ["whitted-physical: its limit was not rendered: it would have overrun "
                           "the scene's share of --budget"]


def test_a_scene_whose_every_render_would_overrun_says_none_fitted(sweep, mirror_scene, tmp_path,
                                                                    monkeypatch):
    """Each render predicted to take an hour, past the scene's share of --budget: the
    reference is read, nothing is rendered, and the scene's notes say why."""
    from whitted.compare.budget import Budget
    out, _ = sweep
    monkeypatch.setattr(Budget, "predict", staticmethod(lambda setting, done: (3600.0, 0.0)))
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=(1,), rounds=1, budget=60.0, cache=out / "references", quiet=True)
    (entry,) = cmp.compare([mirror_scene], options)
    assert entry.measurements == [] and len(entry.skipped) == 3
    (note,) = [note for note in entry.notes if note.startswith("no render fitted")]
    took = "was read from the cache" if entry.reference_cached else f"took {entry.reference_seconds:.1f} s"
    match = re.fullmatch(r"no render fitted in the time left of the scene's ([\d.]+) s share after "
                         r"its reference \((.*)\)", note)
    assert match and 0 < float(match[1]) <= 60.0 and match[2] == took


#: No light and a black background: the path tracer draws black, so does the article's model
#: with ambient 0.
BLACK_SCENE = """\
size 16 12
ambient 0
sphere 0 0 0 1 color 0.9 0.2 0.2
"""


def test_a_black_reference_says_there_is_nothing_to_compare(tmp_path, monkeypatch):
    """Every relative MSE against a black reference is 0 or measures only brightness: the
    verdict says so in words, not "error 0; the path tracer never got as close (its best: 0)"."""
    import json
    scene = tmp_path / "black.scn"
    scene.write_text(BLACK_SCENE)
    without_report_pictures(monkeypatch)
    without_headline_rounds(monkeypatch)
    out = tmp_path / "out"
    options = cmp.Options(out=out, reference_spp=64, depths=(1, 2), whitted_spp=(1,),
                          path_spp=(1, 4), rounds=1, cache=tmp_path / "references", quiet=True)
    (entry,) = cmp.compare([scene], options)
    assert entry.limits == {}   # nor the limits and the fit, which no sentence reads there
    said = "The reference is black everywhere"
    summary = (out / "summary.txt").read_text(encoding="utf-8")
    assert said in summary
    for nonsense in ("never got as close", "instead of 0", "stops improving at 0 ", "no path render"):
        assert nonsense not in summary
    found = json.loads((out / "findings.json").read_text(encoding="utf-8"))["scenes"]["black"]
    assert found["reference_black"] is True and found["methods"] == {} and found["levels"] == []
    page = (out / "report.html").read_text(encoding="utf-8")
    verdict = re.search(r'<p class="verdict">(.*?)</p>', page, re.S)[1]
    assert said in verdict and "no error floor" not in page.lower().replace("\n", " ")


def test_a_stop_while_the_outputs_are_written_still_writes_them_all(sweep, mirror_scene, tmp_path,
                                                                   monkeypatch):
    """Ctrl-C after the last render, while the report is drawn, left results.csv and the plot
    but no summary.txt, findings.json or report.html, and said only "whitted: interrupted":
    the outputs are written whole, marked as a stopped run's, as for a stop during the sweep."""
    import whitted.compare.report as report
    from whitted import interrupt
    out, _ = sweep
    real, calls = report.contact_sheet, []

    def stopped_the_first_time(*args, **kwargs):
        calls.append(args)
        if len(calls) == 1:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(report, "contact_sheet", stopped_the_first_time)
    monkeypatch.setattr(interrupt, "_outcome", None)
    without_headline_rounds(monkeypatch)
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=(1,), whitted_spp=(1,),
                          path_spp=(1, 4), rounds=1, cache=out / "references", quiet=True)
    with pytest.raises(KeyboardInterrupt):
        cmp.compare([mirror_scene], options)
    rows = read_rows(tmp_path / "results.csv")
    marker = f"Interrupted after {len(rows)} of {len(rows)} renders"
    assert (tmp_path / "summary.txt").read_text(encoding="utf-8").startswith(marker)
    assert marker in (tmp_path / "report.html").read_text(encoding="utf-8")
    assert (tmp_path / "findings.json").exists()
    assert interrupt.message().endswith(f"the outputs in {tmp_path} hold what was done "
                                        f"({len(rows)} of {len(rows)} renders)")


def test_a_best_ambient_that_is_the_scenes_own_is_not_said_to_be_instead_of_it():
    """mirrors.scn under --quick in a folder: "the best ambient (0.15 instead of 0.15) brings it
    to 0.0558", the limit's own error: a change that is none, said as one."""
    from whitted.compare.analysis import Decomposition, decomposition_text
    from whitted.compare.curves import Floor
    from whitted.compare.results import Limit, Measurement, Setting
    render = Measurement(Setting("whitted", "article", 1, 3), 0.0155, 0.0, 0.0581, 0.1)
    limit = Limit("whitted-article", 4, 8, 0.0001, True, 0.05581, 0.5, ambient=0.15,
                  best_ambient=0.1512, rel_mse_at_best_ambient=0.05579)
    text = decomposition_text(Decomposition("whitted-article", Floor(render, 0.0155, 0.0581, 0.0575,
                                                                    True), limit, None))
    assert "instead of" not in text
    assert "the best ambient (0.15, the scene's own) brings it to 0.0558" in text
    moved = decomposition_text(Decomposition("whitted-article", Floor(render, 0.0155, 0.0581, 0.0575,
                                                                     True),
                                             Limit("whitted-article", 4, 8, 0.0001, True, 0.05581,
                                                   0.5, ambient=0.15, best_ambient=0.3,
                                                   rel_mse_at_best_ambient=0.04), None))
    assert "the best ambient (0.3 instead of 0.15) brings it to 0.04" in moved


def test_a_floor_whose_deepest_densest_render_was_skipped_is_not_called_as_good_as_it_gets(
        sweep, mirror_scene, tmp_path, monkeypatch):
    """scenes/mirrors.scn under --quick on a busy machine: --budget skipped each Whitted method's
    d8 · 16 spp (its best error, which the floor is within 5% of), and the verdict still said
    "The article's model is as good as it gets at d3 · 1 spp" (the default's floor: d4 · 1 spp).
    A floor without that render is the best of the renders done, and says so."""
    import json
    from whitted.compare.budget import Budget
    out, _ = sweep
    real = Budget.predict

    def deepest_densest_overruns(setting, done):
        if setting.integrator == "whitted" and (setting.max_depth, setting.spp) == (3, 4):
            return 3600.0, 0.0
        return real(setting, done)

    monkeypatch.setattr(Budget, "predict", staticmethod(deepest_densest_overruns))
    without_headline_rounds(monkeypatch)
    options = cmp.Options(out=tmp_path, reference_spp=REFERENCE_SPP, depths=DEPTHS,
                          whitted_spp=WHITTED_SPP, path_spp=(1, 4), rounds=1, budget=600.0,
                          cache=out / "references", quiet=True)
    (entry,) = cmp.compare([mirror_scene], options)
    assert {(s.max_depth, s.spp) for s in entry.skipped} == {(3, 4)}
    summary = (tmp_path / "summary.txt").read_text(encoding="utf-8")
    assert "as good as it gets" not in summary and "stops improving" not in summary
    assert summary.count("its deepest, densest render (d3 · 4 spp) was skipped") == 4  # 2 verdicts, 2 floors
    found = json.loads((tmp_path / "findings.json").read_text(encoding="utf-8"))
    for method in ("whitted-article", "whitted-physical"):
        assert found["scenes"]["mirror"]["methods"][method]["floor"]["settled"] is False


def test_a_path_tracer_no_measurably_faster_is_not_said_to_be_faster_there():
    """The verdict said "the path tracer is as accurate already from about 1.69 ms on: faster
    there" whenever its median time was under the floor's, while the floor's sentence, from
    the paired interval (0.86–1.14×), said "no measurable difference in time"."""
    from whitted.compare.analysis import FloorStatement, floor_text
    from whitted.compare.curves import Floor, Reading
    from whitted.compare.report import template
    from whitted.compare.results import Measurement, Setting
    from whitted.compare.timing import Interval
    render = Measurement(Setting("whitted", "article", 16, 1), 0.00171, 0.0, 0.0109, 0.03)
    low, high = (Measurement(Setting("path", "physical", n, 5), t, 0.0, e, 0.05)
                 for n, t, e in ((4, 0.0015, 0.02), (16, 0.0029, 0.005)))
    statement = FloorStatement("whitted-article", Floor(render, 0.00171, 0.0109, 0.0109, True),
                               Reading(0.00169, "interpolated", (low, high)), high,
                               Interval(0.99, 0.86, 1.14, 10, 0.05))
    words = template("words.txt.j2").module
    assert "no measurable difference" in floor_text(statement, 1e-5, 0.05)
    verdict = str(words.verdict(statement))
    assert "faster there" not in verdict
    assert "from about 1.69 ms on, the path tracer is more accurate" in verdict
    faster = FloorStatement(statement.method, statement.floor, statement.path, high,
                            Interval(0.7, 0.6, 0.8, 10, 0.05))
    assert "faster there" in str(words.verdict(faster))


def test_a_portable_scene_is_refused_with_advice_compare_can_follow(mirror_scene, tmp_path, capsys):
    """A student's `whitted convert --portable` output: compare renders it with the Whitted
    integrator too, so "use the path integrator (--integrator path)", render's advice, is an
    option compare does not have; its own advice names the .scn and the default XML."""
    assert main(["convert", "--portable", "-o", str(tmp_path), str(mirror_scene)]) == 0
    capsys.readouterr()
    status = main(["compare", str(tmp_path / "mirror.portable.xml"), "--out", str(tmp_path / "out"),
                   "--cache", str(tmp_path / "refs"), "-q"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "--integrator" not in err and "without --portable" in err
    assert not (tmp_path / "out").exists()
