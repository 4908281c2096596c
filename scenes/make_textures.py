"""Make the example scenes' texture: ``scenes/earth.png``, a small made-up world map.

A latitude/longitude image (256 x 128, north at the top row, longitude growing
to the right from the seam) drawn from formulas, so it needs no download and is
the same on every machine. It is deliberately easy to read on a sphere: blobby
continents, a 30-degree grid, a yellow equator, a white north cap unlike the grey
south one, red letters "N" in the northern band and a red arrow pointing north
at the center column, which faces the camera with the default ``north 0 1 0``
and ``equator 0 0 -1``. A map drawn upside down or mirrored is obvious at once.

Run: ``python scenes/make_textures.py`` (``make scenes`` does). The file is only
rewritten when its bytes change.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 256, 128
HERE = Path(__file__).resolve().parent

# (latitude, longitude, radius) in degrees; longitude 0 is the seam (u = 0).
CONTINENTS = [
    (48, 95, 30), (62, 130, 22), (28, 112, 16),          # a northern landmass
    (8, 205, 20), (-22, 212, 17),                        # a southern one
    (46, 248, 26), (66, 290, 18), (30, 272, 12),         # a north-western one
    (-28, 318, 13), (-8, 40, 18), (18, 28, 12),          # islands
]
OCEAN = np.array([28, 68, 150])
LAND = np.array([70, 140, 62])
DESERT = np.array([190, 160, 95])
NORTH_CAP = np.array([250, 250, 250])
SOUTH_CAP = np.array([150, 160, 175])
GRID = np.array([20, 30, 60])
EQUATOR = np.array([245, 210, 40])
MARK = np.array([215, 30, 30])

LETTER_N = [
    "1...1",
    "11..1",
    "1.1.1",
    "1..11",
    "1...1",
    "1...1",
    "1...1",
]
ARROW = [
    "....1....",
    "...111...",
    "..11111..",
    ".1111111.",
    "111111111",
    "...111...",
    "...111...",
    "...111...",
    "...111...",
    "...111...",
]


def lat_long() -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude (degrees) of each texel center; row 0 is the north."""
    lat = 90.0 - (np.arange(HEIGHT) + 0.5) * 180.0 / HEIGHT
    lon = (np.arange(WIDTH) + 0.5) * 360.0 / WIDTH
    return np.meshgrid(lat, lon, indexing="ij")


def land_mask(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Blobs around the continent centers, by great-circle distance, with wavy coasts."""
    phi, lam = np.radians(lat), np.radians(lon)
    height = np.zeros_like(lat)
    for c_lat, c_lon, radius in CONTINENTS:
        p, l = np.radians(c_lat), np.radians(c_lon)
        cos_d = np.sin(phi) * np.sin(p) + np.cos(phi) * np.cos(p) * np.cos(lam - l)
        d = np.degrees(np.arccos(np.clip(cos_d, -1.0, 1.0)))
        height = np.maximum(height, np.exp(-(d / radius) ** 2))
    coast = 0.12 * np.sin(7 * lam + 2 * phi) * np.cos(5 * phi)
    return height + coast > 0.45


def stamp(image: np.ndarray, pattern: list[str], row: int, col: int, scale: int, color) -> None:
    """Draw a 0/1 pattern with its top-left texel at (row, col), wrapping in longitude."""
    for r, line in enumerate(pattern):
        for c, bit in enumerate(line):
            if bit == "1":
                rows = slice(row + r * scale, row + (r + 1) * scale)
                for k in range(scale):
                    image[rows, (col + c * scale + k) % WIDTH] = color


def earth() -> np.ndarray:
    """The map as 8-bit sRGB texels, shape (HEIGHT, WIDTH, 3)."""
    lat, lon = lat_long()
    image = np.empty((HEIGHT, WIDTH, 3))
    shade = (0.8 + 0.2 * np.cos(np.radians(lat)))[..., None]
    image[:] = OCEAN * shade
    land = land_mask(lat, lon)
    dry = (np.abs(np.abs(lat) - 22) < 9)[..., None]
    image[land] = np.where(dry, DESERT, LAND)[land]
    image[lat > 72] = NORTH_CAP
    image[lat < -70] = SOUTH_CAP
    step = 360.0 / WIDTH
    on_meridian = np.abs((lon + 15) % 30 - 15) < step / 2
    on_parallel = np.abs((lat + 15) % 30 - 15) < 180.0 / HEIGHT / 2
    image[on_meridian | on_parallel] = GRID
    image[np.abs(lat) < 180.0 / HEIGHT] = EQUATOR
    # Markers that show which way is north: letters N in the northern band,
    # an arrow pointing north on the center column (u = 0.5).
    for u in (0.125, 0.375, 0.625, 0.875):
        stamp(image, LETTER_N, row=12, col=int(u * WIDTH) - 5, scale=2, color=MARK)
    stamp(image, ARROW, row=HEIGHT // 2 - 24, col=WIDTH // 2 - 9, scale=2, color=MARK)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def write_if_changed(path: Path, pixels: np.ndarray) -> bool:
    """Write ``pixels`` as PNG unless ``path`` already holds exactly that image."""
    import mitsuba as mi
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    if path.exists():
        try:
            if np.array_equal(np.array(mi.Bitmap(str(path))), pixels):
                return False
        except RuntimeError:
            pass  # unreadable: replace it
    bitmap = mi.Bitmap(pixels, pixel_format=mi.Bitmap.PixelFormat.RGB)
    tmp = path.with_name(f".{path.name}.tmp.png")
    bitmap.write(str(tmp))
    tmp.replace(path)
    return True


def main() -> None:
    path = HERE / "earth.png"
    if write_if_changed(path, earth()):
        print(f"wrote {path.relative_to(Path.cwd()) if path.is_relative_to(Path.cwd()) else path}")


if __name__ == "__main__":
    main()
