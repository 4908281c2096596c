"""``whitted``: the article's recursive ray tracer as a Mitsuba integrator.

Properties: ``max_depth`` (the article's depth N, primary rays have depth 1),
``ambient`` (A), ``lighting`` ("article" or "physical") and
``light_reference`` (the point where an article light's colour was measured,
the scene's ``lookat``; see :mod:`.effects`), ``wavefront_size``
(camera samples per pass, 0 = automatic), which bounds memory, and
``min_weight`` (Hall and Greenberg's adaptive depth control, 0 = off: see
:meth:`WhittedIntegrator._traced`).

How the ray tree is evaluated. The article's ``trace`` is recursive, but its
result is linear in the children's colours, so the colour of a camera ray is
a sum over the tree's rays of ``w·contribution``, where ``w`` is the product of
the KR and KT factors along the way (see :mod:`.shading`). The integrator
keeps a stack of *wavefronts*: rays of one level with their weights and the
camera sample each belongs to. Shading a wavefront adds its contributions to
its camera samples and pushes one wavefront of children, holding only the
lanes that really spawn a ray (``dr.compress``). In the JIT variants a
wavefront is a Dr.Jit array of up to ``wavefront_size`` lanes (wider ones
are split, so trees that double at each level still run in bounded memory);
in the scalar variant it is a single ray and the same loop is an ordinary
depth-first traversal. No Python runs per ray in the JIT variants.

The image is rendered in passes of at most ``wavefront_size`` camera
samples (2^20 by default; 2^24 when the tree has a single level, which stores
nothing per lane), accumulated in Mitsuba's image block and developed by the
film. Camera rays come from the sensor's ``sample_ray`` (Mitsuba's perspective
camera), placed in their pixels by :mod:`.pixel_samples`.

The modules behind it: :mod:`.effects` (what the scene calls for),
:mod:`.geometry` (hit points, normals, UV), :mod:`.surfaces` (material
lookups), :mod:`.shading` (the article's model), :mod:`.optics` (reflection
and refraction) and :mod:`.pixel_samples`.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from whitted import defaults as D

from .effects import analyse
from .pixel_samples import pixel_offset
from .shading import RayCounter, Shader

#: default camera samples per pass (and widest wavefront) in the JIT variants:
#: a level holds about 100 bytes per lane, so a pass stays around 100 MiB
JIT_SAMPLES_PER_PASS = 1 << 20
#: the same when the tree has a single level: then one kernel traces, shades
#: and splats each sample, storing nothing per lane, and larger passes are free
JIT_SAMPLES_PER_FLAT_PASS = 1 << 24
#: the scalar variant traces one ray at a time; passes only pace the progress bar
SCALAR_SAMPLES_PER_PASS = 1 << 10


@dataclass
class RayCounts:
    """Rays traced by one render (``whitted render --stats``).

    A refracted share sent along the mirror direction by total internal
    reflection still counts as a refraction ray: it is the ray the refraction
    term spawns. ``max_depth_reached`` is the deepest level that traced a ray.
    ``culled`` counts the reflected and refracted rays left untraced because
    their path weight was below ``min_weight``, and ``culled_weight`` sums
    their weights: each would have added at most its weight times the
    brightest colour in the scene, so ``culled_weight / spp`` times that
    colour bounds the total error of an image (summed over its pixels).
    """
    camera: int = 0
    shadow: int = 0
    reflection: int = 0
    refraction: int = 0
    max_depth_reached: int = 0
    culled: int = 0
    culled_weight: float = 0.0

    def rays(self) -> dict:
        return {kind: getattr(self, kind) for kind in ("camera", "shadow", "reflection", "refraction")}


@dataclass
class Rendering:
    """What :meth:`WhittedIntegrator.render_detailed` returns."""
    image: object          # mi.TensorXf (H, W, channels), developed by the film
    rays: RayCounts
    effects: tuple         # see plugins/effects.py
    depth: int             # the tree depth the scene needed (<= max_depth)
    passes: int


@dataclass
class Wavefront:
    """Rays of one level of the tree, with their path weights.

    ``owner`` holds each lane's camera sample within the pass; None for the
    camera rays themselves (lane i is sample i) and in the scalar variant.
    """
    ray: object
    weight: object
    owner: object
    level: int


class WhittedIntegrator(mi.SamplingIntegrator):
    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.max_depth = D.check_depth(props.get("max_depth", D.DEPTH), "whitted: max_depth")
        self.ambient = D.check_ambient(props.get("ambient", D.AMBIENT), "whitted: ambient")
        self.lighting = D.check_lighting(str(props.get("lighting", D.LIGHTING)), "whitted: lighting")
        self.light_reference = mi.ScalarPoint3f(props.get("light_reference", mi.ScalarPoint3f(0, 0, 0)))
        self.wavefront_size = int(props.get("wavefront_size", 0))
        self.min_weight = D.check_min_weight(props.get("min_weight", D.MIN_WEIGHT), "whitted: min_weight")
        if self.wavefront_size < 0:
            raise ValueError(f"whitted: wavefront_size must be >= 0, got {self.wavefront_size}")
        self.vectorized = dr.is_jit_v(mi.Float)
        self._lanes = self.wavefront_size or JIT_SAMPLES_PER_PASS

    # -- Mitsuba's entry points ------------------------------------------------------------------

    def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
        if not develop:
            raise ValueError("the whitted integrator only renders developed images (develop=True)")
        return self.render_detailed(scene, sensor, seed, spp).image

    def sample(self, scene, sampler, ray, medium=None, active=True):
        """The colour of ``ray``'s whole tree (for callers that drive the integrator per ray)."""
        shader = Shader(scene, analyse(scene, self.max_depth, self.light_reference),
                        self.ambient, self.lighting, RayCounter())
        colour = self._trace(shader, mi.Ray3f(ray), RayCounts())
        return colour, mi.Bool(True), []

    # -- Rendering ------------------------------------------------------------------------------

    def render_detailed(self, scene, sensor=0, seed=0, spp=0, progress=None) -> Rendering:
        """Render ``scene`` and report what was traced.

        ``progress``, when given, is called with the number of camera samples
        finished after each pass.
        """
        if isinstance(sensor, int):
            sensor = scene.sensors()[sensor]
        seed = int(dr.ravel(mi.UInt32(seed))[0]) if self.vectorized else int(seed)
        spp = int(spp) or sensor.sampler().sample_count()
        film = sensor.film()
        width, height = (int(c) for c in film.crop_size())
        total = width * height * spp

        analysis = analyse(scene, self.max_depth, self.light_reference)
        counter = RayCounter()
        shader = Shader(scene, analysis, self.ambient, self.lighting, counter)
        rays = RayCounts()

        film.prepare([])
        block = film.create_block()
        block.set_coalesce(block.coalesce() and spp >= 4)
        if self.wavefront_size:
            per_pass = self.wavefront_size
        elif not self.vectorized:
            per_pass = SCALAR_SAMPLES_PER_PASS
        else:
            per_pass = JIT_SAMPLES_PER_PASS if analysis.depth > 1 else JIT_SAMPLES_PER_FLAT_PASS
        passes = 0
        for first in range(0, total, per_pass):
            count = min(per_pass, total - first)
            render_pass = self._render_pass_jit if self.vectorized else self._render_pass_scalar
            render_pass(shader, sensor, block, first, count, width, spp, seed, rays)
            passes += 1
            if progress is not None:
                progress(count)
        film.put_block(block)
        image = film.develop()
        rays.shadow = counter.shadow
        return Rendering(image, rays, analysis.effects, analysis.depth, passes)

    def _render_pass_jit(self, shader, sensor, block, first, count, width, spp, seed, rays):
        # Samples first .. first + count - 1 (of every pixel's spp, pixel after pixel);
        # counted from the pass's first pixel, so that 32-bit indices never overflow.
        first_pixel, first_sample = divmod(first, spp)
        index = dr.arange(mi.UInt32, count)
        if spp == 1:
            pixel, sample = index, mi.UInt32(0)
        else:
            spp_ = dr.opaque(mi.UInt32, spp)
            index += dr.opaque(mi.UInt32, first_sample)
            pixel = index // spp_
            sample = index - pixel * spp_
        pixel += dr.opaque(mi.UInt32, first_pixel)
        width_ = dr.opaque(mi.UInt32, width)
        y = pixel // width_
        x = pixel - y * width_
        ray, ray_weight, position = self._camera_ray(sensor, x, y, pixel, sample, spp, seed)
        rays.camera += count
        colour = self._trace(shader, ray, rays) * ray_weight
        self._splat(sensor.film(), block, position, colour)
        dr.eval()          # this pass's kernels and side effects (the block's accumulation)
        dr.sync_thread()   # so that progress reports finished work

    def _render_pass_scalar(self, shader, sensor, block, first, count, width, spp, seed, rays):
        film = sensor.film()
        for index in range(first, first + count):
            pixel, sample = divmod(index, spp)
            y, x = divmod(pixel, width)
            ray, ray_weight, position = self._camera_ray(sensor, x, y, pixel, sample, spp, seed)
            rays.camera += 1
            colour = self._trace(shader, ray, rays) * ray_weight
            self._splat(film, block, position, colour)

    @staticmethod
    def _camera_ray(sensor, x, y, pixel, sample, spp, seed):
        """The camera ray of a sample, its weight, and where it lands on the film."""
        film = sensor.film()
        offset = pixel_offset(pixel, sample, spp, seed)
        corner = mi.Point2f(mi.Float(x), mi.Float(y))
        crop_size = mi.ScalarVector2f(film.crop_size())
        ray, weight = sensor.sample_ray(time=sensor.shutter_open(), sample1=0.5,
                                        sample2=(corner + offset) / crop_size,
                                        sample3=mi.Point2f(0.5))
        # Box filter: a sample belongs to its pixel alone (as Mitsuba's own integrators do).
        position = corner if film.rfilter().is_box_filter() else corner + offset
        return ray, weight, position + mi.ScalarVector2f(film.crop_offset())

    @staticmethod
    def _splat(film, block, position, colour):
        values = [colour.x, colour.y, colour.z]
        if mi.has_flag(film.flags(), mi.FilmFlags.Alpha):
            values.append(mi.Float(1))
        values.append(mi.Float(1))   # the sample's weight: the film develops the mean
        block.put(position, values)

    # -- The ray tree -----------------------------------------------------------------------------

    def _trace(self, shader, ray, rays: RayCounts):
        """Sum of ``w·contribution`` over the trees of the camera rays ``ray``."""
        total, scattered = None, False
        stack = [Wavefront(ray, mi.Float(1), None, 1)]
        while stack:
            front = stack.pop()
            if self.vectorized and front.owner is not None and dr.width(front.weight) > self._lanes:
                stack.extend(reversed(self._split(front)))
                continue
            rays.max_depth_reached = max(rays.max_depth_reached, front.level)
            shaded = shader.shade(front.ray, front.weight, spawn=front.level < shader.depth,
                                  coherent=front.level == 1)
            if total is None:
                total = shaded.colour
            elif self.vectorized:
                dr.scatter_reduce(dr.ReduceOp.Add, total, shaded.colour, front.owner)
                scattered = True
            else:
                total += shaded.colour
            if shaded.children:
                stack.extend(self._spawn(front, shaded.children, total, rays))
        if scattered:
            dr.eval(total)   # finish the last scatter before anything reads the total
        return total

    def _traced(self, weight):
        """Whether a child ray is traced: any ray that can still add colour, or,
        with ``min_weight`` > 0, enough of it.

        This is Hall and Greenberg's adaptive depth control (1983): a ray's
        colour reaches the pixel multiplied by its path weight, the product of
        the KR and KT factors above it, so a subtree below weight W can change
        the pixel by at most W times the brightest colour in the scene, and is
        not worth tracing when W is below what the image can show.
        """
        if self.min_weight > 0:
            return weight >= (dr.opaque(mi.Float, self.min_weight) if self.vectorized else self.min_weight)
        return weight > 0

    def _count_culled(self, weight, rays):
        """Count the children of weight ``weight`` that had some, but too little for :meth:`_traced`."""
        if self.min_weight == 0:
            return
        if self.vectorized:
            culled = (weight > 0) & ~self._traced(weight)
            rays.culled += int(dr.count(culled)[0])
            rays.culled_weight += float(dr.sum(dr.select(culled, weight, 0))[0])
        elif 0 < weight and not self._traced(weight):
            rays.culled += 1
            rays.culled_weight += float(weight)

    def _spawn(self, front, children, total, rays):
        """The wavefronts of ``children``: only the lanes that :meth:`_traced` accepts."""
        if not self.vectorized:
            live = [c for c in children if self._traced(c.weight)]
            for c in live:
                setattr(rays, c.kind, getattr(rays, c.kind) + 1)
            for c in children:
                self._count_culled(c.weight, rays)
            return [Wavefront(c.ray, c.weight, None, front.level + 1) for c in live]

        # One kernel shades this level, adds its colour, and stores the children ...
        dr.eval(total, front.owner, [(c.ray.o, c.ray.d, c.weight) for c in children])
        # ... then the live children of every kind are packed into one wavefront,
        # interleaved so that siblings stay next to each other.
        kinds = len(children)
        if kinds == 1:
            weight = children[0].weight
        else:
            slot = dr.arange(mi.UInt32, kinds * dr.width(children[0].weight))
            weight = dr.select((slot & 1) == 1,
                               dr.gather(mi.Float, children[1].weight, slot >> 1),
                               dr.gather(mi.Float, children[0].weight, slot >> 1))
        lane = dr.compress(self._traced(weight))
        self._count_culled(weight, rays)
        live = dr.width(lane)
        if live == 0:
            return []
        if kinds == 1:
            parent, kind = lane, None
            n_second = 0
        else:
            parent, kind = lane >> 1, (lane & 1) == 1
            n_second = int(dr.count(kind)[0])
        setattr(rays, children[0].kind, getattr(rays, children[0].kind) + live - n_second)
        if kinds == 2:
            setattr(rays, children[1].kind, getattr(rays, children[1].kind) + n_second)

        def pick(tp, field):
            first = dr.gather(tp, field(children[0]), parent, True if kind is None else ~kind)
            return first if kind is None else dr.select(
                kind, dr.gather(tp, field(children[1]), parent, kind), first)

        ray = mi.Ray3f(pick(mi.Point3f, lambda c: c.ray.o), pick(mi.Vector3f, lambda c: c.ray.d))
        weight = pick(mi.Float, lambda c: c.weight)
        owner = parent if front.owner is None else dr.gather(mi.UInt32, front.owner, parent)
        return [Wavefront(ray, weight, owner, front.level + 1)]

    def _split(self, front):
        """``front`` cut into wavefronts of at most ``wavefront_size`` lanes."""
        dr.eval(front.ray, front.weight, front.owner)
        n = dr.width(front.weight)
        pieces = []
        for start in range(0, n, self._lanes):
            lane = dr.arange(mi.UInt32, min(self._lanes, n - start)) + dr.opaque(mi.UInt32, start)
            pieces.append(Wavefront(
                mi.Ray3f(dr.gather(mi.Point3f, front.ray.o, lane), dr.gather(mi.Vector3f, front.ray.d, lane)),
                dr.gather(mi.Float, front.weight, lane), dr.gather(mi.UInt32, front.owner, lane), front.level))
        return pieces

    def to_string(self):
        return (f"WhittedIntegrator[max_depth={self.max_depth}, ambient={self.ambient}, "
                f"lighting={self.lighting}, min_weight={self.min_weight}]")
