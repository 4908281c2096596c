"""``article``: the article's material as a Mitsuba BSDF.

Parameters (as in the scene format): ``color`` (RGB or texture, the base
colour B), ``reflect`` (KR), ``refract`` (KT) and ``ior``. The Whitted
integrator reads them through :meth:`eval_diffuse_reflectance` and
:meth:`eval_attribute_1`.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


class ArticleBSDF(mi.BSDF):
    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.color = props.get_texture("color", 1.0) if props.has_property("color") else \
            mi.load_dict({"type": "uniform", "value": 1.0})
        self.reflect = float(props.get("reflect", 0.0))
        self.refract = float(props.get("refract", 0.0))
        self.ior = float(props.get("ior", 1.0))
        flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        self.m_components = [flags]
        self.m_flags = flags

    def eval_diffuse_reflectance(self, si, active=True):
        return self.color.eval(si, active)

    def eval_attribute_1(self, name, si, active=True):
        value = {"reflect": self.reflect, "refract": self.refract, "ior": self.ior}.get(name)
        if value is None:
            raise ValueError(f"article BSDF has no attribute '{name}'")
        return mi.Float(value)

    def has_attribute(self, name, active=True):
        return name in ("color", "reflect", "refract", "ior")

    def sample(self, ctx, si, sample1, sample2, active=True):
        raise NotImplementedError("article BSDF sampling: see issue 4")

    def eval(self, ctx, si, wo, active=True):
        raise NotImplementedError("article BSDF evaluation: see issue 4")

    def pdf(self, ctx, si, wo, active=True):
        raise NotImplementedError("article BSDF pdf: see issue 4")

    def traverse(self, callback):
        callback.put("color", self.color, mi.ParamFlags.Differentiable)

    def to_string(self):
        return (f"ArticleBSDF[color={self.color}, reflect={self.reflect}, "
                f"refract={self.refract}, ior={self.ior}]")
