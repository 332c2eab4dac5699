"""MP03 pulse (Eq. 5, closed forms from csrc/pulse.c), Rupakhety et al. Eqs. (6)-(7) and the
Latin-hypercube sampling of the pulse parameters. Expected numbers: hand calculations of the
printed equations, the distributions the paper states, and numerical derivatives/integrals."""
import math

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import trapezoid

from pycolfrag.core.errors import ModelRangeError, ParameterError
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp
from pycolfrag.ground_motion import rupakhety_2011 as r11
from pycolfrag.ground_motion import sample_pulse_parameters

N = 100          # the paper's samples per scenario
SEED = 2016


@pytest.fixture(scope="module")
def lhs():
    return sample_pulse_parameters(7.0, 5.0, N, SEED)   # the paper's Fig. 4 scenario


# ---------------------------------------------------------------- Eqs. (6) and (7)
@pytest.mark.parametrize("mw, r, log_vp", [
    # -5.17 + 1.98*6.5 - 0.14*6.5^2 - 0.10*log10(10^2 + 0.562)
    #   = -5.17 + 12.87 - 5.915 - 0.10*2.0024343 = 1.5847566
    (6.5, 10.0, 1.5847566),
    # -5.17 + 10.89 - 4.235 - 0.10*log10(25.562) (= 0.10*1.4075955) = 1.3442405
    (5.5, 5.0, 1.3442405),
    # -5.17 + 13.86 - 6.86 - 0.10*log10(400.562) (= 0.10*2.6026697) = 1.5697330
    (7.0, 20.0, 1.5697330),
    # Mw 7.5 > Msat = 7.0: Eq. (6) uses 7.0, so the same as the line above
    (7.5, 20.0, 1.5697330),
])
def test_eq6_mean_vp(mw, r, log_vp):
    assert math.log10(r11.mean_vp_cm_s(mw, r)) == pytest.approx(log_vp, abs=1e-7)


def test_eq6_saturation_and_scale():
    assert r11.mean_vp_cm_s(7.5, 5.0) == r11.mean_vp_cm_s(7.0, 5.0)
    assert r11.mean_vp_cm_s(7.0, 5.0) != r11.mean_vp_cm_s(6.9, 5.0)
    assert r11.mean_vp_cm_s(6.0, 8.0, vp_scale=1.5) == pytest.approx(1.5 * r11.mean_vp_cm_s(6.0, 8.0), rel=1e-15)


@pytest.mark.parametrize("mw, tp", [
    (5.5, 10 ** -0.285),    # -2.87 + 0.47*5.5 = -0.285 -> Tp = 0.5188 s
    (6.5, 10 ** 0.185),     # -2.87 + 3.055   =  0.185 -> 1.5311 s
    (7.5, 10 ** 0.655),     # no cap in Eq. (7)       -> 4.5186 s
])
def test_eq7_mean_fp(mw, tp):
    assert r11.mean_tp_s(mw) == pytest.approx(tp, rel=1e-12)
    assert r11.mean_fp_hz(mw) == pytest.approx(1 / tp, rel=1e-12)


# ---------------------------------------------------------------- closed forms
PULSES = [(0.5, 0.4, 0.3, 1.8), (1.0, 1.2, -1.4, 1.05), (0.3, 0.25, 1.5, 3.0), (2.0, 0.7, 0.0, 1.0)]


@pytest.mark.parametrize("A, fp, nu, gamma", PULSES)
def test_acceleration_is_derivative_of_velocity(A, fp, nu, gamma):
    # np.gradient (2nd-order central differences, h = 1e-4 s): error h^2/6 |V'''| <= h^2/6 A k^3
    # with k = 2 pi fp (1 + 1/gamma) <= 15 rad/s here, i.e. <= 4e-7 of scale = A k; tolerance 1e-6 scale.
    t0 = 3.0
    ts, te = mp.support(fp, gamma, t0)
    t = np.arange(ts + 1e-3, te - 1e-3, 1e-4)
    v, a, d = mp.pulse(t, A, fp, nu, gamma, t0)
    scale = A * 2 * np.pi * fp * (1 + 1 / gamma)
    np.testing.assert_allclose(a[1:-1], np.gradient(v, t)[1:-1], rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(v[1:-1], np.gradient(d, t)[1:-1], rtol=0, atol=1e-6 * A)


@pytest.mark.parametrize("A, fp, nu, gamma", PULSES)
def test_displacement_is_integral_and_constant_after(A, fp, nu, gamma):
    # trapezoid of V over the support with 2e5 intervals: error ~ L^3/(12 n^2) |V''| < 1e-9
    ts, te = mp.support(fp, gamma, 0.0)
    t = np.linspace(ts, te, 200001)
    residual = trapezoid(mp.velocity(t, A, fp, nu, gamma), t)
    after = mp.displacement(np.array([te + 0.01, te + 100.0]), A, fp, nu, gamma)
    assert after[0] == pytest.approx(residual, abs=1e-8 * A / fp)
    assert after[1] == after[0]
    before = mp.pulse(np.array([ts - 1.0, ts - 1e-6]), A, fp, nu, gamma)
    assert np.all(before[0] == 0) and np.all(before[1] == 0) and np.all(before[2] == 0)


# ---------------------------------------------------------------- sampling
def test_peak_velocity_equals_sampled_vp(lhs):
    # The defining property of A (the paper's Eq. 5): max_t |V| = Vp. Checked on a grid of 1e-4 in fp*tau:
    # a sampled peak is low by at most (2 pi)^2 (0.5e-4)^2 / 2 ~ 5e-8 relative; tolerance 1e-6.
    for i in range(N):
        vp, fp, nu, g, A = (lhs[k][i] for k in ("Vp_cm_s", "fp_hz", "nu_rad", "gamma", "A_cm_s"))
        u = np.arange(-g / 2, g / 2, 1e-4)
        v = mp.velocity(u / fp, A, fp, nu, g, 0.0)
        assert np.abs(v).max() == pytest.approx(vp, rel=1e-6)
        assert A >= vp * (1 - 1e-12)             # |V| <= A everywhere, so A >= Vp
        tpk = mp.peak_velocity_time(fp, nu, g, 0.0)
        assert abs(tpk - u[np.argmax(np.abs(v))] / fp) <= 2e-4 / fp   # within two grid steps
    assert np.array_equal(lhs["Tp_s"], 1 / lhs["fp_hz"])


def _cdfs(lhs, mw=7.0, r=5.0):
    lv, lf = math.log10(r11.mean_vp_cm_s(mw, r)), math.log10(r11.mean_fp_hz(mw))
    a = (1.0 - 1.8) / 0.4
    return [
        (np.log10(lhs["Vp_cm_s"]), stats.norm(lv, 0.16).cdf),          # paper: sigma log10 Vp 0.16
        (np.log10(lhs["fp_hz"]), stats.norm(lf, 0.18).cdf),            # sigma log10 fp 0.18
        (lhs["nu_rad"], stats.uniform(-np.pi / 2, np.pi).cdf),          # nu ~ U[-pi/2, pi/2]
        (lhs["gamma"], stats.truncnorm(a, np.inf, loc=1.8, scale=0.4).cdf),  # N(1.8, 0.4) >= 1
    ]


def test_marginals_ks(lhs):
    # KS against the stated distributions, n = 100. An LHS is more even than i.i.d. sampling, so
    # the p-values sit near 1; 0.05 is the usual level. (Measured p-values: see docs/ground_motion.md.)
    for x, cdf in _cdfs(lhs):
        assert stats.kstest(x, cdf).pvalue > 0.05
    assert lhs["gamma"].min() >= 1.0
    assert np.all(np.abs(lhs["nu_rad"]) <= np.pi / 2)


def test_each_stratum_holds_one_sample(lhs):
    # mapped back through its CDF, each dimension occupies each of the N strata [k/N, (k+1)/N)
    # exactly once (the Latin-hypercube property). 1e-9 guards the round trip through the CDFs.
    for x, cdf in _cdfs(lhs):
        k = np.floor(np.clip(cdf(x), 0, 1 - 1e-12) * N + 1e-9).astype(int)
        assert sorted(k) == list(range(N))


def test_sampling_is_reproducible(lhs):
    again = sample_pulse_parameters(7.0, 5.0, N, SEED)
    for key in ("Vp_cm_s", "fp_hz", "nu_rad", "gamma", "A_cm_s", "Tp_s"):
        assert again[key].shape == (N,)
        assert np.array_equal(again[key], lhs[key])
    other = sample_pulse_parameters(7.0, 5.0, N, SEED + 1)
    assert not np.array_equal(other["Vp_cm_s"], lhs["Vp_cm_s"])
    big = sample_pulse_parameters(7.0, 5.0, N, np.uint32(2**32 - 1))   # 32-bit seeds from SeedSequence
    assert big["gamma"].shape == (N,)


def test_vp_scale_shifts_the_median():
    a = sample_pulse_parameters(6.0, 10.0, 50, 3)
    b = sample_pulse_parameters(6.0, 10.0, 50, 3, vp_scale=2.0)
    np.testing.assert_allclose(b["Vp_cm_s"], 2 * a["Vp_cm_s"], rtol=1e-13)
    np.testing.assert_array_equal(b["fp_hz"], a["fp_hz"])


@pytest.mark.parametrize("kwargs, exc, word", [
    ({"Mw": 9.0}, ModelRangeError, "9.0"),
    ({"Mw": float("nan")}, ParameterError, "nan"),
    ({"dist_km": -1.0}, ModelRangeError, "-1.0"),
    ({"dist_km": "far"}, ParameterError, "'far'"),
    ({"n": 0}, ParameterError, "0"),
    ({"n": 2.5}, ParameterError, "2.5"),
    ({"seed": -3}, ParameterError, "-3"),
    ({"seed": 1.5}, ParameterError, "1.5"),
    ({"vp_scale": 0.0}, ParameterError, "0.0"),
    # a bool is not a magnitude (float(True) would be 1.0; the package-wide rule of _validate)
    ({"vp_scale": True}, ParameterError, "True"),
    ({"dist_km": True}, ParameterError, "True"),
])
def test_bad_input(kwargs, exc, word):
    args = {"Mw": 6.5, "dist_km": 10.0, "n": 10, "seed": 1, "vp_scale": 1.0}
    args.update(kwargs)
    with pytest.raises(exc) as ei:
        sample_pulse_parameters(args["Mw"], args["dist_km"], args["n"], args["seed"], vp_scale=args["vp_scale"])
    assert word in str(ei.value)


def test_pulse_bad_parameters():
    with pytest.raises(ParameterError, match="fp"):
        mp.velocity([0.0], 1.0, 0.0, 0.0, 1.5)
    with pytest.raises(ParameterError, match="gamma"):
        mp.acceleration([0.0], 1.0, 1.0, 0.0, -1.0)
    with pytest.raises(ParameterError, match="t"):
        mp.velocity([np.nan], 1.0, 1.0, 0.0, 1.5)
    with pytest.raises(ParameterError, match="nu"):
        mp.velocity([0.0], 1.0, 1.0, False, 1.5)


# ---------------------------------------------------------------- alternative pulse period (Baker 2007)
def test_baker_2007_median_period_by_hand():
    """Baker (2007): ln Tp = -6.45 + 1.11 Mw. Mw 7: exp(1.32) = 3.7434 s; Mw 6: exp(0.21) = 1.2337 s
    (hand values; 1e-12 relative: the library's pow and a literal ln 10 agree to a few ulp)."""
    from pycolfrag.ground_motion import baker_2007 as b07
    assert b07.mean_tp_s(7.0) == pytest.approx(math.exp(1.32), rel=1e-12)
    assert b07.mean_tp_s(6.0) == pytest.approx(math.exp(0.21), rel=1e-12)
    assert b07.SIGMA_LOG10_FP == pytest.approx(0.56 / math.log(10), rel=1e-15)
    with pytest.raises(ModelRangeError, match="9.5"):
        b07.mean_tp_s(9.5)


def test_baker_2007_sampling_pairs_with_the_default_and_has_its_moments():
    """Same seed, other Tp model: Vp, nu, gamma unchanged bit for bit and the standardised log fp the
    same (one uniform column of the LHS for both relations), so grids with the two models pair row by
    row; the sample of ln Tp has Baker's mean and spread. With n = 2000 LHS points the stratified
    sample mean of ln Tp is within 1e-3 of -6.45 + 1.11 Mw (its error is far below the i.i.d.
    0.56/sqrt(2000) = 0.0125) and the standard deviation within 1 % of 0.56."""
    mw, n, seed = 6.5, 2000, 7
    a = sample_pulse_parameters(mw, 10.0, n, seed)
    b = sample_pulse_parameters(mw, 10.0, n, seed, tp_model="baker_2007")
    for k in ("Vp_cm_s", "nu_rad", "gamma"):
        np.testing.assert_array_equal(a[k], b[k])
    za = (np.log10(a["fp_hz"]) - r11.log10_fp_mean(mw)) / r11.SIGMA_LOG10_FP
    from pycolfrag.ground_motion import baker_2007 as b07
    zb = (np.log10(b["fp_hz"]) - b07.log10_fp_mean(mw)) / b07.SIGMA_LOG10_FP
    np.testing.assert_allclose(za, zb, atol=1e-9)
    ln_tp = np.log(b["Tp_s"])
    assert ln_tp.mean() == pytest.approx(-6.45 + 1.11 * mw, abs=1e-3)
    assert ln_tp.std(ddof=1) == pytest.approx(0.56, rel=0.01)
    with pytest.raises(ParameterError, match="'bogus'"):
        sample_pulse_parameters(mw, 10.0, 5, seed, tp_model="bogus")


# ---------------------------------------------------------------- the pulse-shape registry
def test_pulse_shapes_are_the_registry_and_the_grid_choices():
    """PULSE_SHAPES holds every model of kind "pulse" by its SHAPE (each meets the interface of
    pulse_shape); the grid's --pulse offers them and "none" (the stochastic record alone), and nothing
    else."""
    from pycolfrag import grid
    from pycolfrag.ground_motion import pulse_shape, registry
    pulses = [m for m in registry.MODELS.values() if m.KIND == "pulse"]
    assert list(registry.PULSE_SHAPES.values()) == pulses and registry.NO_PULSE not in registry.PULSE_SHAPES
    for name, m in registry.PULSE_SHAPES.items():
        assert m.SHAPE == name and pulse_shape.missing(m) == [] and set(m.INPUTS) <= set(m.PARAMETERS)
    assert registry.PULSE_SHAPES[registry.DEFAULT_PULSE_SHAPE] is mp
    assert tuple(grid.PULSES) == (*registry.PULSE_SHAPES, "none")
    action = next(a for a in grid.build_parser()._actions if "--pulse" in a.option_strings)
    assert tuple(action.choices) == tuple(grid.PULSES)
    with pytest.raises(ParameterError, match="unknown pulse shape 'x'"):
        registry.pulse_shape_of("x")
    with pytest.raises(ParameterError, match="unknown pulse shape 'none'"):
        sample_pulse_parameters(7.0, 5.0, 3, SEED, shape="none")


def test_the_registry_refuses_a_shape_that_breaks_the_interface():
    """A pulse shape lacking part of the interface, named "none" or like another, or declaring a row
    field another shape declares with another meaning, stops the registry at import (ImportError
    naming it), instead of failing later in a grid."""
    from types import SimpleNamespace

    from pycolfrag.core.names import Parameter
    from pycolfrag.ground_motion import registry

    def shape(name, params=mp.PARAMETERS, **kw):
        return SimpleNamespace(**{"NAME": f"toy_{name}", "KIND": "pulse", "SHAPE": name, "PARAMETERS": params,
                                  "INPUTS": params[:1], "NORMALS": mp.NORMALS, "sample_parameters": mp.sample_parameters,
                                  "parameters_from_normals": mp.parameters_from_normals, "prepare": mp.prepare, **kw})
    assert list(registry._pulse_shapes([mp, shape("toy")])) == ["mp03", "toy"]
    bare = shape("bare")
    del bare.prepare
    for bad, word in ((bare, "lacks prepare"), (shape("none"), "no-pulse"), (shape("mp03"), "another shape")):
        with pytest.raises(ImportError, match=word):
            registry._pulse_shapes([mp, bad])
    # sharing a row field: allowed with the same meaning, refused with another unit
    same = (mp.PARAMETERS[0],)
    other = (Parameter("Vp", "m/s", (0.0, math.inf), "pulse amplitude Vp", "Vp_cm_s", "vp_cm_s"),)
    assert registry._pulse_fields([mp, shape("a", same)]) == registry._pulse_fields([mp])
    with pytest.raises(ImportError, match="vp_cm_s"):
        registry._pulse_fields([mp, shape("b", other)])


@pytest.mark.parametrize("name", list(__import__("pycolfrag.ground_motion.registry",
                                                 fromlist=["PULSE_SHAPES"]).PULSE_SHAPES))
def test_every_shape_keeps_its_promises(name):
    """For every shape of the registry, its prepared pulse against its own acceleration (integrated
    here by the trapezoid rule on a 1 ms grid, an independent check of the shape's closed forms): zero
    outside the declared support, the velocity's peak |V| at t0 + peak_offset_s (to 2 ms) with the
    sign peak_sign; its meta holds every PARAMETERS value in order; synthesize(shape=name) places it on
    a record whose meta names the shape and carries the declared keys."""
    from scipy.integrate import cumulative_trapezoid

    from pycolfrag.ground_motion import registry, synthesize
    shape = registry.pulse_shape_of(name)
    rows = shape.sample_parameters(6.5, 10.0, 4, SEED, 1.0, registry.tp_model_of(registry.DEFAULT_TP_MODEL))
    for i in range(4):
        p = shape.prepare(*(rows[q.meta_key][i] for q in shape.INPUTS))
        t0, dt = 10.0, 1e-3
        t = np.arange(0.0, t0 + p.after_s + 5.0, dt)
        acc = p.acceleration(t, t0)
        outside = (t < t0 - p.before_s - 1e-9) | (t > t0 + p.after_s + 1e-9)
        assert np.all(acc[outside] == 0.0) and np.any(acc[~outside] != 0.0)
        vel = cumulative_trapezoid(acc, t, initial=0.0)
        k = int(np.argmax(np.abs(vel)))
        assert abs(t[k] - (t0 + p.peak_offset_s)) <= 2e-3 and np.sign(vel[k]) == p.peak_sign
        values = p.meta(t0, acc)
        assert len(values) == len(shape.PARAMETERS) and all(np.isfinite(values))
    rec = synthesize(6.5, 10.0, 3, shape=name)
    assert rec.meta["pulse_shape"] == name
    assert all(q.meta_key in rec.meta for q in shape.PARAMETERS)
    # from standard normals: the median quantiles give the inputs, each within its declared range
    med = shape.parameters_from_normals(6.5, 10.0, np.zeros(len(shape.NORMALS)))
    assert list(med) == [q.meta_key for q in shape.INPUTS]
    assert all(q.check(med[q.meta_key], q.meta_key) == med[q.meta_key] for q in shape.INPUTS)
    with pytest.raises(ParameterError, match="unknown pulse shape"):
        synthesize(6.5, 10.0, 3, shape="no_such_shape")
