"""Timing whose conclusions reproduce (whitted/compare/timing.py): renders timed in
interleaved rounds, ratios paired by round with an interval, floors chosen by work.

No render here: the sweep's renders are stand-ins whose times the test sets, and the
reports are made from hand-built results.
"""

from __future__ import annotations

import json
import math
import random

import numpy as np
import pytest

import whitted.compare as cmp
from whitted.compare.analysis import analyse
from whitted.compare.results import Limit, Measurement, SceneResult, Setting
from whitted.compare.report import findings, summary
from whitted.compare.analysis import faster_text, ratio_text
from whitted.compare.timing import Interval, _order_rank
from whitted.defaults import COMPARE_LONG_ROUNDS, COMPARE_MAX_ROUNDS, COMPARE_RUN_SHARE, COMPARE_SETTLED_WIDTH


# --------------------------------------------------------------------------- the interval

def _binomial_tail(n: int, k: int) -> float:
    """P(Binomial(n, ½) < k), summed term by term."""
    return sum(math.comb(n, i) for i in range(k)) / 2 ** n


@pytest.mark.parametrize("n", range(1, 30))
def test_the_interval_is_the_widest_order_statistics_of_90_percent(n):
    """[x(k), x(n+1-k)] holds the median with probability 1 - 2·P(X < k): k is the largest
    rank whose two tails stay within 10% (1 where even the extremes do not)."""
    k = _order_rank(n, 0.9)
    if k > 1:
        assert 2 * _binomial_tail(n, k) <= 0.1
    assert k == (n + 1) // 2 or 2 * _binomial_tail(n, k + 1) > 0.1


def test_coverage_is_the_binomial_probability_of_the_interval():
    """coverage(n): 1 - 2 P(Bin(n, 1/2) < k) for the interval's rank k; 75% over three rounds
    (their extremes), 90% or more from five rounds on (checked by simulation too)."""
    from whitted.compare.timing import coverage
    assert coverage(1) == 0.0 and coverage(2) == 0.5 and coverage(3) == 0.75
    assert all(coverage(n) >= 0.9 for n in range(5, 30))
    rng = random.Random(3)
    for n in (3, 7, 11):
        inside = 0
        for _ in range(4000):
            values = [rng.gauss(0.0, 1.0) for _ in range(n)]   # true median 0
            interval = Interval.of(values)
            inside += interval.low <= 0.0 <= interval.high
        assert abs(inside / 4000 - coverage(n)) < 0.025, (n, inside / 4000, coverage(n))


def test_interval_of_known_values():
    # n = 9: k = 2 (P(X < 2) = 10/512 ≈ 0.0195; P(X < 3) ≈ 0.0898 > 0.05)
    interval = Interval.of([5, 1, 9, 3, 7, 2, 8, 4, 6])
    assert (interval.value, interval.low, interval.high, interval.rounds) == (5, 2, 8, 9)
    # NaN (a round where nothing was compared) is left out
    assert Interval.of([2.0, math.nan, 2.2, 1.8]).rounds == 3


def test_an_interval_holding_one_is_no_measurable_difference():
    even = Interval.of([0.9, 1.05, 1.1, 0.95, 1.2])
    assert even.straddles_one
    assert faster_text(even, "the article's model", "the path tracer").startswith(
        "no measurable difference in time between the article's model and the path tracer")
    assert ratio_text(even).startswith("≈ 1 (0.9–1.2)")
    clear = Interval.of([2.0, 2.1, 1.9, 2.2, 2.05])
    assert not clear.straddles_one and clear.settled
    assert faster_text(clear, "A", "B") == "A gets there 2.05× faster (1.9–2.2× over 5 rounds)"
    slower = Interval.of([0.5, 0.5, 0.5])
    assert faster_text(slower, "A", "B") == "B gets there 2× faster (2–2× over 3 rounds)"


def test_a_wide_interval_is_unsettled_and_says_so():
    wide = Interval.of([1.5, 3.0, 2.0, 4.0, 1.6])
    assert wide.high / wide.low > 1 + COMPARE_SETTLED_WIDTH and not wide.settled
    assert "unsettled" in faster_text(wide, "A", "B")
    assert ratio_text(wide).endswith("?")


# --------------------------------------------------------------------------- made-up results

def _measurement(method: str, depth: int, spp: int, times, rel_mse: float, work: int) -> Measurement:
    integrator, lighting = ("path", "physical") if method == "path" else ("whitted", method.split("-")[1])
    times = tuple(times)
    return Measurement(Setting(integrator, lighting, spp, depth), float(np.median(times)) if times else 0.01, 0.0,
                       rel_mse, rel_mse / 10, work, times=times)


def _entry(whitted_times, path_times, rounds: int = 7) -> SceneResult:
    """The article's model at depths 1–6, 1 spp (errors 0.3, 0.15, 0.102, 0.1, 0.101, 0.1:
    four renders within 5% of the best), each depth costing more rays; the path tracer at
    1, 4, 16 spp (errors 0.4, 0.1, 0.025). ``*_times(setting, round)`` give the times."""
    entry = SceneResult("made-up", None, 32, 24, "test", 1024, 6)
    for depth, error in zip(range(1, 7), (0.3, 0.15, 0.102, 0.1, 0.101, 0.1)):
        setting = (depth, 1)
        entry.measurements.append(_measurement("whitted-article", depth, 1,
                                               [whitted_times(setting, r) for r in range(rounds)],
                                               error, 1000 * depth))
    for spp, error in ((1, 0.4), (4, 0.1), (16, 0.025)):
        entry.measurements.append(_measurement("path", 6, spp, [path_times(spp, r) for r in range(rounds)],
                                               error, spp * 768))
    return entry


def _steady_whitted(setting, r):
    return 0.002 * setting[0]


def _steady_path(spp, r):
    return 0.01 * spp


def test_the_floor_is_the_render_of_least_work_whatever_the_timings(tmp_path):
    """Depths 3–6 are within 5% of the best error: the floor is depth 3 (fewest rays), and
    stays so when every time is perturbed (up to 3× either way, per render and round), where
    the fastest of them would follow the noise."""
    baseline = analyse(_entry(_steady_whitted, _steady_path)).floors[0].render.setting
    assert baseline == Setting("whitted", "article", 1, 3)
    rng = random.Random(5)
    chosen = set()
    for _ in range(50):
        noise = {}

        def noisy(setting, r, base=_steady_whitted):
            return base(setting, r) * noise.setdefault((setting, r), 3 ** rng.uniform(-1, 1))
        entry = _entry(noisy, lambda spp, r: _steady_path(spp, r) * 3 ** rng.uniform(-1, 1))
        chosen.add(analyse(entry).floors[0].render.setting)
    assert chosen == {baseline}


def test_a_load_shared_by_a_round_leaves_the_headline_alone():
    """Each round is slowed by its own factor (1–4×, as another program comes and goes): the
    median times move, but the ratios paired by round do not."""
    load = [1.0, 3.7, 1.4, 2.2, 4.0, 1.1, 2.9]
    steady = analyse(_entry(_steady_whitted, _steady_path)).floors[0]
    loaded = analyse(_entry(lambda s, r: _steady_whitted(s, r) * load[r],
                            lambda spp, r: _steady_path(spp, r) * load[r])).floors[0]
    assert loaded.interval.value == pytest.approx(steady.interval.value)
    # every round agrees: only what moves between runs widens it
    assert loaded.interval.low * (1 + COMPARE_RUN_SHARE) ** 2 == pytest.approx(loaded.interval.high)
    assert loaded.interval.settled and loaded.interval.rounds == 7
    # unpaired, the same times would give anything from a quarter to four times the ratio
    assert max(load) / min(load) == 4.0


@pytest.mark.parametrize("noise", [0.06, 0.04])
def test_errors_within_twice_the_reference_noise_say_so(noise):
    """An error within a factor 2 of the reference's own noise cannot be told from that
    noise: the floor's words and the decomposition's say so, and with a quieter reference
    they do not. A limit whose own noise is too high says that its parts are rough.
    What the report says is read from findings.json and summary.txt."""
    entry = _entry(_steady_whitted, _steady_path)
    entry.reference_noise = noise
    entry.limits["whitted-article"] = Limit("whitted-article", 6, 64, noise=0.02, converged=False,
                                            rel_mse=0.09, seconds=1.0)
    analysis = analyse(entry)
    (floor,), (decomposition,) = analysis.floors, analysis.decompositions
    cautioned = floor.floor.error < 2 * noise
    assert cautioned == (noise == 0.06)   # the two cases: 0.102 against 0.12, then 0.08
    assert ("Caution: that is within a factor 2 of the reference's own noise" in floor.text) == cautioned
    assert (decomposition.limit.rel_mse < 2 * noise) == cautioned
    assert ("within a factor 2 of the reference's own noise" in decomposition.text) == cautioned
    assert ("is light the model does not transport" in decomposition.text) != cautioned
    assert "no pixel depends on the ambient, so all 0.09 of it" in decomposition.text
    assert "The limit's own noise, 0.02, is not yet a tenth" in decomposition.text
    found = findings([analysis])["scenes"]["made-up"]["methods"]["whitted-article"]
    assert (found["floor_text"], found["text"]) == (floor.text, decomposition.text)
    assert found["limit"]["converged"] is False
    text = " ".join(summary([analysis]).split())
    assert floor.text in text and decomposition.text in text


def test_interval_and_unsettled_flag_reach_findings_summary_and_page(tmp_path):
    """A path tracer whose times jump by round while the Whitted renders' do not: the headline
    never settles, and every report says so, with the interval."""
    jumpy = [1.0, 2.5, 0.8, 3.0, 1.2, 2.8, 0.9]
    entry = _entry(_steady_whitted, lambda spp, r: _steady_path(spp, r) * jumpy[r])
    analysis = analyse(entry)
    (floor,) = analysis.floors
    assert not floor.interval.settled

    found = findings([analysis])["scenes"]["made-up"]["methods"]["whitted-article"]
    headline = found["path_time_over_floor_time"]
    assert headline["rounds"] == 7 and headline["settled"] is False
    assert headline["low"] < headline["value"] < headline["high"]
    assert json.loads(json.dumps(found))   # plain JSON
    assert "over 7 rounds" in found["floor_text"] and "unsettled" in found["floor_text"]

    text = summary([analysis])
    assert "unsettled" in text and f"{headline['low']:.3g}–{headline['high']:.3g}× over 7 rounds" in text

    from whitted.compare.report import write_page
    page = tmp_path / "report.html"
    write_page(page, [analysis], {"made-up": "plot.png"},
               {"csv": "results.csv", "plot": "plot.png", "sheet": "sheet.png",
                "summary": "summary.txt", "findings": "findings.json"})
    html = page.read_text(encoding="utf-8")
    html = html[:html.index('<section id="glossary">')]  # which defines "unsettled" on every page
    assert "unsettled" in html and "over 7 rounds" in html


# --------------------------------------------------------------------------- the rounds

class _FakeRenders:
    """Stands in for whitted.rendering.render: ``seconds(setting, call)`` is each render's
    time, by which it advances the sweep's clock (``monotonic``, installed as the sweep
    module's ``time``); the calls are kept, in order."""

    def __init__(self, seconds, monkeypatch):
        import whitted.compare.sweep as sweep_module
        import whitted.rendering as render_module
        self.seconds, self.calls, self.now = seconds, [], 1000.0
        monkeypatch.setattr(render_module, "render", self)
        monkeypatch.setattr(sweep_module, "time", self)

    def monotonic(self) -> float:
        return self.now

    def __call__(self, scene, **kwargs):
        from whitted.rendering import RenderResult
        setting = (kwargs["integrator"], kwargs["max_depth"], kwargs["spp"])
        t = self.seconds(setting, len(self.calls))
        self.calls.append(setting)
        self.now += t
        return RenderResult(np.zeros((4, 4, 3), np.float32), t, 0.0, {"rays": {"camera": 16}}, t)


def _sweep_entry() -> SceneResult:
    entry = SceneResult("made-up", None, 4, 4, "test", 1024, 6)
    for depth, error in ((1, 0.3), (2, 0.2)):
        entry.measurements.append(_measurement("whitted-article", depth, 1, (), error, depth))
    for spp, error in ((1, 0.4), (4, 0.1)):
        entry.measurements.append(_measurement("path", 6, spp, (), error, spp))
    return entry


def test_rounds_interleave_the_settings_forward_then_backward(monkeypatch):
    """The first round times every setting once, in order; the next ones, in reverse then in
    order, only the renders the verdict reads (the path tracer's, floors, each level's
    cheapest); within a round a render under 50 ms is repeated until its renders add up to
    50 ms (at most 8) and the fastest kept."""
    import itertools

    import whitted.compare.sweep as sweep_module
    from whitted.compare.sweep import time_rounds
    monkeypatch.setattr(sweep_module, "COMPARE_HEADLINE_ROUNDS", 0)   # the regular rounds alone
    base = {("whitted", 1, 1): 0.001, ("whitted", 2, 1): 0.002, ("path", 6, 1): 0.012, ("path", 6, 4): 0.04}
    # every third render is slowed 1.5×: the fastest of a round's repeats is the base time
    renders = _FakeRenders(lambda setting, call: base[setting] * (1.5 if call % 3 == 0 else 1.0), monkeypatch)
    entry = SceneResult("made-up", None, 4, 4, "test", 1024, 6)
    # d2 has d1's error for twice its work: neither the floor nor any level's cheapest
    entry.measurements += [_measurement("whitted-article", 1, 1, (), 0.2, 1),
                           _measurement("whitted-article", 2, 1, (), 0.2, 2),
                           _measurement("path", 6, 1, (), 0.4, 1), _measurement("path", 6, 4, (), 0.1, 4)]
    time_rounds(None, entry, 3)
    order = [(m.setting.integrator, m.setting.max_depth, m.setting.spp) for m in entry.measurements]
    verdict = [setting for setting in order if setting != ("whitted", 2, 1)]
    runs = [(setting, len(list(group))) for setting, group in itertools.groupby(renders.calls)]
    # (a round's last setting is the next round's first: their renders run together)
    expected = [setting for setting, _ in itertools.groupby(order + verdict[::-1] + verdict)]
    assert [setting for setting, _ in runs] == expected   # three rounds: settled at once
    repeats = dict(runs[:len(order)])
    assert repeats[("whitted", 1, 1)] == 8                   # 8 ms < 50 ms: the cap
    assert repeats[("path", 6, 1)] == 4                      # 12, 12, 18 or 12·4 ≥ 50 ms
    # (40 ms: one or two renders a round; its first round's run together with the second's)
    for m in entry.measurements:
        setting = (m.setting.integrator, m.setting.max_depth, m.setting.spp)
        rounds = 3 if setting in verdict else 1
        assert m.rounds == rounds and m.seconds == float(np.median(m.times))
        if base[setting] * 1.5 < 0.05:   # repeated in every round: one of two renders is not slowed
            assert m.times == (base[setting],) * rounds


class _Recording(_FakeRenders):
    """:class:`_FakeRenders` that notes Dr.Jit's thread count and ``fresh_memory`` at each
    render, reports half its wall time as CPU time, and is interrupted at render ``stop``."""

    def __init__(self, seconds, monkeypatch, stop: int | None = None):
        super().__init__(seconds, monkeypatch)
        self.seen, self.stop = [], stop

    def __call__(self, scene, **kwargs):
        import drjit as dr

        from whitted.rendering import RenderResult
        if len(self.calls) == self.stop:
            raise KeyboardInterrupt
        self.seen.append((dr.thread_count(), kwargs["fresh_memory"]))
        wall = super().__call__(scene, **kwargs)
        return RenderResult(wall.image, wall.seconds, 0.0, wall.stats, wall.seconds / 2)


def test_rounds_time_one_thread_s_cpu_time_with_the_memory_cache_kept(monkeypatch):
    """The rounds run Dr.Jit on COMPARE_TIMING_THREADS (1) and read CPU time (COMPARE_CLOCK),
    Dr.Jit's memory cache kept; the process's thread count comes back after, and after a
    Ctrl-C in a round too."""
    import drjit as dr
    import mitsuba as mi

    from whitted.compare.sweep import time_rounds
    if not mi.variant().startswith("llvm"):
        pytest.skip("Dr.Jit's thread count is the LLVM backend's")
    before = dr.thread_count()
    renders = _Recording(lambda setting, call: 0.1, monkeypatch)
    entry = _sweep_entry()
    time_rounds(None, entry, 3)
    assert renders.seen and set(renders.seen) == {(1, False)}
    assert dr.thread_count() == before
    # (the path renders, which the verdict reads, in every round; the others in the first)
    assert all(m.times == (0.05,) * (3 if m.setting.integrator == "path" else len(m.times))
               and m.seconds == 0.05 for m in entry.measurements)
    _Recording(lambda setting, call: 0.1, monkeypatch, stop=2)
    with pytest.raises(KeyboardInterrupt):
        time_rounds(None, _sweep_entry(), 3)
    assert dr.thread_count() == before


def test_the_headline_s_renders_get_extra_rounds_of_their_own(monkeypatch):
    """After the regular rounds, COMPARE_HEADLINE_ROUNDS more of the headline's renders alone
    (the floor, d2, and the path renders its error lies between), even when every headline
    is settled: its ratio is read from renders timed back to back."""
    from whitted.compare.sweep import time_rounds
    from whitted.defaults import COMPARE_HEADLINE_ROUNDS as EXTRA
    base = {("whitted", 1, 1): 0.03, ("whitted", 2, 1): 0.06, ("path", 6, 1): 0.07, ("path", 6, 4): 0.2}
    renders = _FakeRenders(lambda setting, call: base[setting], monkeypatch)
    entry = _sweep_entry()
    time_rounds(None, entry, 3)
    assert EXTRA >= 1
    # d1 (0.3) is not the floor (d2, 0.2) and reaches none of the levels (0.26 down to 0.11):
    # the first round alone; the 200-ms path render is known from two (COMPARE_LONG_SECONDS)
    assert {(m.setting.integrator, m.setting.max_depth, m.setting.spp): m.rounds
            for m in entry.measurements} == {("whitted", 1, 1): 1, ("whitted", 2, 1): 3 + EXTRA,
                                             ("path", 6, 1): 3 + EXTRA, ("path", 6, 4): 2 + EXTRA}
    last_regular = max(k for k, setting in enumerate(renders.calls) if setting == ("whitted", 1, 1))
    extra = renders.calls[last_regular + 1:]
    assert set(extra) == {("whitted", 2, 1), ("path", 6, 1), ("path", 6, 4)}
    # the rest of the first round, the second, the third without the long one, the extra rounds
    assert len(extra) == 3 + 3 + 2 + 3 * EXTRA
    floor = analyse(entry).floors[0]
    assert floor.interval.rounds == 2 + EXTRA and floor.interval.settled


def test_the_memory_cache_is_handed_back_above_the_bound(monkeypatch):
    """After each setting of a round, Dr.Jit's memory cache is flushed when the process holds
    more than COMPARE_KEPT_MEMORY bytes, and kept below it."""
    import drjit as dr

    import whitted.compare.sweep as sweep_module
    from whitted.compare.sweep import time_rounds
    from whitted.defaults import COMPARE_KEPT_MEMORY
    flushes = []
    monkeypatch.setattr(dr, "flush_malloc_cache", lambda: flushes.append(1))
    _FakeRenders(lambda setting, call: 0.1, monkeypatch)
    monkeypatch.setattr(sweep_module.rendering, "resident_bytes", lambda: COMPARE_KEPT_MEMORY // 2)
    time_rounds(None, _sweep_entry(), 3)
    assert not flushes
    monkeypatch.setattr(sweep_module.rendering, "resident_bytes", lambda: COMPARE_KEPT_MEMORY + 1)
    entry = _sweep_entry()
    time_rounds(None, entry, 3)
    assert len(flushes) == sum(m.rounds for m in entry.measurements)   # once per setting and round


def test_more_rounds_while_the_headline_is_unsettled_up_to_the_cap(monkeypatch):
    """The path tracer's times swing up to 16× from one call to the next: the headline never
    settles, and its renders (the floor, d2 · 1 spp, and the path renders at 1 and 4 spp
    around its error) are timed up to the cap; d1 · 1 spp only in the rounds asked for."""
    from whitted.compare.sweep import time_rounds
    swing = random.Random(3)
    _FakeRenders(lambda setting, call: 0.002 if setting[0] == "whitted"
                 else 0.01 * setting[2] * 16 ** swing.random(), monkeypatch)
    import whitted.compare.sweep as sweep_module
    monkeypatch.setattr(sweep_module, "COMPARE_ROUNDS_SECONDS", math.inf)   # the rounds' cap alone
    monkeypatch.setattr(sweep_module, "COMPARE_LONG_SECONDS", math.inf)     # no render sits out
    entry = _sweep_entry()
    time_rounds(None, entry, 3)
    rounds = {m.setting.label: m.rounds for m in entry.measurements}
    assert rounds == {"d1 · 1 spp": 1, "d2 · 1 spp": COMPARE_MAX_ROUNDS, "1 spp": COMPARE_MAX_ROUNDS,
                      "4 spp": COMPARE_MAX_ROUNDS}
    assert not analyse(entry).floors[0].interval.settled


def test_rounds_stop_before_the_budget_runs_out(monkeypatch):
    from whitted.compare.sweep import time_rounds
    clock = _FakeRenders(lambda setting, call: 0.01, monkeypatch)
    entry = _sweep_entry()
    # the first round: 4 × 50 ms, the next: the verdict's 3 × 50 ms (not d1, see above); 2 fit
    time_rounds(None, entry, 5, deadline=clock.now + 0.4)
    assert {m.setting.label: m.rounds for m in entry.measurements} == {
        "d1 · 1 spp": 1, "d2 · 1 spp": 2, "1 spp": 2, "4 spp": 2}
    assert entry.notes == ["timed in 2 rounds, not 5: the next would have overrun the scene's "
                           "share of --budget"]


def test_extra_rounds_time_the_unsettled_headline_s_renders_only(monkeypatch):
    """A 3 s path render is timed in its first COMPARE_LONG_ROUNDS rounds only (a long render's
    time is known by then): the headline is read between
    the path tracer's 1 and 4 spp renders, which the extra rounds time with the floor render;
    the ratio pairs the rounds that timed all three."""
    import whitted.compare.sweep as sweep_module
    from whitted.compare.sweep import time_rounds
    monkeypatch.setattr(sweep_module, "COMPARE_LONG_SECONDS", 1.0)   # the 3-s render alone is long
    swing = random.Random(3)
    _FakeRenders(lambda setting, call: 3.0 if setting[2] == 64 else 0.002 if setting[0] == "whitted"
                 else 0.01 * setting[2] * 16 ** swing.random(), monkeypatch)
    entry = _sweep_entry()
    entry.measurements.append(_measurement("path", 6, 64, (), 0.02, 64))
    time_rounds(None, entry, 3)
    rounds = {m.setting.label: m.rounds for m in entry.measurements}
    assert rounds["d1 · 1 spp"] == 1 and rounds["64 spp"] == COMPARE_LONG_ROUNDS
    assert rounds["d2 · 1 spp"] == rounds["1 spp"] == rounds["4 spp"] > 3
    assert 3 < analyse(entry).floors[0].interval.rounds <= rounds["1 spp"]


def test_a_render_missing_from_some_rounds_pairs_the_rounds_it_has():
    """The extra rounds leave the slow renders out: a ratio with a render missing from a round
    is not read there (no reading at an unknown time), and the others still are."""
    entry = _entry(_steady_whitted, _steady_path)
    for m in entry.measurements:
        if m.setting.integrator == "whitted" and m.setting.max_depth >= 4:
            m.times = m.times[:3]   # timed in 3 of the 7 rounds
    analysis = analyse(entry)
    assert analysis.floors[0].interval.rounds == 7          # d3 · 1 spp has all its rounds
    rows = {r.whitted.setting.max_depth: r for r in analysis.equal_time if r.interval is not None}
    assert rows[5].interval.rounds == rows[6].interval.rounds == 3   # within the path tracer's range


def test_a_timed_render_whose_clock_did_not_move_is_not_a_time(monkeypatch):
    """A round's time of 0 (a CPU clock that did not move once the compilation is taken off,
    seen on Dask workers) is rendered again, never reported; NaN when nothing measured."""
    from whitted.compare import sweep
    monkeypatch.setattr(sweep, "_render", lambda loaded, setting, timed=False: None)
    monkeypatch.setattr(sweep, "COMPARE_ROUND_REPEATS", 3)
    values = iter([0.0, 0.003, 0.002])
    monkeypatch.setattr(sweep, "_seconds", lambda result: next(values))
    assert sweep._time_in_a_round(None, None) == 0.002
    monkeypatch.setattr(sweep, "_seconds", lambda result: 0.0)
    assert math.isnan(sweep._time_in_a_round(None, None))


def test_a_widened_interval_turned_round_stays_as_settled_as_its_rounds():
    """A ratio under 1 is said the other way round ("the path tracer gets there 1.8× faster"):
    the interval's widening between runs goes with it, so rounds narrow enough to quote are
    not called unsettled because of it."""
    rounds = Interval.of([0.5, 0.6, 0.55])           # 1.2× wide: settled
    interval = rounds.widened(COMPARE_RUN_SHARE)     # 1.2 · 1.05² ≈ 1.32× wide
    assert rounds.settled and interval.settled
    assert interval.high / interval.low > 1 + COMPARE_SETTLED_WIDTH
    text = faster_text(interval, "the article's model", "the path tracer")
    assert text.startswith("the path tracer gets there 1.82× faster") and "unsettled" not in text


@pytest.mark.parametrize("deadline, note", [
    (0.25, "timed in 1 round, not 5: the next would have overrun the scene's share of --budget"),
    (0.0, "not timed in rounds (5 asked): the first would have overrun the scene's share of --budget; "
          "its times are those of its scored renders (wall time, every thread, once each), not "
          "of timed rounds")])
def test_a_scene_timed_in_one_round_or_none_says_so_in_words(monkeypatch, deadline, note):
    """A folder of the four examples under --quick on a busy machine: three scenes said "timed in
    0 rounds, not 2", and their verdicts quoted the scored renders' wall times on every thread,
    while the header says every time is the rounds' CPU time on one thread."""
    from whitted.compare.sweep import time_rounds
    clock = _FakeRenders(lambda setting, call: 0.01, monkeypatch)
    entry = _sweep_entry()
    time_rounds(None, entry, 5, deadline=clock.now + deadline)
    assert entry.notes == [note]


def test_the_reports_say_how_sure_an_interval_of_few_rounds_is():
    """--quick times in 2 rounds: an equal-quality ratio over 2 rounds holds its median with 50%
    confidence (findings.json: "confidence": 0.5), and the reports' header named only 90% over 5
    rounds or more and 75% over 3."""
    from whitted.compare.analysis import TIMING
    from whitted.compare.timing import coverage
    for rounds in (2, 3, 4):
        assert f"{coverage(rounds):.0%} over {rounds}" in TIMING
    from pathlib import Path
    import whitted.compare
    page = Path(whitted.compare.__file__).parent / "templates" / "report.html.j2"
    assert "75% over 3, 50% over 2" in " ".join(page.read_text(encoding="utf-8").split())  # glossary


def test_an_interval_that_does_not_hold_one_never_reads_as_holding_it():
    """textured.scn under --quick: "the article's model gets there 1.11× faster (1–1.2× over 10
    rounds)", its low end 1.0007 shown as 1: "faster" beside an interval that reads as holding 1."""
    from whitted.compare.analysis import ratio_text
    from whitted.compare.timing import Interval
    interval = Interval(1.107, 1.0007, 1.198, 10)
    assert interval.range_text() == "1.001–1.2× over 10 rounds"
    assert ratio_text(interval) == "1.11× (1.001–1.2)"
    assert Interval(0.95, 0.9, 0.9996, 10).range_text() == "0.9–0.9996× over 10 rounds"
    assert Interval(1.5, 1.2, 1.8, 10).range_text() == "1.2–1.8× over 10 rounds"   # as before
