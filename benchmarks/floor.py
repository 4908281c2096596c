"""The ray-casting floor: the rays of a Whitted render at depth 1, and nothing else.

For a diffuse scene under one point light: the integrator's camera rays, the nearest hit,
the facing test and the shadow ray, in one Dr.Jit kernel with no shading and no film
(``film=True`` adds Mitsuba's film). What a render costs above it is the price of shading;
benchmarks/run_notes.md ("The ray-casting floor") says how it is compared.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from whitted.plugins.film import CameraSamples, FilmSplats

HIT_FINDERS = ("ray_intersect", "sphere table")


class RayCastingFloor:
    def __init__(self, scene, light_position, spp: int, hit_finder: str, film: bool = False):
        from whitted.plugins.scene_tables import scene_tables
        from whitted.plugins.hits import SphereHits
        self.scene, self.spp, self.film = scene, spp, film
        self.light = mi.Point3f(light_position)
        self.table = SphereHits(scene, scene_tables(scene), need_uv=False) if hit_finder == "sphere table" else None
        # the integrator's own camera rays (the same code, the same kernels)
        self.camera = CameraSamples(scene.sensors()[0], spp, 0)

    def trace(self):
        """``(hit, shadow_ray_cast, value)`` per sample, not yet evaluated."""
        sensor = self.scene.sensors()[0]
        width, height = (int(c) for c in sensor.film().crop_size())
        index = dr.arange(mi.UInt32, width * height * self.spp)
        if self.spp == 1:
            pixel, sample = index, mi.UInt32(0)
        else:
            pixel = index // dr.opaque(mi.UInt32, self.spp)
            sample = index - pixel * dr.opaque(mi.UInt32, self.spp)
        ray, _, self.position = self.camera.ray(pixel, sample)
        if self.table is not None:
            hit, si = self.table.intersect(ray, coherent=True)[:2]
        else:
            si = self.scene.ray_intersect(ray, ray_flags=mi.RayFlags.Minimal, coherent=True)
            hit = si.is_valid()
        n = dr.select(dr.dot(ray.d, si.n) > 0, -si.n, si.n)
        to_light = self.light - si.p
        cos = dr.dot(n, to_light) * dr.rsqrt(dr.squared_norm(to_light))
        cast = hit & (cos > 0)
        visible = cast & ~self.scene.ray_test(si.spawn_ray_to(self.light), cast)
        return hit, cast, dr.select(visible, cos, 0)

    def __call__(self):
        value = self.trace()[2]
        if not self.film:
            dr.eval(value)
            return value
        film = FilmSplats(self.scene.sensors()[0].film(), self.spp)   # the integrator's own
        film.put(None, self.position, mi.Color3f(value))
        image = film.develop()
        dr.eval(image)
        return image

    def counts(self) -> tuple[int, int]:
        """``(hits, shadow rays)``: camera rays that hit a surface, and the shadow rays cast."""
        hit, cast, _ = self.trace()
        return int(dr.count(hit)[0]), int(dr.count(cast)[0])
