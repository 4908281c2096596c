"""``import whitted``: cheap, yet Mitsuba users get the plugins without asking.

Each case runs in a fresh interpreter, since what is imported first matters.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

XML = ('<scene version="3.0.0"><integrator type="whitted"><integer name="max_depth" value="3"/>'
       '</integrator><shape type="sphere"><bsdf type="article"><float name="reflect" value="0.5"/>'
       '</bsdf></shape></scene>')


def run(code: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    last = done.stdout.strip().splitlines()[-1]   # Mitsuba may log a warning first, in color
    return re.sub(r"\x1b\[[0-9;]*m", "", last).split()


def test_import_whitted_loads_neither_mitsuba_nor_drjit():
    assert run("import sys, whitted\n"
               "print('mitsuba' in sys.modules, 'drjit' in sys.modules, 'numpy' in sys.modules)") \
        == ["False", "False", "False"]


@pytest.mark.parametrize("order", ["whitted first", "mitsuba first"])
def test_plugins_are_registered_for_mitsuba_users(order):
    imports = "import whitted\nimport mitsuba as mi\n" if order == "whitted first" else \
              "import mitsuba as mi\nimport whitted\n"
    out = run(imports + f"scene = mi.load_string({XML!r})\n"
              "print(mi.variant(), type(scene.integrator()).__name__)\n")
    assert out[1] == "WhittedIntegrator" and out[0] in ("llvm_ad_rgb", "scalar_rgb")


def test_a_variant_set_later_gets_the_plugins_too():
    out = run("import whitted\nimport mitsuba as mi\nmi.set_variant('scalar_rgb')\n"
              f"scene = mi.load_string({XML!r})\n"
              "print(mi.variant(), type(scene.integrator()).__name__)\n")
    assert out == ["scalar_rgb", "WhittedIntegrator"]


def test_a_variant_chosen_before_whitted_is_kept():
    out = run("import mitsuba as mi\nmi.set_variant('scalar_rgb')\nimport whitted\n"
              f"scene = mi.load_string({XML!r})\nprint(mi.variant())\n")
    assert out == ["scalar_rgb"]


def test_the_api_is_at_the_top_level():
    out = run("import whitted\nprint(callable(whitted.render), callable(whitted.load_scene), "
              "callable(whitted.write_image), callable(whitted.read_image), whitted.__version__)")
    assert out[:4] == ["True"] * 4
    from whitted.defaults import VERSION
    assert out[4] == VERSION


def test_version_flag():
    done = subprocess.run([sys.executable, "-m", "whitted", "--version"], capture_output=True, text=True)
    from whitted.defaults import VERSION
    assert done.returncode == 0 and done.stdout.strip() == f"whitted {VERSION}"


def test_bad_variant_in_the_environment_is_one_line(tmp_path):
    scene = tmp_path / "s.scn"
    scene.write_text("size 4 4\nsphere 0 0 0 1\n")
    done = subprocess.run([sys.executable, "-m", "whitted", "render", str(scene), "-o",
                           str(tmp_path / "x.png")], capture_output=True, text=True,
                          env={**__import__("os").environ, "WHITTED_VARIANT": "bogus"})
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "whitted: error: WHITTED_VARIANT=bogus: not a variant whitted runs in; "
        "choose one of scalar_rgb, llvm_ad_rgb, cuda_ad_rgb"]
    assert not (tmp_path / "x.png").exists()


def test_the_package_builds_without_setuptools_warnings(tmp_path):
    """A wheel built as pip builds it (isolated, current setuptools) ships the report's
    template and draws no BuildBackendWarning (``make demo`` printed 40 lines of one)."""
    import shutil
    import zipfile
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    source = tmp_path / "source"   # pip builds in the source tree: a copy, not the checkout
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(repo / name, source / name)
    for name in ("whitted", "converter", "plugins"):
        shutil.copytree(repo / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-v", "--no-deps", "-w", str(tmp_path),
                            str(source)], capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stderr[-2000:]
    assert "BuildBackendWarning" not in build.stdout + build.stderr
    (wheel,) = tmp_path.glob("whitted-*.whl")
    assert "whitted/compare/templates/report.html.j2" in zipfile.ZipFile(wheel).namelist()
