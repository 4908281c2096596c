"""Mitsuba's ``ellipsoids`` shape as a fast path for spheres: load time, ray-cast time, accuracy.

Mitsuba spends 60–110 µs on every ``sphere`` shape it loads (a plugin object,
an Embree user geometry, a Dr.Jit registry entry each); its ``ellipsoids``
shape holds any number of primitives in one shape, built from three tensors.
An ellipsoid with equal scales and the identity quaternion is a sphere, and the
shape culls back faces, which the article's model never needs for an opaque
sphere that holds neither the eye nor a light (no ray starts inside one). So
the question is whether the ellipsoids shape is as *accurate* as the sphere
shape, and how much faster it loads and traces.

Three measurements (``--only`` picks some):

``accuracy``
    One sphere of radius 10⁻³ … 10⁶, at the origin and 10⁴ from it, seen from
    3, 100 and 10⁴ radii away (20 000 rays each, ``llvm_ad_rgb``). Rays aimed at
    impact parameters below 0.99 r must hit, above 1.01 r must miss; the
    float32 hit point ``o + t·d`` (evaluated in float64) must lie within the
    integrator's error bound ``e = ε(8r + 4 max|Cᵢ|)`` of the sphere
    (``whitted/float32.hit_error``), by which it moves secondary rays off the
    surface. Three intersectors: Mitsuba's ``sphere``, its ``ellipsoids``, and
    the ellipsoid routine with a one-line fix, emulated in numpy float32 in
    Mitsuba's operation order (see :func:`ellipsoid_t`).
``load``
    N random non-overlapping spheres (four materials) as N ``sphere`` shapes vs
    four ``ellipsoids`` shapes, ``mi.load_dict(parallel=False)``, wall and CPU
    seconds (including Embree's build).
``load`` (continued)
    The same 512² camera rays through both scenes:
    ``scene.ray_intersect_preliminary`` (what the integrator's sphere table
    uses) and ``scene.ray_intersect``.
``scene``
    End to end on a scene file (default: the level-5 sphereflake, 66 431
    spheres, 59 049 of them leaves of one radius), each way in a fresh
    process: parse, ``whitted.load_scene(ellipsoids=False|True)``, a first
    render (kernels compiled) and a second one. Three ways: sphere shapes as
    written, sphere shapes in the scaled frame the ellipsoids need, and
    ellipsoids; the images' differences, and with ``--reference`` the float64
    reference at the pixels where they differ.

Usage::

    python -m benchmarks.studies.ellipsoids [--only accuracy,load,scene] [--counts 1000,10000,66000] [--scene F.scn]

Timings are wall-clock on whatever machine runs this; on a shared machine they
are noisy (the CPU seconds column is less so).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

import drjit as dr
import mitsuba as mi

import whitted  # noqa: F401  (selects the variant, registers the plugins)

from .. import scenes
from ..timing import measure, timed

REPO = Path(__file__).resolve().parents[2]

F32 = np.float32
#: float32's unit round-off (whitted/float32.py)
EPS = 2.0 ** -24


def error_bound(radius, center):
    from whitted.float32 import hit_error
    return hit_error(radius, np.abs(np.asarray(center, float)).max())


# -- the ellipsoid routine, emulated ---------------------------------------------------------

def _fma(a, b, c):
    """float32 fused multiply-add (the product of two float32 values is exact in float64)."""
    return (np.float64(a) * np.float64(b) + np.float64(c)).astype(F32)


def _dot(a, b):
    """Dr.Jit's ``dot``: a₀b₀, then fused multiply-adds."""
    return _fma(a[2], b[2], _fma(a[1], b[1], (a[0] * b[0]).astype(F32)))


def ellipsoid_t(origin, direction, center, radius, fixed: bool):
    """Mitsuba's ``ray_ellipsoid_intersection`` for a sphere (scales r, identity rotation),
    in float32 and its operation order: the nearest front-facing hit distance, inf if none.

    Mitsuba 3.9 (src/shapes/ellipsoids.cpp) moves the origin to "the plane through the
    center" as ``plane_t = dot(-o, d) / norm(d)``, in the unit sphere's coordinates where
    ``|d| = 1/r``: that point lies ``t·|1/r - 1|`` from the plane instead of on it, and
    the quadratic then cancels catastrophically for r far from 1. ``fixed`` divides by
    ``squared_norm(d)`` instead, which puts it on the plane.
    """
    o_world = origin.astype(F32) - np.asarray(center, F32)[:, None]
    inverse = F32(1) / F32(radius)
    o, d = (o_world * inverse).astype(F32), (direction.astype(F32) * inverse).astype(F32)
    dd = _dot(d, d)
    plane_t = (_dot(-o, d) / (dd if fixed else np.sqrt(dd).astype(F32))).astype(F32)
    p = _fma(d, plane_t, o)
    a, b, c = dd, (F32(2) * _dot(p, d)).astype(F32), (_dot(p, p) - F32(1)).astype(F32)
    discriminant = _fma(b, b, -(F32(4) * a * c).astype(F32))
    root = np.sqrt(np.maximum(discriminant, 0)).astype(F32)
    temp = (F32(-0.5) * (b + np.copysign(root, b))).astype(F32)
    with np.errstate(divide="ignore", invalid="ignore"):
        x0, x1 = (temp / a).astype(F32), (c / temp).astype(F32)
    near, far = np.minimum(x0, x1) + plane_t, np.maximum(x0, x1) + plane_t
    hit = (discriminant >= 0) & (far >= 0) & ~(near < 0)
    return np.where(hit, near, np.inf)


# -- accuracy -------------------------------------------------------------------------------

def one_sphere(kind: str, center, radius):
    if kind == "sphere":
        shape = {"type": "sphere", "center": [float(x) for x in center], "radius": float(radius)}
    else:
        shape = {"type": "ellipsoids", "extent": 1.0,
                 "centers": mi.TensorXf(np.asarray(center, F32).reshape(1, 3)),
                 "scales": mi.TensorXf(np.full((1, 3), radius, F32)),
                 "quaternions": mi.TensorXf(np.array([[0, 0, 0, 1]], F32))}
    return mi.load_dict({"type": "scene", "ball": shape})


def aimed_rays(center, radius, view, n, rng, impact):
    """Rays from random points ``view`` from the center, aimed at impact parameters drawn from
    ``impact`` (in radii). Returns float32 origins and unit directions (3×n)."""
    center = np.asarray(center, float)[:, None]
    towards = rng.normal(size=(3, n))
    towards /= np.linalg.norm(towards, axis=0)
    origin = center + view * towards
    side = rng.normal(size=(3, n))
    side -= (side * towards).sum(axis=0) * towards
    side /= np.linalg.norm(side, axis=0)
    target = center + radius * impact(n) * side
    direction = target - origin
    direction /= np.linalg.norm(direction, axis=0)
    return origin.astype(F32), direction.astype(F32)


def exact_t(origin, direction, center, radius):
    """The float64 nearest hit of the float32 rays (stable form), inf on a miss."""
    o, d = origin.astype(float), direction.astype(float)
    f = o - np.asarray(center, float)[:, None]
    a, b = (d * d).sum(axis=0), (f * d).sum(axis=0)
    q = f - (b / a) * d
    disc = a * (radius * radius - (q * q).sum(axis=0))
    c = (f * f).sum(axis=0) - radius * radius
    with np.errstate(invalid="ignore", divide="ignore"):
        t = c / (-b + np.sqrt(disc))
    return np.where(disc >= 0, t, np.inf)


def miss_distance(origin, direction, center):
    """How far the (float32) rays pass from ``center``, in float64."""
    d = direction.astype(float) / np.linalg.norm(direction.astype(float), axis=0)
    f = origin.astype(float) - np.asarray(center, float)[:, None]
    return np.linalg.norm(f - (f * d).sum(axis=0) * d, axis=0)


def judge(t, si, origin, direction, center, radius, should_hit, judged):
    """``(lost, false, dt, angle, p_err)`` of the hit distances ``t``: hits lost, false hits
    (rays passing within 0.5 % of the silhouette are not ``judged``), the worst error of the
    hit distance in radii, and, given Mitsuba's interaction ``si``, the worst angle of its
    normal to the true one (rad) and the worst distance of its point from the sphere over the
    integrator's error bound."""
    hit = np.isfinite(t)
    lost = int((should_hit & ~hit).sum())
    false = int((judged & ~should_hit & hit).sum())
    ok = hit & should_hit
    true = exact_t(origin, direction, center, radius)[ok]
    dt = float(np.abs(t[ok] - true).max(initial=0.0)) / radius
    if si is None:
        return lost, false, dt, np.nan, np.nan
    c = np.asarray(center, float)[:, None]
    truth = origin[:, ok].astype(float) + true * direction[:, ok].astype(float) - c
    truth /= np.linalg.norm(truth, axis=0)
    normal = np.array(si.n, float)[:, ok]
    cos = (normal * truth).sum(axis=0) / np.linalg.norm(normal, axis=0)
    angle = float(np.arccos(np.clip(cos, -1, 1)).max(initial=0.0))
    point = np.array(si.p, float)[:, ok]
    p_err = float(np.abs(np.linalg.norm(point - c, axis=0) - radius).max(initial=0.0))
    return lost, false, dt, angle, p_err / error_bound(radius, center)


ACCURACY_RADII = (1e-3, 1e-2, 0.1, 1.0, 10.0, 1e2, 1e4, 1e6)
ACCURACY_PLACES = {"0": (0.0, 0.0, 0.0),
                   "1e4": tuple(1e4 * np.array([1.0, -0.7, 0.3]) / np.linalg.norm([1.0, -0.7, 0.3]))}


def accuracy(n: int = 20000, seed: int = 3):
    """Rows of the accuracy table: one per (radius, place, viewing distance)."""
    rng = np.random.default_rng(seed)
    rows = []
    for radius in ACCURACY_RADII:
        for place, center in ACCURACY_PLACES.items():
            for view in (3, 100, 1e4):
                if view > 3 and (view * radius > 1e5 or (view == 1e4 and radius > 1)):
                    continue
                half = n // 2
                o1, d1 = aimed_rays(center, radius, view * radius, half, rng,
                                    lambda k: 0.99 * np.sqrt(rng.uniform(0, 1, k)))
                o2, d2 = aimed_rays(center, radius, view * radius, n - half, rng,
                                    lambda k: rng.uniform(1.01, 1.5, k))
                origin, direction = np.concatenate([o1, o2], axis=1), np.concatenate([d1, d2], axis=1)
                # judged by the float32 rays' own impact parameters (rounding moves them)
                impact = miss_distance(origin, direction, center) / radius
                should = impact <= 0.995
                judged = should | (impact >= 1.005)
                ray = mi.Ray3f(mi.Point3f(origin), mi.Vector3f(direction))
                row = {"r": radius, "|C|": place, "view/r": view}
                for kind in ("sphere", "ellipsoids"):
                    scene = one_sphere(kind, center, radius)   # alive until the lazy result is read
                    si = scene.ray_intersect(ray)
                    t = np.where(np.array(si.is_valid()), np.array(si.t, float), np.inf)
                    row[kind] = judge(t, si, origin, direction, center, radius, should, judged)
                t = ellipsoid_t(origin, direction, center, radius, fixed=True).astype(float)
                row["fixed"] = judge(t, None, origin, direction, center, radius, should, judged)
                rows.append(row)
    return rows


def text_accuracy(rows, n):
    lines = []
    lines.append(f"\n== accuracy: {n} rays per row, half aimed at impact parameters below 0.99 r, half at "
          "1.01-1.5 r.\n   lost: hits missed; false: misses hit; dt/r: worst hit-distance error in radii; "
          "angle: worst error of Mitsuba's si.n (rad); p/e: worst distance of Mitsuba's si.p from the "
          "sphere over the integrator's error bound e = eps(8r + 4max|C|). 'fixed': the ellipsoid "
          "routine with the one-line fix, emulated (no si).")
    head = ["r", "|C|", "view/r"]
    for kind in ("sphere", "ellipsoids", "fixed"):
        head += [f"{kind} lost", "false", "dt/r"] + (["angle", "p/e"] if kind != "fixed" else [])
    lines += ["", "| " + " | ".join(head) + " |\n|" + "---|" * len(head)]
    for row in rows:
        cells = [f"{row['r']:g}", row["|C|"], f"{row['view/r']:g}"]
        for kind in ("sphere", "ellipsoids", "fixed"):
            lost, false, dt, angle, p_err = row[kind]
            cells += [str(lost), str(false), f"{dt:.1e}"]
            cells += [f"{angle:.1e}", f"{p_err:.2g}"] if kind != "fixed" else []
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


# -- load and ray-cast time ---------------------------------------------------------------------

MATERIALS = 4


def random_spheres(count: int, seed: int = 1):
    """``count`` non-overlapping spheres in a cube (:func:`benchmarks.scenes.random_spheres`) as
    arrays: centers 3×N, radii N, material index N."""
    spheres = scenes.random_spheres(count, seed, materials=MATERIALS)
    index: dict = {}
    material = np.array([index.setdefault(s.material, len(index)) for s in spheres])
    return (np.array([s.center for s in spheres]).T, np.array([s.radius for s in spheres]), material)


def bsdfs():
    return {f"m{k}": {"type": "diffuse", "id": f"m{k}", "reflectance": {"type": "rgb", "value": [0.2 * k + 0.1] * 3}}
            for k in range(MATERIALS)}


def sphere_dict(center, radius, material):
    scene = {"type": "scene", **bsdfs()}
    for k in range(len(radius)):
        scene[f"s{k}"] = {"type": "sphere", "center": center[:, k].tolist(), "radius": float(radius[k]),
                          "bsdf": {"type": "ref", "id": f"m{material[k]}"}}
    return scene


def ellipsoids_dict(center, radius, material):
    scene = {"type": "scene", **bsdfs()}
    for m in range(MATERIALS):
        pick = material == m
        count = int(pick.sum())
        scene[f"e{m}"] = {"type": "ellipsoids", "extent": 1.0,
                          "centers": mi.TensorXf(np.ascontiguousarray(center[:, pick].T, F32)),
                          "scales": mi.TensorXf(np.repeat(radius[pick].astype(F32)[:, None], 3, axis=1)),
                          "quaternions": mi.TensorXf(np.tile(np.array([0, 0, 0, 1], F32), (count, 1))),
                          "bsdf": {"type": "ref", "id": f"m{m}"}}
    return scene


def camera_rays(size: int):
    """``size``² pinhole rays from (0, 0, -20) looking at the cube of spheres (45° field of view)."""
    x, y = np.meshgrid((np.arange(size) + 0.5) / size * 2 - 1, (np.arange(size) + 0.5) / size * 2 - 1)
    direction = np.stack([x.ravel() * np.tan(np.pi / 8), y.ravel() * np.tan(np.pi / 8), np.ones(size * size)])
    direction /= np.linalg.norm(direction, axis=0)
    origin = np.zeros_like(direction)
    origin[2] = -20
    return mi.Ray3f(mi.Point3f(origin.astype(F32)), mi.Vector3f(direction.astype(F32)))


def cast(scene, ray, preliminary: bool):
    def run():
        if preliminary:
            pi = scene.ray_intersect_preliminary(ray, coherent=True)
            dr.eval(pi.t, pi.prim_index, pi.shape)
        else:
            si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.Minimal, coherent=True)
            dr.eval(si.t, si.n, si.p)
        dr.sync_thread()
    return run


def load_and_cast(counts, size: int = 512, rounds: int = 5):
    """Rows of the load/ray-cast table. Each scene is measured alone and released before the
    next is loaded: Dr.Jit traces a ``ray_intersect`` once for every shape *registered*, in
    every scene alive, so a 66 000-sphere scene would slow the other's interactions too."""
    import gc
    rows = []
    ray = camera_rays(size)
    for count in counts:
        center, radius, material = random_spheres(count)
        row, hits = {"N": count}, {}
        for kind, build in (("sphere", sphere_dict), ("ellipsoids", ellipsoids_dict)):
            description, row[f"{kind} dict s"], _ = timed(lambda: build(center, radius, material))
            scene, row[f"{kind} load s"], row[f"{kind} load cpu s"] = \
                timed(lambda: mi.load_dict(description, parallel=False))
            contenders = {how: cast(scene, ray, how == "preliminary") for how in ("preliminary", "interaction")}
            for how, timing in measure(contenders, rounds).items():
                row[f"{kind} {how}"] = timing.median
            pi = scene.ray_intersect_preliminary(ray)
            hits[kind] = np.where(np.array(pi.is_valid()), np.array(pi.t), np.inf)
            del description, scene, contenders, pi
            gc.collect()
        t = hits["sphere"], hits["ellipsoids"]
        row["same hit"] = float(np.mean(np.isfinite(t[0]) == np.isfinite(t[1])))
        both = np.isfinite(t[0]) & np.isfinite(t[1])
        row["max |dt|/t"] = float(np.max(np.abs(t[0][both] - t[1][both]) / t[0][both], initial=0))
        rows.append(row)
    return rows


def text_load(rows, size):
    lines = []
    lines.append(f"\n== load (mi.load_dict, parallel=False; wall s, CPU s) and {size}x{size} camera rays "
          "(median wall ms, interleaved rounds)")
    head = ["N", "sphere load s", "(cpu)", "ellipsoids load s", "(cpu)", "dict s sph/ell",
            "prelim ms sph", "ell", "interaction ms sph", "ell", "same hit", "max |dt|/t"]
    lines += ["", "| " + " | ".join(head) + " |\n|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join([
            str(r["N"]), f"{r['sphere load s']:.2f}", f"{r['sphere load cpu s']:.2f}",
            f"{r['ellipsoids load s']:.3f}", f"{r['ellipsoids load cpu s']:.3f}",
            f"{r['sphere dict s']:.2f}/{r['ellipsoids dict s']:.3f}",
            f"{1e3 * r['sphere preliminary']:.1f}", f"{1e3 * r['ellipsoids preliminary']:.1f}",
            f"{1e3 * r['sphere interaction']:.1f}", f"{1e3 * r['ellipsoids interaction']:.1f}",
            f"{r['same hit']:.5f}", f"{r['max |dt|/t']:.1e}"]) + " |")
    return "\n".join(lines)


# -- end to end on a scene file -----------------------------------------------------------------

#: the ways ``--only scene`` loads a scene: as written, as written but in the scaled frame
#: the ellipsoids need, and with the ellipsoids
WAYS = ("spheres", "spheres, scaled frame", "ellipsoids")


def one_process(path: str, way: str, out: str) -> dict:
    """Times of one way of loading and rendering ``path`` (run in its own process)."""
    start = time.perf_counter()
    from dataclasses import replace

    from whitted import sealed
    from whitted.converter import parse_file
    model = parse_file(path)
    parsed = time.perf_counter()
    if way == "spheres, scaled frame":   # the grouping's frame, nothing grouped
        grouping = sealed.choose(model, min_group=1)
        model = sealed.remaining(model, replace(grouping, member=np.zeros_like(grouping.member)))
    scene = whitted.load_scene(path, model=model, ellipsoids=way == "ellipsoids")
    loaded = time.perf_counter()
    first = whitted.render(scene)
    rendered = time.perf_counter()
    second = whitted.render(scene)
    again = time.perf_counter()
    np.save(out, first.image)
    kinds = [shape.class_name() for shape in scene.shapes()]
    return {"parse s": parsed - start, "load s": loaded - parsed, "first render s": rendered - loaded,
            "second render s": again - rendered, "total s": rendered - start,
            "shapes": len(kinds), "ellipsoids": kinds.count("Ellipsoids")}


def end_to_end(path: str, ways=WAYS):
    """``{way: times}`` and ``{way: image}``, each way in a fresh process."""
    import json
    import subprocess
    import tempfile
    rows, images, path = {}, {}, str(Path(path).resolve())
    with tempfile.TemporaryDirectory() as folder:
        for k, way in enumerate(ways):
            out = str(Path(folder) / f"{k}.npy")
            code = ("import json; from benchmarks.studies import ellipsoids; "
                    "print(json.dumps(ellipsoids.one_process(%r, %r, %r)))" % (path, way, out))
            wall = time.perf_counter()
            done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                                  check=True)
            rows[way] = json.loads(done.stdout.strip().splitlines()[-1])
            rows[way]["process s"] = time.perf_counter() - wall
            images[way] = np.load(out).astype(np.float64)
    return rows, images


def off(a, b) -> np.ndarray:
    """Per pixel, whether two images differ by more than 0.02 in a channel."""
    return np.abs(a - b).max(axis=2) > 0.02


def reference_at(path: str, pixels) -> dict:
    """The float64 reference (benchmarks/reference.py) of ``pixels`` ((row, column) pairs) of the
    scene at ``path``: its own formulas, with the loop over the spheres of its nearest-hit
    and shadow tests done by numpy (the same stable discriminant, the same skip rule)."""
    from .. import reference as R
    from whitted.converter import parse_file
    model = parse_file(path)
    center = np.array([s.center for s in model.spheres])
    radius = np.array([s.radius for s in model.spheres])

    def roots(origin, direction):
        f = np.asarray(origin) - center
        b = f @ np.asarray(direction)
        c = (f * f).sum(axis=1) - radius ** 2
        perpendicular = f - b[:, None] * np.asarray(direction)
        disc = radius ** 2 - (perpendicular * perpendicular).sum(axis=1)
        root = np.sqrt(np.maximum(disc, 0))
        q = np.where(b > 0, -b - root, -b + root)
        with np.errstate(divide="ignore", invalid="ignore"):
            other = np.where(q != 0, c / q, 0.0)
        return disc >= 0, np.minimum(q, other), np.maximum(q, other)

    def nearest_hit(scene, origin, direction):
        skip = R._skip(origin)
        ok, near, far = roots(origin, direction)
        t = np.where(ok & (near > skip), near, np.where(ok & (far > skip), far, np.inf))
        k = int(np.argmin(t))
        return (float(t[k]), scene.spheres[k]) if np.isfinite(t[k]) else None

    def blocked(scene, point, light_position):
        to_light = R.sub(light_position, point)
        distance = R.norm(to_light)
        skip = R._skip(point)
        ok, near, far = roots(point, R.mul(to_light, 1 / distance))
        inside = ((skip < near) & (near < distance - skip)) | ((skip < far) & (far < distance - skip))
        return bool((ok & inside).any())

    saved = R.nearest_hit, R.blocked
    R.nearest_hit, R.blocked = nearest_hit, blocked
    try:
        tracer = R.Reference(model)
        return {(j, i): np.array(tracer.trace(*R.camera_ray(model, i + 0.5, j + 0.5))) for j, i in pixels}
    finally:
        R.nearest_hit, R.blocked = saved


def text_end_to_end(path, rows, images, reference=None):
    lines = [f"\n== end to end: {path}, each way in a fresh process (wall s)"]
    keys = ["shapes", "ellipsoids", "parse s", "load s", "first render s", "second render s",
            "total s", "process s"]
    lines += ["", "| loaded as | " + " | ".join(keys) + " |\n|" + "---|" * (len(keys) + 1)]
    for way, row in rows.items():
        cells = [str(row[k]) if isinstance(row[k], int) else f"{row[k]:.2f}" for k in keys]
        lines.append(f"| {way} | " + " | ".join(cells) + " |")
    lines += ["", "| images | mean abs. difference | pixels off by > 0.02 |", "|---|---|---|"]
    ways = list(images)
    for a, b in zip(ways, ways[1:] + ways[:1]):
        lines.append(f"| {b} vs {a} | {np.abs(images[a] - images[b]).mean():.2e} | "
                     f"{off(images[a], images[b]).mean():.3%} |")
    if reference is not None:
        pixels, values = reference
        lines += ["", f"Against the float64 reference (benchmarks/reference.py) at the {len(pixels)} pixels where "
                  "the images differ by more than 0.02 (elsewhere they agree):", "",
                  "| loaded as | pixels off the reference by > 0.02 | mean abs. difference there |",
                  "|---|---|---|"]
        for way, image in images.items():
            error = np.array([np.abs(image[j, i] - values[(j, i)]).max() for j, i in pixels])
            lines.append(f"| {way} | {int((error > 0.02).sum())} | {error.mean():.4f} |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="accuracy,load,scene",
                        help="accuracy, load (includes ray casting), scene")
    parser.add_argument("--counts", default="1000,10000,66000")
    parser.add_argument("--rays", type=int, default=20000)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--scene", help="the .scn file of --only scene (default: the level-5 sphereflake)")
    parser.add_argument("--reference", action="store_true",
                        help="with --only scene: the float64 reference at the pixels where the ways differ "
                             "(minutes for 66 000 spheres)")
    parser.add_argument("--markdown", metavar="FILE", help="record the run in FILE's 'ellipsoids' section")
    args = parser.parse_args(argv)
    only = set(args.only.split(","))
    texts = [f"Mitsuba {mi.__version__}, Dr.Jit {dr.__version__}, variant {mi.variant()}, "
             f"{os.cpu_count()} CPUs; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load average "
             f"{os.getloadavg()[0]:.1f} at the start (times are wall-clock: a busy machine inflates them)"]
    print(texts[-1])
    if "accuracy" in only:
        texts.append(text_accuracy(accuracy(args.rays), args.rays))
        print(texts[-1])
    if "load" in only:
        texts.append(text_load(load_and_cast([int(c) for c in args.counts.split(",")], args.size), args.size))
        print(texts[-1])
    if "scene" in only:
        import tempfile
        with tempfile.TemporaryDirectory() as folder:
            path = args.scene
            if path is None:
                import sphereflake
                path = str(sphereflake.write(5, Path(folder) / "sphereflake5.scn"))
            rows, images = end_to_end(path)
            reference = None
            if args.reference:
                masks = [off(a, b) for a in images.values() for b in images.values()]
                pixels = [tuple(p) for p in np.argwhere(np.logical_or.reduce(masks)).tolist()]
                reference = pixels, reference_at(path, pixels)
            texts.append(text_end_to_end(args.scene or "sphereflake level 5", rows, images, reference))
            print(texts[-1])
    if args.markdown:
        import sections
        body = "## Mitsuba's ellipsoids shape as a fast path for spheres (benchmarks/studies/ellipsoids.py)\n\n" + \
            "\n".join(texts).replace("\n== ", "\n### ") + \
            "\n\nRun `.venv/bin/python -m benchmarks.studies.ellipsoids --reference --markdown benchmarks/RESULTS.md` " \
            "to rewrite this section."
        sections.replace(args.markdown, "ellipsoids", body)


if __name__ == "__main__":
    main()
