"""Variant selection: a good libLLVM is chosen before Dr.Jit starts, else scalar_rgb."""

import os
import re
import subprocess
import sys

import pytest

from whitted import variant


@pytest.mark.parametrize("name, version", [
    ("libLLVM-19.so", 19),
    ("libLLVM-19.so.1", 19),
    ("libLLVM.so.19.1", 19),
    ("libLLVM-15.so", 15),
    ("libLLVM-14.0.6.so.1", 14),
    ("libLLVM.19.dylib", 19),
    ("libLLVM.so", None),
    ("libfoo.so.19", None),
])
def test_version_from_file_name(name, version):
    assert variant.llvm_version_of(f"/usr/lib/{name}") == version


def test_version_from_llvm_folder():
    assert variant.llvm_version_of("/usr/lib/llvm-17/lib/libLLVM.so") == 17


def _fake_libs(folder, names):
    for name in names:
        (folder / name).write_bytes(b"")


def test_newest_good_library_wins(tmp_path, monkeypatch):
    _fake_libs(tmp_path, ["libLLVM-15.so", "libLLVM-16.so", "libLLVM-19.so", "libLLVM-19.so.1"])
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setenv("WHITTED_LIBLLVM_DIRS", str(tmp_path))
    assert variant.find_libllvm() == str(tmp_path / "libLLVM-19.so")


def test_old_libraries_are_refused(tmp_path, monkeypatch):
    _fake_libs(tmp_path, ["libLLVM-14.so", "libLLVM-15.so", "libLLVM-15.so.1"])
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setenv("WHITTED_LIBLLVM_DIRS", str(tmp_path))
    assert variant.find_libllvm() is None


def test_user_choice_wins(tmp_path, monkeypatch):
    chosen = tmp_path / "custom-llvm.so"
    chosen.write_bytes(b"")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(chosen))
    assert variant.find_libllvm() == str(chosen)


def _run_python(code, **env_changes):
    env = {k: v for k, v in os.environ.items() if k not in ("DRJIT_LIBLLVM_PATH", "WHITTED_VARIANT")}
    env.update(env_changes)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=300)


def test_without_libllvm_falls_back_to_scalar_with_one_warning(tmp_path):
    _fake_libs(tmp_path, ["libLLVM-15.so"])
    code = ("import whitted, mitsuba as mi; "
            "s = mi.load_dict({'type': 'scene', 's': {'type': 'sphere'}}); "
            "print(mi.variant(), s.ray_test(mi.Ray3f([0, 0, -5], [0, 0, 1])))")
    done = _run_python(code, WHITTED_LIBLLVM_DIRS=str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["scalar_rgb", "True"]
    warnings = [line for line in done.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "libllvm19" in warnings[0]


def test_with_libllvm_defaults_to_llvm():
    if variant.find_libllvm() is None:
        pytest.skip("no libLLVM >= 16 on this machine")
    done = _run_python("import whitted, mitsuba as mi; print(mi.variant())")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "llvm_ad_rgb"


def test_variant_already_chosen_is_kept():
    done = _run_python("import mitsuba as mi; mi.set_variant('scalar_rgb'); import whitted; "
                       "print(mi.variant())")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "scalar_rgb"


def test_unknown_variant_is_a_clean_error():
    with pytest.raises(variant.WhittedError, match="unsupported variant"):
        variant.set_variant("llvm_ad_spectral_polarized_typo")


def test_a_libllvm_dr_jit_cannot_load_is_one_line_before_dr_jit_starts(tmp_path):
    """$DRJIT_LIBLLVM_PATH naming a file that is no library: status 2 and one line naming it,
    no traceback (it was Dr.Jit's ImportError, after Dr.Jit's own complaints) and no image."""
    broken = tmp_path / "libLLVM-19.so"
    broken.write_bytes(b"not a library")
    (tmp_path / "ball.scn").write_text("size 8 6\nlight 0 5 5\nsphere 0 0 0 1\n")
    env = {k: v for k, v in os.environ.items() if k != "WHITTED_VARIANT"}
    done = subprocess.run([sys.executable, "-m", "whitted", "render", "ball.scn", "-o", "ball.png"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env={**env, "DRJIT_LIBLLVM_PATH": str(broken)})
    assert done.returncode == 2
    [line] = done.stderr.splitlines()   # the loader's reason in brackets ("file too short")
    assert re.fullmatch(f"whitted: error: DRJIT_LIBLLVM_PATH={re.escape(str(broken))}: not a library "
                        r"Dr.Jit can load \([^/]+\)", line), line
    assert not (tmp_path / "ball.png").exists()


@pytest.mark.parametrize("kind", ["missing", "not libLLVM"])
def test_a_libllvm_choice_dr_jit_would_refuse_or_abort_on_is_refused(kind, tmp_path, monkeypatch):
    """A library without LLVM-C's LLVMGetVersion (libLLVM 15, on which Dr.Jit aborts the process,
    has none) is refused, as a missing file is; a scalar variant does not need one."""
    import _ctypes
    path = str(tmp_path / "libLLVM-19.so") if kind == "missing" else _ctypes.__file__
    monkeypatch.setattr(variant, "_USER_LIBLLVM", path)
    why = "no such file" if kind == "missing" else "not libLLVM 16 or newer"
    for chosen in (None, "llvm_ad_rgb"):
        with pytest.raises(variant.WhittedError, match=f"^DRJIT_LIBLLVM_PATH={re.escape(path)}: {why}"):
            variant.check_user_libllvm(chosen)
    variant.check_user_libllvm("scalar_rgb")


def test_import_mitsuba_with_a_libllvm_that_is_none_says_so(tmp_path):
    """``import whitted, mitsuba`` (a notebook's way) warns once, naming the variable, and sets
    no variant (Dr.Jit's ImportError was a traceback)."""
    import _ctypes
    done = _run_python("import whitted, mitsuba as mi; print(mi.variant())",
                       DRJIT_LIBLLVM_PATH=_ctypes.__file__)
    assert done.returncode == 0 and done.stdout.split() == ["None"], done.stderr
    [warning] = [line for line in done.stderr.splitlines() if line.startswith("whitted:")]
    assert warning.startswith(f"whitted: warning: DRJIT_LIBLLVM_PATH={_ctypes.__file__}: not libLLVM 16")


def test_the_libllvm_whitted_finds_passes_the_check(monkeypatch):
    found = variant.find_libllvm()
    if found is None:
        pytest.skip("no libLLVM >= 16 on this machine")
    monkeypatch.setattr(variant, "_USER_LIBLLVM", found)
    variant.check_user_libllvm(None)
