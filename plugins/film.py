"""Camera samples on the film: where each one starts in its pixel, and where its color goes.

Where a sample starts. With one sample per pixel the ray passes exactly through the pixel
center, so a render is deterministic (the scene format's rule). With N samples the pixel is
cut into an ``nx × ny = N`` grid of equal cells (the most nearly square factorisation of N;
a prime N gives N columns) and each sample is jittered uniformly inside its own cell:
stratified sampling, unbiased, whatever N is (:func:`pixel_offset`). The jitter is a hash of
(pixel, sample, seed) rather than a stream from a sampler, so an image does not depend on
how the render is split into passes. That is what the ``independent`` sampler (the one
converted scenes name) gets; any other sampler type draws the samples itself, and a thin
lens gets lens samples (:class:`CameraSamples`).

Where its color goes: straight into the developed image, or through Mitsuba's film. Why two
ways. Mitsuba's film accepts samples anywhere on the image plane and spreads each over the
pixels its reconstruction filter covers: ``ImageBlock.put`` evaluates the filter and adds,
per sample, red, green, blue and a weight into a block of four floats per pixel; the film
then adds the block into its own storage (four more) and develops a third image, each
pixel's weighted sum divided by its summed weights: three images, 44 bytes a pixel, and a
share of the render time that benchmarks/RESULTS.md measures.

With a box filter (what converted scenes use, and Mitsuba's integrators put a box-filtered
sample at its pixel alone), every sample lands in one pixel with weight 1, and every pixel
gets ``spp`` of them, so the developed pixel is simply the mean of its samples.
:class:`PixelMeans` adds ``color / spp`` of each sample into that pixel of one RGB array,
which *is* the developed image: three adds per sample (pre-reduced within a SIMD packet,
where a pixel's samples sit side by side), nothing else to develop, 12 bytes a pixel. It is
the film's image up to the order of the additions (an ulp or so; none with one sample per
pixel). It serves Mitsuba's ``hdrfilm`` with a box filter and RGB pixels in the JIT
variants; :class:`FilmSplats` serves every other film, filter and pixel format, and the
scalar variant, through the film.

Either way the film holds the render: ``film.bitmap()``, ``film.write()`` and
``film.develop()`` after ``mi.render`` give the image the render returned.
:class:`PixelMeans` hands the film its image as the film's own storage (each pixel's RGB and
a weight of 1, which the film divides by: the same values) through ``ImageBlock`` and
``put_block``, as a lazy Dr.Jit expression over the image: nothing is computed or copied
unless the film is read.
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


def pixel_offset(pixel, sample, spp: int, seed: int):
    """Offset of a camera sample inside its pixel, in [0, 1)^2 (Point2f).

    ``pixel`` is the pixel's linear index and ``sample`` the sample's number
    within the pixel (UInt32, or ints in scalar variants).
    """
    if spp == 1:
        return mi.Point2f(0.5, 0.5)
    nx, ny = strata(spp)
    column = sample % nx
    row = sample // nx
    # The seed is opaque: a new seed must not compile new kernels.
    seed_offset = (seed * SEED_STRIDE) & 0xFFFFFFFF
    # (the mask wraps the sum to 32 bits where UInt32 is a Python int: scalar variants)
    salt = (mi.UInt32(sample) + dr.opaque(mi.UInt32, seed_offset)) & 0xFFFFFFFF
    bits_x, bits_y = mi.sample_tea_32(mi.UInt32(pixel), salt)
    jitter = mi.Point2f(mi.Float(bits_x >> 8), mi.Float(bits_y >> 8)) * (1.0 / (1 << 24))
    return mi.Point2f((mi.Float(column) + jitter.x) / nx, (mi.Float(row) + jitter.y) / ny)


def lens_offset(pixel, sample, seed: int):
    """Where a camera sample crosses a thin lens, in [0, 1)^2 (Point2f): a hash of (pixel,
    sample, seed) as in :func:`pixel_offset`, from another stream (its own salt)."""
    seed_offset = (seed * SEED_STRIDE + LENS_SALT) & 0xFFFFFFFF
    salt = (mi.UInt32(sample) + dr.opaque(mi.UInt32, seed_offset)) & 0xFFFFFFFF
    # 8 rounds of TEA: with the default 4, a pixel's lens samples (consecutive salts) are
    # visibly correlated (measured: twice path's noise on a defocused image at 48 spp)
    bits_x, bits_y = mi.sample_tea_32(mi.UInt32(pixel), salt, LENS_ROUNDS)
    return mi.Point2f(mi.Float(bits_x >> 8), mi.Float(bits_y >> 8)) * (1.0 / (1 << 24))


#: what sets the lens's stream of hashes apart from the pixel's (any odd 32-bit constant)
LENS_SALT = 0x85EBCA6B
LENS_ROUNDS = 8


def sample_count(sensor, spp: int) -> int:
    """The samples per pixel of a render asking for ``spp`` (0: the sampler's own), as the
    sensor's sampler rounds it (``stratified``: up to a square, ``orthogonal``: to a prime's
    square, ``ldsampler``: to a power of two) and Mitsuba's integrators then render it."""
    sampler = sensor.sampler()
    if spp and spp != sampler.sample_count():
        sampler = sampler.clone()
        sampler.set_sample_count(spp)
    return sampler.sample_count()


class CameraSamples:
    """The camera rays of a render: where each sample starts in its pixel and on the lens.

    * One sample per pixel: the pixel's center and the lens's (the scene format's rule),
      whatever the sampler, its seed or the lens (:attr:`unused` names what that leaves
      unused, for the integrator to warn about).
    * More, with the ``independent`` sampler (what converted scenes name): the stratified
      jitter of :func:`pixel_offset`, and :func:`lens_offset` on a thin lens, hashes of
      (pixel, sample, seed) that do not depend on how the render is split into passes.
    * More, with any other sampler (``stratified``, ``multijitter``, ``ldsampler``,
      ``orthogonal``): that sampler's own 2D samples, the pixel's then the lens's, as
      Mitsuba's integrators draw them; each pass holds whole pixels and seeds the sampler
      (the render's seed for the first pass), so the image depends on the seed and the
      pass size.

    How many: :attr:`spp` is what the sampler rounds ``spp`` to (:func:`sample_count`), as
    in Mitsuba's integrators: 8 asked of ``stratified`` are 9, 1 asked of ``orthogonal`` or
    ``ldsampler`` are 4.

    Lens samples are drawn only for a sensor that needs them (``thinlens``): a pinhole
    camera's kernels hold no lens code. With the film's ``sample_border`` the samples cover
    the border the reconstruction filter reaches beyond the crop too (:attr:`border`
    pixels on each side), as in Mitsuba's integrators.
    """

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

    def ray(self, x, y, pixel, sample):
        """The camera ray of a sample (in pixel ``(x, y)`` of the sample grid, linear index
        ``pixel``), its weight, and where it lands on the film."""
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
            values.append(mi.Float(1) if alpha is None else dr.select(alpha, mi.Float(1), mi.Float(0)))
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
        self.image = self._cleared(3 * self.width * self.height, spp)

    @staticmethod
    def _cleared(size: int, spp: int):
        """The image's values: zeros where samples are added up (``spp`` > 1), else
        uninitialised (one sample, or one pixel's mean, is stored per value).

        Zeroed a band at a time: ``dr.zeros`` is one memset kernel, which at 16384² is
        3 GiB of first-touched memory and seconds long, during which Ctrl-C waits
        (Python regains control only between kernels)."""
        image = dr.empty(mi.Float, size)
        if spp > 1:
            zero = dr.opaque(mi.Float, 0.0)
            for first in range(0, size, CLEAR_BAND):
                index = dr.arange(mi.UInt32, min(CLEAR_BAND, size - first)) + dr.opaque(mi.UInt32, first)
                dr.scatter(image, zero, index)
                dr.eval(image)
        return image

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
        over their samples 0 … spp - 1, added up in a loop inside the kernel: no atomic adds,
        one store per pixel (what a single-level ray tree allows: see the integrator)."""
        if self.spp == 1:
            total = color_of_sample(mi.UInt32(0))
        else:
            spp = dr.opaque(mi.UInt32, self.spp)
            _, total = dr.while_loop(
                (mi.UInt32(0), mi.Color3f(0)), lambda sample, total: sample < spp,
                lambda sample, total: (sample + 1, total + color_of_sample(sample)))
        dr.scatter(self.image, total / dr.opaque(mi.Float, self.spp), pixel)   # as the film divides

    def develop(self):
        """The image as an ``mi.TensorXf`` (H, W, 3): the same array, no copy. The film
        receives it too (see the module docstring), at no cost until it is read."""
        self.film.put_block(mi.ImageBlock(self._film_storage(), self.film.crop_offset(),
                                          self.film.rfilter()))
        return mi.TensorXf(self.image, (self.height, self.width, 3))

    def _film_storage(self):
        """The image as the film stores it, (H, W, 4): R, G, B and the weight 1 per pixel,
        a lazy expression (gathers from the image when the film is read)."""
        index = dr.arange(mi.UInt32, 4 * self.width * self.height)
        channel = index & 3
        rgb = channel < 3
        value = dr.select(rgb, dr.gather(mi.Float, self.image, (index >> 2) * 3 + channel, rgb), 1.0)
        return mi.TensorXf(value, (self.height, self.width, 4))
