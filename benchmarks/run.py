"""Benchmarks of the Whitted integrator (``make bench``; ``--quick`` for a short run).

Every comparison is measured in this one process, as the median of interleaved runs
after warm-up, against the fastest honest alternative doing the same work; run_notes.md,
which RESULTS.md includes, says how and what is compared.

The exit status is 1 when an acceptance target (``TARGET_DEPTH``, ``TARGET_DIRECT``) is missed.
"""

from __future__ import annotations

import argparse
import gc
import math
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

import whitted  # (selects the variant, registers the plugins)
from whitted import interrupt
from whitted.atomic import write_text
from whitted.compare.timing import interleaved, median
from whitted.errors import WhittedError
from whitted.rendering import Clock

from . import floor, run_main, scenes
from .report import Table, check_markdown, machine, marked_sections, mib, ms, summary

#: acceptance targets (ratios of median times)
TARGET_DEPTH = 1.15
TARGET_DIRECT = 1.25
#: an interquartile range above this fraction of the median (and above the jitter of a
#: millisecond render, ``JITTER`` seconds) means the machine was busy
NOISY = 0.10
JITTER = 0.5e-3

FULL = {"rounds": 11, "counts": (10, 100, 1000, 10_000), "count_rounds": 5, "big_rounds": 3,
        "resolutions": ((256, 192), (512, 384), (1024, 768), (2048, 1536)), "spps": (1, 4, 16, 64)}
QUICK = {"rounds": 5, "counts": (10, 100, 1000), "count_rounds": 3, "big_rounds": 1,
         "resolutions": ((256, 192), (1024, 768)), "spps": (1, 16)}


def renderer(scene, integrator, spp: int):
    """One whole render, as a user would call it: ``mi.render`` and the developed image."""
    def run():
        image = mi.render(scene, integrator=integrator, spp=spp, seed=0)
        dr.eval(image)
        return image
    return run


def clocked(run, fresh_memory: bool = False) -> Clock:
    """``run()`` to its end on the clock of ``whitted compare``'s renders: its seconds are
    wall seconds without kernel compilation."""
    interrupt.check()   # a stop the handler could not raise (in a finalizer) ends the run here
    with Clock(fresh_memory=fresh_memory) as clock:
        run()
        dr.sync_thread()
    return clock


@dataclass
class Timing:
    median: float            # seconds
    q1: float
    q3: float
    compile_seconds: float   # compilation left in a run after warm-up (should be 0)
    times: list              # seconds, one per round

    @classmethod
    def of(cls, clocks: list[Clock]) -> "Timing":
        times = [c.seconds for c in clocks]
        q = statistics.quantiles(times, n=4) if len(times) > 1 else times * 3
        return cls(statistics.median(times), q[0], q[2], max(c.compile for c in clocks), times)

    def spread(self) -> str:
        """The interquartile range relative to the median, e.g. '±3%'."""
        return f"±{50 * (self.q3 - self.q1) / self.median:.0f}%" if self.median else "-"

    def noisy(self) -> bool:
        return self.q3 - self.q1 > max(NOISY * self.median, JITTER)

    def over(self, other: "Timing") -> float:
        """This contender's time over ``other``'s: the median of their per-round ratios."""
        return median(a / b for a, b in zip(self.times, other.times))


def measure(contenders: dict, rounds: int, min_seconds: float = 0.5, max_rounds: int = 200) -> dict[str, Timing]:
    """Each contender timed in at least ``rounds`` interleaved rounds after two runs each (kernels
    compiled and cached), in more (up to ``max_rounds``) until they take about ``min_seconds``:
    a millisecond render timed five times says little on a shared machine."""
    for _ in range(2):
        one_round = sum(clocked(run).wall for run in contenders.values())
    rounds = max(rounds, min(max_rounds, math.ceil(min_seconds / max(one_round, 1e-6))))
    clocks = {name: [] for name in contenders}
    gc.collect()
    gc.disable()
    try:
        for r in range(rounds):
            for name in interleaved(list(contenders), r):
                clocks[name].append(clocked(contenders[name]))
    finally:
        gc.enable()
    return {name: Timing.of(c) for name, c in clocks.items()}


def peak_memory(run) -> int:
    """Dr.Jit's high-water mark of allocated bytes during ``run()``: every array it holds, not
    Embree's acceleration structure or Python's heap."""
    return clocked(run, fresh_memory=True).peak_memory


class Bench:
    def __init__(self, settings: dict, folder: Path):
        self.s = settings
        self.texture = scenes.write_texture(folder / "checker.png")
        self.tables: list[Table] = []
        self.summary: dict[str, float] = {}
        self.noisy: list[str] = []   # contenders whose times spread widely

    def measure(self, contenders: dict, rounds: int, label: str = "") -> dict:
        """:func:`measure`, remembering which contenders ran on a busy machine."""
        timing = measure(contenders, rounds)
        self.noisy += [f"{label}{name}" for name, t in timing.items() if t.noisy()]
        return timing

    def show(self, table: Table):
        self.tables.append(table)
        print(table.text(), flush=True)

    def against_direct_and_floor(self):
        width, height, spp = 1024, 768, 4
        model = scenes.diffuse_spheres(10, width, height, spp)
        scene, scene_direct = scenes.load(model), scenes.load_for_direct(model)
        light = model.lights[0].position
        physical = scenes.load_whitted(model, lighting="physical")
        contenders = {
            "whitted (physical lighting)": renderer(scene, physical, spp),
            "whitted (article lighting)": renderer(scene, scenes.load_whitted(model), spp),
            "whitted (article lighting), max depth 16": renderer(scene, scenes.load_whitted(model, max_depth=16),
                                                                 spp),
            "Mitsuba direct": renderer(scene_direct, scenes.direct_integrator(), spp),
            **{f"floor: {h} + ray_test": floor.RayCastingFloor(scene, light, spp, h)
               for h in floor.HIT_FINDERS},
            "floor + Mitsuba's film": floor.RayCastingFloor(scene, light, spp, "sphere table", film=True),
        }
        timing = self.measure(contenders, self.s["rounds"])
        direct = timing["Mitsuba direct"]
        floor_name = min((n for n in timing if n.startswith("floor:")), key=lambda n: timing[n].median)
        floor_time = timing[floor_name]

        # The same work: the same camera rays, the same shadow rays as the floor, the same image.
        rays = physical.render_detailed(scene, spp=spp).rays
        hits, floor_shadow = contenders[floor_name].counts()
        ours = np.array(contenders["whitted (physical lighting)"]())[..., :3].mean()
        theirs = np.array(contenders["Mitsuba direct"]())[..., :3].mean()
        samples = width * height * spp

        table = Table(f"Whitted vs Mitsuba's direct and the ray-casting floor "
                      f"({width}×{height}, {spp} spp, {len(model.spheres)} diffuse spheres, 1 point light)",
                      ["contender", "median ms", "spread", "vs direct", "vs floor", "ns/sample", "compile s"],
                      note=(f"Rays: {rays.camera} camera, {rays.shadow} shadow (Whitted); the floor casts "
                            f"{floor_shadow} shadow rays; direct casts one per hit, facing the light or not "
                            f"({hits}). "
                            f"Mean pixel value, Whitted physical / direct: {ours / theirs:.4f}."))
        for name, t in timing.items():
            table.add(name, ms(t.median), t.spread(), t.over(direct), t.over(floor_time),
                      f"{1e9 * t.median / samples:.1f}", f"{t.compile_seconds:.3f}")
        self.show(table)
        best_whitted = timing["whitted (physical lighting)"]
        self.summary["whitted / direct"] = best_whitted.over(direct)
        self.summary["whitted (article) / direct"] = timing["whitted (article lighting)"].over(direct)
        self.summary["whitted / floor"] = best_whitted.over(floor_time)
        self.summary["depth 16 / depth 1"] = timing["whitted (article lighting), max depth 16"].over(
            timing["whitted (article lighting)"])

    def _whitted_and_direct(self, model, rounds):
        """Both renders of ``model`` timed, and the two runs by name."""
        label = f"{len(model.spheres)} spheres {model.width}×{model.height} {model.samples} spp "
        scene, scene_direct = scenes.load(model), scenes.load_for_direct(model)
        runs = {"whitted": renderer(scene, scenes.load_whitted(model, lighting="physical"), model.samples),
                "direct": renderer(scene_direct, scenes.direct_integrator(), model.samples)}
        return self.measure(runs, rounds, label), runs

    def scaling(self):
        columns = ["whitted ms", "ns/sample", "direct ms", "whitted / direct", "whitted MiB", "direct MiB"]
        s = self.s
        tables = [("spheres", "Cost against sphere count (512×384, 4 spp, 1 light)",
                   [(n, scenes.diffuse_spheres(n, 512, 384, 4), n >= 10_000) for n in s["counts"]]),
                  ("resolution", "Cost against resolution (10 spheres, 4 spp)",
                   [(f"{w}×{h}", scenes.diffuse_spheres(10, w, h, 4), w * h > 10**6) for w, h in s["resolutions"]]),
                  ("spp", "Cost against samples per pixel (10 spheres, 512×384)",
                   [(n, scenes.diffuse_spheres(10, 512, 384, n), n > 16) for n in s["spps"]])]
        for key, title, rows in tables:
            fixed = key == "spheres"     # with the cost of a render that does not grow with its samples
            table = Table(title, [key, *columns, *(["fixed ms: whitted / direct"] if fixed else [])],
                          note=FIXED_NOTE if fixed else "")
            for label, model, big in rows:
                rounds = s["big_rounds"] if big else s["count_rounds"]
                extra = []
                if fixed:
                    small = replace(model, width=1, height=1, samples=1)
                    timing = self._whitted_and_direct(small, rounds)[0]
                    extra.append(f"{ms(timing['whitted'].median)} / {ms(timing['direct'].median)}")
                timing, runs = self._whitted_and_direct(model, rounds)
                w, d = timing["whitted"], timing["direct"]
                samples = model.width * model.height * model.samples
                table.add(label, ms(w.median), f"{1e9 * w.median / samples:.1f}", ms(d.median), w.over(d),
                          *(mib(peak_memory(run)) for run in runs.values()), *extra)
            self.show(table)

    def effects(self):
        """The every-effect scene with each effect left out by ``whitted render --without``."""
        from whitted.defaults import SWITCHABLE_EFFECTS
        width, height, spp = 512, 384, 4
        model = scenes.every_effect(self.texture, width, height, spp)
        scene = scenes.load(model)
        integrators = {"every effect": scenes.load_whitted(model),
                       **{f"--without {e}": scenes.load_whitted(model, without=e) for e in SWITCHABLE_EFFECTS}}
        timing = self.measure({name: renderer(scene, i, spp) for name, i in integrators.items()}, self.s["rounds"])
        full = timing["every effect"]
        table = Table(f"Each effect left out by --without ({width}×{height}, {spp} spp, max depth {model.depth})",
                      ["render", "median ms", "spread", "this / every effect", "effects",
                       "rays (cam/shadow/refl/refr)"])
        for name, integrator in integrators.items():
            rendering = integrator.render_detailed(scene, spp=spp)
            r, t = rendering.rays, timing[name]
            table.add(name, ms(t.median), t.spread(), t.over(full), " ".join(rendering.effects) or "none",
                      f"{r.camera}/{r.shadow}/{r.reflection}/{r.refraction}")
        self.show(table)

    def adaptive(self):
        width, height, spp = 512, 384, 4
        model = scenes.every_effect(self.texture, width, height, spp, depth=16)
        scene = scenes.load(model)
        thresholds = (0.0, 0.001, 0.01, 0.05)
        integrators = {w: scenes.load_whitted(model, min_weight=w) for w in thresholds}
        timing = self.measure({f"min_weight {w:g}": renderer(scene, i, spp) for w, i in integrators.items()},
                              self.s["rounds"])
        base = timing["min_weight 0"]
        # mi.render's very images (it calls render_detailed), with what each traced
        renders = {w: integrator.render_detailed(scene, spp=spp) for w, integrator in integrators.items()}
        reference = np.array(renders[0.0].image, np.float64)[..., :3]
        table = Table(f"Adaptive depth control (every-effect scene at max depth 16, "
                      f"{width}×{height}, {spp} spp)",
                      ["min weight", "median ms", "vs off", "secondary rays", "culled", "depth reached",
                       "mean abs error"])
        for w, rendered in renders.items():
            rays, t = rendered.rays, timing[f"min_weight {w:g}"]
            error = np.abs(np.array(rendered.image, np.float64)[..., :3] - reference).mean()
            table.add(f"{w:g}", ms(t.median), t.over(base), rays.reflection + rays.refraction, rays.culled,
                      rays.max_depth_reached, f"{error:.2e}")
        self.show(table)


#: the note under the sphere-count table
FIXED_NOTE = ("Peak memory: Dr.Jit's allocations during the render (scene arrays, wavefronts, image), not "
              "Embree's BVH. Fixed: the same scene rendered at 1×1 pixel and 1 spp, the cost of a render "
              "that does not grow with its samples (Whitted: reading the scene's materials and building "
              "its sphere table in Python; direct: tracing a call per shape instance).")

#: the sections of a run, in order (``--only``)
SECTIONS = ("against_direct_and_floor", "scaling", "effects", "adaptive")

#: the prose of RESULTS.md between the acceptance table and the results: how to reproduce, what
#: is compared
NOTES = Path(__file__).with_name("run_notes.md")


def acceptance(summary: dict) -> tuple[Table, list[str]]:
    """The acceptance table, and the ratios that missed their target."""
    rows = [("depth 16 / depth 1", "(diffuse, 1024×768, 4 spp)", TARGET_DEPTH, ""),
            ("whitted / direct", "(same rays)", TARGET_DIRECT, " (stretch: < 1)"),
            ("whitted (article) / direct", "(article lighting)", None, ""),
            ("whitted / floor", "(the ray-casting floor)", None, "(information)")]
    table = Table("Acceptance (ratios of median times)", ["ratio", "measured", "target"])
    missed = [name for name, _, target, _ in rows if target and summary[name] > target]
    for name, what, target, note in rows:
        verdict = f"≤ {target}: {'MISSED' if name in missed else 'met'}" if target else ""
        table.add(f"{name} {what}", f"{summary[name]:.3f}", verdict + note)
    return table, missed


def markdown(bench: Bench, info: dict, mode: str, seconds: float, accepted: Table) -> str:
    lines = ["# Benchmark results", "",
             f"Measured on {info['date']}: {summary(info)}. Source: {info['source']}. "
             f"Mode: {mode}; the whole run took {seconds:.0f} s.", "",
             *([f"Another process loaded the machine during the run: the times of {len(bench.noisy)} "
                f"contenders spread over ±{50 * NOISY:.0f}% (see the spread columns); the ratios, "
                f"paired per round, are less affected.", ""] if bench.noisy else []),
             accepted.markdown(), "", NOTES.read_text(), "## Results", ""]
    for table in bench.tables:
        lines += [table.markdown(), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer rounds and sizes")
    parser.add_argument("--variant", default="llvm_ad_rgb", choices=("llvm_ad_rgb", "cuda_ad_rgb"))
    parser.add_argument("--markdown", metavar="FILE",
                        help="write the results as Markdown (benchmarks/RESULTS.md)")
    parser.add_argument("--only", choices=SECTIONS,
                        help="run one section only (no acceptance check; not with --markdown)")
    args = parser.parse_args(argv)
    if args.only and args.markdown:   # RESULTS.md is a whole run's: one section would drop the others
        parser.error("--markdown records a whole run (the acceptance table and every section): "
                     "not with --only")
    if args.markdown:
        try:   # before the run, not after it
            check_markdown(args.markdown)
        except WhittedError as error:
            parser.error(str(error))

    whitted.set_variant(args.variant)
    info = machine()
    print(f"whitted benchmarks ({'quick' if args.quick else 'full'}): {summary(info)}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        bench = Bench(QUICK if args.quick else FULL, Path(folder))
        for section in [args.only] if args.only else SECTIONS:
            getattr(bench, section)()
        if args.only:
            return 0
    seconds = time.perf_counter() - start

    accepted, missed = acceptance(bench.summary)
    print(accepted.text())
    print(f"total {seconds:.0f} s")
    if bench.noisy:
        print(f"warning: the machine was busy (times spread over ±{50 * NOISY:.0f}% for "
              f"{', '.join(bench.noisy)}); ratios are paired per round, but run again "
              f"on a quiet machine")

    if args.markdown:
        # Keep the sections other benchmarks own in the same file.
        path = Path(args.markdown)
        others = marked_sections(path.read_text(encoding="utf-8")) if path.exists() else []
        write_text(path, "\n".join([markdown(bench, info, "quick" if args.quick else "full", seconds,
                                             accepted), *others]))
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(run_main(main))
