"""How far the portable XML (stock plugins, ``whitted convert --portable``) is from the default one.

For each example scene: the stock ``mitsuba`` command (no whitted) renders
``scenes_xml/NAME.portable.xml`` and ``whitted render --integrator path`` (through
:func:`whitted.render`) renders the scene's default form, at the same size and spp
(both ``llvm_ad_rgb``); printed are their relative MSE (``whitted.metrics``), the
noise part of it (two path renders with different seeds, same spp: for unbiased
estimates their relMSE is what noise alone gives), and how the relMSE splits by the
material of the surface each pixel's center sees first, classed by what its stock form
gets wrong (``converter.portable.inexact``): nothing (exact), the ``blendbsdf``
weighting of a mirror reflection against a non-white diffuse color (blend), Fresnel in
``dielectric`` (glass).
Then the lobe weights behind those differences, measured by sampling the stock
BSDFs (``scalar_rgb``): the mirror lobe of a 50/50 mirror–diffuse ``blendbsdf``
(B = 0.5) and of the same blend with a ``roughconductor`` (alpha 10⁻³) instead.
docs/portable.md has the results.

    python -m benchmarks.studies.portable [--spp 1024] [--scale 0.5] [--rough]

``--rough`` also renders each portable scene with ``roughconductor`` (alpha 10⁻³) in
place of the ``conductor`` mirrors, the stock construction that avoids the weighting.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from whitted.converter.description import material_dict
from whitted.converter.portable import inexact

REPO = Path(__file__).resolve().parents[2]
SCENES = ("globe", "mirrors", "spheres", "tir")


def material_class(material) -> str:
    """What the stock form of an article material gets wrong (converter/portable.py)."""
    reasons = " ".join(inexact(material_dict(material, None)))
    return "glass" if "Fresnel" in reasons else "blend" if "blendbsdf" in reasons else "exact"


def stock_render(xml_text: str, folder: Path, spp: int) -> np.ndarray:
    """The stock ``mitsuba`` command's render of ``xml_text`` (llvm_ad_rgb), written in ``folder``."""
    import whitted
    from whitted.variant import find_libllvm
    xml, out = folder / "scene.portable.xml", folder / "scene.exr"
    xml.write_text(xml_text, encoding="utf-8")
    env = dict(os.environ)
    if find_libllvm():
        env["DRJIT_LIBLLVM_PATH"] = find_libllvm()
    mitsuba = Path(sys.executable).parent / "mitsuba"
    subprocess.run([str(mitsuba), "-m", "llvm_ad_rgb", "-D", f"spp={spp}", "-o", str(out), str(xml)],
                   check=True, env=env, stdout=subprocess.DEVNULL)
    return whitted.read_image(out)


def first_hits(scene, model) -> np.ndarray:
    """The material class of the sphere each pixel center sees first ("background" if none)."""
    import drjit as dr
    import mitsuba as mi
    sensor = scene.sensors()[0]
    width, height = (int(c) for c in sensor.film().crop_size())
    j, i = np.mgrid[0:height, 0:width]
    position = mi.Point2f(((i + 0.5) / width).ravel(), ((j + 0.5) / height).ravel())
    rays, _ = sensor.sample_ray(0.0, 0.5, position, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(rays)
    classes = np.full(width * height, "background", dtype=object)
    for shape in scene.shapes():
        sphere = model.spheres[int(shape.id().split("_")[1])]
        hit = np.array(si.is_valid() & (si.shape == mi.ShapePtr(shape)), dtype=bool)
        classes[hit] = material_class(sphere.material)
    return classes.reshape(height, width)


def lobe_weights(child: dict, cos: float, samples: int = 20000) -> float:
    """The mirror lobe's sampled albedo of a 50/50 blend of ``child`` and a diffuse B = 0.5."""
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    bsdf = mi.load_dict({"type": "blendbsdf", "weight": 0.5, "bsdf_1": child,
                         "bsdf_0": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}})
    si = dr.zeros(mi.SurfaceInteraction3f)
    sin = np.sqrt(1 - cos * cos)
    si.wi, si.n = mi.Vector3f(sin, 0, cos), mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    mirror = np.array([-sin, 0.0, cos])
    rng = np.random.default_rng(1)
    total = 0.0
    for _ in range(samples):
        bs, weight = bsdf.sample(mi.BSDFContext(), si, float(rng.random()), mi.Point2f(rng.random(), rng.random()))
        if float(np.dot(np.array(bs.wo), mirror)) > np.cos(np.radians(1.0)):
            total += weight[0]
    return total / samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--scale", type=float, default=0.5, help="image size, a fraction of the scene's")
    parser.add_argument("--rough", action="store_true", help="also with roughconductor mirrors")
    args = parser.parse_args()

    import whitted
    from whitted.converter import parse_file, scene_to_xml
    from whitted.metrics import relative_mse
    whitted.set_variant("llvm_ad_rgb")
    rough = " | relMSE, roughconductor mirrors" if args.rough else ""
    print(f"| scene | size | spp | relMSE stock vs path | noise (path vs path) | "
          f"share on exact / blend / Fresnel / background{rough} |")
    print("|---|---|---|---|---|---|" + ("---|" if args.rough else ""))
    with tempfile.TemporaryDirectory() as tmp:
        for name in SCENES:
            model = parse_file(REPO / "scenes" / f"{name}.scn")
            model = replace(model, width=max(1, round(model.width * args.scale)),
                            height=max(1, round(model.height * args.scale)))
            xml = scene_to_xml(model, tmp, portable=True)
            stock = stock_render(xml, Path(tmp), args.spp)
            scene = whitted.load_scene(REPO / "scenes" / f"{name}.scn", model=model)
            path = whitted.render(scene, integrator="path", spp=args.spp, seed=1).image
            other = whitted.render(scene, integrator="path", spp=args.spp, seed=2).image
            terms = ((stock.astype(np.float64) - path) ** 2 / (path.astype(np.float64) ** 2 + 1e-2)).mean(axis=-1)
            classes = first_hits(scene, model)
            shares = " / ".join(f"{terms[classes == c].sum() / terms.sum():.0%}"
                                for c in ("exact", "blend", "glass", "background"))
            row = (f"| {name} | {model.width}×{model.height} | {args.spp} | {relative_mse(stock, path):.2e} | "
                   f"{relative_mse(other, path):.2e} | {shares} |")
            if args.rough:
                rough_xml = xml.replace('<bsdf type="conductor"', '<bsdf type="roughconductor"').replace(
                    '<string name="material" value="none"/>',
                    '<string name="material" value="none"/>\n<float name="alpha" value="0.001"/>')
                row += f" {relative_mse(stock_render(rough_xml, Path(tmp), args.spp), path):.2e} |"
            print(row, flush=True)
    print()
    print("| 50/50 blend with a diffuse B = 0.5 | mirror lobe at cos θ = 1 | 0.5 | 0.1 | exact |")
    print("|---|---|---|---|---|")
    for label, child in (("conductor (delta mirror)", {"type": "conductor", "material": "none"}),
                         ("roughconductor alpha 1e-3", {"type": "roughconductor", "material": "none",
                                                        "alpha": 1e-3})):
        print(f"| {label} | " + " | ".join(f"{lobe_weights(child, c):.3f}" for c in (1.0, 0.5, 0.1)) + " | 0.5 |")


if __name__ == "__main__":
    main()
