"""Scene model -> Mitsuba 3 XML (format version 3.0.0).

The XML holds everything needed to render the scene with stock Mitsuba plus the
project's plugins (``import whitted`` registers them): the perspective sensor,
spheres, point lights, background, the article's materials and textures, and
the Whitted integrator. Output is deterministic: the same scene gives
byte-identical XML.

Radiometry (see README, "Lights"): a point light of article colour ``c`` becomes
a Mitsuba ``point`` emitter of intensity ``I = c * pi * d^2`` where ``d`` is the
light's distance to ``lookat`` (1 when zero). A physically lit white diffuse
surface at ``lookat`` facing the light then receives, after the BSDF's 1/pi,
exactly the article's ``c``; the Whitted integrator divides the factor out again
for article lighting (it gets ``lookat`` as ``light_reference``).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import replace
from pathlib import Path
from xml.sax.saxutils import escape

from .scene import Material, Scene, Sphere, Vec3

FORMAT_VERSION = "3.0.0"


def num(x: float) -> str:
    """Shortest text that reads back as the same float64 (and never '-0.0')."""
    x = float(x)
    if x == 0.0:
        x = 0.0
    if x == int(x) and abs(x) < 1e15:
        return repr(float(int(x)))
    return repr(x)


def vec(v: Vec3, sep: str = " ") -> str:
    return sep.join(num(c) for c in v)


def attr(text: str) -> str:
    """A string made safe inside a double-quoted XML attribute."""
    return escape(str(text), {'"': "&quot;", "\n": "&#10;", "\r": "&#13;", "\t": "&#9;"})


def string_value(text: str) -> str:
    """A literal string for a Mitsuba attribute: XML-escaped, and '$' escaped as '\\$'
    so that Mitsuba's parameter substitution ($spp, ...) leaves it alone."""
    return attr(str(text).replace("$", "\\$"))


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _normalize(a: Vec3) -> Vec3:
    """``a`` / |a|, scaled first so that tiny or huge components neither underflow nor overflow."""
    scale = max(abs(c) for c in a)
    a = (a[0] / scale, a[1] / scale, a[2] / scale)
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def comment(text: str) -> str:
    """``text`` made safe inside an XML comment: printable, no '--', not ending in '-'."""
    text = "".join(c if c.isprintable() and not 0xD800 <= ord(c) <= 0xDFFF else "?" for c in text)
    text = re.sub(r"-(?=-)", "- ", text)
    return text + " " if text.endswith("-") else text


def texture_frame(north: Vec3, equator: Vec3) -> tuple[Vec3, Vec3, Vec3]:
    """The sphere's local axes (x, y, z) = (Ve, Vn x Ve, Vn).

    With these, Mitsuba's sphere UV (u = atan2(y, x) / 2pi, v = acos(z) / pi)
    equals the article's lat/long mapping with v flipped: Mitsuba's v = 0 is the
    north pole and a bitmap's top row, as the article's row floor((1 - v) H).
    """
    vn = _normalize(north)
    d = _dot(equator, vn)
    ve = _normalize((equator[0] - d * vn[0], equator[1] - d * vn[1], equator[2] - d * vn[2]))
    return ve, _cross(vn, ve), vn


def light_intensity(scene: Scene, position: Vec3, color: Vec3) -> Vec3:
    """Point-light intensity that matches the article's brightness at ``lookat``."""
    d2 = _dot(_sub(position, scene.lookat), _sub(position, scene.lookat))
    if d2 == 0.0:
        d2 = 1.0
    return tuple(c * math.pi * d2 for c in color)


def clip_range(scene: Scene) -> tuple[float, float]:
    """Near and far clip distances that contain every sphere seen from the eye."""
    extent = math.sqrt(_dot(_sub(scene.lookat, scene.eye), _sub(scene.lookat, scene.eye)))
    for s in scene.spheres:
        extent = max(extent, math.sqrt(_dot(_sub(s.center, scene.eye), _sub(s.center, scene.eye))) + s.radius)
    far = 4.0 * extent
    # Mitsuba starts primary rays on the near plane, not at the eye. A near/far
    # ratio of 1e-12 keeps them at the eye for any fov and aspect ratio while the
    # directions stay as float32-exact as with Mitsuba's defaults (measured: the
    # directions degrade only below a ratio of about 1e-16).
    return far * 1e-12, far


def _material_xml(material: Material, mat_id: str, base_dir: Path | None) -> list[str]:
    lines = [f'    <bsdf type="article" id="{mat_id}">']
    if material.texture is not None:
        # Real paths: the OS resolves '..' after following a symlinked output folder.
        rel = material.texture if base_dir is None else \
            os.path.relpath(os.path.realpath(material.texture), os.path.realpath(base_dir))
        lines += [
            '        <texture type="bitmap" name="color">',
            f'            <string name="filename" value="{string_value(Path(rel).as_posix())}"/>',
            '            <string name="filter_type" value="nearest"/>',
            '            <string name="wrap_mode" value="clamp"/>',
            '        </texture>',
        ]
    else:
        lines.append(f'        <rgb name="color" value="{vec(material.color)}"/>')
    lines += [
        f'        <float name="reflect" value="{num(material.reflect)}"/>',
        f'        <float name="refract" value="{num(material.refract)}"/>',
        f'        <float name="ior" value="{num(material.ior)}"/>',
        '    </bsdf>',
    ]
    return lines


def _sphere_xml(sphere: Sphere, index: int, mat_id: str) -> list[str]:
    lines = [f'    <shape type="sphere" id="sphere_{index}">']
    if sphere.material.texture is None:
        lines += [
            f'        <point name="center" value="{vec(sphere.center, ", ")}"/>',
            f'        <float name="radius" value="{num(sphere.radius)}"/>',
        ]
    else:
        # Oriented so that Mitsuba's own UV is the article's mapping.
        x, y, z = texture_frame(sphere.north, sphere.equator)
        r, c = sphere.radius, sphere.center
        rows = [(x[i] * r, y[i] * r, z[i] * r, c[i]) for i in range(3)] + [(0.0, 0.0, 0.0, 1.0)]
        matrix = " ".join(num(v) for row in rows for v in row)
        lines += [
            '        <transform name="to_world">',
            f'            <matrix value="{matrix}"/>',
            '        </transform>',
        ]
    lines += [f'        <ref id="{mat_id}"/>', '    </shape>']
    return lines


def _shared(material: Material) -> Material:
    """The material as written: a texture replaces the colour, which then plays no part."""
    return material if material.texture is None else replace(material, color=Material.color)


def scene_to_xml(scene: Scene, base_dir: str | os.PathLike | None) -> str:
    """The Mitsuba XML of ``scene``. Texture paths are written relative to ``base_dir``
    (the folder the XML will live in: Mitsuba resolves paths against it), or
    absolute when ``base_dir`` is None (XML loaded from memory)."""
    base_dir = None if base_dir is None else Path(os.path.abspath(base_dir))
    near, far = clip_range(scene)
    out = [
        '<?xml version="1.0" encoding="utf-8"?>',
        f'<!-- Converted by whitted from {comment(scene.source.name)} -->',
        f'<scene version="{FORMAT_VERSION}">',
        f'    <default name="spp" value="{scene.samples}"/>',
        f'    <default name="max_depth" value="{scene.depth}"/>',
        f'    <default name="ambient" value="{num(scene.ambient)}"/>',
        '    <default name="lighting" value="article"/>',
        # Written only when the scene sets it: otherwise the integrator's own default applies.
        *([f'    <default name="min_weight" value="{num(scene.min_weight)}"/>']
          if scene.min_weight is not None else []),
        '',
        '    <integrator type="whitted">',
        '        <integer name="max_depth" value="$max_depth"/>',
        '        <float name="ambient" value="$ambient"/>',
        '        <string name="lighting" value="$lighting"/>',
        *(['        <float name="min_weight" value="$min_weight"/>'] if scene.min_weight is not None else []),
        f'        <point name="light_reference" value="{vec(scene.lookat, ", ")}"/>',
        '    </integrator>',
        '',
        '    <sensor type="perspective">',
        '        <string name="fov_axis" value="x"/>',
        f'        <float name="fov" value="{num(scene.fov)}"/>',
        f'        <float name="near_clip" value="{num(near)}"/>',
        f'        <float name="far_clip" value="{num(far)}"/>',
        '        <transform name="to_world">',
        f'            <lookat origin="{vec(scene.eye, ", ")}" target="{vec(scene.lookat, ", ")}"'
        f' up="{vec(_normalize(scene.up), ", ")}"/>',
        '        </transform>',
        '        <sampler type="independent">',
        '            <integer name="sample_count" value="$spp"/>',
        '        </sampler>',
        '        <film type="hdrfilm">',
        f'            <integer name="width" value="{scene.width}"/>',
        f'            <integer name="height" value="{scene.height}"/>',
        '            <string name="pixel_format" value="rgb"/>',
        '            <rfilter type="box"/>',
        '        </film>',
        '    </sensor>',
    ]
    if any(c > 0 for c in scene.background):
        out += ['', '    <emitter type="constant" id="background">',
                f'        <rgb name="radiance" value="{vec(scene.background)}"/>',
                '    </emitter>']
    for i, light in enumerate(scene.lights):
        out += ['', f'    <emitter type="point" id="light_{i}">',
                f'        <point name="position" value="{vec(light.position, ", ")}"/>',
                f'        <rgb name="intensity" value="{vec(light_intensity(scene, light.position, light.color))}"/>',
                '    </emitter>']
    # Identical materials are written once and shared, which keeps Mitsuba's
    # per-material dispatch small for scenes of many spheres.
    materials: dict[Material, str] = {}
    for sphere in scene.spheres:
        if _shared(sphere.material) not in materials:
            materials[_shared(sphere.material)] = f"material_{len(materials)}"
    for material, mat_id in materials.items():
        out += [''] + _material_xml(material, mat_id, base_dir)
    for i, sphere in enumerate(scene.spheres):
        out += [''] + _sphere_xml(sphere, i, materials[_shared(sphere.material)])
    out += ['</scene>', '']
    return "\n".join(out)
