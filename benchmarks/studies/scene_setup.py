"""What a render spends reading the scene (sphere and material tables, lights, effects),
on a scene of many spheres: the first render, a render of the unchanged scene, and a
render after ``params.update()`` moved one sphere.

Usage::

    python -m benchmarks.studies.scene_setup [SPHERES]      # default 66 000

The integrator builds these tables once per scene state and checks them at every render
(plugins/scene_tables.py); this prints the time of that check or build, :func:`analyse`
and the :class:`Recursion` construction, which is all a render does with the scene before its
kernels run.
"""

from __future__ import annotations

import statistics
import sys
import time

import drjit as dr
import mitsuba as mi

import whitted  # noqa: F401  (selects the variant, registers the plugins)
from whitted.plugins.recursion import Recursion
from whitted.plugins.scene_tables import analyse, scene_tables

from .. import scenes


def main(count: int) -> None:
    model = scenes.diffuse_spheres(count, 64, 48, 1)
    start = time.perf_counter()
    scene = scenes.load(model)
    print(f"{count} spheres ({mi.variant()}): loading took {time.perf_counter() - start:.1f} s")
    reference = mi.ScalarPoint3f(model.lookat)

    def setup() -> float:
        start = time.perf_counter()
        Recursion(scene, analyse(scene_tables(scene), model.depth, reference), model.ambient, "article")
        dr.eval()
        return time.perf_counter() - start

    print(f"first render:          {1e3 * setup():9.1f} ms")
    print(f"unchanged scene:       {1e3 * statistics.median(setup() for _ in range(5)):9.3f} ms (median of 5)")
    params = mi.traverse(scene)
    key = next(k for k in params.keys() if k.endswith("to_world") and "sphere" in k)
    after = []
    for _ in range(3):
        params[key] = mi.Transform4f().translate([0.01, 0, 0]) @ params[key]
        params.update()
        after.append(setup())
    print(f"after params.update(): {1e3 * statistics.median(after):9.1f} ms (median of 3)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 66_000)
