"""Records as pure functions of explicit standard normals: ``stochastic(normals=...)``,
``synthesize(normals=...)``, ``draw_normals`` and the pulse's inverse-CDF map from normals
(``mavroeidis_papageorgiou_2003.parameters_from_normals``), against today's seeded records and today's
Latin-hypercube map (``cf_pulse_sample_map``).

Where the expected numbers come from: the SHA-256 digests below are of records made by main at
7e7e46a (before records could be made from normals) with ``stochastic(Mw, R, seed)`` and
``synthesize(6.25, 10, 123, pulse=row)``; the records are bitwise the same on every CPU (the library's
own math functions and FFT, ``-ffp-contract=off``), so the digests are exact references.
"""
import hashlib

import numpy as np
import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.ground_motion import draw_normals, normals_layout, sample_pulse_parameters, stochastic, synthesize
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp
from pycolfrag.ground_motion import rupakhety_2011 as r11

TODAY = {  # (Mw, R km, seed) -> sha256 of stochastic(Mw, R, seed).acc at main 7e7e46a
    (6.5, 10.0, 1): "4d4fa887faabcc2e5a74b926c04633e563995c7eb6199c815543c3e7a56e3a24",
    (5.5, 20.0, 2**40 + 7): "a28f24e49cb47249148b2931ab0e0e16e10098a04a3c91824bc7dedb62b0505e",
    (7.5, 5.0, 0): "81d031faf2513620743237ba0b04db20d6403b7cad42df62516b691f2121a94f",
}
#: synthesize(6.25, 10.0, 123, pulse=row 1 of sample_pulse_parameters(6.25, 10.0, 3, 11)) at main 7e7e46a.
TODAY_SYNTH = "bd674c92097d3a2fc24f239656ec0e5010a67b95559065aa5f6f9aaeb351db49"


def _sha(a):
    return hashlib.sha256(np.ascontiguousarray(a, dtype="<f8").tobytes()).hexdigest()


# ------------------------------------------------------------- today's records from their normals
@pytest.mark.parametrize("key", sorted(TODAY))
def test_stochastic_from_drawn_normals_is_todays_record(key):
    mw, r, seed = key
    z = draw_normals(mw, r, seed)
    assert z.shape == (normals_layout(mw, r, shape="none").noise,)
    from_normals = stochastic(mw, r, normals=z)
    assert _sha(stochastic(mw, r, seed).acc) == TODAY[key]       # the seeded path is unchanged
    assert _sha(from_normals.acc) == TODAY[key]                  # and the normals give the same bits
    assert from_normals.meta["seed"] is None


def test_synthesize_with_a_pulse_row_and_drawn_normals_is_todays_record():
    lhs = sample_pulse_parameters(6.25, 10.0, 3, 11)
    row = {k: float(v[1]) for k, v in lhs.items()}
    assert _sha(synthesize(6.25, 10.0, 123, pulse=row).acc) == TODAY_SYNTH
    rec = synthesize(6.25, 10.0, pulse=row, normals=draw_normals(6.25, 10.0, 123))
    assert _sha(rec.acc) == TODAY_SYNTH and rec.meta["pulse_seeded_from"] == "argument"


def test_draw_normals_are_the_generators_stream():
    """The normals of a seed are cf_rng_normal's after cf_rng_seed (xoshiro256**, polar method), in
    order: the stream tests/c/test_rng.c checks against the reference generator."""
    n = normals_layout(6.0, 10.0).noise
    rng = ffi.new("cf_rng *")
    lib.cf_rng_seed(rng, 99)
    expected = np.array([lib.cf_rng_normal(rng) for _ in range(n)])
    assert np.array_equal(draw_normals(6.0, 10.0, 99), expected)


# ------------------------------------------------------------- the whole record from normals
def test_synthesize_from_normals_uses_both_parts():
    lay = normals_layout(6.25, 10.0)
    assert lay.pulse == len(mp.NORMALS) == 4 and lay.size == lay.pulse + lay.noise
    z = np.random.default_rng(5).standard_normal(lay.size)
    rec = synthesize(6.25, 10.0, normals=z)
    pulse = mp.parameters_from_normals(6.25, 10.0, z[:4])
    assert {k: rec.meta[k] for k in pulse} == pulse and rec.meta["pulse_seeded_from"] == "normals"
    hf = stochastic(6.25, 10.0, normals=z[4:]).acc
    n_pre = int(round(rec.meta["pad_before_s"] / rec.dt))
    assert np.array_equal(rec.components["hf"][n_pre:n_pre + hf.size], rec.meta["hf_polarity"] * hf)
    again = synthesize(6.25, 10.0, normals=z.tolist())
    assert np.array_equal(again.acc, rec.acc)
    # the pulse part moves the pulse only: another z_vp, the same noise
    z2 = z.copy()
    z2[0] += 1.0
    other = synthesize(6.25, 10.0, normals=z2)
    assert other.meta["Vp_cm_s"] == pytest.approx(pulse["Vp_cm_s"] * 10 ** r11.SIGMA_LOG10_VP, rel=1e-12)
    assert other.meta["fp_hz"] == pulse["fp_hz"]


@pytest.mark.parametrize("kwargs, words", [
    ({"seed": 1, "normals": "full"}, "exactly one of seed and normals"),
    ({}, "exactly one of seed and normals"),
    ({"normals": "short"}, "then 2470 white-noise normals"),
    ({"normals": "full", "pulse": "row"}, "the pulse row is given, so only the 2470"),
    ({"normals": "nan"}, "non-finite value nan at index (7,)"),
])
def test_synthesize_refuses_bad_normals(kwargs, words):
    lay = normals_layout(6.5, 10.0)
    assert lay.noise == 2470
    z = np.zeros(lay.size)
    values = {"full": z, "short": z[:-1], "nan": np.where(np.arange(lay.size) == 7, np.nan, z), "row": {
        "Vp_cm_s": 50.0, "fp_hz": 1.0, "nu_rad": 0.0, "gamma": 1.8}}
    args = {k: values.get(v, v) if isinstance(v, str) else v for k, v in kwargs.items()}
    with pytest.raises(ParameterError, match=words.replace("(", r"\(").replace(")", r"\)")):
        synthesize(6.5, 10.0, **args)


def test_stochastic_refuses_bad_normals():
    n = normals_layout(6.5, 10.0, shape="none").noise
    with pytest.raises(ParameterError, match="n_normals = 2470"):
        stochastic(6.5, 10.0, normals=np.ones(n + 1))
    with pytest.raises(ParameterError, match="exactly one"):
        stochastic(6.5, 10.0, 3, normals=np.ones(n))
    with pytest.raises(ParameterError, match="2-D|1-D"):
        stochastic(6.5, 10.0, normals=np.ones((2, n)))
    with pytest.raises(Exception, match="zero noise spectrum"):       # C: CF_EUNSTABLE, its message
        as00.simulate(6.5, 10.0, normals=np.zeros(n))
    with pytest.raises(ParameterError, match="unknown pulse shape"):
        normals_layout(6.5, 10.0, shape="ricker")


# ------------------------------------------------------------- the pulse from its normals
def _lhs_map(mw, r, u):
    """cf_pulse_sample_map at the uniforms u (n x 4): today's Latin-hypercube map."""
    d = mp._distribution(lib.cf_math_log10(r11.mean_vp_cm_s(mw, r)), r11.log10_fp_mean(mw), r11.SIGMA_LOG10_FP)
    u = np.ascontiguousarray(u, dtype=np.float64)
    out = [np.empty(len(u)) for _ in range(4)]
    p = lambda a: ffi.cast("double *", a.ctypes.data)                   # noqa: E731
    assert lib.cf_pulse_sample_map(d, p(u), len(u), *(p(a) for a in out)) == 0
    return out


def _uniforms():
    """2 000 uniforms per column: random ones and the extremes of doubles in (0, 1)."""
    u = np.random.default_rng(3).random((2000, 4))
    u[:8] = [[1e-300] * 4, [1e-17] * 4, [2**-53] * 4, [0.5] * 4, [0.5 + 2**-53] * 4, [1 - 2**-53] * 4,
             [1 - 1e-12] * 4, [0.25] * 4]
    return u


def test_pulse_from_normals_against_todays_map_at_the_same_uniforms():
    """z = ndtri(u): Vp and fp bitwise (both are 10^(mean + sd ndtri(u)) through the same functions);
    nu and gamma to rounding, because Phi(ndtri(u)) equals u only to a few ulp: |d nu| <= pi |du|
    <= pi * 4 * 2^-53 = 1.4e-15 absolute; gamma's derivative in u is bounded on (0, 1) except in its
    upper tail, where both maps work with 1 - u exactly (relative 1e-14 allows 45 ulp)."""
    mw, r = 6.5, 10.0
    u = _uniforms()
    vp, fp, nu, gamma = _lhs_map(mw, r, u)
    for i in range(len(u)):
        q = mp.parameters_from_normals(mw, r, [lib.cf_math_ndtri(x) for x in u[i]])
        assert q["Vp_cm_s"] == vp[i] and q["fp_hz"] == fp[i], (i, u[i])
        assert abs(q["nu_rad"] - nu[i]) <= 1.4e-15, (i, u[i])
        assert q["gamma"] == pytest.approx(gamma[i], rel=1e-14, abs=0), (i, u[i])


def test_pulse_from_normals_against_todays_map_at_the_same_normals():
    """u = Phi(z): nu bitwise (the same -pi/2 + pi u), gamma bitwise below the truncated median (the same
    ndtri(Phi(a) + u (1 - Phi(a)))). Above it this map uses Phi(-z) where today's map has 1 - u, the
    same number in exact arithmetic; but u = Phi(z) is rounded to a double (error <= 2^-53 near 1), so
    today's gamma is off by up to 0.4 (1 - Phi(a)) 2^-53 / phi(t) (t its standard quantile), which the
    test allows twice over; this map's own gamma is checked by its round trip: the truncated normal's
    survival function at gamma, Phi(-t) / (1 - Phi(a)), returns Phi(-z) to 1e-12 (condition number
    about t^2 of Phi's upper tail times a few ulp)."""
    mw, r = 6.0, 15.0
    z = np.random.default_rng(8).standard_normal((2000, 4)) * 1.5
    z[:4, 3] = [4.1, 6.0, 8.0, -8.0]
    u = np.array([[lib.cf_math_norm_cdf(x) for x in row] for row in z])
    _, _, nu, gamma = _lhs_map(mw, r, u)
    a = (mp.GAMMA_MIN - mp.GAMMA_MEAN) / mp.GAMMA_SD
    q_a = lib.cf_math_norm_cdf(-a)
    median = (0.5 - lib.cf_math_norm_cdf(a)) / q_a
    lower = 0
    for i in range(len(z)):
        q = mp.parameters_from_normals(mw, r, z[i])
        assert q["nu_rad"] == nu[i]
        if u[i, 3] < median:
            lower += 1
            assert q["gamma"] == gamma[i], (i, z[i])
            continue
        t = (q["gamma"] - mp.GAMMA_MEAN) / mp.GAMMA_SD
        assert lib.cf_math_norm_cdf(-t) / q_a == pytest.approx(lib.cf_math_norm_cdf(-z[i, 3]), rel=1e-12)
        phi_t = np.exp(-0.5 * t * t) / np.sqrt(2 * np.pi)
        assert abs(q["gamma"] - gamma[i]) <= 2 * 0.4 * q_a * 2.0**-53 / phi_t + 4e-16 * q["gamma"], (i, z[i])
    assert 500 < lower < 1500


def test_pulse_from_normals_tails_and_truncation():
    """The declared ranges hold for any normals: nu in [-pi/2, pi/2] (its ends at z = -/+40, where Phi is
    0 and 1 in doubles), gamma >= 1 (1 at the far lower tail: the truncation) and finite far in
    the upper tail (z = 8: the truncated normal's quantile at Phi(-8) (1 - Phi(a)) of the upper tail,
    which Phi(-z) keeps; 1 - Phi(8) would be 6e-16 and lose it). z_vp and z_fp move log10 Vp and
    log10 fp by 0.16 and 0.18 per unit (the scatter of Eqs. 6-7)."""
    lo = mp.parameters_from_normals(6.5, 10.0, [0, 0, -40, -40])
    hi = mp.parameters_from_normals(6.5, 10.0, [0, 0, 40, 8])
    assert lo["nu_rad"] == -np.pi / 2 and hi["nu_rad"] == np.pi / 2
    assert mp.GAMMA_MIN <= lo["gamma"] <= mp.GAMMA_MIN + 1e-15      # ndtri(Phi(a)) = a to rounding
    t = -lib.cf_math_ndtri(lib.cf_math_norm_cdf(-8.0) * lib.cf_math_norm_cdf(2.0))
    assert hi["gamma"] == pytest.approx(1.8 + 0.4 * t, rel=1e-15) and 4.9 < hi["gamma"] < 5.2
    base = mp.parameters_from_normals(6.5, 10.0, [0, 0, 0, 0])
    assert base["Vp_cm_s"] == pytest.approx(r11.mean_vp_cm_s(6.5, 10.0), rel=1e-15)
    assert base["fp_hz"] == pytest.approx(r11.mean_fp_hz(6.5), rel=1e-15)
    up = mp.parameters_from_normals(6.5, 10.0, [1, -1, 0, 0])
    assert np.log10(up["Vp_cm_s"] / base["Vp_cm_s"]) == pytest.approx(0.16, rel=1e-12)
    assert np.log10(base["fp_hz"] / up["fp_hz"]) == pytest.approx(0.18, rel=1e-12)
    with pytest.raises(ParameterError, match="pulse normals has 3 values"):
        mp.parameters_from_normals(6.5, 10.0, [0, 0, 0])
