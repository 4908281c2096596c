"""What a gradient of the article's model costs beside its plain render.

A gradient records the whole render as Dr.Jit's AD graph, where a plain render keeps one
level of the ray tree. Both are measured in interleaved rounds, each in a process of its
own (every untextured color, the ambient and the lights with gradients on).

``--quick``: 160×100, one round, for a check that it works.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=str(REPO / "scenes" / "tir.scn"))
    parser.add_argument("--size", type=int, nargs=2, default=(640, 400), metavar=("W", "H"))
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--only", choices=("primal", "gradient"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.quick:
        args.size, args.rounds = (160, 100), 1
    if args.only is None:
        return _side_by_side(args)

    import drjit as dr
    import mitsuba as mi

    import whitted
    from whitted.rendering import Clock
    scene = whitted.load_scene(args.scene, variant="llvm_ad_rgb", ellipsoids=False, spp=args.spp,
                               width=args.size[0], height=args.size[1])
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
        grads = [dr.grad(params[key]) for key in keys]
        dr.eval(grads)
        for key in keys:
            dr.disable_grad(params[key])
        params.update()

    work = primal if args.only == "primal" else gradient
    work()   # warm-up: kernels compiled (or read from Dr.Jit's cache)
    with Clock() as clock:
        work()
        dr.sync_thread()
    print(json.dumps({"seconds": clock.wall, "peak": clock.peak_memory, "resident": clock.peak_resident,
                      "parameters": len(keys), "threads": dr.thread_count()}))
    return 0


def _side_by_side(args) -> int:
    best = {"primal": None, "gradient": None}
    for _ in range(args.rounds):
        for name in best:
            run = subprocess.run([sys.executable, __file__, "--only", name, "--scene", args.scene,
                                  "--size", *map(str, args.size), "--spp", str(args.spp)],
                                 capture_output=True, text=True)
            if run.returncode != 0:
                print(run.stderr, file=sys.stderr)
                return 1
            measured = json.loads(run.stdout.strip().splitlines()[-1])
            if best[name] is None or measured["seconds"] < best[name]["seconds"]:
                best[name] = measured
    w, h = args.size
    print(f"{Path(args.scene).name} at {w}x{h}, {args.spp} spp, {best['gradient']['parameters']} parameters "
          f"with gradients, best of {args.rounds} interleaved rounds (llvm_ad_rgb, "
          f"{best['gradient']['threads']} threads):")
    for name, m in best.items():
        print(f"  {name:8s} {m['seconds']:7.3f} s   Dr.Jit peak {m['peak'] / 2**20:8.1f} MiB   "
              f"peak resident {m['resident'] / 2**20:8.1f} MiB")
    print(f"  gradient / primal: {best['gradient']['seconds'] / best['primal']['seconds']:.1f}x the time, "
          f"{best['gradient']['peak'] / max(1, best['primal']['peak']):.1f}x Dr.Jit's peak memory")
    return 0


if __name__ == "__main__":
    sys.exit(main())
