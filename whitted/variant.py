"""Choosing Mitsuba's variant (only here), and a libLLVM that Dr.Jit can use: its llvm
backend *aborts the process* on a libLLVM older than 16, so before Dr.Jit starts the newest
libLLVM >= 16 is found and ``DRJIT_LIBLLVM_PATH`` points at it; without one the default
variant is ``scalar_rgb``, with a warning.
"""

from __future__ import annotations

import glob
import os
import re
import sys

from .defaults import DEFAULT_VARIANT, FALLBACK_VARIANT, VARIANTS
from .errors import WhittedError, first_line

MIN_LLVM_VERSION = 16

_LIB_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib",
             "/usr/local/lib", "/usr/lib/llvm-*/lib", "/opt/homebrew/opt/llvm/lib",
             "/usr/local/opt/llvm/lib")
#: libLLVM.so.19(.1); libLLVM-19.so(.1), libLLVM-19.dylib, libLLVM.19.dylib
_VERSIONED = re.compile(r"^libLLVM(?:\.so\.(\d+)|[-.](\d+)(?:\.\d+)*\.(?:so|dylib))(?:\.\d+)*$")
_fallback_warned = False
#: the variant asked for before Mitsuba's import, whose hook then sets it (set once)
_requested: str | None = None
#: $DRJIT_LIBLLVM_PATH as the user set it, before :func:`prepare_llvm` may set it
_USER_LIBLLVM = os.environ.get("DRJIT_LIBLLVM_PATH")


def llvm_version_of(path: str) -> int | None:
    """The major version in a libLLVM file name, or None when the name has none."""
    name = os.path.basename(path)
    match = _VERSIONED.match(name)
    if match:
        return int(match[1] or match[2])
    # /usr/lib/llvm-19/lib/libLLVM.so: the version is in the folder.
    match = re.search(r"llvm-(\d+)", path)
    if name.startswith("libLLVM") and match:
        return int(match.group(1))
    return None


def find_libllvm() -> str | None:
    """``$DRJIT_LIBLLVM_PATH``, else the newest libLLVM >= 16 in ``$WHITTED_LIBLLVM_DIRS`` (else
    the usual folders), or None."""
    chosen = os.environ.get("DRJIT_LIBLLVM_PATH")
    if chosen and os.path.isfile(chosen):
        return chosen
    dirs = os.environ.get("WHITTED_LIBLLVM_DIRS")
    candidates = []
    for pattern in (dirs.split(os.pathsep) if dirs is not None else _LIB_DIRS):
        for folder in glob.glob(pattern):
            for path in glob.glob(os.path.join(folder, "libLLVM*")):
                version = llvm_version_of(path)
                if version is not None and version >= MIN_LLVM_VERSION and os.path.isfile(path):
                    candidates.append((version, len(path), path))
    if not candidates:
        return None
    # Newest version first; among its names, the shortest (libLLVM-19.so).
    candidates.sort(key=lambda c: (-c[0], c[1], c[2]))
    return candidates[0][2]


def prepare_llvm() -> str | None:
    """Point Dr.Jit at a usable libLLVM before it starts; return its path."""
    path = find_libllvm()
    if path is not None:
        os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path


def check_environment() -> str | None:
    """``$WHITTED_VARIANT`` (None: unset), or a clean error if it names no supported variant."""
    requested = os.environ.get("WHITTED_VARIANT")
    if requested and requested not in VARIANTS:
        raise WhittedError(f"WHITTED_VARIANT={requested}: not a variant whitted runs in; choose one of "
                           + ", ".join(VARIANTS))
    return requested or None


def check_user_libllvm(variant: str | None) -> None:
    """Refuse a ``$DRJIT_LIBLLVM_PATH`` that an llvm variant (``variant``, or the default: None)
    could not use. The command asks before Mitsuba is imported: Dr.Jit, on its import, *aborts
    the process* on libLLVM 15. The version is asked of the library (LLVM-C's
    ``LLVMGetVersion``, which libLLVM has from 16 on)."""
    import ctypes
    path = _USER_LIBLLVM
    if not path or (variant is not None and not variant.startswith("llvm")):
        return
    where = f"DRJIT_LIBLLVM_PATH={path}"
    if not os.path.isfile(path):
        raise WhittedError(f"{where}: no such file")
    try:
        library = ctypes.CDLL(path)
    except OSError as error:
        why = first_line(error).removeprefix(f"{path}: ")
        raise WhittedError(f"{where}: not a library Dr.Jit can load ({why})") from None
    version = [ctypes.c_uint() for _ in range(3)]
    if hasattr(library, "LLVMGetVersion"):
        library.LLVMGetVersion(*map(ctypes.byref, version))
    if version[0].value < MIN_LLVM_VERSION:
        raise WhittedError(f"{where}: not libLLVM {MIN_LLVM_VERSION} or newer, which Dr.Jit needs "
                           "(install Debian's libllvm19, or unset it to let whitted find one)")


def default_variant() -> str:
    """``$WHITTED_VARIANT``, else llvm_ad_rgb when a good libLLVM exists, else scalar_rgb."""
    global _fallback_warned
    if _requested is not None:
        return _requested
    requested = check_environment()
    if requested:
        return requested
    if prepare_llvm() is not None:
        return DEFAULT_VARIANT
    if not _fallback_warned:
        _fallback_warned = True
        print(f"whitted: warning: no libLLVM >= {MIN_LLVM_VERSION} found (install Debian's "
              f"libllvm19 or set DRJIT_LIBLLVM_PATH); using the slow {FALLBACK_VARIANT} variant",
              file=sys.stderr)
    return FALLBACK_VARIANT


def set_variant(variant: str | None = None) -> str:
    """Select a Mitsuba variant (None: the one set, else the default) and register the plugins."""
    from .interrupt import deferred
    request(variant)
    with deferred():
        import mitsuba as mi

        if variant is None:
            variant = mi.variant() or default_variant()
        if variant not in VARIANTS:
            raise WhittedError(f"unsupported variant '{variant}'; choose one of "
                               + ", ".join(VARIANTS))
        if variant.startswith("llvm") and prepare_llvm() is None:
            raise WhittedError(f"variant {variant} needs libLLVM >= {MIN_LLVM_VERSION}: install "
                               "Debian's libllvm19 or set DRJIT_LIBLLVM_PATH")
        if variant.startswith("cuda"):
            import drjit as dr
            if not dr.has_backend(dr.JitBackend.CUDA):
                raise WhittedError(f"variant {variant} needs an NVIDIA GPU with a CUDA driver")
        if variant not in mi.variants():
            raise WhittedError(f"this Mitsuba build has no variant {variant}")
        if mi.variant() != variant:
            check_user_libllvm(variant)
            try:
                mi.set_variant(variant)
            except ImportError as error:   # Dr.Jit could not start the variant's backend
                raise WhittedError(f"variant {variant}: {first_line(error)}") from None
        from whitted import plugins
        plugins.register()
        return variant


def request(variant: str | None) -> None:
    """Ask for ``variant`` before Mitsuba is imported: its import hook then sets this one."""
    global _requested
    if variant in VARIANTS and "mitsuba" not in sys.modules:
        _requested = variant


def on_variant_changed(old: str | None, new: str | None) -> None:
    """Mitsuba's variant callback: the plugins registered, or refusing where they do not run."""
    from whitted import plugins
    if new in VARIANTS:
        plugins.register()
    elif new:
        plugins.refuse(VARIANTS)


def ensure_llvm() -> str | None:
    """``make``'s: find a libLLVM >= 16, else install Debian's libllvm19 (apt-get, as root or
    by password-less sudo, unless ``$WHITTED_NO_APT``), else say what to do."""
    import shutil
    import subprocess

    path = find_libllvm()
    apt, sudo = shutil.which("apt-get"), shutil.which("sudo")
    if path is None and apt and not os.environ.get("WHITTED_NO_APT"):
        prefix = [] if os.geteuid() == 0 else None
        if prefix is None and sudo and subprocess.run([sudo, "-n", "true"],
                                                      capture_output=True).returncode == 0:
            prefix = [sudo, "-n"]
        if prefix is not None:
            print("whitted: no libLLVM >= 16 found; installing Debian's libllvm19")
            env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
            subprocess.run(prefix + [apt, "-qq", "update"], env=env, check=False)
            subprocess.run(prefix + [apt, "-qq", "install", "-y", "libllvm19"], env=env,
                           check=False)
            path = find_libllvm()
    if path is not None:
        print(f"whitted: using {path} for the llvm variants")
        return path
    print(f"whitted: warning: no libLLVM >= {MIN_LLVM_VERSION}; install Debian's libllvm19 "
          f"(apt-get install libllvm19) or set DRJIT_LIBLLVM_PATH. Using {FALLBACK_VARIANT}.")
    return None
