"""What a gradient of the article's model costs beside its plain render.

A gradient records the whole render as Dr.Jit's AD graph, where a plain render keeps one
level of the ray tree. Both are timed as run.py times renders (interleaved rounds after
warm-up), with gradients on every untextured color, the ambient and the lights.

``--quick``: 160×100, one round, for a check that it works.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import drjit as dr
import mitsuba as mi

import whitted

from . import run_main
from .report import Table, mib, ms
from .run import measure, peak_memory


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="scenes/tir.scn", help="(from the repository root)")
    parser.add_argument("--size", type=int, nargs=2, default=(640, 400), metavar=("W", "H"))
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    if args.quick:
        args.size, args.rounds = (160, 100), 1
    if args.rounds < 1:
        parser.error(f"--rounds must be >= 1, got {args.rounds}")
    try:   # a missing scene, a size or spp out of range
        scene = whitted.load_scene(args.scene, variant="llvm_ad_rgb", ellipsoids=False,
                                   spp=args.spp, width=args.size[0], height=args.size[1])
    except whitted.WhittedError as error:
        parser.error(str(error))
    params = mi.traverse(scene)
    keys = [k for k in params.keys() if k.endswith("color.value") or k.endswith("intensity.value")
            or k == "integrator.ambient"]

    def primal():
        dr.eval(mi.render(scene, spp=args.spp))

    def gradient():
        for key in keys:
            dr.enable_grad(params[key])
        params.update()
        image = mi.render(scene, params, spp=args.spp)
        dr.backward(dr.mean(image, axis=None))
        dr.eval([dr.grad(params[key]) for key in keys])
        for key in keys:
            dr.disable_grad(params[key])
        params.update()

    runs = {"primal": primal, "gradient": gradient}
    timing = measure(runs, args.rounds)
    table = Table(f"{Path(args.scene).name} at {args.size[0]}x{args.size[1]}, {args.spp} spp, {len(keys)} "
                  f"parameters with gradients (llvm_ad_rgb, {dr.thread_count()} threads)",
                  ["render", "median ms", "spread", "over primal", "Dr.Jit peak MiB"])
    for name, run in runs.items():
        t = timing[name]
        table.add(name, ms(t.median), t.spread(), t.over(timing["primal"]), mib(peak_memory(run)))
    print(table.text())
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main))
