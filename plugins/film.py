"""Camera samples on the film: where each one starts in its pixel (:class:`CameraSamples`;
jittered by a hash of (pixel, sample, seed): an image does not depend on how the render is
split into passes), and where its color goes: through Mitsuba's film (:class:`FilmSplats`, 44
bytes a pixel) or, for a box-filtered RGB ``hdrfilm`` in the JIT variants, straight into the
developed image (:class:`PixelMeans`, 12 bytes a pixel); either way the film holds the render.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from whitted.defaults import SEED_STRIDE


# -- where a sample starts ----------------------------------------------------------------------

def strata(spp: int) -> tuple[int, int]:
    """``(nx, ny)`` with ``nx·ny = spp``, ``nx >= ny``, as square as possible."""
    ny = math.isqrt(spp)
    while spp % ny:
        ny -= 1
    return spp // ny, ny


def _hash(pixel, sample, seed_offset: int, rounds: int = 4):
    """Two numbers in [0, 1) hashed from (pixel, sample, seed): TEA of ``rounds`` rounds.
    The seed is opaque (no new kernels); the mask wraps where UInt32 is a Python int."""
    salt = (mi.UInt32(sample) + dr.opaque(mi.UInt32, seed_offset & 0xFFFFFFFF)) & 0xFFFFFFFF
    bits_x, bits_y = mi.sample_tea_32(mi.UInt32(pixel), salt, rounds)
    return mi.Point2f(mi.Float(bits_x >> 8), mi.Float(bits_y >> 8)) * (1.0 / (1 << 24))


def pixel_offset(pixel, sample, spp: int, seed: int):
    """Offset in [0, 1)^2 of sample number ``sample`` inside the pixel of linear index ``pixel``."""
    if spp == 1:
        return mi.Point2f(0.5, 0.5)
    nx, ny = strata(spp)
    column = sample % nx
    row = sample // nx
    jitter = _hash(pixel, sample, seed * SEED_STRIDE)
    return mi.Point2f((mi.Float(column) + jitter.x) / nx, (mi.Float(row) + jitter.y) / ny)


def lens_offset(pixel, sample, seed: int):
    """Where a camera sample crosses a thin lens, in [0, 1)^2: :func:`pixel_offset`'s hash
    from another stream (``LENS_SALT``, any odd 32-bit constant), of 8 rounds: with 4, a
    pixel's lens samples (consecutive salts) are visibly correlated (measured: twice path's
    noise on a defocused image at 48 spp)."""
    return _hash(pixel, sample, seed * SEED_STRIDE + LENS_SALT, 8)


LENS_SALT = 0x85EBCA6B


def sample_count(sensor, spp: int) -> int:
    """The samples per pixel of a render asking for ``spp`` (0: the sampler's own), as the
    sensor's sampler rounds it (``stratified``: up to a square)."""
    sampler = sensor.sampler()
    if spp and spp != sampler.sample_count():
        sampler = sampler.clone()
        sampler.set_sample_count(spp)
    return sampler.sample_count()


class CameraSamples:
    """The camera rays of a render: where each sample starts in its pixel and on the lens.
    One sample per pixel: the centers (the scene format's rule), whatever the sampler, seed or
    lens (:attr:`unused` names what that leaves unused). More: an ``nx × ny`` grid jittered by
    :func:`pixel_offset` and :func:`lens_offset` for the ``independent`` sampler, else that
    sampler's own samples, seeded per pass of whole pixels. With ``sample_border``,
    :attr:`border` pixels beyond the crop too."""

    def __init__(self, sensor, spp: int, seed: int):
        spp = sample_count(sensor, spp)
        self.sensor, self.spp, self.seed = sensor, spp, seed
        film = sensor.film()
        self.box = film.rfilter().is_box_filter()
        self.border = int(film.rfilter().border_size()) if film.sample_border() else 0
        width, height = (int(c) for c in film.crop_size())
        #: the sample grid: the crop and its border
        self.width, self.height = width + 2 * self.border, height + 2 * self.border
        sampler = sensor.sampler()
        independent = sampler.class_name() == "IndependentSampler"
        self.lens = spp > 1 and sensor.needs_aperture_sample()
        self.sampler = None
        if spp > 1 and not independent:
            self.sampler = sampler.clone()
            self.sampler.set_sample_count(spp)
            if dr.is_jit_v(mi.Float):   # a pixel's samples are consecutive lanes
                self.sampler.set_samples_per_wavefront(spp)
        unused = []
        if spp == 1:
            if seed != 0:
                unused.append(f"seed {seed}")
            if sensor.needs_aperture_sample():
                unused.append("thin lens's aperture")
            if not independent:
                unused.append(f"{sampler.class_name()}")
        self.unused = tuple(unused)
        self.jit = dr.is_jit_v(mi.Float)
        self.pass_seed = seed

    def start_pass(self, index: int, count: int) -> None:
        """A pass of ``count`` samples (whole pixels when a sampler is used) begins."""
        if self.sampler is None:
            return
        self.pass_seed = self.seed if index == 0 else (self.seed * SEED_STRIDE + index) & 0xFFFFFFFF
        if self.jit:
            self.sampler.seed(self.pass_seed, count)

    def ray(self, pixel, sample):
        """The camera ray of a sample (in the pixel of linear index ``pixel`` in the sample
        grid), its weight, and where it lands on the film."""
        width = dr.opaque(mi.UInt32, self.width)
        y = pixel // width
        x = pixel - y * width
        if self.sampler is None:
            offset = pixel_offset(pixel, sample, self.spp, self.seed)
            aperture = lens_offset(pixel, sample, self.seed) if self.lens else mi.Point2f(0.5)
        else:
            if not self.jit and sample == 0:   # scalar: one pixel's samples at a time
                self.sampler.seed(mi.sample_tea_32(self.pass_seed, pixel)[0])
            offset = self.sampler.next_2d()
            aperture = self.sampler.next_2d() if self.lens else mi.Point2f(0.5)
            if not self.jit:
                self.sampler.advance()
        film = self.sensor.film()
        corner = mi.Point2f(mi.Float(x), mi.Float(y))
        if self.border:
            corner = corner - self.border
        crop_size = mi.ScalarVector2f(film.crop_size())
        # (as Mitsuba's integrators ask for it: some sensors, the irradiance meter, give no plain ray)
        ray, weight = self.sensor.sample_ray_differential(
            time=self.sensor.shutter_open(), sample1=0.5, sample2=(corner + offset) / crop_size, sample3=aperture)
        # Box filter: a sample belongs to its pixel alone (as Mitsuba's own integrators do).
        position = corner if self.box else corner + offset
        return mi.Ray3f(ray), weight, position + mi.ScalarVector2f(film.crop_offset())


# -- where its color goes ------------------------------------------------------------------------

#: values zeroed per kernel when an image is cleared (64 MiB of float32): short enough
#: for Ctrl-C to act between two
CLEAR_BAND = 1 << 24


def image_for(film, spp: int):
    """How a render of ``spp`` samples per pixel accumulates on ``film``."""
    if dr.is_jit_v(mi.Float) and PixelMeans.applies(film):
        return PixelMeans(film, spp)
    return FilmSplats(film, spp)


class FilmSplats:
    """Samples splatted into Mitsuba's film through an image block (any film, any filter)."""

    #: whether :meth:`PixelMeans.put_pixels` is available
    takes_pixels = False

    def __init__(self, film, spp: int):
        self.film = film
        film.prepare([])
        self.block = film.create_block()
        self.block.set_coalesce(self.block.coalesce() and spp >= 4)
        self.alpha = mi.has_flag(film.flags(), mi.FilmFlags.Alpha)

    def put(self, pixel, position, color, alpha=None) -> None:
        """Add the sample ``color`` at film ``position`` (``pixel``: its linear index in the
        crop); ``alpha`` (Bool: whether the sample is opaque) for films with an alpha channel."""
        values = [color.x, color.y, color.z]
        if self.alpha:
            values.append(dr.select(alpha, mi.Float(1), mi.Float(0)))
        values.append(mi.Float(1))   # the sample's weight: the film develops the mean
        self.block.put(position, values)

    def develop(self):
        """The developed image, an ``mi.TensorXf`` (H, W, channels)."""
        self.film.put_block(self.block)
        self.block = None
        return self.film.develop()


class PixelMeans:
    """Each pixel's mean of its samples, accumulated in place (box filter, RGB; JIT variants)."""

    @staticmethod
    def applies(film) -> bool:
        """Whether ``film`` develops each pixel as the plain mean RGB of its samples."""
        return (film.class_name() == "HDRFilm" and film.rfilter().is_box_filter()
                and not film.sample_border() and film.base_channels_count() == 3
                and "pixel_format = rgb," in str(film))   # not xyz, which has three channels too

    takes_pixels = True
    #: the film has no alpha channel: :meth:`put` takes no alpha
    alpha = False

    def __init__(self, film, spp: int):
        self.film = film
        film.prepare([])   # the film's storage, cleared (a literal zero: nothing allocated yet)
        self.width, self.height = (int(c) for c in film.crop_size())
        self.spp = spp
        self.scale = dr.opaque(mi.Float, 1.0 / spp)
        size = 3 * self.width * self.height
        self.image = dr.empty(mi.Float, size)
        if spp > 1:   # samples are added up: zeroed a band at a time (Ctrl-C acts between kernels)
            zero = dr.opaque(mi.Float, 0.0)
            for first in range(0, size, CLEAR_BAND):
                index = dr.arange(mi.UInt32, min(CLEAR_BAND, size - first)) + dr.opaque(mi.UInt32, first)
                dr.scatter(self.image, zero, index)
                dr.eval(self.image)

    def put(self, pixel, position, color, alpha=None) -> None:
        """Add ``color / spp`` to ``pixel`` (its linear index in the crop; ``position`` and
        ``alpha`` unused)."""
        index = pixel * 3
        for channel in range(3):
            value = color[channel] * self.scale
            if self.spp == 1:    # one sample per pixel: nothing to add up
                dr.scatter(self.image, value, index + channel)
            else:
                dr.scatter_reduce(dr.ReduceOp.Add, self.image, value, index + channel,
                                  mode=dr.ReduceMode.Local)

    def put_pixels(self, pixel, color_of_sample) -> None:
        """Set the pixels ``pixel`` (one lane each) to the mean of ``color_of_sample(sample)``
        over their samples, summed in a loop inside the kernel (single-level trees)."""
        if self.spp == 1:
            total = color_of_sample(mi.UInt32(0))
        else:
            spp = dr.opaque(mi.UInt32, self.spp)
            _, total = dr.while_loop(
                (mi.UInt32(0), mi.Color3f(0)), lambda sample, total: sample < spp,
                lambda sample, total: (sample + 1, total + color_of_sample(sample)))
        dr.scatter(self.image, total / dr.opaque(mi.Float, self.spp), pixel)   # as the film divides

    def develop(self):
        """The image as an ``mi.TensorXf`` (H, W, 3), no copy; the film gets it lazily too, as
        it stores it: (H, W, 4) with weight 1."""
        index = dr.arange(mi.UInt32, 4 * self.width * self.height)
        channel = index & 3
        rgb = channel < 3
        value = dr.select(rgb,
                          dr.gather(mi.Float, self.image, (index >> 2) * 3 + channel, rgb), 1.0)
        self.film.put_block(mi.ImageBlock(mi.TensorXf(value, (self.height, self.width, 4)),
                                          self.film.crop_offset(), self.film.rfilter()))
        return mi.TensorXf(self.image, (self.height, self.width, 3))
