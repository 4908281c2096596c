"""``whitted convert --portable``: the scene in Mitsuba's stock plugins only.

What a portable file must do, checked against independent judges: the stock
``mitsuba`` command (a subprocess: no Python, no whitted) renders it in
``scalar_rgb`` and ``llvm_ad_rgb``; a Python process that never imports
whitted loads it with ``mi.load_file``; its materials have the article's lobe
weights (1 − KR − KT, KR, KT, read back from the XML); and its render matches
``whitted render --integrator path`` on the default form: within noise for
diffuse-only scenes, within the measured difference of docs/portable.md for
the examples (Fresnel in ``dielectric``, the ``blendbsdf`` weighting).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest

import whitted
from hard_cases.hazard_scenes import HAZARDS, build
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, parse_file, scene_to_xml
from whitted.converter.description import describe, meshes
from whitted.converter.xml_writer import xml_of
from whitted.images import read_image
from whitted.metrics import relative_mse
from whitted.variant import find_libllvm

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((REPO / "scenes").glob("*.scn"))
MITSUBA = Path(sys.executable).parent / "mitsuba"

#: relMSE of the stock render against ``--integrator path`` at 64×40 and 1024 spp (both
#: sides) that the tests allow: the measured value (docs/portable.md, "In the tests") + 30 %
EXAMPLE_BOUNDS = {"globe": 1.1e-3, "mirrors": 3e-3, "spheres": 2e-3, "tir": 5e-3}
SIZE = (64, 40)


def stock_env() -> dict:
    env = dict(os.environ)
    if find_libllvm():
        env["DRJIT_LIBLLVM_PATH"] = find_libllvm()
    return env


def stock_mitsuba(variant: str, files: list[Path], **params) -> None:
    """The stock ``mitsuba`` command on ``files`` (each renders to X.exr beside it)."""
    defines = [arg for name, value in params.items() for arg in ("-D", f"{name}={value}")]
    run = subprocess.run([str(MITSUBA), "-m", variant, *defines, *map(str, files)], env=stock_env(),
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]


def portable_file(model: Scene, folder: Path, name: str) -> Path:
    """The portable XML of ``model`` in ``folder``, with its giant spheres' meshes beside it
    (converter/giants.py; named after the model's source: one model per source here)."""
    path = folder / f"{name}.portable.xml"
    model = replace(model, source=folder / f"{name}.scn")
    description = describe(model, base_dir=folder)
    for mesh in meshes(description):
        (folder / mesh.filename).write_bytes(mesh.data)
    path.write_text(xml_of(description, portable=True), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def every_scene(tmp_path_factory) -> dict[str, tuple[Scene, Path]]:
    """Every example and hazard scene (tests/hard_cases) as portable XML in one folder."""
    folder = tmp_path_factory.mktemp("portable")
    scenes = {}
    for scn in EXAMPLES:
        scenes[scn.stem] = parse_file(scn)
    for name in HAZARDS:
        scenes[name] = build(name, folder)
    return {name: (model, portable_file(model, folder, name)) for name, model in scenes.items()}


# ------------------------------------------------------------ the command

def test_convert_portable_names_and_folders(tmp_path, capsys):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (scenes / "a.scn").write_text("size 8 6\nlight 1 1 1\nsphere 0 0 0 1 reflect 0.5\n")
    (scenes / "b.scn").write_text("light 1 1 1\nsphere 0 0 0 1\n")
    assert main(["convert", str(scenes / "a.scn"), "--portable"]) == 0
    assert (scenes / "a.portable.xml").is_file() and not (scenes / "a.xml").exists()
    assert main(["convert", str(scenes), "-o", str(tmp_path / "out"), "--portable"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.portable.xml", "b.portable.xml"]
    assert main(["convert", str(scenes / "b.scn"), "-o", str(tmp_path / "named.xml"), "--portable"]) == 0
    assert 'type="path"' in (tmp_path / "named.xml").read_text()
    assert capsys.readouterr() == ("", "")


def test_convert_portable_bad_scene_is_one_line_and_writes_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.scn"
    bad.write_text("size 8 6\n\nsphere 0 0 0 -1\n")
    assert main(["convert", str(bad), "--portable"]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [err.strip()] and f"{bad}:3:" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.scn"]


def test_convert_portable_loads_neither_mitsuba_nor_drjit(tmp_path):
    (tmp_path / "x.scn").write_text("size 8 8\nlight 1 1 1\nsphere 0 0 0 1 refract 0.5 1.5\n")
    code = ("import sys\n"
            "from whitted.cli import main\n"
            "status = main(['convert', 'x.scn', '--portable'])\n"
            "print(status, ','.join(m for m in ('mitsuba', 'drjit') if m in sys.modules) or '-')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["0", "-"] and (tmp_path / "x.portable.xml").is_file()


# ------------------------------------------------------------ what the file says

def lobes(element: ET.Element, weight: float = 1.0, found=None) -> dict[str, float]:
    """The share of each stock leaf BSDF (diffuse, conductor, dielectric) in a material."""
    found = {} if found is None else found
    kind = element.get("type")
    if kind == "blendbsdf":
        t = float(element.find("float[@name='weight']").get("value"))
        first, second = element.findall("bsdf")
        lobes(first, weight * (1 - t), found)
        lobes(second, weight * t, found)
    elif kind == "twosided":
        lobes(element.find("bsdf"), weight, found)
    else:
        found[kind] = found.get(kind, 0.0) + weight
    return found


MATERIALS = [Material(color=(0.8, 0.5, 0.2)), Material(reflect=1.0), Material(color=(0.3, 0.9, 0.4), reflect=0.3),
             Material(refract=1.0, ior=1.5), Material(color=(0.9, 0.9, 0.8), reflect=0.1, refract=0.8, ior=1.33),
             Material(reflect=0.4, refract=0.6, ior=0.7), Material(refract=1.0, ior=1.0), Material(reflect=0.5)]
MIXED = Scene(width=8, height=6, lights=[Light((3.0, 5.0, 5.0))],
              spheres=[Sphere((2.0 * k, 0.0, 0.0), 0.9, m) for k, m in enumerate(MATERIALS)])


def test_materials_have_the_article_lobe_weights(tmp_path):
    root = ET.fromstring(scene_to_xml(MIXED, tmp_path, portable=True))
    for k, material in enumerate(MATERIALS):
        element = root.find(f"bsdf[@id='material_{k}']")
        shares = lobes(element)
        expected = {"diffuse": 1 - material.reflect - material.refract, "conductor": material.reflect,
                    "dielectric": material.refract}
        assert set(shares) == {kind for kind, w in expected.items() if w > 0}
        for kind, share in shares.items():
            assert share == pytest.approx(expected[kind], abs=1e-12), (k, kind)
        for leaf in element.iter("bsdf"):
            if leaf.get("type") == "diffuse":
                assert leaf.find("rgb").get("value") == " ".join(repr(c) for c in material.color)
            if leaf.get("type") == "conductor":
                assert leaf.find("string[@name='material']").get("value") == "none"
            if leaf.get("type") == "dielectric":
                assert float(leaf.find("float[@name='int_ior']").get("value")) == material.ior
                assert float(leaf.find("float[@name='ext_ior']").get("value")) == 1.0
        # diffuse and mirror lobes see both sides of the sphere, as the article shades them
        for leaf in element.iter("bsdf"):
            if leaf.get("type") in ("diffuse", "conductor"):
                assert any(a.get("type") == "twosided" and leaf in a.iter("bsdf") for a in element.iter("bsdf"))


def test_header_lists_exactly_the_inexact_materials(tmp_path):
    xml = scene_to_xml(MIXED, tmp_path, portable=True)
    header = xml[:xml.index("<scene")]
    listed = {line.split("Not exact, ")[1].split(":")[0] for line in header.splitlines() if "Not exact, " in line}
    # exact: diffuse, pure mirror, glass of IOR 1 (no Fresnel), a white mirror-and-diffuse blend
    assert listed == {"material_2", "material_3", "material_4", "material_5"}
    assert "Fresnel" in header.split("material_3:")[1].splitlines()[0]
    assert "blendbsdf" not in header.split("material_3:")[1].splitlines()[0]
    assert "blendbsdf" in header.split("material_2:")[1].splitlines()[0]


def test_defaults_are_the_scene_s_and_the_path_depth(tmp_path):
    model = replace(MIXED, depth=7, samples=3, width=30, height=20)
    root = ET.fromstring(scene_to_xml(model, tmp_path, portable=True))
    defaults = {d.get("name"): d.get("value") for d in root.findall("default")}
    assert {k: defaults[k] for k in ("spp", "max_depth", "width", "height")} == \
        {"spp": "3", "max_depth": "8", "width": "30", "height": "20"}
    assert "ambient" not in defaults and "lighting" not in defaults
    assert [i.get("type") for i in root.findall("integrator")] == ["path"]
    types = {e.get("type") for e in root.iter() if e.get("type")}
    assert not types & {"whitted", "article"}


def test_positions_follow_the_default_form(tmp_path, every_scene):
    """Everything but integrator, materials and the film's size parameters is the default XML's."""
    for name in ("globe", "spheres", "large_floor", "texture_poles"):
        model, _ = every_scene[name]
        default = ET.fromstring(scene_to_xml(model, tmp_path))
        portable = ET.fromstring(scene_to_xml(model, tmp_path, portable=True))
        for tag in ("shape", "emitter"):
            assert [ET.tostring(e) for e in default.findall(tag)] == [ET.tostring(e) for e in portable.findall(tag)]
        assert ET.tostring(default.find("sensor/transform")) == ET.tostring(portable.find("sensor/transform"))


# ------------------------------------------------------------ stock Mitsuba reads it

@pytest.mark.parametrize("variant", ["scalar_rgb", "llvm_ad_rgb"])
def test_the_stock_mitsuba_command_renders_every_scene(variant, every_scene, tmp_path):
    folder = tmp_path / variant
    folder.mkdir()
    files = [portable_file(model, folder, name) for name, (model, _) in every_scene.items()]
    stock_mitsuba(variant, files, spp=2, width=12, height=8)
    for f in files:
        image = read_image(f.with_suffix(".exr"))
        assert image.shape == (8, 12, 3) and np.isfinite(image).all() and (image >= 0).all(), f.name
        model = every_scene[f.name.split(".")[0]][0]
        if model.lights or any(model.background):
            assert image.max() > 0, f.name


def test_python_without_whitted_loads_every_scene(every_scene):
    files = {name: str(path) for name, (_, path) in every_scene.items()}
    code = (
        "import json, sys\n"
        "import mitsuba as mi\n"
        "out = {}\n"
        "for variant in ('scalar_rgb', 'llvm_ad_rgb'):\n"
        "    mi.set_variant(variant)\n"
        "    for name, path in json.loads(sys.argv[1]).items():\n"
        "        s = mi.load_file(path, spp=2)\n"
        "        out[variant + ' ' + name] = [len(s.shapes()), len(s.emitters()), s.integrator().class_name(),\n"
        "                                    s.sensors()[0].sampler().sample_count()]\n"
        "assert not any(m == 'whitted' or m.startswith('whitted.') for m in sys.modules)\n"
        "print(json.dumps(out))\n")
    run = subprocess.run([sys.executable, "-c", code, json.dumps(files)], env=stock_env(), cwd="/",
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    loaded = json.loads(run.stdout)
    for variant in ("scalar_rgb", "llvm_ad_rgb"):
        for name, (model, _) in every_scene.items():
            lights = len(model.lights) + (1 if any(model.background) else 0)
            assert loaded[f"{variant} {name}"] == [len(model.spheres), lights, "PathIntegrator", 2]


# ------------------------------------------------------------ whitted render on a portable file

@pytest.fixture
def mirrors_portable(tmp_path):
    return portable_file(replace(parse_file(REPO / "scenes" / "mirrors.scn"), width=16, height=10),
                         tmp_path, "mirrors")


def test_whitted_integrator_is_refused_in_one_line(mirrors_portable, tmp_path, capsys):
    out = tmp_path / "out.png"
    assert main(["render", str(mirrors_portable), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(mirrors_portable) in err and "--integrator path" in err
    assert not out.exists()
    with pytest.raises(whitted.WhittedError, match="article"):
        whitted.render(whitted.load_scene(mirrors_portable))


def test_compare_refuses_a_portable_file_before_any_work(mirrors_portable, tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", str(mirrors_portable), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"whitted: error: {mirrors_portable}: ") and err.count("\n") == 1
    assert not out.exists()


def test_overrides_the_portable_file_lacks_are_one_line(mirrors_portable, tmp_path, capsys):
    out = tmp_path / "out.png"
    assert main(["render", str(mirrors_portable), "-o", str(out), "-q", "--integrator", "path",
                 "--ambient", "0.3"]) == 2
    assert capsys.readouterr().err.strip() == f"whitted: error: {mirrors_portable}: the scene has no ambient to override"
    assert not out.exists()


def test_path_integrator_renders_with_the_file_s_own_depth(mirrors_portable, tmp_path, llvm):
    out = tmp_path / "out.exr"
    assert main(["render", str(mirrors_portable), "-o", str(out), "-q", "--integrator", "path", "--spp", "4"]) == 0
    scene = mi.load_file(str(mirrors_portable), spp=4)
    assert "max_depth = 13" in str(scene.integrator())    # mirrors.scn: depth 12
    np.testing.assert_array_equal(read_image(out), np.array(mi.render(scene, spp=4, seed=0))[..., :3])


# ------------------------------------------------------------ the same image as --integrator path

def diffuse_only(model: Scene) -> Scene:
    return replace(model, spheres=[replace(s, material=replace(s.material, reflect=0.0, refract=0.0))
                                   for s in model.spheres])


#: name -> (stock spp, reference spp): diffuse-only versions of examples (the globe's own noise
#: at 256 spp is already 1.7e-3, so it is held to the bound at 1024), and the examples themselves
SETTINGS = {"spheres-diffuse": (256, 4096), "tir-diffuse": (256, 4096), "globe-diffuse": (1024, 4096),
            **{name: (1024, 1024) for name in EXAMPLE_BOUNDS}}


@pytest.fixture(scope="module")
def differences(tmp_path_factory) -> dict[str, tuple[float, float]]:
    """For each of :data:`SETTINGS`: the relMSE of the stock ``mitsuba`` render (llvm_ad_rgb)
    against ``whitted.render(..., integrator="path")`` of the default form, and that of another
    path render of the stock spp (a new seed) against the same reference: what noise alone gives."""
    folder = tmp_path_factory.mktemp("stock")
    models = {}
    for name, (stock_spp, _) in SETTINGS.items():
        model = parse_file(REPO / "scenes" / f"{name.split('-')[0]}.scn")
        models[name] = replace(diffuse_only(model) if name.endswith("-diffuse") else model,
                               width=SIZE[0], height=SIZE[1])
    files = {name: portable_file(model, folder, name) for name, model in models.items()}
    for spp in sorted({stock for stock, _ in SETTINGS.values()}):
        stock_mitsuba("llvm_ad_rgb", [files[n] for n, (s, _) in SETTINGS.items() if s == spp], spp=spp)
    previous = mi.variant()
    whitted.set_variant("llvm_ad_rgb")
    try:
        result = {}
        for name, model in models.items():
            stock_spp, reference_spp = SETTINGS[name]
            scene = whitted.load_scene(model.source, model=model)
            reference = whitted.render(scene, integrator="path", spp=reference_spp, seed=1).image
            other = whitted.render(scene, integrator="path", spp=stock_spp, seed=2).image
            result[name] = (relative_mse(read_image(files[name].with_suffix(".exr")), reference),
                            relative_mse(other, reference))
    finally:
        whitted.set_variant(previous)
    return result


@pytest.mark.parametrize("name", [n for n in SETTINGS if n.endswith("-diffuse")])
def test_diffuse_scenes_match_the_path_tracer_within_noise(name, differences):
    stock, noise = differences[name]
    assert stock <= 2e-3
    assert stock <= 1.25 * noise


@pytest.mark.parametrize("name", sorted(EXAMPLE_BOUNDS))
def test_examples_differ_by_the_documented_amount(name, differences):
    assert differences[name][0] <= EXAMPLE_BOUNDS[name]


def test_fresnel_sets_the_glass_scene_apart(differences):
    """tir.scn's glass is the one large difference (docs/portable.md): well above noise."""
    stock, noise = differences["tir"]
    assert stock > 3 * noise


@pytest.mark.parametrize("cos, b", [(1.0, 0.5), (0.5, 0.5), (0.5, 1.0)])
def test_blendbsdf_weights_a_mirror_mixed_with_diffuse_as_documented(cos, b):
    """Mitsuba 3.8+ (3.9.1 here): a blendbsdf of weight w choosing its delta child weights that
    sample (w + (1 − w)·B·cosθ/π) / (w + (1 − w)·cosθ/π) instead of 1 (it mixes the diffuse
    pdf into the delta's): a 50/50 mirror–diffuse blend with B = 0.5 reflects 0.44, not 0.5, at
    normal incidence; with B = 1 the weight is 1, exact. Should Mitsuba fix it, this fails:
    then update docs/portable.md and the header notes of converter/portable.py."""
    previous = mi.variant()
    whitted.set_variant("scalar_rgb")
    try:
        w = 0.5
        bsdf = mi.load_dict({"type": "blendbsdf", "weight": w,
                             "bsdf_0": {"type": "diffuse", "reflectance": {"type": "rgb", "value": b}},
                             "bsdf_1": {"type": "conductor", "material": "none"}})
        si = mi.SurfaceInteraction3f()
        si.wi, si.n = mi.Vector3f(np.sqrt(1 - cos * cos), 0, cos), mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        sample, weight = bsdf.sample(mi.BSDFContext(), si, 0.25, mi.Point2f(0.5, 0.5))   # 0.25 < w: the mirror
        assert mi.has_flag(sample.sampled_type, mi.BSDFFlags.DeltaReflection)
        p = cos / np.pi
        assert weight[0] == pytest.approx((w + (1 - w) * b * p) / (w + (1 - w) * p), rel=1e-5)
        if (cos, b) == (1.0, 0.5):
            assert w * weight[0] == pytest.approx(0.44, abs=0.005)
    finally:
        whitted.set_variant(previous)
