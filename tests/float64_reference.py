"""A float64 reference renderer of the article's model, written from docs/scene-format.md.

The tests hold the integrator to it. It shares no code with the integrator: its own camera,
sphere intersection, shading and texture mapping, in plain Python floats on the scene model
(``whitted.converter.Scene``); only an image file's raw texels are read by ``mi.Bitmap``.
Its numerics (the stable discriminant, the exact ``|o − C|² − r²``): docs/numerics.md,
sections 4 ("The quadratic's cancellation") and 14 ("Giant spheres").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: hits closer than EPSILON·(1 + |origin|) to a ray's ends are the surfaces it starts or ends on
EPSILON = 1e-9


# -- vectors -------------------------------------------------------------------------------------

def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def hadamard(a, b):
    return (a[0] * b[0], a[1] * b[1], a[2] * b[2])


# -- camera --------------------------------------------------------------------------------------

def camera_ray(scene, i: float, j: float):
    """The ray through image position (i, j) (column, row; pixel centers at +0.5): the spec's formula."""
    f = normalize(sub(scene.lookat, scene.eye))
    right = normalize(cross(f, scene.up))
    true_up = cross(right, f)
    w, h = scene.width, scene.height
    x = 2 * i / w - 1
    y = 1 - 2 * j / h
    tan = math.tan(math.radians(scene.fov) / 2)
    d = add(add(f, mul(right, x * tan)), mul(true_up, y * tan * h / w))
    return scene.eye, normalize(d)


# -- spheres -------------------------------------------------------------------------------------

def _square(a):
    """``(p, e)`` with p + e = a² exactly (Dekker's product, Veltkamp's split)."""
    p = a * a
    big = a * 134217729.0   # 2^27 + 1
    high = big - (big - a)
    low = a - high
    return p, ((high * high - p) + 2 * high * low) + low * low


def _difference(a, b):
    """``(s, e)`` with s + e = a − b exactly (Knuth's two-sum)."""
    s = a - b
    z = s - a
    return s, (a - (s - z)) - (b + z)


def _squares_minus(origin, center, r):
    """|origin − center|² − r², from the exact differences, rounded once."""
    terms = []
    for o, c in zip(origin, center):
        high, low = _difference(o, c)
        terms += [*_square(high), 2 * high * low, low * low]
    terms += [-part for part in _square(r)]
    return math.fsum(terms)


def intersect(sphere, origin, direction):
    """Both roots t of |origin + t·direction − C| = r (direction unit), or None, free of
    cancellation (docs/numerics.md, "4. The quadratic's cancellation"). The vector helpers'
    arithmetic written out, in their order: this runs millions of times a test run."""
    (ox, oy, oz), (cx, cy, cz), (dx, dy, dz) = origin, sphere.center, direction
    fx, fy, fz = ox - cx, oy - cy, oz - cz                    # f = origin − C
    b = fx * dx + fy * dy + fz * dz                           # f · direction
    r2 = sphere.radius ** 2
    c = (fx * fx + fy * fy + fz * fz) - r2                    # f · f − r²
    if abs(c) < 1e-6 * r2:   # the origin near the surface: c has cancelled
        c = _squares_minus(origin, sphere.center, sphere.radius)
    px, py, pz = fx - dx * b, fy - dy * b, fz - dz * b        # f − direction·b
    disc = r2 - (px * px + py * py + pz * pz)
    if disc < 0:
        return None
    root = math.sqrt(disc)
    q = -b - root if b > 0 else -b + root    # no cancellation
    t_other = c / q if q != 0 else 0.0
    return min(q, t_other), max(q, t_other)


def _skip(origin):
    return EPSILON * (1 + norm(origin))


def nearest_hit(scene, origin, direction):
    """(t, sphere) of the nearest hit in front of ``origin``, or None."""
    skip = _skip(origin)
    best = None
    for sphere in scene.spheres:
        roots = intersect(sphere, origin, direction)
        if roots is None:
            continue
        for t in roots:
            if t > skip:
                if best is None or t < best[0]:
                    best = (t, sphere)
                break
    return best


def blocked(scene, point, light_position):
    """True when a sphere crosses the segment from ``point`` to the light (a light on a
    surface is not hidden by it)."""
    to_light = sub(light_position, point)
    distance = norm(to_light)
    direction = mul(to_light, 1 / distance)
    skip = _skip(point)
    for sphere in scene.spheres:
        roots = intersect(sphere, point, direction)
        if roots is not None and any(skip < t < distance - skip for t in roots):
            return True
    return False


# -- textures ------------------------------------------------------------------------------------

def srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def load_texels(path) -> np.ndarray:
    """The texture's texels as linear RGB float64, (H, W, 3), row 0 at the top (integer
    images decoded from sRGB here)."""
    import mitsuba as mi
    raw = np.array(mi.Bitmap(str(path)))
    if raw.ndim == 2:
        raw = raw[..., None]
    if raw.shape[2] in (1, 2):                 # grey (with alpha)
        raw = np.repeat(raw[..., :1], 3, axis=2)
    raw = raw[..., :3]
    if raw.dtype == np.uint8:
        return srgb_to_linear(raw / 255.0)
    if raw.dtype == np.uint16:
        return srgb_to_linear(raw / 65535.0)
    return raw.astype(np.float64)


def lat_long(sphere, point):
    """The article's (u, v) of ``point`` on ``sphere`` (spec, "Texture mapping")."""
    vn = normalize(sphere.north)
    e = sphere.equator
    ve = normalize(sub(e, mul(vn, dot(e, vn))))
    vp = normalize(sub(point, sphere.center))
    c = dot(vn, vp)
    phi = math.acos(max(-1.0, min(1.0, -c)))
    v = phi / math.pi
    s = math.sqrt(max(0.0, 1.0 - c * c))    # sin(phi); math.sin(math.pi) is 1.2e-16, not 0
    if s == 0:
        return 0.0, v
    theta = math.acos(max(-1.0, min(1.0, dot(vp, ve) / s))) / (2 * math.pi)
    u = theta if dot(cross(vn, ve), vp) > 0 else 1 - theta
    return u, v


def texel(texels: np.ndarray, u: float, v: float):
    """Nearest texel: column floor(u·W), row floor((1 − v)·H), clamped; row 0 at the top."""
    h, w = texels.shape[:2]
    column = min(max(int(math.floor(u * w)), 0), w - 1)
    row = min(max(int(math.floor((1 - v) * h)), 0), h - 1)
    return tuple(float(c) for c in texels[row, column])


# -- the model -----------------------------------------------------------------------------------

@dataclass
class Reference:
    scene: object                      # whitted.converter.Scene
    max_depth: int | None = None       # None: the scene's depth
    ambient: float | None = None
    lighting: str = "article"          # or "physical": (B/π)·I·cos/r², I = color·π·d_ref²
    without: tuple = ()                # effects left out, as by ``whitted render --without``

    def __post_init__(self):
        self.depth = self.scene.depth if self.max_depth is None else self.max_depth
        self.a = self.scene.ambient if self.ambient is None else self.ambient
        self._textures = {}
        self.tir_events = 0            # how often total internal reflection happened
        # rays traced, as --stats counts them (a shadow ray towards every light in front)
        self.rays = {"camera": 0, "shadow": 0, "reflection": 0, "refraction": 0}
        self.deepest = 0               # the deepest level that traced a ray

    def base_color(self, sphere, point):
        material = sphere.material
        if material.texture is None:
            return tuple(material.color)
        if "textures" in self.without:
            return (1.0, 1.0, 1.0)
        path = str(material.texture)
        if path not in self._textures:
            self._textures[path] = load_texels(path)
        return texel(self._textures[path], *lat_long(sphere, point))

    def light_strength(self, light, point, normal):
        """The article's s·light_color, or physically I·cos/r²; 0 when shadowed."""
        to_light = sub(light.position, point)
        r = norm(to_light)
        if r == 0:
            return (0.0, 0.0, 0.0)
        cos = dot(normal, to_light) / r
        if cos <= 0:
            return (0.0, 0.0, 0.0)
        if "shadows" not in self.without:
            self.rays["shadow"] += 1
            if blocked(self.scene, point, light.position):
                return (0.0, 0.0, 0.0)
        if self.lighting == "article":
            return mul(light.color, cos)
        d2 = dot(sub(light.position, self.scene.lookat), sub(light.position, self.scene.lookat)) or 1.0
        intensity = mul(light.color, math.pi * d2)
        return mul(intensity, cos / (r * r))

    def trace(self, origin, direction, depth: int = 1):
        self.deepest = max(self.deepest, depth)
        hit = nearest_hit(self.scene, origin, direction)
        if hit is None:
            return tuple(self.scene.background)
        t, sphere = hit
        p = add(origin, mul(direction, t))
        n = normalize(sub(p, sphere.center))
        inside = dot(direction, n) > 0
        n_facing = mul(n, -1) if inside else n
        base = self.base_color(sphere, p)

        direct = (0.0, 0.0, 0.0)
        for light in self.scene.lights:
            direct = add(direct, self.light_strength(light, p, n_facing))
        if self.lighting == "article":
            point = hadamard(base, add((self.a,) * 3, mul(direct, 1 - self.a)))
        else:
            point = hadamard(mul(base, 1 / math.pi), direct)

        m = sphere.material
        color = mul(point, 1 - m.reflect - m.refract)
        c1 = -dot(n_facing, direction)
        r = add(direction, mul(n_facing, 2 * c1))
        if m.reflect > 0 and depth < self.depth and "reflection" not in self.without:
            self.rays["reflection"] += 1
            color = add(color, mul(self.trace(p, normalize(r), depth + 1), m.reflect))
        if m.refract > 0 and depth < self.depth and "refraction" not in self.without:
            self.rays["refraction"] += 1
            eta = m.ior if inside else 1 / m.ior
            k = 1 - eta * eta * (1 - c1 * c1)
            if k < 0:
                self.tir_events += 1
                refracted_direction = r
            else:
                refracted_direction = add(mul(direction, eta), mul(n_facing, eta * c1 - math.sqrt(k)))
            color = add(color, mul(self.trace(p, normalize(refracted_direction), depth + 1), m.refract))
        return color

    def render(self, subsamples: int = 1) -> np.ndarray:
        """The image, (H, W, 3) float64; ``subsamples``² rays per pixel on a regular grid, averaged."""
        s = self.scene
        image = np.zeros((s.height, s.width, 3))
        offsets = [(k + 0.5) / subsamples for k in range(subsamples)]
        for j in range(s.height):
            for i in range(s.width):
                total = (0.0, 0.0, 0.0)
                for sy in offsets:
                    for sx in offsets:
                        self.rays["camera"] += 1
                        total = add(total, self.trace(*camera_ray(s, i + sx, j + sy)))
                image[j, i] = mul(total, 1 / subsamples ** 2)
        return image


def render_reference(scene, subsamples: int = 1, **options) -> np.ndarray:
    return Reference(scene, **options).render(subsamples)


# -- the acceptance rule for a render against this reference ----------------------------------------

def assert_matches(image: np.ndarray, expected: np.ndarray, mean_tol=0.004, outliers=0.01):
    """Finite, mean absolute difference <= ``mean_tol``, at most ``outliers`` of the pixels
    off by more than 0.02 (in any channel)."""
    assert image.shape == expected.shape
    assert np.all(np.isfinite(image)), "NaN or infinity in the image"
    diff = np.abs(image.astype(np.float64) - expected)
    mean = diff.mean()
    off = (diff.max(axis=2) > 0.02).mean()
    assert mean <= mean_tol, f"mean absolute difference {mean:.5f} > {mean_tol}"
    assert off <= outliers, f"{off:.2%} of pixels off by more than 0.02"
