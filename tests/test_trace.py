"""``whitted trace`` and ``whitted.trace_pixel``: the ray tree of a pixel, as the renderer computed it.

The trees come from the render's own code (the tracer's and the shader's recording hooks),
so what is checked is that they *are* the render: on every example and hazard scene, at
pixels picked on edges, glass, shadows and textures, the contributions of a pixel's tree
add up to the pixel of a 1-spp render (both variants), and every node obeys the
article's formulas (a child's weight is its parent's times KR or KT; the contribution is
``w·(1 − KR − KT)·point``; the point is its ambient and light terms). A tree with a branch
dropped or a weight changed fails these checks.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json

import numpy as np
import pytest

import whitted
from conftest import REPO
from whitted.cli import main
from whitted.converter import parse_file
from whitted.converter.scn_writer import scene_to_scn
from whitted.trace import trace_pixel, trace_pixels
from whitted.trace.nodes import Node

import hard_cases.hazard_scenes as hs

EXAMPLES = sorted(p.stem for p in (REPO / "scenes").glob("*.scn"))
SCENES = [f"example:{name}" for name in EXAMPLES] + list(hs.HAZARDS) + [f"giant:{name}" for name in hs.GIANTS]
#: the examples are traced at this fraction of their size (the scalar render of a full
#: example takes ten seconds); the hazard scenes are small already
SHRINK = 4
PIXELS = 20
#: how far the sum of a tree's contributions may lie from the pixel
TOLERANCE = 1e-6

TIR = REPO / "scenes" / "tir.scn"


def scene_file(name: str, folder) -> "Path":
    """The scene ``name`` as a ``.scn`` file in ``folder`` (the examples shrunk)."""
    if name.startswith("example:"):
        path = REPO / "scenes" / f"{name.split(':')[1]}.scn"
        model = parse_file(path)
        model = dataclasses.replace(model, width=model.width // SHRINK, height=model.height // SHRINK)
        text = path.read_text()
        import re
        text = re.sub(r"(?im)^\s*size\s+\d+\s+\d+", f"size {model.width} {model.height}", text)
        out = folder / path.name
        out.write_text(text)
        for texture in path.parent.glob("*.png"):
            (folder / texture.name).write_bytes(texture.read_bytes())
        return out
    model = hs.GIANTS[name.split(":")[1]]() if name.startswith("giant:") else hs.build(name, folder)
    out = folder / f"{name.replace(':', '_')}.scn"
    out.write_text(scene_to_scn(model, folder, comment=name))
    return out


def chosen_pixels(image: np.ndarray, count: int = PIXELS) -> list[tuple[int, int]]:
    """Half the pixels where the image changes most (edges, shadow borders, texels, the rims of
    glass), half at random (a fixed seed), all distinct."""
    height, width = image.shape[:2]
    gradient = np.zeros((height, width))
    gradient[:, 1:] += np.abs(np.diff(image, axis=1)).sum(axis=2)
    gradient[1:, :] += np.abs(np.diff(image, axis=0)).sum(axis=2)
    order = np.argsort(-gradient, axis=None, kind="stable")
    picked = [(int(k % width), int(k // width)) for k in order[:count // 2]]
    rng = np.random.default_rng(40)
    while len(picked) < min(count, width * height):
        pixel = (int(rng.integers(width)), int(rng.integers(height)))
        if pixel not in picked:
            picked.append(pixel)
    return picked


def check_node(node: Node, ambient: float) -> None:
    """The article's formulas at one node. A child's weight is its parent's times KR or KT
    exactly, as the shader multiplies: in float32 (JIT variants) or in Python's float64 (the
    scalar variants' Python arithmetic)."""
    f32 = np.float32
    if node.hit:
        m = node.material
        assert node.diffuse_weight == pytest.approx(1 - m["reflect"] - m["refract"], abs=1e-7)
        expected = [float(f32(node.weight) * f32(node.diffuse_weight) * f32(p)) for p in node.local]
        np.testing.assert_allclose(node.contribution, expected, rtol=1e-5, atol=1e-7)
        local = np.asarray(node.ambient) + sum(np.asarray(t.term) for t in node.lights)
        np.testing.assert_allclose(node.local, local, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(node.ambient, np.asarray(m["color"]) * ambient, rtol=1e-6)
        for term in node.lights:
            if term.blocked or not term.facing:
                assert term.term == (0.0, 0.0, 0.0)
        for child in node.children:
            if child.merged:
                shares = (f32(m["reflect"]) + f32(m["refract"]), m["reflect"] + m["refract"])
            elif child.kind == "reflection":
                shares = (f32(m["reflect"]), m["reflect"])
            else:
                shares = (f32(m["refract"]), m["refract"])
            products = (float(f32(node.weight) * shares[0]), node.weight * shares[1])
            assert child.weight in products, (node.kind, child.kind, child.weight, products)
    else:
        assert not node.children and node.stop == "missed: background"
    assert node.stop is None or not node.children


def check_tree(tree, ambient: float) -> float:
    """Every node's formulas; the largest difference between the tree's sum and its color."""
    for node in tree.root.walk():
        check_node(node, ambient)
    return float(np.abs(np.asarray(tree.total()) - np.asarray(tree.color)).max())


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("trace-scenes")
    return {name: scene_file(name, folder) for name in SCENES}


@pytest.mark.slow
def test_contributions_add_up_to_the_1spp_pixel(variant, scene_files, capsys):
    """Acceptance: on every example and hazard scene, at 20 pixels each, the tree's
    contributions add up to the 1-spp render's pixel within 1e-6 (in float64; the tracer's
    own float32 sum is the pixel exactly), and every node obeys the article's formulas."""
    worst, where, rays = 0.0, None, 0
    for name in SCENES:
        scene = whitted.load_scene(scene_files[name], meshes=False)
        image = np.asarray(whitted.render(scene, spp=1).image, np.float64)
        pixels = chosen_pixels(image)
        traces = trace_pixels(scene, pixels)
        ambient = traces.settings["ambient"]
        for tree, (x, y) in zip(traces, pixels):
            check_tree(tree, ambient)
            gap = float(np.abs(np.asarray(tree.total()) - image[y, x]).max())
            rays += tree.root.count()
            if gap > worst:
                worst, where = gap, (name, x, y)
            assert gap <= TOLERANCE, f"{name} pixel ({x}, {y}): the tree adds up to {tree.total()}, " \
                                     f"the render has {image[y, x]}"
            # the color the tracer summed for the tree is the render's pixel, bit for bit
            assert tree.color == tuple(image[y, x]), (name, x, y)
    with capsys.disabled():
        print(f"\n{variant}: {len(SCENES)} scenes x {PIXELS} pixels, {rays} rays: "
              f"max |sum - pixel| = {worst:.3g} at {where}")


def test_tree_of_a_glass_pixel_names_the_file_s_spheres(variant):
    tree = trace_pixel(TIR, 160, 90)
    root = tree.root
    assert root.kind == "camera" and root.hit
    assert root.sphere.line == 19 and root.sphere.comment == "the glass ball"
    assert root.origin == pytest.approx((0.0, 0.5, 7.0), abs=1e-6)   # the file's eye, not the frame's
    kinds = [node.kind for node in root.walk()]
    assert kinds == ["camera", "reflection", "refraction", "total internal reflection"]
    bubble = root.children[1]
    assert bubble.sphere.comment == "the air bubble in it" and bubble.diffuse_weight == 0
    floor = bubble.children[0]
    assert floor.sphere.line == 18 and floor.stop == "no reflection or refraction"
    blocked = [t for t in floor.lights if t.blocked]
    assert blocked and all(t.blocker.line == 19 for t in blocked)   # the glass ball shadows the floor
    assert [t.line for t in floor.lights] == [15, 16]
    assert check_tree(tree, 0.3) < TOLERANCE
    text = str(tree)
    assert "# the glass ball" in text and "total internal reflection" in text and "blocked by tir.scn:19" in text


def test_branches_stop_for_a_reason(llvm, write_scene):
    """Max depth, the adaptive depth control's cut and a miss each end a branch, and say so."""
    path = write_scene("size 8 8\neye 0 0 5\nfov 30\ndepth 2\nlight 3 3 3\n"
                       "sphere 0 0 0 1 color 1 1 1 reflect 0.5 refract 0.3 1.5\n")
    tree = trace_pixel(path, 4, 4)
    assert tree.root.stop is None and len(tree.root.children) == 2
    assert {node.stop for node in tree.root.children} <= {"max depth", "missed: background"}
    deepest = [node for node in tree.root.walk() if node.level == 2 and node.hit]
    assert deepest and all(u["why"] == "max depth" for node in deepest for u in node.untraced)
    lighter = trace_pixel(path, 4, 4, min_weight=0.5)   # the refracted branch alone is too light
    assert [c.kind for c in lighter.root.children] == ["reflection"]
    assert lighter.root.untraced == [{"kind": "refraction", "weight": pytest.approx(0.3), "why": "cut by weight"}]
    cut = trace_pixel(path, 4, 4, min_weight=0.9)   # together they can change the pixel by less
    assert not cut.root.children and cut.root.stop == "cut by weight"
    assert {u["kind"] for u in cut.root.untraced} == {"reflection", "refraction"}
    miss = trace_pixel(path, 0, 0)
    assert miss.root.stop == "missed: background" and miss.root.count() == 1


def test_a_dropped_branch_or_a_wrong_weight_is_caught(llvm):
    """The checks above fail on a tree that is not the render's."""
    tree = trace_pixel(TIR, 160, 90)
    assert check_tree(tree, 0.3) < TOLERANCE
    dropped = dataclasses.replace(tree, root=dataclasses.replace(tree.root, children=tree.root.children[:1]))
    assert check_tree(dropped, 0.3) > 1e-3   # the refracted branch carried most of the pixel
    child = tree.root.children[0]
    child.weight *= 1.01   # a reflection weight that is not the parent's times KR
    with pytest.raises(AssertionError):
        check_tree(tree, 0.3)


def test_json_and_text_from_the_command_line(llvm, tmp_path, capsys):
    assert main(["trace", str(TIR), "--pixel", "160", "90", "--pixel", "5", "5", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scene"] == "tir.scn" and [p["pixel"] for p in data["pixels"]] == [[160, 90], [5, 5]]
    first = data["pixels"][0]
    assert first["tree"]["sphere"]["comment"] == "the glass ball"
    assert first["sum"] == pytest.approx(first["color"], abs=TOLERANCE)
    sky = data["pixels"][1]["tree"]
    assert sky["hit"] is False and sky["stop"] == "missed: background"
    assert main(["trace", str(TIR), "--pixel", "160", "90"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("pixel (160, 90) of tir.scn") and "\n    total internal reflection" in out


@pytest.mark.parametrize("args, message", [
    (["--pixel", "320", "0"], "pixel (320, 0) is outside the 320x200 image"),
    (["--pixel", "-1", "5"], "pixel (-1, 5) is outside"),
])
def test_bad_pixels_are_one_line_and_write_nothing(llvm, tmp_path, capsys, args, message):
    page = tmp_path / "page.html"
    assert main(["trace", str(TIR), *args, "-o", str(page)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_missing_scene_is_one_line(tmp_path, capsys):
    assert main(["trace", str(tmp_path / "nope.scn"), "--pixel", "1", "1"]) == 2
    err = capsys.readouterr().err
    assert "nope.scn" in err and len(err.strip().splitlines()) == 1


def test_help_describes_every_option(capsys):
    with pytest.raises(SystemExit):
        main(["trace", "--help"])
    out = capsys.readouterr().out
    for option in ("--pixel", "--json", "--output", "--variant", "--max-depth", "--ambient", "--lighting",
                   "--min-weight"):
        assert option in out


def test_a_loaded_scene_keeps_its_file_s_names(llvm):
    """``trace_pixel`` of a scene from ``load_scene`` (grouped spheres too) or ``loads``."""
    scene = whitted.load_scene(TIR)
    assert trace_pixel(scene, 160, 90).root.sphere.line == 19
    text = "size 16 16\neye 0 0 5\nlookat 0 0.5 0\nlight 2 2 2\nsphere 0 0.5 0 1  # the ball\n"
    tree = trace_pixel(whitted.loads(text), 8, 8)
    assert tree.root.sphere.comment == "the ball" and tree.root.sphere.line == 5
    # on the ball in the file's coordinates (the frame's are the file's minus the lookat)
    assert np.linalg.norm(np.subtract(tree.root.position, (0, 0.5, 0))) == pytest.approx(1.0, rel=1e-6)
    many = "size 16 16\neye 0 0 20\nlight 5 5 5\n" + "".join(
        f"sphere {x * 2 - 3} {y * 2 - 3} 0 0.9  # ball {x} {y}\n" for x in range(4) for y in range(4))
    grouped = whitted.loads(many, ellipsoids=True)
    tree = trace_pixel(grouped, 8, 8)
    assert tree.root.hit and tree.root.sphere.comment.startswith("ball ")
    assert tree.root.sphere.center == (1.0, -1.0, 0.0)   # grouped in a frame scaled by 1/0.9
    assert np.linalg.norm(np.subtract(tree.root.position, tree.root.sphere.center)) == pytest.approx(0.9, rel=1e-5)


# --------------------------------------------------------------------------- the page


@pytest.fixture(scope="module")
def page_file(tmp_path_factory):
    """The page of three pixels of tir.scn (glass with total internal reflection, the floor in
    the ball's shadow, the background), written through the command line."""
    whitted.set_variant("llvm_ad_rgb")
    page = tmp_path_factory.mktemp("trace-page") / "tir.html"
    assert main(["trace", str(TIR), "--pixel", "160", "90", "--pixel", "60", "150", "--pixel", "5", "5",
                 "-o", str(page)]) == 0
    return page


def test_page_is_self_contained(page_file):
    html = page_file.read_text()
    import re
    assert not re.search(r"<script[^>]*\bsrc=", html) and "<link" not in html   # no file fetched
    assert re.search(r"plotly\.js v\d", html)        # plotly's script is in the page
    assert "data:image/png;base64," in html           # the image is inlined
    assert html.count('class="tree"') == 3            # a table per pixel
    assert "tir.scn:19 (the glass ball)" in html and "total internal reflection" in html


@pytest.fixture(scope="module")
def chromium_session():
    """Playwright and the Chromium to test with, once for the module: a process holds one
    synchronous Playwright session at a time."""
    from test_compare_page import chromium
    executable = chromium()
    if executable is None:
        pytest.skip("no Chromium: install Debian's chromium or set $WHITTED_CHROMIUM")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[test]')")
    with sync_playwright() as playwright:
        yield playwright, executable


@pytest.fixture(scope="module")
def browser(page_file, tmp_path_factory, chromium_session):
    """The page opened from disk in headless Chromium: (page, console errors, requests)."""
    from test_compare_page import CHROMIUM_ARGS
    playwright, executable = chromium_session
    profile = tmp_path_factory.mktemp("chromium-profile")
    context = playwright.chromium.launch_persistent_context(
        str(profile), executable_path=executable, headless=True,
        args=[*CHROMIUM_ARGS, "--enable-unsafe-swiftshader", "--use-angle=swiftshader"])
    context.set_default_timeout(30_000)
    page = context.new_page()
    errors: list[str] = []
    requests: list[str] = []
    page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.on("request", lambda request: requests.append(request.url))
    page.goto(page_file.as_uri(), wait_until="load")
    page.wait_for_function("document.querySelector('.js-plotly-plot') && "
                           "document.querySelector('.js-plotly-plot')._fullLayout")
    yield page, errors, requests
    context.close()


def test_page_shows_the_3d_view_and_the_tables_in_a_browser(browser):
    page, errors, requests = browser
    names = page.evaluate("Array.from(document.querySelector('.js-plotly-plot').data, t => t.name)")
    for name in ("camera", "reflection", "refraction", "total internal reflection", "shadow ray, lit",
                 "shadow ray, blocked", "lights", "missed (to the background)"):
        assert name in names
    assert page.locator(".js-plotly-plot canvas").count() > 0   # drawn (WebGL)
    dashed = page.evaluate("Array.from(document.querySelector('.js-plotly-plot').data)"
                           ".filter(t => t.name === 'shadow ray, blocked').map(t => t.line.dash)")
    assert dashed == ["dash"]
    assert page.locator("table.tree").count() == 3
    assert page.locator("table.tree").first.locator("tbody tr").count() == 4   # the glass pixel's 4 rays
    assert page.locator(".stage img").evaluate("i => i.naturalWidth") == 320
    assert page.locator(".stage svg circle").count() == 2 * 3    # each pixel marked
    assert not errors, errors
    assert all(url.startswith(("file:", "data:", "blob:", "about:")) for url in requests), requests


def test_notebook_shows_the_figure_and_table(llvm):
    tree = trace_pixel(TIR, 160, 90)
    html = tree._repr_html_()
    import re
    assert "Plotly.newPlot" in html and 'class="tree"' in html and "<html" not in html
    assert not re.search(r"<script[^>]*\bsrc=", html) and re.search(r"plotly\.js v\d", html)
    assert str(tree).splitlines()[0].startswith("pixel (160, 90) of tir.scn")


def test_a_converted_xml_is_traced_in_its_own_frame(llvm):
    """A converted .xml has no scene file to name spheres from: shape ids, the XML's positions
    (the .scn's minus its lookat), the same tree."""
    from_scn = trace_pixel(TIR, 160, 90)
    from_xml = trace_pixel(REPO / "scenes_xml" / "tir.xml", 160, 90)
    assert from_xml.color == from_scn.color
    line = from_scn.root.sphere.line   # the glass ball's: "# the glass ball" in tir.scn
    assert TIR.read_text().splitlines()[line - 1].endswith("# the glass ball")
    assert from_xml.root.sphere.name == f"sphere_l{line}_the_glass_ball" and from_xml.root.sphere.line is None
    assert from_xml.root.origin == pytest.approx((0.0, 0.3, 7.0), abs=1e-6)   # tir.scn's lookat is 0 0.2 0
    assert str(from_xml).startswith("pixel (160, 90) of tir.xml")


@pytest.mark.parametrize("effect", ["shadows", "reflection", "refraction", "diffuse", "ambient"])
def test_a_render_without_an_effect_adds_up_too(llvm, scene_files, effect):
    """With an effect left out (``without``), each tree still adds up to its 1-spp pixel."""
    scene = whitted.load_scene(scene_files["example:tir"], meshes=False, without=effect)
    image = np.asarray(whitted.render(scene, spp=1).image, np.float64)
    pixels = chosen_pixels(image)
    for tree, (x, y) in zip(trace_pixels(scene, pixels), pixels):
        assert float(np.abs(np.asarray(tree.total()) - image[y, x]).max()) <= TOLERANCE, (effect, x, y)


@pytest.mark.parametrize("x, y, expected", [("29%", "57%", (29, 57)), ("0%", "100%", (0, 99)),
                                             ("14.5%", "99.99%", (14, 99))])
def test_a_percentage_is_that_share_of_the_size_exactly(llvm, write_scene, x, y, expected):
    """29% of 100 pixels is column 29: 0.29 · 100 in binary floating point is 28.999…, which
    must not round the pixel down to 28."""
    path = write_scene("size 100 100\neye 0 0 5\nlight 3 3 3\nsphere 0 0 0 1\n")
    tree = trace_pixel(path, x, y)
    assert (tree.x, tree.y) == expected


@pytest.fixture
def open_page(chromium_session):
    """``with open_page(page_file) as page``: the page in a fresh headless Chromium, 1280×800."""
    from test_compare_page import CHROMIUM_ARGS
    playwright, executable = chromium_session

    @contextlib.contextmanager
    def opened(page_file):
        browser = playwright.chromium.launch(executable_path=executable, headless=True, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(page_file.as_uri(), wait_until="load")
            yield page
        finally:
            browser.close()
    return opened


def test_a_deep_tree_s_table_fits_a_projector_s_width(llvm, write_scene, tmp_path, open_page):
    """A tree 24 rays deep between two mirrors: its table stays within a 1280-pixel window (the
    ray labels wrap and the indent stops growing), where it was 2050 pixels wide and the
    contributions and branch ends lay off the projected screen."""
    path = write_scene("size 8 8\neye 0 0 1.5\nfov 30\ndepth 24\nlight 0 0 0\n"
                       "sphere 0 0 -1002 1000 reflect 1\nsphere 0 0 1002 1000 reflect 1\n")
    page_file = tmp_path / "deep.html"
    assert main(["trace", str(path), "--pixel", "4", "4", "-o", str(page_file)]) == 0
    with open_page(page_file) as page:
        assert page.locator("table.tree tbody tr").count() == 24
        right = page.evaluate("document.querySelector('table.tree').getBoundingClientRect().right")
        assert right <= 1280 and page.evaluate("document.documentElement.scrollWidth") <= 1280


def test_lights_at_one_spot_are_named_by_their_own_lines(llvm, write_scene):
    """A red and a blue light at the same position: each term names its own line (the blue
    one was named by the red one's line, as the first light at that spot)."""
    path = write_scene("size 20 20\neye 0 0 5\nlight -3 3 3  0 0 0\nlight 3 3 3  1 0 0   # red\n"
                       "light 3 3 3  0 0 1   # blue\nsphere 0 0 0 1\n")
    lights = trace_pixel(path, 10, 10).root.lights
    assert [(t.index, t.line) for t in lights] == [(0, 3), (1, 4), (2, 5)]
    assert lights[2].statement == "light 3 3 3  0 0 1" and lights[2].term[0] == 0 < lights[2].term[2]


def test_of_two_spheres_in_one_place_the_one_whose_surface_was_shaded_is_named(variant, write_scene):
    """A red and a blue sphere with the same center and radius: the render shades one of them;
    the tree names that one's line, not the other's beside its color."""
    path = write_scene("size 20 20\neye 0 0 5\nlight 3 3 3\nsphere 0 0 0 1 color 1 0 0  # red\n"
                       "sphere 0 0 0 1 color 0 0 1 reflect 0.2  # blue\n")
    root = trace_pixel(path, 10, 10).root
    named = {4: (1.0, 0.0, 0.0, 0.0), 5: (0.0, 0.0, 1.0, 0.2)}[root.sphere.line]
    assert (*root.material["color"], root.material["reflect"]) == pytest.approx(named)


def test_a_statement_continued_over_lines_is_shown_whole(llvm, write_scene):
    """A sphere and a light each written over several lines (a trailing backslash): the tree
    shows the whole statement and the comment on its last line, not 'sphere 0 0 0 1 \\'."""
    path = write_scene("size 20 20\neye 0 0 5\nlight 3 3 3 \\\n   1 0.5 0.5\nsphere 0 0 0 1 \\\n"
                       "  color 1 0 0 \\\n  reflect 0.2   # the red one\n")
    tree = trace_pixel(path, 10, 10)
    root = tree.root
    assert root.sphere.line == 5 and root.sphere.comment == "the red one"
    assert root.sphere.statement == "sphere 0 0 0 1 color 1 0 0 reflect 0.2"
    assert root.lights[0].statement == "light 3 3 3 1 0.5 0.5"
    assert "hits scene.scn:5: sphere 0 0 0 1 color 1 0 0 reflect 0.2  # the red one" in str(tree)


@pytest.mark.parametrize("name", ["a" * 300 + ".html", "a" * 300 + "/page.html"])
def test_a_page_name_the_system_refuses_is_one_line(tmp_path, capsys, name):
    """A file or folder name longer than the file system allows: one line naming it, no
    traceback (stat's 'File name too long' escaped), nothing written."""
    assert main(["trace", str(TIR), "--pixel", "1", "1", "-o", str(tmp_path / name)]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith("whitted: error: ") and "File name too long" in captured.err
    assert len(captured.err.strip().splitlines()) == 1 and not captured.out and not list(tmp_path.iterdir())


def test_an_xml_without_a_camera_is_named(llvm, tmp_path, capsys):
    """A Mitsuba XML scene without a sensor: the one line names the file, as whitted render's does."""
    scene = tmp_path / "nocamera.xml"
    scene.write_text('<scene version="3.0.0"><shape type="sphere"/></scene>')
    assert main(["trace", str(scene), "--pixel", "0", "0"]) == 2
    err = capsys.readouterr().err
    assert err == f"whitted: error: {scene}: the scene has no sensor (camera) to trace from\n"


@pytest.mark.parametrize("json_output", [False, True])
def test_a_full_disk_behind_standard_output_is_one_line(json_output):
    """``whitted trace ... --json > trees.json`` on a full disk (/dev/full): one line and
    status 2, not an OSError traceback (and no 'Exception ignored' as Python exits)."""
    import os
    import subprocess
    import sys
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    command = [sys.executable, "-m", "whitted", "trace", str(TIR), "--pixel", "160", "90",
               "--variant", "scalar_rgb", *(["--json"] if json_output else [])]
    with open("/dev/full", "w") as full:
        result = subprocess.run(command, stdout=full, stderr=subprocess.PIPE, text=True, timeout=120)
    assert result.returncode == 2, result.stderr
    assert result.stderr == ("whitted: error: cannot write the trees to standard output: "
                             "No space left on device\n")


def test_the_mark_of_a_corner_pixel_is_drawn_whole(llvm, tmp_path, open_page):
    """Pixel (0, 0)'s circle reaches past the image's corner: it is drawn there too, not cut
    to the quarter inside the image."""
    page_file = tmp_path / "corner.html"
    assert main(["trace", str(TIR), "--pixel", "0", "0", "-o", str(page_file)]) == 0
    with open_page(page_file) as page:
        # the circle's left edge, 8 pixels left of the image (its center is 1 pixel in)
        tag = page.evaluate("(() => { const r = document.querySelector('.stage').getBoundingClientRect();"
                            " return document.elementFromPoint(r.left - 8, r.top + 1).tagName; })()")
        assert tag == "circle"
