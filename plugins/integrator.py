"""``whitted``: the article's recursive ray tracer as a Mitsuba integrator (issue 3)."""

from __future__ import annotations

import mitsuba as mi


class WhittedIntegrator(mi.SamplingIntegrator):
    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.max_depth = int(props.get("max_depth", 5))
        self.ambient = float(props.get("ambient", 0.2))
        self.lighting = str(props.get("lighting", "article"))
        self.light_reference = mi.ScalarPoint3f(props.get("light_reference", mi.ScalarPoint3f(0, 0, 0)))

    def sample(self, scene, sampler, ray, medium=None, active=True):
        raise NotImplementedError("the Whitted integrator: see issue 3")

    def to_string(self):
        return f"WhittedIntegrator[max_depth={self.max_depth}, ambient={self.ambient}, lighting={self.lighting}]"
