"""POV-Ray 3.7 as a yardstick: the same scene model written as a POV-Ray scene, and run.

POV-Ray is the long-lived, widely installed classic ray tracer of the article's kind, in
C++ with its own bounding hierarchy. The scene written makes it trace whitted's tree and
shade it with the article's model: point lights without fall-off, hard shadows; per sphere
``finish { ambient (1-KR-KT)·A  diffuse (1-KR-KT)·(1-A)  reflection KR }`` (POV-Ray adds the
reflected color to the local one), ``transmit KT`` with ``interior { ior IOR }``;
``max_trace_level`` the depth with ``adc_bailout 0`` (whitted's ``--min-weight 0``), one ray
per pixel; ``right -x·W/H`` turns its left-handed frame into the scene format's. POV-Ray 3.7
refuses every option without ``~/.povray/3.7/povray.conf``: :func:`run` gives it a private
home with an empty one. ``make povray`` installs Debian's povray.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from whitted.converter.scene import Scene

from . import process


def _v(v) -> str:
    return "<" + ", ".join(repr(float(c)) for c in v) + ">"


def _f(x: float) -> str:
    return repr(float(x))


def scene_to_pov(scene: Scene) -> str:
    """The POV-Ray 3.7 scene of ``scene`` (the module docstring says how)."""
    if any(s.material.texture is not None for s in scene.spheres):
        raise ValueError("the POV-Ray writer handles untextured spheres only")
    a = scene.ambient
    out = [
        "// written by whitted's benchmarks/povray.py: the article's model in POV-Ray 3.7",
        "#version 3.7;",
        f"global_settings {{ assumed_gamma 1.0 ambient_light rgb 1 max_trace_level {scene.depth} "
        f"adc_bailout 0 }}",
        f"background {{ rgb {_v(scene.background)} }}",
        "camera {",
        "  perspective",
        f"  location {_v(scene.eye)}",
        f"  sky {_v(scene.up)}",
        "  up y",
        f"  right -x*{scene.width}/{scene.height}",
        f"  angle {_f(scene.fov)}",
        f"  look_at {_v(scene.lookat)}",
        "}",
    ]
    out += [f"light_source {{ {_v(light.position)} color rgb {_v(light.color)} }}" for light in scene.lights]
    # One texture per distinct material, declared once (as the XML shares its BSDFs).
    materials: dict = {}
    for sphere in scene.spheres:
        materials.setdefault(sphere.material, f"M{len(materials)}")
    for m, name in materials.items():
        local = 1.0 - m.reflect - m.refract
        out += [f"#declare {name} = texture {{",
                f"  pigment {{ rgb {_v(m.color)}" + (f" transmit {_f(m.refract)}" if m.refract else "") + " }",
                f"  finish {{ ambient {_f(local * a)} diffuse {_f(local * (1 - a))} "
                f"reflection {{ {_f(m.reflect)} }} specular 0 phong 0 }}",
                "}"]
        if m.refract:
            out.append(f"#declare {name}_interior = interior {{ ior {_f(m.ior)} }}")
    for s in scene.spheres:
        name = materials[s.material]
        interior = f" interior {{ {name}_interior }}" if s.material.refract else ""
        out.append(f"sphere {{ {_v(s.center)}, {_f(s.radius)} texture {{ {name} }}{interior} }}")
    return "\n".join(out) + "\n"


def find() -> tuple[str | None, str]:
    """POV-Ray 3.7's executable, or None and why it is missing."""
    exe = shutil.which("povray")
    if exe is None:
        return None, "POV-Ray is not installed (Debian: apt-get install povray, or make bench as root)"
    with tempfile.TemporaryDirectory() as home:
        result = subprocess.run([exe, "--version"], capture_output=True, text=True, env=_env(Path(home)))
    match = re.search(r"POV-Ray (\d+\.\d+)", result.stdout + result.stderr)
    if not match:
        return None, f"{exe} --version does not name a POV-Ray version"
    if match.group(1) != "3.7":
        return None, f"{exe} is POV-Ray {match.group(1)}, not 3.7"
    return exe, ""


def _env(home: Path) -> dict:
    """A private home with the ``.povray/3.7/povray.conf`` POV-Ray 3.7 needs."""
    (home / ".povray" / "3.7").mkdir(parents=True, exist_ok=True)
    (home / ".povray" / "3.7" / "povray.conf").touch()
    return {**os.environ, "HOME": str(home)}


@dataclass
class PovRun:
    wall_seconds: float      # the whole process
    peak_rss: int            # bytes: the process's peak resident memory (process.py)
    trace_seconds: float     # POV-Ray's own "Trace Time"
    parse_seconds: float     # POV-Ray's own "Parse Time" (reading the scene, before tracing)
    bounding_seconds: float  # POV-Ray's own "Bounding Time" (its hierarchy's build)
    shadow_rays: int         # POV-Ray's "Shadow Ray Tests"
    reflected_rays: int      # POV-Ray's "Reflected Rays"


def run(exe: str, pov: Path, image: Path, width: int, height: int, threads: int = 2,
        timeout: float | None = None) -> PovRun:
    """Render ``pov`` to the PNG ``image``; times from POV-Ray's report, the process's wall time
    and peak memory measured (process.py); :class:`process.DidNotFinish` past ``timeout``."""
    pov, image = Path(pov).resolve(), Path(image).resolve()
    image.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory() as home:
        # PNG, no display, no anti-aliasing, no progress; statistics on (they hold the times)
        command = [exe, f"+I{pov}", f"+O{image}", f"+W{width}", f"+H{height}", "+FN", "-D", "-A",
                   "-V", "+GS", f"+WT{threads}"]
        result = process.succeeded(process.run(command, timeout, cwd=image.parent, env=_env(Path(home))),
                                   "POV-Ray", pov.name)
    report = result.stdout + result.stderr

    def seconds(name: str) -> float:
        found = re.search(rf"{name}:\s+\d+ hours?\s+\d+ minutes?\s+\d+ seconds? \(([\d.]+) seconds?\)", report)
        return float(found.group(1)) if found else math.nan

    def count(name: str) -> int:
        found = re.search(rf"{name}:\s+(\d+)", report)
        return int(found.group(1)) if found else 0
    if math.isnan(seconds("Trace Time")) or not image.exists():
        raise RuntimeError(f"POV-Ray gave no image or no Trace Time on {pov.name}: {report.strip()[-300:]}")
    return PovRun(result.wall_seconds, result.peak_rss, seconds("Trace Time"), seconds("Parse Time"),
                  seconds("Bounding Time"), count("Shadow Ray Tests"), count("Reflected Rays"))
