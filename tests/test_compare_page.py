"""``whitted compare``'s report page, checked in a real browser, and what it is made of.

The page is opened from disk in headless Chromium (Debian's ``chromium``, driven with
Playwright over the DevTools protocol; ``make test`` installs it when it can). The
test checks what a reader relies on: every image loads, the viewer flips between a
render, the reference and the render's error map, and the console shows no error.
Where no Chromium or no Playwright can be had, the browser test is skipped and says
why; the other tests here need no browser.
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import shutil
import statistics
from pathlib import Path

import numpy as np
import pytest

from conftest import without_report_pictures
from whitted import compare as cmp
from whitted.images import read_image
from whitted.cli import main

SCENE = """\
size 32 24
eye 0 0 6
fov 50
light 4 5 6
depth 3
sphere -0.9 0 0 0.8  color 0.9 0.9 0.9  reflect 0.8
sphere 0.9 0 0 0.8   color 0.9 0.2 0.2  reflect 0.3
"""
DEPTHS, WHITTED_SPP, PATH_SPP, LEVELS = (1, 2), (1, 2), (1, 4, 16), (0.1, 0.01)

#: Chromium's switches for a closed network and no display (without them it stalls).
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]


def chromium() -> str | None:
    """The Chromium to test with: $WHITTED_CHROMIUM, Debian's /usr/bin/chromium, or one on PATH."""
    for candidate in (os.environ.get("WHITTED_CHROMIUM"), "/usr/bin/chromium",
                      shutil.which("chromium"), shutil.which("chromium-browser")):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return None


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> tuple[Path, list]:
    """One small comparison through the CLI; its output folder and its results."""
    folder = tmp_path_factory.mktemp("page")
    scene = folder / "pair.scn"
    scene.write_text(SCENE)
    out = folder / "out"
    options = cmp.Options(out=out, reference_spp=128, depths=DEPTHS, whitted_spp=WHITTED_SPP,
                          path_spp=PATH_SPP, rounds=2, levels=LEVELS, quiet=True)
    return out, cmp.compare([scene], options)


# --------------------------------------------------------------------------- files


def test_every_render_is_kept_as_exr_png_and_error_map(report):
    out, (entry,) = report
    assert len(entry.measurements) == 2 * len(DEPTHS) * len(WHITTED_SPP) + len(PATH_SPP)
    reference = read_image(entry.reference_file)
    for m in entry.measurements:
        image = read_image(out / m.image)
        assert image.shape == (24, 32, 3)
        # the kept EXR is the scored image: its relative MSE is the CSV's
        from whitted import metrics
        assert metrics.relative_mse(image, reference) == pytest.approx(m.rel_mse, rel=1e-5)
        png = read_image(out / m.image_png)
        np.testing.assert_allclose(png, np.clip(image, 0, 1), atol=0.02)  # the same, 8-bit sRGB
        error_map = read_image(out / m.error_map)
        assert error_map.shape == (24, 32, 3)
    assert (out / entry.reference_png).is_file()


def test_error_map_colors_follow_flips_per_pixel_error(report):
    """The map's brightest pixels are where the render differs most from the reference."""
    import mitsuba as mi

    from whitted import metrics
    out, (entry,) = report
    reference = read_image(entry.reference_file)
    worst = max(entry.measurements, key=lambda m: m.flip)
    error, mean = metrics.flip_map(read_image(out / worst.image), reference)
    assert mean == pytest.approx(worst.flip, rel=1e-5) and error.shape == (24, 32)
    colors = np.array(mi.Bitmap(str(out / worst.error_map)), dtype=np.float64)
    brightness = colors.sum(axis=2)
    # magma grows brighter with the error: the map's order is the error's order
    high, low = error > np.quantile(error, 0.8), error < np.quantile(error, 0.2)
    assert brightness[high].mean() > brightness[low].mean() + 100


def test_csv_keeps_its_columns_and_adds_the_timing_spread_and_files(report):
    out, (entry,) = report
    with open(out / "results.csv", newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    old = ["scene", "method", "integrator", "lighting", "spp", "max_depth", "seconds",
           "compile_seconds", "rel_mse", "flip", "repeats", "width", "height", "variant",
           "reference_spp"]
    assert reader.fieldnames[:len(old)] == old
    assert {"seconds_min", "seconds_max", "seconds_each", "image", "error_map"} <= set(reader.fieldnames)
    for row in rows:
        each = [float(t) for t in row["seconds_each"].split(";")]
        # the path tracer's (the verdict reads them): at least the two rounds asked for, more
        # while a headline is unsettled (a busy machine); every render: at least the first
        assert len(each) == int(row["repeats"]) >= (2 if row["method"] == "path" else 1)
        assert float(row["seconds"]) == pytest.approx(statistics.median(each), rel=1e-5)
        assert int(row["work"]) > 0
        assert float(row["seconds_min"]) == pytest.approx(min(each), rel=1e-5)
        assert float(row["seconds_max"]) == pytest.approx(max(each), rel=1e-5)
        assert float(row["seconds_min"]) <= float(row["seconds"]) <= float(row["seconds_max"])
        assert (out / row["image"]).is_file() and (out / row["error_map"]).is_file()
    assert float(rows[0]["reference_noise"]) > 0


def test_summary_is_saved_with_floors_and_both_tables(report):
    out, _ = report
    text = (out / "summary.txt").read_text(encoding="utf-8")
    assert "Equal quality" in text and "Equal time" in text
    assert "The article's model" in text and "The physically lit ray tree" in text


def test_template_ships_as_package_data():
    """A non-editable install has the template: pyproject lists it as package data, and the
    package's resources hold it."""
    import tomllib
    from importlib import resources

    root = Path(__file__).resolve().parent.parent
    with open(root / "pyproject.toml", "rb") as f:
        package_data = tomllib.load(f)["tool"]["setuptools"]["package-data"]
    pattern = package_data["whitted.compare.templates"][0]  # the templates folder: a data package
    templates = list((root / "whitted" / "compare" / "templates").glob(pattern))
    assert templates and all(t.suffix == ".j2" for t in templates)
    assert resources.files("whitted.compare").joinpath("templates/report.html.j2").is_file()


# --------------------------------------------------------------------------- plot labels


def test_plot_labels_do_not_overlap():
    """Sixty crowded points: every label placed lies inside the axes and overlaps no other
    label and no point; those with no free place are left out."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox

    from whitted.compare.plot import place_labels

    fig = Figure(figsize=(4, 3), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.set_xscale("log")
    ax.set_yscale("log")
    rng = np.random.default_rng(1)
    points = [(10 ** rng.uniform(-3, -1), 10 ** rng.uniform(-2, -1.5)) for _ in range(60)]
    ax.scatter(*zip(*points))
    fig.draw_without_rendering()
    dots = [Bbox.from_extents(x - 3, y - 3, x + 3, y + 3)
            for x, y in (ax.transData.transform(p) for p in points)]
    placed = place_labels(fig, ax, [(x, y, f"d{i}·16", "k") for i, (x, y) in enumerate(points)],
                          list(dots))
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in ax.texts]
    assert len(boxes) == placed and 10 <= placed < 60  # crowded: some had no free place
    frame = ax.get_window_extent(renderer)
    for box in boxes:
        assert frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
        assert not any(box.overlaps(dot) for dot in dots)
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b)


# --------------------------------------------------------------------------- browser


@pytest.fixture(scope="module")
def browser_page(report, tmp_path_factory):
    """report.html opened from disk in headless Chromium; (page, console errors)."""
    executable = chromium()
    if executable is None:
        pytest.skip("no Chromium: install Debian's chromium (make test does, as root) or set "
                    "$WHITTED_CHROMIUM")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[test]')")
    out, _ = report
    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(profile), executable_path=executable, headless=True, args=CHROMIUM_ARGS)
        context.set_default_timeout(30_000)
        page = context.new_page()
        errors: list[str] = []
        page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto((out / "report.html").as_uri(), wait_until="load")
        yield page, errors
        context.close()


def test_every_image_of_the_page_loads(browser_page, report):
    page, errors = browser_page
    page.wait_for_function("Array.from(document.images).every(i => i.complete)")
    images = page.eval_on_selector_all("img", "all => all.map(i => [i.getAttribute('src'), i.naturalWidth])")
    _, (entry,) = report
    cards = page.locator(".card").count()
    assert 0 < cards <= len(entry.measurements)
    assert len(images) >= 2 * cards + 2  # gallery pairs, viewer, plot
    broken = [src for src, width in images if not width > 0]
    assert not broken, f"images that did not load: {broken}"
    assert all(not src.startswith(("/", "http", "file:")) for src, _ in images)  # relative paths
    assert not errors, errors


def test_viewer_flips_between_render_reference_and_error_map(browser_page, report):
    page, errors = browser_page
    _, (entry,) = report
    viewer = page.locator(".viewer").first
    shown = viewer.locator("img.shown")
    # the gallery's card of one render selects it
    card = page.locator(".card").first
    (first,) = [m for m in entry.measurements if m.image_png == card.get_attribute("data-png")]
    card.click()
    assert shown.get_attribute("src") == first.image_png
    viewer.locator('button[data-mode="reference"]').click()
    assert shown.get_attribute("src") == entry.reference_png
    viewer.locator('button[data-mode="error"]').click()
    assert shown.get_attribute("src") == first.error_map
    assert viewer.locator(".colorbar").evaluate("e => getComputedStyle(e).visibility") == "visible"
    page.keyboard.press("1")  # the keys flip too
    assert shown.get_attribute("src") == first.image_png
    page.keyboard.press("2")
    assert shown.get_attribute("src") == entry.reference_png
    page.wait_for_function("document.querySelector('.viewer img.shown').naturalWidth > 0")
    page.keyboard.press("1")
    viewer.locator("button.next").click()  # the next render of the list
    assert shown.get_attribute("src") != first.image_png
    assert not errors, errors


def test_page_tables_hold_every_whitted_render_and_level(browser_page, report):
    page, _ = browser_page
    _, (entry,) = report
    whitted = [m for m in entry.measurements if m.setting.integrator == "whitted"]
    assert page.locator("table.equal-time tbody tr").count() == len(whitted)
    assert page.locator("table.equal-quality tbody tr").count() == len(LEVELS)
    findings = page.locator(".findings").first.inner_text()
    assert "The article's model" in findings and "path tracer" in findings
    assert "noise" in findings
    # what the error is made of, in words, at the top of the section
    article, physical = (page.locator(".findings .decomposition").nth(i).inner_text() for i in (0, 1))
    limit = entry.limits["whitted-article"]
    assert article.startswith("Of the article model's")
    assert f"its limit (d{max(DEPTHS)}, every ray of the tree, {limit.spp} spp)" in article
    assert f"scores {limit.rel_mse:.3g}" in article
    assert f"the best ambient ({limit.best_ambient:.2g} instead of 0.2)" in article
    assert "light the model does not transport" in article
    assert physical.startswith("Of the physically lit ray tree's") and "ambient" not in physical


def test_viewer_lists_every_render_and_shows_those_without_a_card(browser_page, report):
    page, errors = browser_page
    _, (entry,) = report
    viewer = page.locator(".viewer").first
    options = viewer.locator("select.pick option")
    assert options.count() == len(entry.measurements)
    carded = set(page.eval_on_selector_all(".card", "all => all.map(c => c.dataset.png)"))
    for m in entry.measurements:  # one without a card, else any
        if m.image_png not in carded:
            break
    viewer.locator('button[data-mode="render"]').click()
    value = viewer.locator("select.pick option", has_text=f"{m.setting.method} {m.setting.label}")
    viewer.locator("select.pick").select_option(value.first.get_attribute("value"))
    assert viewer.locator("img.shown").get_attribute("src") == m.image_png
    assert m.setting.label in viewer.locator(".shown-caption").inner_text()
    assert not errors, errors


#: The terms a reader meets on the first screen, each with the glossary entry that defines it.
TERMS = {"article's model": "g-article", "physically lit": "g-physical", "path tracer": "g-path",
         "reference": "g-reference", "spp": "g-spp", "sample per pixel": "g-spp",
         "samples per pixel": "g-spp", "depth": "g-depth", "relative MSE": "g-rel-mse",
         "rel. MSE": "g-rel-mse", "FLIP": "g-flip", "error map": "g-flip", "noise": "g-noise",
         "bias": "g-bias", "as good as it gets": "g-floor", "floor": "g-floor", "limit": "g-limit",
         "interval": "g-interval", "unsettled": "g-unsettled", "llvm_ad_rgb": "g-variant",
         "scalar_rgb": "g-variant", "cuda_ad_rgb": "g-variant"}
#: What the glossary must define whatever the first screen says (the words of the tables below).
GLOSSARY = ("spp", "depth", "relative MSE", "FLIP", "reference", "floor", "limit", "interval",
            "unsettled")
#: The text of the page in reading order up to the first image, and the text drawn on the first
#: screen (a text node whose box starts above the window's bottom edge).
TEXT_BEFORE_FIRST_IMAGE = """() => {
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const image = document.images[0], parts = [];
  while (walker.nextNode()) {
    const node = walker.currentNode;
    if (image.compareDocumentPosition(node) & Node.DOCUMENT_POSITION_FOLLOWING) break;
    if (!node.parentElement.closest("script, style")) parts.push(node.textContent);
  }
  return parts.join(" ");
}"""
TEXT_ON_FIRST_SCREEN = """() => {
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT), parts = [];
  while (walker.nextNode()) {
    const node = walker.currentNode, range = document.createRange();
    range.selectNodeContents(node);
    const box = range.getBoundingClientRect();
    if (!node.parentElement.closest("script, style") && box.height > 0 && box.top < innerHeight)
      parts.push(node.textContent);
  }
  return parts.join(" ");
}"""


def test_first_screen_is_the_verdict_and_the_images_with_every_term_defined(browser_page, report):
    """At 1280x800 a student sees the verdict, then the article's render, the path tracer's, the
    reference and their error maps, after at most 150 words; every term on that screen is
    defined on the page."""
    page, errors = browser_page
    page.set_viewport_size({"width": 1280, "height": 800})
    page.evaluate("window.scrollTo(0, 0)")
    page.wait_for_function("Array.from(document.images).every(i => i.complete)")
    _, results = report
    (entry,) = results
    strip = page.eval_on_selector_all(".strip img", "all => all.map(i => [i.getAttribute('src'), "
                                      "i.getBoundingClientRect().bottom])")
    found = results.findings["scenes"][entry.name]["methods"]["whitted-article"]["floor"]
    (floor,) = [m for m in entry.measurements if m.setting.method == "whitted-article"
                and (m.setting.max_depth, m.setting.spp) == (found["max_depth"], found["spp"])]
    near = min((m for m in entry.measurements if m.setting.method == "path"),
               key=lambda m: abs(math.log(m.seconds / floor.seconds)))
    sources = [src for src, _ in strip]
    assert sources == [floor.image_png, near.image_png, entry.reference_png, floor.error_map,
                       near.error_map]
    assert all(bottom <= 800 for _, bottom in strip), strip  # all five above the fold
    assert page.locator("img").first.get_attribute("src") == sources[0]
    assert page.locator(".verdict").first.bounding_box()["y"] < strip[0][1]
    before = page.evaluate(TEXT_BEFORE_FIRST_IMAGE).split()
    assert 0 < len(before) <= 150, " ".join(before)
    screen = " ".join(page.evaluate(TEXT_ON_FIRST_SCREEN).split())
    met = {term for term in TERMS if term.lower() in screen.lower()}
    assert {"spp", "depth", "relative MSE", "reference", "FLIP", "path tracer"} <= met, screen
    defined = dict(page.eval_on_selector_all(".glossary dt", "all => all.map(d => [d.id, d.innerText])"))
    for term in met:
        assert TERMS[term] in defined, f"{term!r} is on the first screen but not in the glossary"
    for term in GLOSSARY:
        assert any(term.lower() in text.lower() for text in defined.values()), term
    assert not errors, errors


# --------------------------------------------------------------------------- CLI


def test_cli_names_the_page(tmp_path, capsys, monkeypatch):
    without_report_pictures(monkeypatch)
    scene = tmp_path / "pair.scn"
    scene.write_text(SCENE)
    status = main(["compare", str(scene), "--out", str(tmp_path / "out"), "--reference-spp", "32",
                   "--depths", "1", "--spp", "1", "--path-spp", "1", "--rounds", "1", "-q"])
    assert status == 0
    assert str(tmp_path / "out" / "report.html") in capsys.readouterr().err
    assert (tmp_path / "out" / "report.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")


def test_plot_labels_keep_off_the_lines():
    """A label placed with the lines' boxes as obstacles covers no part of a line."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from whitted.compare.plot import line_boxes, place_labels

    fig = Figure(figsize=(4, 3), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.set_xscale("log")
    ax.set_yscale("log")
    lines = [[(10 ** (-3 + k / 4), 10 ** (-1 - k / 6)) for k in range(9)],
             [(10 ** (-3 + k / 4), 10 ** (-1.2 - k / 5)) for k in range(9)]]
    for line in lines:
        ax.plot(*zip(*line))
    fig.draw_without_rendering()
    taken = [box for line in lines for box in line_boxes(ax, line)]
    placed = place_labels(fig, ax, [(x, y, f"d{i}·4", "k") for line in lines
                                    for i, (x, y) in enumerate(line)], taken)
    assert placed >= 4
    renderer = fig.canvas.get_renderer()
    for text in ax.texts:
        box = text.get_window_extent(renderer)
        for line in lines:
            points = ax.transData.transform(line)
            for (ax0, ay0), (ax1, ay1) in zip(points, points[1:]):
                for k in range(101):  # every point of the segment, finely
                    x, y = ax0 + (ax1 - ax0) * k / 100, ay0 + (ay1 - ay0) * k / 100
                    assert not (box.x0 < x < box.x1 and box.y0 < y < box.y1), text.get_text()


def test_help_names_every_output(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in ("report.html", "summary.txt", "findings.json", "results.csv", "error_vs_time.png",
                 "contact_sheet.png"):
        assert f"DIR/{name}" in text
