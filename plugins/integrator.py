"""``whitted``: the article's recursive ray tracer as a Mitsuba integrator.

A render prepares (the scene's tables, :mod:`.scene_tables`, and the recursion,
:mod:`.recursion`), traces camera rays (:class:`.film.CameraSamples`) in passes of at most
``wavefront_size`` and develops the sensor's film (:mod:`.film`).
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from whitted import defaults as D
from whitted.errors import WhittedError
from whitted.float32 import parse_exact_spheres

from .film import CameraSamples, image_for
from .recursion import RayCounts, Recursion, Wavefronts
from .scene_tables import analyse, scene_tables


@dataclass
class DetailedRender:
    """What :meth:`WhittedIntegrator.render_detailed` returns."""
    image: object          # mi.TensorXf (H, W, channels), developed by the film
    rays: RayCounts
    effects: tuple         # see plugins/scene_tables.py
    passes: int
    error_bound: float     # the most the adaptive depth control can have changed a pixel


class WhittedIntegrator(mi.SamplingIntegrator):
    r"""
    .. _integrator-whitted:

    Whitted ray tracer (:monosp:`whitted`)
    --------------------------------------

    .. pluginparameters::

     * - max_depth
       - |int|
       - The article's depth N: the deepest level of the ray tree, primary rays
         having depth 1, from 1 to 64. Depth 1 shows no reflections or
         refractions. (Default: 5)

     * - ambient
       - |float|
       - The article's ambient coefficient A in [0, 1]: a lit point's color is
         ``B·(A + (1 - A)·Σ s·light)``. Article lighting only. (Default: 0.2)

     * - lighting
       - |string|
       - ``article``: the article's model, light colors without fall-off;
         ``physical``: radiometric point lights, ``(B/π)·Σ I·cos/r²``, no
         ambient term (what Mitsuba's ``path`` integrator computes).
         (Default: article)

     * - light_reference
       - |point|
       - Where an article light's color was measured (the scene's ``lookat``):
         a light of color c at distance d from it is a point emitter of
         intensity ``c·π·d²``. (Default: 0, 0, 0)

     * - min_weight
       - |float|
       - Adaptive depth control (POV-Ray's ``adc_bailout``), in [0, 1]: reflected
         and refracted rays are left untraced while together they cannot change
         a pixel by more than this; 0 traces the exact tree. (Default: 1/255)

     * - exact_spheres
       - |string|
       - Giant spheres (radius up to 10^7 next to small ones) the integrator
         intersects in float64: ``id: x y z r`` per shape, the exact center and
         radius, separated by ``;`` (docs/numerics.md, hazard 14). (Default: none)

     * - hide_emitters
       - |bool|
       - Camera rays that escape see black, not the background, and have alpha
         0, as in Mitsuba's own integrators (reflections and refractions still
         show the background). (Default: false)

     * - without
       - |string|
       - Effects the render leaves out, as if the scene lacked them, separated by
         commas: ``shadows`` (no shadow test), ``reflection`` and ``refraction`` (no
         such rays: their share KR or KT is dropped, the diffuse share stays),
         ``textures`` (a textured sphere is white), ``diffuse`` (no light's term: B·A),
         ``ambient`` (A = 0); docs/lessons.md says exactly what each means. (Default: none)

     * - wavefront_size
       - |int|
       - Camera samples per pass, and the widest wavefront the JIT variants
         trace at once: it bounds memory. 0 lets the tracer choose (2^20, or
         2^21 when the tree has a single level). (Default: 0)

    The article's ray tracer (docs/scene-format.md, "Shading") for scenes of the
    :ref:`article <bsdf-article>` BSDF, point lights and an environment. ``mi.traverse``
    exposes the numbers (edits checked as at load; the strings change only by loading
    again); at 1 spp the seed, sampler and lens change nothing (a warning says so);
    gradients (JIT AD variants) hold visibility fixed (:mod:`.gradients`).

    An example scene, with the :ref:`article <bsdf-article>` BSDF too:

    .. tabs::

        .. code-tab:: xml
            :name: whitted-integrator

            <scene version="3.0.0">
                <integrator type="whitted">
                    <integer name="max_depth" value="10"/>
                    <point name="light_reference" x="0" y="0.2" z="0"/>
                    <float name="ambient" value="0.3"/>
                    <string name="lighting" value="article"/>
                    <string name="without" value="shadows,reflection"/>
                </integrator>
                <shape type="sphere">
                    <bsdf type="article">
                        <rgb name="color" value="1, 1, 1"/>
                        <float name="reflect" value="0.05"/>
                        <float name="refract" value="0.9"/>
                        <float name="ior" value="1.5"/>
                    </bsdf>
                </shape>
            </scene>

        .. code-tab:: python

            'type': 'scene',
            'integrator': {'type': 'whitted', 'max_depth': 10, 'light_reference': [0, 0.2, 0],
                           'ambient': 0.3, 'lighting': 'article', 'without': 'shadows,reflection'},
            'sphere': {'type': 'sphere',
                       'bsdf': {'type': 'article', 'color': {'type': 'rgb', 'value': [1, 1, 1]},
                                'reflect': 0.05, 'refract': 0.9, 'ior': 1.5}}
    """

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        given = {name: props.get(name, default) for name, default in D.WHITTED_DEFAULTS.items()}
        self._take(D.check_plugin_parameters("whitted", given))
        self.hide_emitters = bool(props.get("hide_emitters", False))
        self._warned = ()   # what the last warning about 1 spp named (once per change)
        self._gradient_keys = {}   # parameters seen with gradients: differentiated? (warned once)
        self.exact_spheres = parse_exact_spheres(str(props.get("exact_spheres", "")))

    def _take(self, checked: dict) -> None:
        for name, value in checked.items():
            setattr(self, name, mi.ScalarPoint3f(*value) if name == "light_reference" else value)

    #: what :meth:`traverse` exposes, as float64 vectors (an edit of max_depth to 2.5 is refused)
    TRAVERSED = {"max_depth": dr.scalar.Array1f64, "ambient": dr.scalar.Array1f64,
                 "min_weight": dr.scalar.Array1f64, "light_reference": dr.scalar.Array3f64}

    def traverse(self, callback):
        # arrays SceneParameters writes into in place; the ambient differentiable (AD variants)
        if not hasattr(self, "_values"):
            self._values = {name: (mi.Float64 if name in self.DIFFERENTIABLE and dr.is_jit_v(mi.Float) else tp)(
                *self._traversed_value(name)) for name, tp in self.TRAVERSED.items()}
        for name, value in self._values.items():
            differentiable = name in self.DIFFERENTIABLE and dr.is_diff_v(mi.Float)
            callback.put(name, value, mi.ParamFlags.Differentiable if differentiable
                         else mi.ParamFlags.NonDifferentiable)

    #: what :meth:`render_forward` and :meth:`render_backward` differentiate among :data:`TRAVERSED`
    DIFFERENTIABLE = ("ambient",)

    def _traversed_value(self, name):
        value = getattr(self, name)
        return [float(c) for c in value] if name == "light_reference" else [value]

    def parameters_changed(self, keys=[]):  # noqa: B006  (Mitsuba's own default)
        """Take what ``params.update()`` wrote, checked as at load (an invalid edit is undone)."""
        raw = {name: [value[k] for k in range(len(value))] if name == "light_reference" else value[0]
               for name, value in self._values.items()}
        try:
            checked = D.check_plugin_parameters("whitted", raw)
        except WhittedError:
            for name in self.TRAVERSED:   # undo the whole edit
                for k, c in enumerate(self._traversed_value(name)):
                    self._values[name][k] = c
            raise
        self._take(checked)

    #: the settings :meth:`settings` reports and :meth:`with_settings` changes
    SETTINGS = ("max_depth", "ambient", "lighting", "light_reference", "min_weight", "without",
                "exact_spheres")

    def settings(self) -> dict:
        return {name: getattr(self, name) for name in self.SETTINGS}

    def with_settings(self, **changes):
        """This integrator if ``changes`` change none of its :meth:`settings`, else a new one."""
        current = self.settings()
        if all(current[name] == value for name, value in changes.items()):
            return self
        settings = {**current, **changes}
        giants = settings.pop("exact_spheres")   # data, handed over as it is (no text)
        settings["without"] = ",".join(D.check_without(settings["without"]))
        integrator = mi.load_dict({"type": "whitted", **settings, "hide_emitters": self.hide_emitters,
                                   "wavefront_size": self.wavefront_size})
        integrator.exact_spheres = list(giants)
        return integrator

    # -- Mitsuba's entry points ------------------------------------------------------------------

    def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
        if not develop:
            raise ValueError("the whitted integrator only renders developed images (develop=True)")
        outer = scene.integrator()
        if outer is not None and outer is not self and outer.class_name() == "AOVIntegrator":
            # nested in an ``aov`` integrator: the color of the very rays of the AOVs
            return super().render(scene, sensor, seed, spp, develop, evaluate)
        return self.render_detailed(scene, sensor, seed, spp).image

    def sample(self, scene, sampler, ray, medium=None, active=True):
        """The color of ``ray``'s whole tree, and whether it hit a surface or sees the background."""
        tracer, analysis = self._recursion(scene)
        tracer.keep_camera_hit = True
        color = tracer.trace(mi.Ray3f(ray))
        seen = analysis.has("background") and not self.hide_emitters
        return color, mi.Bool(tracer.camera_hit | seen), []

    def render_forward(self, scene, params=None, sensor=0, seed=0, spp=0):
        """The image's derivative along the parameters' gradients (forward mode)."""
        with dr.resume_grad():
            image = self._attached_image("render_forward", scene, params, sensor, seed, spp)
            dr.forward_to(image)
        return dr.grad(image)

    def render_backward(self, scene, params, grad_in, sensor=0, seed=0, spp=0):
        """Add ``grad_in`` times the image's derivatives to the parameters' gradients (reverse mode)."""
        with dr.resume_grad():
            image = self._attached_image("render_backward", scene, params, sensor, seed, spp)
            dr.set_grad(image, grad_in)
            dr.enqueue(dr.ADMode.Backward, image)
            dr.traverse(dr.ADMode.Backward)

    def _attached_image(self, what, scene, params, sensor, seed, spp):
        """The image of a gradient render (refused in a variant without automatic
        differentiation), naming once the parameters it does not differentiate."""
        if not dr.is_diff_v(mi.Float):
            raise WhittedError(f"whitted: {what} needs gradients, which the {mi.variant()} variant "
                               "cannot compute: use llvm_ad_rgb (or cuda_ad_rgb)")
        from . import gradients
        gradients.name_undifferentiated(scene, mi.traverse(scene) if params is None else params, self,
                                        self._gradient_keys)
        return self.render_detailed(scene, sensor, seed, spp, attached=True).image

    # -- Rendering ------------------------------------------------------------------------------

    def _recursion(self, scene, tables=None, attached=False):
        """The recursion and the analysis of a render of ``scene`` (``attached``: for gradients)."""
        analysis = analyse(tables or scene_tables(scene), self.max_depth, self.light_reference,
                           self.without)
        values = None
        if attached:
            from .gradients import attached as attached_values
            values = attached_values(scene, analysis, self)
        walk = Wavefronts if dr.is_jit_v(mi.Float) else Recursion
        return walk(scene, analysis, self, values), analysis

    def render_detailed(self, scene, sensor=0, seed=0, spp=0, progress=None, tables=None,
                        attached=False) -> DetailedRender:
        """Render ``scene`` and report what was traced. ``tables``: what
        :func:`whitted.plugins.check_scene` just returned; ``progress(n)`` is told of finished
        camera samples (between levels, where Ctrl-C lands); ``attached``: for gradients."""
        if isinstance(sensor, int):
            sensor = scene.sensors()[sensor]
        # mi.render may pass a UInt32; any integer up to 2^64 - 1 is folded to 32 bits
        seed = D.check_seed(int(seed[0]) if dr.is_array_v(seed) else seed, "whitted: seed")
        camera = CameraSamples(sensor, int(spp), seed)
        spp = camera.spp   # (as the sampler rounds it)
        # (not for a gradient: mi.render derives the seed of render_forward/backward itself)
        if camera.unused and camera.unused != self._warned and not attached:
            self._warned = camera.unused
            mi.Log(mi.LogLevel.Warn, f"whitted: at 1 sample per pixel every camera ray passes through "
                   f"its pixel's center and the lens's (the scene format's rule): the "
                   f"{' and the '.join(camera.unused)} change{'s' if len(camera.unused) == 1 else ''} "
                   "nothing; render spp > 1 for them")

        tracer, analysis = self._recursion(scene, tables, attached)
        image = image_for(sensor.film(), spp)
        tracer.keep_camera_hit = image.alpha
        background_seen = analysis.has("background") and not self.hide_emitters
        # A single-level tree stores nothing between levels: then, where the image takes
        # whole pixels, each lane renders one pixel, looping over its samples in the kernel.
        # (Not in a differentiable render: Dr.Jit differentiates no loop in a kernel backwards.)
        by_pixel = analysis.depth == 1 and image.takes_pixels and camera.sampler is None and not attached
        whole_pixels = by_pixel or camera.sampler is not None
        per_pass = self.wavefront_size or tracer.samples_per_pass
        per_pass = max(spp, per_pass // spp * spp) if whole_pixels else per_pass
        total = camera.width * camera.height * spp
        passes = [(first, min(per_pass, total - first)) for first in range(0, total, per_pass)]
        for index, (first, count) in enumerate(passes):
            if by_pixel:
                self._render_pixels(tracer, camera, image, first // spp, count // spp)
                if progress is not None:
                    progress(count)
            else:
                camera.start_pass(index, count)
                self._render_pass(tracer, camera, image, first, count, progress, background_seen)
        rays = tracer.tally.read(camera=total, max_depth_reached=tracer.deepest)
        error_bound = rays.sample_culled_weight * tracer.bright if rays.culled else 0.0
        return DetailedRender(image.develop(), rays, analysis.effects, len(passes), error_bound)

    def _render_pass(self, tracer, camera, image, first, count, progress, background_seen=False):
        """Samples first … first + count - 1 (pixel after pixel), as ``tracer`` takes them."""
        spp = camera.spp
        # Counted from the pass's first pixel, so that 32-bit indices never overflow.
        first_pixel, first_sample = divmod(first, spp)
        opaque_spp = dr.opaque(mi.UInt32, spp)
        opaque_first_sample = dr.opaque(mi.UInt32, first_sample)
        opaque_first_pixel = dr.opaque(mi.UInt32, first_pixel)
        for index in tracer.samples(count):
            if spp == 1:
                pixel, sample = index, mi.UInt32(0)
            else:
                index = index + opaque_first_sample
                pixel = index // opaque_spp
                sample = index - pixel * opaque_spp
            pixel = pixel + opaque_first_pixel
            ray, ray_weight, position = camera.ray(pixel, sample)
            color = tracer.trace(ray, progress) * ray_weight
            image.put(pixel, position, color,
                      tracer.camera_hit | background_seen if image.alpha else None)
        tracer.finish_pass()

    def _render_pixels(self, tracer, camera, image, first_pixel, pixels):
        """Pixels first_pixel … first_pixel + pixels - 1, one lane each (single-level trees)."""
        pixel = dr.arange(mi.UInt32, pixels) + dr.opaque(mi.UInt32, first_pixel)

        def color(sample):
            ray, ray_weight, _ = camera.ray(pixel, sample)
            return tracer.trace(ray) * ray_weight
        image.put_pixels(pixel, color)
        tracer.finish_pass()

    def trace_pixels(self, scene, pixels, recorder, sensor=0) -> list:
        """The colors of the camera rays through the centers of ``pixels`` (``(x, y)`` in the
        crop), traced as a 1 spp render traces them, each batch's shown to ``recorder``
        (whitted/trace/record.py: ``attach(tracer)``, then ``camera(weight)`` per batch)."""
        if isinstance(sensor, int):
            sensor = scene.sensors()[sensor]
        camera = CameraSamples(sensor, 1, 0)
        tracer, _ = self._recursion(scene)
        recorder.attach(tracer)
        index = [(y + camera.border) * camera.width + x + camera.border for x, y in pixels]
        colors = []
        for pixel in [mi.UInt32(index)] if dr.is_jit_v(mi.Float) else index:
            ray, ray_weight, _ = camera.ray(pixel, mi.UInt32(0))
            recorder.camera(ray_weight)
            colors.append(tracer.trace(ray) * ray_weight)
        return colors

    def to_string(self):
        return (f"WhittedIntegrator[max_depth={self.max_depth}, ambient={self.ambient}, "
                f"lighting={self.lighting}, min_weight={self.min_weight}"
                f"{', without=' + ','.join(self.without) if self.without else ''}]")
