"""The report's formulas against values computed by hand: reading a method's curve on
log–log axes, the error floor, the reference's noise estimate, the budget's reference
spp, and the tables built from them (on made-up measurements: nothing is rendered)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from whitted.compare.analysis import analyse, equal_time_how
from whitted.compare.budget import Budget, fit_cost, render_cost
from whitted.compare.curves import (PathModel, best_ambient, error_at_time, error_floor,
                                    error_levels, fit_inverse, loglog_between, pareto_front,
                                    reference_noise, time_to_reach)
from whitted.compare.results import Measurement, SceneResult, Setting
from whitted.defaults import (COMPARE_MIN_REFERENCE_SPP, COMPARE_REFERENCE_SHARE,
                              COMPARE_REPORT_SECONDS)

# A path tracer whose error is exactly 0.64/spp and whose time is 0.01 s per spp: on
# log–log axes a straight line of slope −1 (error = 0.0064 / seconds).
PATH = [(0.01 * n, 0.64 / n, f"{n} spp") for n in (1, 4, 16, 64)]


def test_loglog_line_through_two_points():
    # y = 0.5 · (x / 1) ** s with s = ln(0.125 / 0.5) / ln(4 / 1) = −1: at x = 2, y = 0.25
    assert loglog_between(2.0, (1.0, 0.5), (4.0, 0.125)) == pytest.approx(0.25)
    # slope ln(100/1) / ln(10/1) = 2: at x = sqrt(10), y = 10
    assert loglog_between(math.sqrt(10), (1.0, 1.0), (10.0, 100.0)) == pytest.approx(10.0)
    assert loglog_between(3.0, (3.0, 0.2), (3.0, 0.1)) == 0.1  # two renders at one time


def test_error_at_time_interpolates_on_the_front_and_says_how():
    reading = error_at_time(PATH, 0.08)  # between 4 spp (0.04 s) and 16 spp (0.16 s)
    assert reading.how == "interpolated" and reading.between == ("4 spp", "16 spp")
    assert reading.value == pytest.approx(0.0064 / 0.08)  # = 0.08, on the 1/spp line
    exact = error_at_time(PATH, 0.16)
    assert exact.value == pytest.approx(0.04) and exact.how == "interpolated"
    faster = error_at_time(PATH, 0.001)  # faster than any path render: its nearest, not a guess
    assert (faster.value, faster.how, faster.between) == (0.64, "nearest", ("1 spp",))
    slower = error_at_time(PATH, 10.0)
    assert (slower.value, slower.how, slower.between) == (0.01, "nearest", ("64 spp",))
    assert error_at_time(PATH, 0.01).how == "rendered"
    assert error_at_time([], 1.0) is None


def test_a_beaten_render_is_not_on_the_curve():
    # 0.1 s at error 0.5 is beaten by the faster 0.04 s at 0.16: read between 0.04 and 0.16 s
    curve = PATH + [(0.1, 0.5, "slow and bad")]
    assert error_at_time(curve, 0.08).between == ("4 spp", "16 spp")
    assert pareto_front([(1.0, 0.5), (2.0, 0.6), (3.0, 0.2), (0.5, 0.9), (4.0, 0.2)]) == [
        (0.5, 0.9), (1.0, 0.5), (3.0, 0.2)]
    assert pareto_front([(1.0, 0.0), (2.0, math.nan), (3.0, 0.1)]) == [(3.0, 0.1)]  # log axes


def test_time_to_reach_solves_the_loglog_line_for_time():
    reading = time_to_reach(PATH, 0.02)  # between 16 spp (0.04) and 64 spp (0.01)
    assert reading.how == "interpolated" and reading.between == ("16 spp", "64 spp")
    assert reading.value == pytest.approx(0.0064 / 0.02)  # = 0.32 s
    # an uneven line: from (1, 1) to (4, 0.25·0.5) the slope is ln(0.125)/ln(4) = −1.5;
    # error 0.25 is reached at x = 1 · 0.25 ** (1 / −1.5) = 2.5198...
    uneven = [(1.0, 1.0, "a"), (4.0, 0.125, "b")]
    assert time_to_reach(uneven, 0.25).value == pytest.approx(0.25 ** (-1 / 1.5))
    first = time_to_reach(PATH, 1.0)  # its fastest render is already better
    assert (first.value, first.how) == (0.01, "nearest")
    assert time_to_reach(PATH, 0.001) is None  # never reached
    assert time_to_reach(PATH, 0.04).how == "rendered"


def test_error_floor_is_the_cheapest_render_within_the_tolerance_of_the_best():
    # (seconds, error, name): the best is 0.1 (at 0.2 s); within 5% (<= 0.105) the cheapest is
    # 0.104 at 0.03 s, not the 0.1 at 0.2 s nor the faster 0.2 at 0.01 s
    curve = [(0.01, 0.2, "d1"), (0.03, 0.104, "d3"), (0.05, 0.1049, "d4"), (0.2, 0.1, "d5·16"),
             (0.02, 0.5, "slow and bad")]
    floor = error_floor(curve, 0.05)
    assert (floor.render, floor.seconds, floor.error, floor.best, floor.settled) == (
        "d3", 0.03, 0.104, 0.1, True)
    floor = error_floor(curve, 0.01)  # within 1% (<= 0.101): only the best itself
    assert (floor.render, floor.error, floor.settled) == ("d5·16", 0.1, False)  # nothing costlier
    assert error_floor([(0.01, 0.3, "a"), (0.02, 0.2, "b")], 0.05).settled is False
    assert error_floor([], 0.05) is None and error_floor([(1.0, math.nan, "x")], 0.05) is None
    # two equally fast renders within the tolerance: the more accurate
    assert error_floor([(0.1, 0.104, "a"), (0.1, 0.101, "b"), (0.5, 0.1, "c")], 0.05).render == "b"


def test_error_levels_include_each_floor_and_levels_between():
    # floors 0.16 and 0.0123: times 1.05 = 0.168 -> 0.17 and 0.012915 -> 0.013 (rounded up);
    # between 0.001 and 1, two levels evenly on log axes: 0.01 and 0.1
    levels = error_levels([0.16, 0.0123], 0.001, 1.0, 2, 0.05)
    assert levels == (0.17, 0.1, 0.013, 0.01)
    for floor in (0.16, 0.0123):  # each floor's method reaches a level
        assert any(floor <= level for level in levels)
    # a level within 10% of a larger one is left out: 0.105 -> 0.11 keeps 0.1 out
    assert error_levels([0.1], 0.001, 1.0, 2, 0.05) == (0.11, 0.01)
    assert error_levels([], 0.5, 0.5, 2, 0.05) == ()
    assert error_levels([0.12], 0.5, 0.5, 2, 0.05) == (0.13,)  # 0.126, rounded up


def test_best_ambient_minimises_the_relative_mse_of_the_affine_image():
    """I(A) = I0 + A·(I1 − I0): the closed form agrees with a fine search over [0, 1]."""
    from whitted import metrics

    rng = np.random.default_rng(11)
    dark = rng.uniform(0.0, 0.5, (8, 8, 3))
    lit = dark + rng.uniform(0.1, 0.4, dark.shape)
    reference = dark + 0.37 * (lit - dark) + rng.normal(0, 0.01, dark.shape)
    ambient, error = best_ambient(dark, lit, reference)
    search = min(np.linspace(0, 1, 10001),
                 key=lambda a: metrics.relative_mse(dark + a * (lit - dark), reference))
    assert ambient == pytest.approx(search, abs=2e-4) and ambient == pytest.approx(0.37, abs=0.02)
    assert error == pytest.approx(metrics.relative_mse(dark + ambient * (lit - dark), reference))
    assert error <= metrics.relative_mse(dark + 0.2 * (lit - dark), reference)
    # a reference brighter than A = 1 can make: clipped to 1
    assert best_ambient(dark, lit, lit * 2)[0] == 1.0
    # nothing depends on A: no ambient to fit
    ambient, error = best_ambient(dark, dark, reference)
    assert math.isnan(ambient) and error == pytest.approx(metrics.relative_mse(dark, reference))


def test_reference_noise_by_hand():
    # One pixel, one channel... three channels alike: A = 1.1, B = 0.9, equal halves.
    # R = 1.0; mean((A − B)² / (R² + 0.01)) · ¼ = 0.04 / 1.01 / 4
    a = np.full((1, 1, 3), 1.1)
    b = np.full((1, 1, 3), 0.9)
    assert reference_noise(a, b, 8, 8) == pytest.approx(0.04 / 1.01 / 4)
    # unequal halves 1 and 3 spp: R = (1.1 + 3 · 0.9) / 4 = 0.95; weight 1·3/16
    assert reference_noise(a, b, 1, 3) == pytest.approx(0.04 / (0.95 ** 2 + 0.01) * 3 / 16)
    assert reference_noise(a, a, 4, 4) == 0


def test_reference_noise_estimates_the_error_of_the_average():
    """Monte Carlo: halves of N/2 noisy samples each. The estimate matches the average's
    true relative MSE against the noiseless image, and is the floor a perfect render
    scores against the average; a render of n spp scores about its own error plus it."""
    from whitted import metrics

    rng = np.random.default_rng(7)
    truth = rng.uniform(0.2, 1.0, (64, 64, 3))
    n, sigma = 64, 0.2  # a reference's noise is small beside its values: a few percent here

    def render(spp):
        return truth + rng.normal(0, sigma, truth.shape) / math.sqrt(spp)

    halves = [render(n // 2), render(n // 2)]
    reference = (halves[0] + halves[1]) / 2
    estimate = reference_noise(*halves, n // 2, n // 2)
    assert estimate == pytest.approx(np.mean((reference - truth) ** 2 / (truth ** 2 + 0.01)), rel=0.1)
    assert estimate == pytest.approx(metrics.relative_mse(truth, reference), rel=0.1)
    four = render(4)
    own = np.mean((four - truth) ** 2 / (truth ** 2 + 0.01))
    assert metrics.relative_mse(four, reference) == pytest.approx(own + estimate, rel=0.1)


def test_budget_scales_the_reference_down_to_a_power_of_two_or_refuses():
    share = COMPARE_REFERENCE_SHARE

    def cost(spp):  # 1 ms per spp
        return 0.001 * spp

    # a 10 s share: the reference may take share · 10 s = 5 s: 5000 spp fit
    assert Budget.reference_spp(4096, cost, 10.0) == 4096
    assert Budget.reference_spp(8192, cost, 10.0) == 4096  # 5000 -> the power of two below
    assert Budget.reference_spp(6000, cost, 10.0) == 4096
    assert Budget.reference_spp(8192, cost, 10.0, spent=share * 10.0 - 1.0) == 512  # 1 s: 1000
    assert Budget.reference_spp(4096, cost, math.inf) == 4096
    minimum = COMPARE_MIN_REFERENCE_SPP
    assert Budget.reference_spp(4096, lambda spp: spp * share * 10.0 / minimum, 10.0) == minimum
    assert Budget.reference_spp(4096, lambda spp: spp * share * 10.0 / (minimum - 0.5), 10.0) is None
    assert Budget.reference_spp(4096, cost, 0.0) is None


def test_render_cost_fits_a_cost_per_call_and_per_spp():
    # probes: 1 spp took 5.1 s, 2 spp 5.9 s: 0.8 s per spp and 4.3 s per render call
    overhead, per_spp = fit_cost([(1, 5.1), (2, 5.9)])
    assert (overhead, per_spp) == (pytest.approx(4.3), pytest.approx(0.8))
    # 10 spp in 3 passes (4 + 4 + 2): 3 · 4.3 s + 10 · 0.8 s
    assert render_cost(10, 3, overhead, per_spp) == pytest.approx(3 * 4.3 + 8.0)
    assert render_cost(0, 0, overhead, per_spp) == 0
    # one probe, or timings that fall (noise): all of the time per spp, an upper bound
    assert fit_cost([(4, 2.0)]) == (0.0, 0.5)
    assert fit_cost([(1, 3.0), (2, 2.5)]) == (0.0, 1.25)


def test_budget_share_keeps_time_for_the_outputs():
    budget = Budget(40.0)
    assert budget.reserve(1) == COMPARE_REPORT_SECONDS
    assert budget.reserve(2) == 2 * COMPARE_REPORT_SECONDS
    assert budget.reserve(100) == pytest.approx(10.0)  # at most a quarter of the budget
    assert budget.share(2) == pytest.approx((40.0 - budget.reserve(2)) / 2, abs=0.05)
    assert Budget(None).share(3) == math.inf and Budget(None).reserve(3) == 0


def _measurement(method: str, depth: int, spp: int, seconds: float, rel_mse: float) -> Measurement:
    integrator, lighting = ("path", "physical") if method == "path" else ("whitted", method.split("-")[1])
    return Measurement(Setting(integrator, lighting, spp, depth), seconds, 0.0, rel_mse,
                       rel_mse / 10, spp * depth, times=(seconds * 0.9, seconds, seconds * 1.2))


@pytest.fixture
def scene_result() -> SceneResult:
    """The article's model: error 0.3, 0.12, 0.1, 0.1 by depth at 1 spp (0.002 s per depth),
    0.098 at depth 3 and 4 spp; the path tracer as in PATH."""
    entry = SceneResult("made-up", None, 32, 24, "test", 1024, 3)
    errors = {1: 0.3, 2: 0.12, 3: 0.1, 4: 0.1}
    entry.measurements = [_measurement("whitted-article", d, 1, 0.002 * d, e) for d, e in errors.items()]
    entry.measurements.append(_measurement("whitted-article", 3, 4, 0.024, 0.098))
    entry.measurements += [_measurement("path", 3, int(n.split()[0]), t, e) for t, e, n in PATH]
    return entry


def test_equal_time_reads_the_path_tracer_at_each_whitted_time(scene_result):
    analysis = analyse(scene_result, (0.2, 0.05))
    rows = {(r.whitted.setting.max_depth, r.whitted.setting.spp): r for r in analysis.equal_time}
    assert len(rows) == 5
    # depth 2 at 1 spp took 0.004 s: faster than the path tracer's 1 spp (0.01 s): the path
    # tracer was not measured then, so nothing is compared
    assert rows[(2, 1)].outside == "faster" and math.isnan(rows[(2, 1)].ratio)
    assert equal_time_how(rows[(2, 1)]) == "faster than the path tracer's fastest render (1 spp, 10 ms)"
    assert rows[(3, 4)].outside is None
    # depth 3 at 4 spp took 0.024 s: the path tracer's 0.0064 / 0.024 there
    assert rows[(3, 4)].rel_mse.value == pytest.approx(0.0064 / 0.024)
    assert rows[(3, 4)].flip.value == pytest.approx(0.00064 / 0.024)


def test_equal_quality_shows_floors_and_speedups(scene_result):
    analysis = analyse(scene_result, (0.2, 0.05))
    at_02, at_005 = analysis.equal_quality
    article, path = at_02.reach["whitted-article"], at_02.reach["path"]
    assert article.fastest.setting == Setting("whitted", "article", 1, 2)  # 0.12 at 0.004 s
    assert path.fastest.setting.spp == 4  # 0.16 at 0.04 s
    assert at_02.speedups["whitted-article"].value == pytest.approx(0.04 / 0.004)
    assert at_02.fastest_method == "whitted-article"
    # 0.05: the article's model never gets there; its floor (best render) is shown instead
    assert at_005.reach["whitted-article"].fastest is None
    assert at_005.reach["whitted-article"].best.rel_mse == 0.098
    assert "whitted-article" not in at_005.speedups and at_005.fastest_method == "path"


@pytest.mark.parametrize("physical_times, fastest, tied", [
    ((0.0041, 0.0042, 0.0046), "whitted-article", True),    # 1.14, 1.05, 0.96 × the article's
    ((0.0037, 0.0038, 0.0047), "whitted-physical", True),   # 1.03, 0.95, 0.98: by the clock alone
    ((0.00367, 0.00408, 0.0049), "whitted-article", True),  # 1.02 every round: within the share
    ((0.00396, 0.0044, 0.00528), "whitted-article", False),  # 1.1 every round: beyond it
    ((0.0080, 0.0078, 0.0094), "whitted-article", False),   # twice the article's, every round
])
def test_equal_quality_says_which_methods_tie_for_fastest(scene_result, physical_times, fastest,
                                                          tied):
    """The article's and the physical lighting's renders of one ray tree do the same work:
    which is "fastest" is the clock's noise unless their paired rounds put one more than
    COMPARE_RUN_SHARE (5%, what moves between runs) ahead, which a run beside another program
    does not undo; a tie is said in one order, whichever the clock favoured."""
    physical = _measurement("whitted-physical", 2, 1, physical_times[1], 0.15)
    scene_result.measurements.append(replace(physical, times=physical_times))
    at_02 = analyse(scene_result, (0.2,)).equal_quality[0]
    assert at_02.fastest_method == fastest   # the article's times: (0.0036, 0.004, 0.0048)
    other = ({"whitted-article", "whitted-physical"} - {fastest}).pop()
    assert at_02.ties == ((other,) if tied else ())
    assert at_02.fastest_text == ("whitted-article ≈ whitted-physical" if tied
                                  else "whitted-article")


def test_floor_is_stated_with_the_path_tracers_time_to_reach_it(scene_result):
    analysis = analyse(scene_result, (0.2,))
    (floor,) = analysis.floors
    # best 0.098 (d3 · 4 spp, 0.024 s); within 5% (<= 0.1029) the cheapest is d3 · 1 spp:
    # 0.1 in 0.006 s
    assert floor.render.setting == Setting("whitted", "article", 1, 3)
    assert (floor.floor.error, floor.floor.best, floor.floor.settled) == (0.1, 0.098, True)
    assert floor.path.value == pytest.approx(0.0064 / 0.1)  # 64 ms on the 1/spp line
    assert floor.text.startswith("The article's model stops improving at 0.098")
    assert "d3 · 1 spp (6 ms) at 0.1" in floor.text and "64 ms" in floor.text
    assert f"{0.064 / 0.006:.3g}× faster" in floor.text


def test_levels_come_from_the_data_by_default(scene_result):
    analysis = analyse(scene_result)
    # the article's floor 0.1 -> 0.105 -> 0.11; the path tracer's best 0.01 -> 0.0105 -> 0.011;
    # between 0.01 and 0.64 on log axes: 0.01 · 64^(1/3) = 0.04, 0.01 · 64^(2/3) = 0.16
    assert analysis.levels == (0.16, 0.11, 0.04, 0.011)
    for method in ("whitted-article", "path"):
        assert any(row.reach[method].fastest is not None for row in analysis.equal_quality)


def test_inverse_fit_of_the_variance_given_c():
    # three points on 0.01 + 0.64/n
    assert fit_inverse([1, 4, 16], [0.65, 0.17, 0.05], 0.01) == pytest.approx(0.64)
    # off the curve: with w = 1/e (2 and 10), x = 1/n and c = 0.1,
    # v = Σ w²·x·(e − c) / Σ w²·x² = (4·1·0.4 + 100·0.25·0) / (4·1 + 100·0.0625)
    #   = 1.6 / 10.25
    assert fit_inverse([1, 4], [0.5, 0.1], 0.1) == pytest.approx(1.6 / 10.25)


def test_path_model_error_and_spp_to_reach():
    model = PathModel(0.01, 0.64, (1, 4, 16), 16, 0.0)
    assert model.error(64) == pytest.approx(0.02)
    assert model.spp_to_reach(0.02) == pytest.approx(64)   # 0.64 / (0.02 − 0.01)
    assert model.spp_to_reach(0.01) == math.inf            # never below c


def test_path_model_is_checked_by_the_next_render():
    from whitted.compare.sweep import checked_path_model

    path = [_measurement("path", 3, n, 0.01 * n, 0.01 + 0.64 / n) for n in (1, 4, 16)]
    assert checked_path_model(path, 0.01) is None   # fitted, not yet checked
    model = checked_path_model(path + [_measurement("path", 3, 64, 0.64, 0.02)], 0.01)
    assert (model.fitted, model.checked) == ((1, 4, 16, 64), 64)
    assert (model.c, model.v, model.deviation) == pytest.approx((0.01, 0.64, 0.0), abs=1e-9)
    # a render 20% off the prediction at 64 spp (0.02): not checked, the ladder goes on
    assert checked_path_model(path + [_measurement("path", 3, 64, 0.64, 0.025)], 0.01) is None


def test_floor_below_the_rendered_path_is_read_from_the_fitted_curve(scene_result):
    # the article's model at 0.005, below the path tracer's best render (64 spp: 0.01)
    scene_result.measurements.append(_measurement("whitted-article", 4, 4, 0.032, 0.005))
    scene_result.path_spp = (1, 4, 16, 64, 256)
    scene_result.path_model = PathModel(0.0, 0.64, (1, 4, 16, 64), 64, 0.02)
    analysis = analyse(scene_result, (0.003,))
    (floor,) = analysis.floors
    # 0.64 / 0.005 = 128 spp; on the line through 16 and 64 spp (0.01 s per spp): 1.28 s
    assert floor.path.how == "fitted" and floor.path.value == pytest.approx(1.28)
    # every round's times are the medians' times the same factor: the ratio is constant
    assert floor.interval.value == pytest.approx(1.28 / 0.032) and floor.interval.rounds == 3
    assert ("read from its fitted curve at 128 spp: error = 0 + 0.64/n, fitted to 1–64 spp and "
            "checked at 64 spp within 2%; time = a + b·n through its 16 spp and 64 spp renders"
            in floor.text)
    assert analysis.findings()["methods"]["whitted-article"]["path_seconds_how"] == "fitted"
    # 256 spp is not rendered: 0.0025 in 2.56 s, read from the fitted curve
    (row,) = analysis.equal_quality
    fastest = row.reach["path"].fastest
    assert fastest.modelled and fastest.rel_mse == pytest.approx(0.0025)
    assert fastest.seconds == pytest.approx(2.56)
    from whitted.compare.analysis import reach_text
    assert reach_text(row.reach["path"]) == "2.56 s (256 spp, fitted)"
    assert analysis.findings()["path_model"]["read_spp"] == [256]


def test_equal_time_past_the_rendered_path_says_it_is_read_from_the_fitted_curve(scene_result):
    # a Whitted render of 1.28 s, slower than the path tracer's 64 spp (0.64 s): read on the
    # log–log line to its fitted 256 spp (2.56 s, 0.0025): 0.01 · (1.28 / 0.64)^−1 = 0.005
    scene_result.measurements.append(_measurement("whitted-article", 4, 16, 1.28, 0.2))
    scene_result.path_spp = (1, 4, 16, 64, 256)
    scene_result.path_model = PathModel(0.0, 0.64, (1, 4, 16, 64), 64, 0.02)
    row = next(r for r in analyse(scene_result, (0.2,)).equal_time if r.whitted.seconds == 1.28)
    assert row.outside is None and row.rel_mse.how == "fitted"
    assert row.rel_mse.value == pytest.approx(0.005)
    assert equal_time_how(row) == "on the fitted curve 64–256 spp"


def test_contact_sheet_says_which_path_counts_are_read_from_the_fitted_curve(scene_result):
    from whitted.compare.sheet import _rows

    scene_result.path_spp = (1, 4, 16, 64, 256, 1024)
    scene_result.path_model = PathModel(0.0, 0.64, (1, 4, 16, 64), 64, 0.02)
    (reference, *path), *_ = _rows(scene_result)
    cells = {title: (image, caption) for title, image, caption in path}
    # rendered: its thumbnail; 256 and 1024 spp: no image, 0.64 / n on the line of 0.01 s per spp
    assert "FLIP" in cells["path · 64 spp"][1]
    assert cells["path · 256 spp"] == (None, "fitted curve, not rendered\nrel 0.0025 · 2.56 s")
    assert cells["path · 1024 spp"] == (None, "fitted curve, not rendered\nrel 0.000625 · 10.2 s")
    scene_result.path_model = None
    (_, *path), *_ = _rows(scene_result)
    assert [caption for title, _, caption in path if "256" in title] == ["not rendered"]


def test_a_reference_its_probes_rendered_already_is_kept_when_they_overran_the_share():
    """A 1600×1000 scene under --quick on a busy machine: the two 16-spp halves that probe the
    reference's noise took 11 s of a 21.6 s share, more than the reference's half of it, and
    the scene was skipped whole, "affords less than the 8 spp a usable reference needs", with
    a 32-spp reference rendered: what is rendered costs nothing more, and is used."""
    share = COMPARE_REFERENCE_SHARE

    def cost(spp):   # the probes' 32 spp are done; each spp more: 0.2 s
        return 0.2 * max(0, spp - 32)

    assert Budget.reference_spp(256, cost, 21.6, spent=share * 21.6 + 0.5) == 32
    assert Budget.reference_spp(256, cost, 21.6, spent=share * 21.6 - 6.5) == 64
    assert Budget.reference_spp(256, lambda spp: 0.2 * spp, 21.6, spent=share * 21.6 + 0.5) is None
