"""The ``article`` BSDF against the scene format's formulas and Mitsuba's chi-square test.

Expected values come from the spec (docs/scene-format.md, "Shading"), written
here again in float64 numpy in world-style terms (V, N, N', c1, n, k), not from
the plugin's code.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from mitsuba.python.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

import whitted

from conftest import VARIANTS
ALBEDO = (0.5, 0.6, 0.7)
# (KR, KT, IOR): diffuse only, all three lobes, mostly glass, dense glass (TIR
# from inside at moderate angles), an IOR below 1 (TIR from *outside*), pure
# mirror, pure glass.
MATERIALS = [(0.0, 0.0, 1.0), (0.3, 0.2, 1.5), (0.1, 0.7, 1.33), (0.2, 0.5, 2.4),
             (0.25, 0.25, 0.7), (1.0, 0.0, 1.0), (0.0, 1.0, 1.5)]


def article(kr, kt, ior, color=ALBEDO):
    return {"type": "article", "color": {"type": "rgb", "value": list(color)},
            "reflect": kr, "refract": kt, "ior": ior}


def random_directions(n, seed):
    """Unit vectors spread over the whole sphere: half arrive from inside (z < 0)."""
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def spec_delta(wi, ior):
    """The spec's reflection and refraction for one incident direction, float64.

    ``wi`` points away from the surface (Mitsuba's convention); the ray direction
    is V = −wi, N = +z is the outward normal. Returns (R, T or None when TIR, eta).
    """
    v = -np.asarray(wi, dtype=np.float64)
    normal = np.array([0.0, 0.0, 1.0])
    inside = float(v @ normal) > 0
    n_prime = -normal if inside else normal
    c1 = -float(n_prime @ v)
    r = v + 2 * c1 * n_prime
    n1, n2 = (ior, 1.0) if inside else (1.0, ior)
    n = n1 / n2
    k = 1 - n * n * (1 - c1 * c1)
    if k < 0:
        return r, None, None
    return r, n * v + (n * c1 - math.sqrt(k)) * n_prime, n2 / n1


def interaction(wi):
    """A surface interaction (local frame = world frame) with direction(s) ``wi``."""
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2])
    si.uv = mi.Point2f(0.5, 0.5)
    return si


def scalar_interaction(wi):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*[float(c) for c in wi])
    si.uv = mi.Point2f(0.5, 0.5)
    return si


def one_interaction(wi):
    """One direction, in whichever variant is current."""
    return scalar_interaction(wi) if mi.variant().startswith("scalar") else interaction(wi)


def one_vector(d):
    if mi.variant().startswith("scalar"):
        return mi.Vector3f(*[float(c) for c in d])
    return mi.Vector3f(mi.Float(float(d[0])), mi.Float(float(d[1])), mi.Float(float(d[2])))


def sample_many(bsdf, ctx, wi, sample1, sample2):
    """``bsdf.sample`` for rows of directions and first samples, in either variant (one
    call per row in scalar variants). Returns numpy arrays: sampled component, wo,
    weight, pdf, eta, sampled type."""
    if not mi.variant().startswith("scalar"):
        bs, weight = bsdf.sample(ctx, interaction(wi), mi.Float(sample1), mi.Point2f(*sample2))
        return (as_np(bs.sampled_component), as_np(bs.wo), as_np(weight), as_np(bs.pdf),
                as_np(bs.eta), as_np(bs.sampled_type))
    rows = []
    for w, u in zip(wi, sample1):
        bs, weight = bsdf.sample(ctx, scalar_interaction(w), float(u), mi.Point2f(*sample2))
        rows.append((bs.sampled_component, as_np(bs.wo), as_np(weight), bs.pdf, bs.eta,
                     bs.sampled_type))
    return tuple(np.array([row[i] for row in rows]) for i in range(6))


def as_np(value):
    """A Dr.Jit value of the current variant as float64 numpy (vectors as (N, 3))."""
    a = np.array(value, dtype=np.float64)
    return a.T if a.ndim == 2 else a


# -- the diffuse lobe: Mitsuba's chi-square test (vectorized variant) ---------

CHI2_CASES = [(kr, kt, ior, wi) for kr, kt, ior in MATERIALS if kr + kt < 1
              for wi in ([0.3, 0.2, 0.9327379], [0.6, 0.0, -0.8], [0.95, 0.0, 0.3122499])]


@pytest.mark.parametrize("kr, kt, ior, wi", CHI2_CASES)
def test_diffuse_component_sampling_matches_its_pdf(llvm, kr, kt, ior, wi):
    """Component 0 alone: cosine-weighted on wi's side (either side)."""
    ctx = mi.BSDFContext(mi.TransportMode.Radiance, +mi.BSDFFlags.All, 0)
    sample, pdf = BSDFAdapter("article", article(kr, kt, ior), wi=wi, ctx=ctx)
    test = ChiSquareTest(SphericalDomain(), sample, pdf, sample_dim=3, sample_count=400_000,
                         res=61)
    assert test.run(test_count=len(CHI2_CASES), quiet=True), test.messages


@pytest.mark.parametrize("kr, kt, ior, wi", CHI2_CASES)
def test_full_sampling_chooses_diffuse_with_its_pdf_share(llvm, kr, kt, ior, wi):
    """All lobes enabled: the diffuse samples (the delta ones are left out of the
    histogram) must follow ``pdf``, which includes the diffuse lobe's selection
    probability; a wrong probability shows up as a histogram/pdf mismatch."""
    bsdf = mi.load_dict(article(kr, kt, ior))
    direction = np.asarray(wi) / np.linalg.norm(wi)

    def sample(u):
        si = interaction(direction)
        bs, weight = bsdf.sample(mi.BSDFContext(), si, u[0], mi.Point2f(u[1], u[2]))
        diffuse = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Diffuse) & (dr.max(weight) > 0)
        return bs.wo, dr.select(diffuse, 1.0, 0.0)

    def pdf(wo):
        si = interaction(direction)
        return bsdf.pdf(mi.BSDFContext(), si, wo)

    test = ChiSquareTest(SphericalDomain(), sample, pdf, sample_dim=3, sample_count=400_000,
                         res=61)
    passed = test.run(test_count=len(CHI2_CASES), quiet=True)
    assert passed, test.messages
    assert test.histogram_sum[0] == pytest.approx(1 - kr - kt, abs=5e-3)


# -- the delta lobes against the spec's formulas ------------------------------

@pytest.mark.parametrize("kr, kt, ior", MATERIALS)
def test_lobe_choice_and_directions_follow_the_spec(variant, kr, kt, ior):
    """For random directions (half of them from inside), stratified sample1 picks
    diffuse / mirror / refraction with probabilities 1−KR−KT, KR, KT (KR+KT and 0
    under total internal reflection); delta directions and weights are the spec's."""
    bsdf = mi.load_dict(article(kr, kt, ior))
    strata = 50
    directions = random_directions(12, seed=int(ior * 100) + int(kr * 10))
    wi = np.repeat(directions, strata, axis=0)
    u = np.tile((np.arange(strata) + 0.5) / strata, len(directions))
    samples = sample_many(bsdf, mi.BSDFContext(), wi, u, (0.37, 0.61))
    for d, direction in enumerate(directions):
        r, t, eta = spec_delta(direction, ior)
        tir = t is None
        expected = {0: 1 - kr - kt, 1: kr + (kt if tir else 0.0), 2: 0.0 if tir else kt}
        rows = slice(d * strata, (d + 1) * strata)
        component, wo, weight, pdf, bs_eta, kind = (a[rows] for a in samples)
        for c, p in expected.items():
            assert np.mean(component == c) == pytest.approx(p, abs=1.0 / strata + 1e-9)
        diffuse, mirror, refracted = (component == c for c in (0, 1, 2))
        np.testing.assert_allclose(weight[diffuse], np.broadcast_to(ALBEDO, weight[diffuse].shape),
                                   rtol=1e-5)
        assert np.all(wo[diffuse, 2] * direction[2] > 0)  # diffuse stays on wi's side
        np.testing.assert_allclose(weight[~diffuse], 1.0, rtol=1e-5)
        np.testing.assert_allclose(pdf[mirror], expected[1], rtol=1e-5)
        np.testing.assert_allclose(pdf[refracted], expected[2], rtol=1e-5)
        np.testing.assert_allclose(wo[mirror], np.broadcast_to(r, wo[mirror].shape), atol=2e-6)
        assert np.all(bs_eta[mirror] == 1.0)
        assert all(mi.has_flag(int(k), mi.BSDFFlags.DeltaReflection) for k in kind[mirror])
        if refracted.any():
            np.testing.assert_allclose(wo[refracted], np.broadcast_to(t, wo[refracted].shape),
                                       atol=2e-6)
            np.testing.assert_allclose(bs_eta[refracted], eta, rtol=1e-6)
            assert all(mi.has_flag(int(k), mi.BSDFFlags.DeltaTransmission)
                       for k in kind[refracted])


def test_total_internal_reflection_sends_kt_along_the_mirror(variant):
    """From inside a glass sphere beyond the critical angle, the refraction weight
    becomes mirror weight: KR + KT for the mirror, nothing refracted."""
    bsdf = mi.load_dict(article(0.2, 0.5, 1.5))
    wi = np.array([0.9, 0.0, -math.sqrt(1 - 0.81)])  # sin θ = 0.9 > 1/1.5
    _, t, _ = spec_delta(wi, 1.5)
    assert t is None
    si = one_interaction(wi)
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, 0.99, mi.Point2f(0.5, 0.5))
    assert int(as_np(bs.sampled_component).reshape(-1)[0]) == 1
    assert float(as_np(bs.pdf).reshape(-1)[0]) == pytest.approx(0.7)
    np.testing.assert_allclose(as_np(bs.wo).reshape(3), [-0.9, 0.0, wi[2]], atol=1e-6)
    # The refraction component alone has nothing left to give ...
    only_t = mi.BSDFContext(mi.TransportMode.Radiance, +mi.BSDFFlags.All, 2)
    _, weight_t = bsdf.sample(only_t, si, 0.5, mi.Point2f(0.5, 0.5))
    np.testing.assert_array_equal(as_np(weight_t).reshape(3), 0.0)
    # ... and the mirror component alone carries KR + KT.
    only_r = mi.BSDFContext(mi.TransportMode.Radiance, +mi.BSDFFlags.All, 1)
    _, weight_r = bsdf.sample(only_r, si, 0.5, mi.Point2f(0.5, 0.5))
    np.testing.assert_allclose(as_np(weight_r).reshape(3), 0.7, rtol=1e-6)


def test_component_and_type_mask_selection(variant):
    """Like Mitsuba's C++ BSDFs: a restricted context samples only what it enables,
    with the weight of that part of the material."""
    bsdf = mi.load_dict(article(0.3, 0.2, 1.5))
    wi = np.array([0.3, 0.1, 0.9486833])
    r, t, _ = spec_delta(wi, 1.5)
    si = one_interaction(wi)
    mode = mi.TransportMode.Radiance
    for u in (0.01, 0.5, 0.99):
        bs, w = bsdf.sample(mi.BSDFContext(mode, +mi.BSDFFlags.All, 1), si, u, mi.Point2f(0.5, 0.5))
        np.testing.assert_allclose(as_np(bs.wo).reshape(3), r, atol=2e-6)
        np.testing.assert_allclose(as_np(w).reshape(3), 0.3, rtol=1e-6)
        bs, w = bsdf.sample(mi.BSDFContext(mode, +mi.BSDFFlags.All, 2), si, u, mi.Point2f(0.5, 0.5))
        np.testing.assert_allclose(as_np(bs.wo).reshape(3), t, atol=2e-6)
        np.testing.assert_allclose(as_np(w).reshape(3), 0.2, rtol=1e-6)
        bs, w = bsdf.sample(mi.BSDFContext(mode, +mi.BSDFFlags.Diffuse, 0xFFFFFFFF), si, u,
                            mi.Point2f(0.5, 0.5))
        assert int(as_np(bs.sampled_component).reshape(-1)[0]) == 0
        np.testing.assert_allclose(as_np(w).reshape(3), np.multiply(ALBEDO, 0.5), rtol=1e-5)
        bs, w = bsdf.sample(mi.BSDFContext(mode, +mi.BSDFFlags.Delta, 0xFFFFFFFF), si, u,
                            mi.Point2f(0.5, 0.5))
        component = int(as_np(bs.sampled_component).reshape(-1)[0])
        assert component == (1 if u < 0.3 / 0.5 else 2)
        assert float(as_np(bs.pdf).reshape(-1)[0]) == pytest.approx(0.6 if component == 1 else 0.4)
        np.testing.assert_allclose(as_np(w).reshape(3), 0.5, rtol=1e-6)
    # eval and pdf describe the diffuse lobe: nothing when it is not enabled.
    wo = np.array([-0.2, 0.3, 0.9327379])
    for ctx in (mi.BSDFContext(mode, +mi.BSDFFlags.Delta, 0xFFFFFFFF),
                mi.BSDFContext(mode, +mi.BSDFFlags.All, 1)):
        wo_v = one_vector(wo)
        assert np.all(as_np(bsdf.eval(ctx, si, wo_v)) == 0)
        assert np.all(as_np(bsdf.pdf(ctx, si, wo_v)) == 0)


def test_flags_name_the_lobes_in_use(variant):
    def flags(kr, kt):
        return mi.load_dict(article(kr, kt, 1.5)).flags()

    assert mi.has_flag(flags(0, 0), mi.BSDFFlags.DiffuseReflection)
    assert not mi.has_flag(flags(0, 0), mi.BSDFFlags.Delta)
    assert not mi.has_flag(flags(1, 0), mi.BSDFFlags.Smooth)      # no light sampling on mirrors
    assert not mi.has_flag(flags(0, 1), mi.BSDFFlags.Smooth)
    assert mi.has_flag(flags(0, 1), mi.BSDFFlags.DeltaReflection)  # TIR
    for lobe in (mi.BSDFFlags.DiffuseReflection, mi.BSDFFlags.DeltaReflection,
                 mi.BSDFFlags.DeltaTransmission):
        assert mi.has_flag(flags(0.3, 0.2), lobe)
    bsdf = mi.load_dict(article(0.3, 0.2, 1.5))
    assert bsdf.component_count() == 3
    for i, lobe in enumerate((mi.BSDFFlags.DiffuseReflection, mi.BSDFFlags.DeltaReflection,
                              mi.BSDFFlags.DeltaTransmission)):
        assert mi.has_flag(bsdf.flags(i), lobe)
        assert mi.has_flag(bsdf.flags(i), mi.BSDFFlags.FrontSide)
        assert mi.has_flag(bsdf.flags(i), mi.BSDFFlags.BackSide)


# -- eval / pdf ----------------------------------------------------------------

@pytest.mark.parametrize("kr, kt, ior", [m for m in MATERIALS if m[0] + m[1] < 1])
def test_eval_and_pdf_agree_with_sampling(llvm, kr, kt, ior):
    """For diffuse samples: weight = eval/pdf, pdf = bs.pdf, eval_pdf = (eval, pdf);
    and eval is (1−KR−KT)·B/π·|cos θo| on wi's side, 0 on the other."""
    bsdf = mi.load_dict(article(kr, kt, ior))
    n = 4096
    wi = random_directions(n, seed=7)
    si = interaction(wi)
    rng = np.random.default_rng(8)
    u = rng.random((3, n))
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, mi.Float(u[0]), mi.Point2f(u[1], u[2]))
    diffuse = as_np(bs.sampled_component) == 0
    assert diffuse.mean() == pytest.approx(1 - kr - kt, abs=0.03)
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    value_e, pdf_p = bsdf.eval(ctx, si, bs.wo), bsdf.pdf(ctx, si, bs.wo)
    value, pdf, value_e, pdf_p = map(as_np, (value, pdf, value_e, pdf_p))
    np.testing.assert_allclose(value, value_e, rtol=1e-6)
    np.testing.assert_allclose(pdf, pdf_p, rtol=1e-6)
    wo = as_np(bs.wo)
    d = diffuse & (np.abs(wo[:, 2]) > 1e-3)
    np.testing.assert_allclose(pdf[d], as_np(bs.pdf)[d], rtol=1e-5)
    np.testing.assert_allclose(as_np(weight)[d], value[d] / pdf[d, None], rtol=1e-4)
    expected = (1 - kr - kt) * np.outer(np.abs(wo[:, 2]), ALBEDO) / math.pi
    np.testing.assert_allclose(value[d], expected[d], rtol=1e-5, atol=1e-7)
    # Mirrored to the other side of the surface, no diffuse sample has a value:
    # the lobe reflects only (on both sides).
    below = wo * np.array([1.0, 1.0, -1.0])
    v_below, p_below = bsdf.eval_pdf(ctx, si, mi.Vector3f(below[:, 0], below[:, 1], below[:, 2]))
    assert np.all(as_np(v_below)[diffuse] == 0) and np.all(as_np(p_below)[diffuse] == 0)


@pytest.mark.parametrize("kr, kt", [(0.0, 0.0), (0.3, 0.2), (0.1, 0.7)])
def test_diffuse_lobe_reflects_its_weighted_albedo_from_either_side(llvm, kr, kt):
    """∫ eval dω over the sphere = (1−KR−KT)·B, for wi outside and inside: the
    lobe is two-sided and energy-conserving (estimated with uniform directions)."""
    bsdf = mi.load_dict(article(kr, kt, 1.5))
    n = 200_000
    wo = random_directions(n, seed=3)
    for wi in ([0.2, -0.3, 0.9327379], [0.2, -0.3, -0.9327379]):
        si = interaction(np.tile(wi, (n, 1)))
        value = as_np(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])))
        integral = value.mean(axis=0) * 4 * math.pi
        np.testing.assert_allclose(integral, (1 - kr - kt) * np.array(ALBEDO), rtol=0.01)


# -- no NaN, whatever the weights and directions ------------------------------

@pytest.mark.parametrize("kr, kt, ior, color", [
    (0.0, 0.0, 1.0, (0, 0, 0)), (1.0, 0.0, 1.0, ALBEDO), (0.0, 1.0, 1.5, ALBEDO),
    (0.5, 0.5, 0.5, ALBEDO), (0.0, 0.0, 1.0, ALBEDO), (0.0, 0.3, 1.0, (1, 1, 1))])
def test_zero_weights_and_grazing_directions_give_no_nan(variant, kr, kt, ior, color):
    bsdf = mi.load_dict(article(kr, kt, ior, color))
    directions = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 0],
                  [0.6, 0, 0.8], [0.6, 0, -0.8]]
    contexts = [mi.BSDFContext(), mi.BSDFContext(mi.TransportMode.Importance),
                *(mi.BSDFContext(mi.TransportMode.Radiance, +mi.BSDFFlags.All, c) for c in range(3)),
                mi.BSDFContext(mi.TransportMode.Radiance, +mi.BSDFFlags.Glossy, 0xFFFFFFFF)]
    for wi in directions:
        si = one_interaction(wi)
        for wo in directions:
            wo_v = one_vector(wo)
            for ctx in contexts:
                for u in (0.0, 0.5, 0.999999):
                    bs, weight = bsdf.sample(ctx, si, u, mi.Point2f(u, 1 - u))
                    values = [weight, bs.wo, bs.pdf, bs.eta, *bsdf.eval_pdf(ctx, si, wo_v),
                              bsdf.eval(ctx, si, wo_v), bsdf.pdf(ctx, si, wo_v)]
                    for value in values:
                        assert np.all(np.isfinite(as_np(value))), (wi, wo, ctx, u, value)
                    assert np.all(as_np(weight) >= 0) and np.all(as_np(bs.pdf) >= 0)
                    # A diffuse sample carries weight only where eval has a value
                    # (e.g. not at grazing incidence, where wi has no side).
                    if int(as_np(bs.sampled_component).reshape(-1)[0]) == 0 and \
                            np.any(as_np(weight) > 0):
                        assert np.all(as_np(bsdf.eval(ctx, si, bs.wo)) > 0)


def test_parameters_reach_the_whitted_integrator(variant):
    """The Whitted integrator reads B, KR, KT and the IOR through these calls."""
    bsdf = mi.load_dict(article(0.3, 0.2, 1.5))
    si = one_interaction([0, 0, 1])
    np.testing.assert_allclose(as_np(bsdf.eval_diffuse_reflectance(si)).reshape(3), ALBEDO, rtol=1e-6)
    assert (bsdf.reflect, bsdf.refract, bsdf.ior) == (0.3, 0.2, 1.5)
    for name, value in (("reflect", 0.3), ("refract", 0.2), ("ior", 1.5)):
        assert float(as_np(bsdf.eval_attribute_1(name, si)).reshape(-1)[0]) == pytest.approx(value)
    assert "reflect = 0.3" in str(bsdf)
    assert any(key.startswith("color") for key in mi.traverse(bsdf).keys())
