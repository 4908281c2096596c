"""What ``whitted compare`` shows a first reader: its images in one view per scene (and FLIP
scored in it), the verdict in plain words first, plot labels that do not collide, and a
progress count that agrees with the last line.

The four examples of scenes/ are compared once, shrunk to 48x30 pixels with short
ladders and no fit of the article's model, so that the whole file runs in well under a minute.
"""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import without_headline_rounds, without_report_pictures
from whitted import compare as cmp
from whitted import metrics
from whitted.images import read_image
from whitted.cli import main
from whitted.images import clipped_fraction, to_srgb

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = ("globe", "mirrors", "spheres", "tir")
LADDERS = dict(reference_spp=256, depths=(1, 2, 3), whitted_spp=(1, 4), path_spp=(1, 4, 16, 64), rounds=2,
               quiet=True)


def shrunk(folder: Path, name: str, size: str = "48 30") -> Path:
    text = re.sub(r"(?im)^\s*size\s+\d+\s+\d+\s*$", f"size {size}", (REPO / "scenes" / f"{name}.scn").read_text())
    path = folder / f"{name}.scn"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """The comparison, without fitting the article's model to each reference: nothing here
    reads the fit (test_fit.py and test_compare_findings.py do), and it takes a third of the
    time; nor the plots and contact sheet it writes (the label test draws its own figure)."""
    folder = tmp_path_factory.mktemp("examples")
    (folder / "earth.png").write_bytes((REPO / "scenes" / "earth.png").read_bytes())
    scenes = [shrunk(folder, name) for name in EXAMPLES]
    out = folder / "out"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("whitted.compare.limits.fit_to_reference", lambda *args, **kwargs: None)
        without_report_pictures(patch)
        without_headline_rounds(patch)
        return out, cmp.compare(scenes, cmp.Options(out=out, **LADDERS))


def test_every_image_of_a_scene_is_shown_and_scored_in_one_view(examples):
    out, entries = examples
    views = {e.name: e.view for e in entries}
    # spheres' path-traced reference runs far above 1 (plain sRGB clips a large share): tone-mapped
    assert views["spheres"] == "aces"
    for entry in entries:
        reference = read_image(entry.reference_file)
        clipped = clipped_fraction(to_srgb(reference))
        assert entry.view == ("clip" if clipped < 0.01 else "aces"), entry.name
        shown = np.asarray(__import__("mitsuba").Bitmap(str(out / entry.reference_png)))
        assert clipped_fraction(shown) < 0.01
        for m in entry.measurements[::5]:
            image = read_image(out / m.image)
            assert m.flip == pytest.approx(metrics.flip(image, reference, view=entry.view), abs=1e-6)
            png = np.asarray(__import__("mitsuba").Bitmap(str(out / m.image_png))).astype(int)
            assert np.abs(png - to_srgb(image, view=entry.view)).max() <= 1
            # the relative MSE reads the linear images, whatever the view
            assert m.rel_mse == pytest.approx(metrics.relative_mse(image, reference), rel=1e-5)


def test_the_page_opens_with_the_verdict_in_plain_words(examples):
    """Each scene's section opens with the article model's verdict in one sentence; the
    physically lit ray tree's and the error's scale follow the images."""
    out, entries = examples
    page = (out / "report.html").read_text(encoding="utf-8")
    findings = entries.findings["scenes"]
    for entry in entries:
        section = page[page.index(f'<section class="scene" id="scene-{entry.name}">'):]
        section = section[:section.index("</section>")]
        first = re.search(r"<p[^>]*>(.*?)</p>", section, re.S)
        assert 'class="verdict"' in first.group(0)
        more = html.unescape(re.search(r'<p class="more">(.*?)</p>', section, re.S).group(1))
        assert "0 is identical, 1 about as far off as a black image" in more
        for method, name, text in (("whitted-article", "The article's model", html.unescape(first.group(1))),
                                   ("whitted-physical", "The physically lit ray tree", more)):
            found = findings[entry.name]["methods"][method]
            floor = found["floor"]
            label = f"d{floor['max_depth']} · {floor['spp']} spp"
            assert re.search(rf"{name} is (as good as it gets at|still improving at its costliest render,) "
                             rf"{re.escape(label)}, [^(]+ \(error {floor['rel_mse']:.3g}\)", text), text
            if found["path_seconds_to_floor"] is not None and found["path_seconds_how"] != "nearest":
                assert "the path tracer is" in text


def test_plot_labels_do_not_overlap_on_the_four_examples(examples):
    from matplotlib.transforms import Bbox

    from whitted.compare.plot import error_vs_time_figure

    _, entries = examples
    fig = error_vs_time_figure(list(entries))
    renderer = fig.canvas.get_renderer()
    axes = [ax for ax in fig.get_axes() if ax.texts]
    assert len(axes) == 2 * len(EXAMPLES)
    for ax in axes:
        boxes = [t.get_window_extent(renderer) for t in ax.texts]
        frame = ax.get_window_extent(renderer)
        for i, a in enumerate(boxes):
            assert frame.contains(a.x0, a.y0) and frame.contains(a.x1, a.y1)
            for b in boxes[i + 1:]:
                assert not a.overlaps(b), (ax.get_title(), a, b)
        # nor over a data point (every line's and scatter's), nor over a timing bar
        points = [ax.transData.transform(xy) for line in ax.lines for xy in line.get_xydata()]
        points += [ax.transData.transform(xy) for c in ax.collections for xy in c.get_offsets()]
        for c in ax.collections:
            for segment in getattr(c, "get_segments", lambda: [])():
                (x0, y0), (x1, y1) = ax.transData.transform(segment[0]), ax.transData.transform(segment[-1])
                points += [(x0 + (x1 - x0) * k / 20, y0 + (y1 - y0) * k / 20) for k in range(21)]
        for x, y in points:
            marker = Bbox.from_extents(x - 2, y - 2, x + 2, y + 2)
            assert not any(box.overlaps(marker) for box in boxes), ax.get_title()
        # the ends of each method's curve are labelled, where a reader looks first
        assert len(ax.texts) >= 3


def test_progress_counts_agree_with_the_last_line(tmp_path, capsys, monkeypatch):
    from whitted.compare.scenes import progress_units

    without_report_pictures(monkeypatch)
    scene = shrunk(tmp_path, "mirrors", "24 16")
    options = dict(LADDERS, quiet=False)
    seen = []
    real = progress_units
    import whitted.compare.run as run

    def counting(settings):
        seen.append(real(settings))
        return seen[-1]

    run.progress_units, saved = counting, run.progress_units
    try:
        assert main(["compare", str(scene), "-o", str(tmp_path / "out"), "--reference-spp", "64",
                     "--depths", "1,2", "--spp", "1", "--path-spp", "1,4", "--rounds", "1"]) == 0
    finally:
        run.progress_units = saved
    err = capsys.readouterr().err
    last = [line for line in err.splitlines() if " renders" in line and " in " in line][-1]
    assert int(re.match(r"(\d+) renders", last).group(1)) == sum(seen), last
    assert options  # the ladders above are the CLI's
