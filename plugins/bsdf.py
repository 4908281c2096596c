"""``article``: the article's material as a Mitsuba BSDF, for Mitsuba's own integrators;
the ``whitted`` integrator reads the parameters directly (:mod:`.scene_tables`).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from whitted import defaults as D
from whitted.errors import ParameterError

from .hits import cos_incidence, facing_normal, reflect, refract, relative_ior
from .scene_tables import uniform_color

DIFFUSE, REFLECTION, TRANSMISSION = 0, 1, 2

_LOBE_TYPES = (mi.BSDFFlags.DiffuseReflection, mi.BSDFFlags.DeltaReflection,
               mi.BSDFFlags.DeltaTransmission)
COMPONENT_FLAGS = tuple(lobe | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
                        for lobe in _LOBE_TYPES)


def delta_directions(wi, ior):
    """``(R, T, tir, eta)``: the article's mirror and refracted directions for ``wi`` (local
    frame, normal +z; :mod:`.hits`), and Mitsuba's ``bs.eta`` for T."""
    v = -wi
    n_facing, inside = facing_normal(v, mi.Vector3f(0, 0, 1))
    c1 = cos_incidence(v, n_facing)
    n = relative_ior(ior, inside)
    t, tir = refract(v, n_facing, c1, n)
    return reflect(v, n_facing, c1), t, tir, dr.rcp(n)


class ArticleBSDF(mi.BSDF):
    r"""
    .. _bsdf-article:

    The article's material (:monosp:`article`)
    ------------------------------------------

    .. pluginparameters::

     * - color
       - |spectrum| or |texture|
       - The base color B: an RGB color, each component in [0, 1], or a texture
         (a ``bitmap`` mapped by the sphere's UV) for a textured sphere. (Default: 1, 1, 1)
       - |exposed|, |differentiable|

     * - reflect
       - |float|
       - KR, the share of the color that comes from the mirror direction, in
         [0, 1]. (Default: 0)
       - |exposed|, |differentiable|

     * - refract
       - |float|
       - KT, the share that comes from the refracted direction, in [0, 1];
         KR + KT <= 1. (Default: 0)
       - |exposed|, |differentiable|

     * - ior
       - |float|
       - The sphere's index of refraction n2 (> 0; the outside's is 1). Below 1
         it reads as a bubble: rays from outside are totally reflected beyond
         the critical angle. (Default: 1)
       - |exposed|

    ``(1 − KR − KT)·point + KR·reflected + KT·refracted`` read as three lobes, two-sided: a
    Lambertian one of albedo B, a perfect mirror and a perfect refraction, total internal
    reflection moving KT onto the mirror, no η² scaling (docs/radiometry.md, "Materials").
    ``mi.traverse`` exposes ``reflect``, ``refract`` and ``ior`` as one-value float64 vectors
    (JIT: the ``whitted`` integrator differentiates KR and KT); loaded values and edits (of
    these or a uniform ``color.value``) meet one rule (:data:`whitted.defaults.PLUGIN_PARAMETERS`),
    and a refused edit is undone. A texture's texels are not checked.

    An example: the :ref:`whitted integrator <integrator-whitted>`'s scene.
    """

    #: what the Whitted integrator checks every shape's BSDF for
    is_article = True

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        values = {name: props.get(name, default)
                  for name, default in zip(self.SCALARS, (D.REFLECT, D.REFRACT, D.IOR))}
        if "color" not in props:
            values["color"] = D.COLOR
        elif props.type("color") == mi.Properties.Type.Color:
            values["color"] = props.get("color")
        #: the uniform base color last accepted (None for a texture): what a refused edit restores
        self._color = None
        # (an RGB color checked before Mitsuba makes it a texture: its own check names no parameter)
        self._take(values)
        self.color = (props.get_texture("color") if "color" in props
                      else mi.load_dict({"type": "rgb", "value": D.COLOR}))
        if self._color is None and not self.color.is_spatially_varying():   # a uniform texture
            self._take({**values, "color": uniform_color(self.color)})
        self.m_components = list(COMPONENT_FLAGS)
        #: how many times ``params.update()`` changed the BSDF: the integrator's tables compare it
        self.changes = 0
        # one-value float64 arrays, which SceneParameters writes into in place (JIT: differentiable)
        one_value = mi.Float64 if dr.is_jit_v(mi.Float) else dr.scalar.Array1f64
        self._values = {name: one_value(getattr(self, name)) for name in self.SCALARS}

    #: the parameters :meth:`traverse` exposes besides ``color``, kept as Python floats
    #: (``self.reflect`` ...) and, for mi.traverse, as one-value Mitsuba vectors
    SCALARS = ("reflect", "refract", "ior")

    def _take(self, values: dict) -> None:
        """Take KR, KT, the IOR and a uniform ``color`` if they pass the plugins' one rule."""
        checked = D.check_plugin_parameters("article BSDF", values)
        self.reflect, self.refract, self.ior = (checked[name] for name in self.SCALARS)
        self._color = checked.get("color", self._color)
        # the flags name only the lobes the material can use (no light sampling on glass)
        flags = mi.BSDFFlags.Empty
        if self.diffuse_weight > 0:
            flags |= COMPONENT_FLAGS[DIFFUSE]
        if self.reflect > 0 or self.refract > 0:    # refraction may turn into TIR
            flags |= COMPONENT_FLAGS[REFLECTION]
        if self.refract > 0:
            flags |= COMPONENT_FLAGS[TRANSMISSION]
        self.m_flags = flags

    def parameters_changed(self, keys=[]):  # noqa: B006  (Mitsuba's own default)
        # checked as at load (an invalid edit is undone and refused), and counted for the tables
        values = {name: self._values[name][0] for name in self.SCALARS}
        color = self._color is not None and (not keys or "color" in keys)
        if color:
            values["color"] = uniform_color(self.color)
        try:
            self._take(values)
        except ParameterError:
            for name in self.SCALARS:
                self._values[name][0] = getattr(self, name)
            if color:
                params = mi.traverse(self.color)
                params["value"] = type(params["value"])(*self._color)
                params.update()
            raise
        self.changes += 1

    @property
    def diffuse_weight(self) -> float:
        return max(0.0, 1.0 - self.reflect - self.refract)

    # -- the lobes' weights and selection probabilities ---------------------

    def _lobe_weights(self, ctx, wi):
        """The weights of the enabled lobes (diffuse, mirror, refraction) for ``wi``,
        with total internal reflection moving KT onto the mirror."""
        _, _, tir, _ = delta_directions(wi, self.ior)
        weights = (mi.Float(self.diffuse_weight),
                   mi.Float(self.reflect) + dr.select(tir, self.refract, 0.0),
                   dr.select(tir, 0.0, self.refract))
        return tuple(w if ctx.is_enabled(_LOBE_TYPES[i], i) else mi.Float(0.0)
                     for i, w in enumerate(weights))

    # -- Mitsuba's BSDF interface -------------------------------------------

    def sample(self, ctx, si, sample1, sample2, active=True):
        wi = si.wi
        cos_i = mi.Frame3f.cos_theta(wi)
        w_d, w_r, w_t = self._lobe_weights(ctx, wi)
        total = w_d + w_r + w_t
        inv_total = dr.select(total > 0, dr.rcp(dr.select(total > 0, total, 1.0)), 0.0)
        p_d, p_r, p_t = w_d * inv_total, w_r * inv_total, w_t * inv_total

        # Diffuse below p_d, refraction (when possible) above p_d + p_r, else mirror:
        # round-off in the sums can never select a lobe of probability 0.
        pick_d = sample1 < p_d
        pick_t = (sample1 >= p_d + p_r) & (p_t > 0)

        r_dir, t_dir, _, t_eta = delta_directions(wi, self.ior)
        d_dir = mi.warp.square_to_cosine_hemisphere(sample2)   # on wi's side, mirrored below
        # At grazing incidence (cos θi = 0) wi has no side and the diffuse lobe no value.
        d_pdf = dr.select(cos_i != 0, p_d * mi.warp.square_to_cosine_hemisphere_pdf(d_dir), 0.0)
        d_dir = mi.Vector3f(d_dir.x, d_dir.y, dr.select(cos_i >= 0, d_dir.z, -d_dir.z))

        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = dr.select(pick_d, d_dir, dr.select(pick_t, t_dir, r_dir))
        bs.pdf = dr.select(pick_d, d_pdf, dr.select(pick_t, p_t, p_r))
        bs.eta = dr.select(pick_t, t_eta, 1.0)
        bs.sampled_component = dr.select(pick_d, mi.UInt32(DIFFUSE),
                                         dr.select(pick_t, mi.UInt32(TRANSMISSION),
                                                   mi.UInt32(REFLECTION)))
        bs.sampled_type = dr.select(pick_d, mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                                    dr.select(pick_t, mi.UInt32(+mi.BSDFFlags.DeltaTransmission),
                                              mi.UInt32(+mi.BSDFFlags.DeltaReflection)))

        # weight = f·|cos θo| / pdf = (lobe weight · lobe value) / (lobe weight / total):
        # B·total for the diffuse lobe (f = w_d·B/π, pdf = p_d·|cos θo|/π), total for a delta lobe.
        albedo = self.color.eval(si, active & pick_d)
        weight = dr.select(pick_d, albedo * dr.select(bs.pdf > 0, total, 0.0), mi.Color3f(total))
        valid = active & (total > 0)
        bs.pdf = dr.select(valid, bs.pdf, 0.0)
        return bs, dr.select(valid, weight, 0.0)

    def eval(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[0]

    def pdf(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[1]

    def eval_pdf(self, ctx, si, wo, active=True):
        w_d, w_r, w_t = self._lobe_weights(ctx, si.wi)
        total = w_d + w_r + w_t
        p_d = dr.select(total > 0, w_d / dr.select(total > 0, total, 1.0), 0.0)
        same_side = mi.Frame3f.cos_theta(si.wi) * mi.Frame3f.cos_theta(wo) > 0
        cos_o = dr.abs(mi.Frame3f.cos_theta(wo))
        active = active & same_side
        value = self.color.eval(si, active) * (w_d * dr.inv_pi * cos_o)
        pdf = p_d * cos_o * dr.inv_pi
        return dr.select(active, value, 0.0), dr.select(active, pdf, 0.0)

    def eval_diffuse_reflectance(self, si, active=True):
        """The base color B (the diffuse lobe's albedo before its weight 1 − KR − KT)."""
        return self.color.eval(si, active)

    def eval_attribute_1(self, name, si, active=True):
        if name not in self.SCALARS:
            raise ValueError(f"article BSDF has no attribute '{name}'")
        return mi.Float(getattr(self, name))

    def has_attribute(self, name, active=True):
        return name in ("color", *self.SCALARS)

    #: the parameters the Whitted integrator differentiates (JIT AD variants); the IOR
    #: bends rays, which would move what they hit (visibility: not differentiated)
    DIFFERENTIABLE = ("reflect", "refract")

    def traverse(self, callback):
        callback.put("color", self.color, mi.ParamFlags.Differentiable)
        for name in self.SCALARS:
            differentiable = name in self.DIFFERENTIABLE and dr.is_diff_v(mi.Float)
            callback.put(name, self._values[name], mi.ParamFlags.Differentiable if differentiable
                         else mi.ParamFlags.NonDifferentiable)

    def to_string(self):
        return (f"ArticleBSDF[\n  color = {self.color},\n  reflect = {self.reflect},\n"
                f"  refract = {self.refract},\n  ior = {self.ior}\n]")
