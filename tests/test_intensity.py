"""Intensity measures (pycolfrag.ground_motion.intensity, csrc/spectra.c) against an independent NumPy twin
and against closed forms. Each expected number's source is stated next to it."""

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid
from scipy.linalg import expm

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import intensity as im

G = 9.81  # m/s^2, the package's g (pycolfrag.solver.run default, intensity.G)


def twin_sdof(acc, dt, period, zeta):
    """Independent twin: exact zero-order-hold-free stepping of the SDOF driven by a
    piecewise-linear a_g, from the matrix exponential of the augmented system
    z = (x, x', a_g, da_g/dt), dz/dt = M z (a different derivation from Nigam-Jennings'
    closed-form coefficients). Returns max |x|, max |x'|, max |x'' + a_g|."""
    w = 2 * np.pi / period
    M = np.zeros((4, 4))
    M[0, 1] = 1.0
    M[1, 0], M[1, 1], M[1, 2] = -w * w, -2 * zeta * w, -1.0
    M[2, 3] = 1.0
    P = expm(M * dt)
    x = np.zeros(2)
    xs, vs = [0.0], [0.0]
    for i in range(1, len(acc)):
        slope = (acc[i] - acc[i - 1]) / dt
        x = P[:2, :2] @ x + P[:2, 2] * acc[i - 1] + P[:2, 3] * slope
        xs.append(x[0])
        vs.append(x[1])
    xs, vs = np.array(xs), np.array(vs)
    return np.abs(xs).max(), np.abs(vs).max(), np.abs(2 * zeta * w * vs + w * w * xs).max()


def test_spectra_match_matrix_exponential_twin():
    # random record (white noise, 1500 samples): both methods are exact for piecewise-linear
    # input, so they agree to rounding; 1e-6 relative leaves room for the b-coefficient
    # cancellation of Nigam-Jennings at long periods (w dt ~ 1e-3 here).
    rng = np.random.default_rng(7)
    acc = rng.normal(scale=2.0, size=1500)
    dt = 0.01
    periods = np.array([0.015, 0.2, 0.5, 1.0, 3.0, 8.0])
    for zeta in (0.0, 0.05, 0.3):
        r = im.response_spectrum(acc, dt, periods, zeta)
        for j, T in enumerate(periods):
            sd, sv, sa = twin_sdof(acc, dt, T, zeta)
            assert r["sd_m"][j] == pytest.approx(sd, rel=1e-6)
            assert r["sv_m_s"][j] == pytest.approx(sv, rel=1e-6)
            assert r["sa_abs_m_s2"][j] == pytest.approx(sa, rel=1e-6)
            w = 2 * np.pi / T
            assert r["psa_m_s2"][j] == pytest.approx(w * w * sd, rel=1e-6)


def test_peaks_match_numpy_twin():
    # trapezoidal integrals (scipy cumulative_trapezoid) and Husid times by np.interp:
    # the same definitions computed independently; agreement to rounding (1e-10).
    rng = np.random.default_rng(3)
    acc = rng.normal(size=4000) * np.hanning(4000)
    dt = 0.005
    v = cumulative_trapezoid(acc, dx=dt, initial=0.0)
    d = cumulative_trapezoid(v, dx=dt, initial=0.0)
    husid = cumulative_trapezoid(acc ** 2, dx=dt, initial=0.0)
    t = np.arange(acc.size) * dt
    t5, t95 = np.interp([0.05 * husid[-1], 0.95 * husid[-1]], husid, t)
    r = im.measures(acc, dt)
    assert r["pga_g"] == pytest.approx(np.abs(acc).max() / G, rel=1e-14)
    assert r["pgv_cm_s"] == pytest.approx(100 * np.abs(v).max(), rel=1e-10)
    assert r["pgd_cm"] == pytest.approx(100 * np.abs(d).max(), rel=1e-10)
    assert r["arias_m_s"] == pytest.approx(np.pi / (2 * G) * husid[-1], rel=1e-10)
    assert r["d5_95_s"] == pytest.approx(t95 - t5, rel=1e-10)
    vel, disp = im.integrate(acc, dt)
    np.testing.assert_allclose(vel, v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(disp, d, rtol=0, atol=1e-12)


def test_sdof_at_resonance():
    # a_g = a0 sin(w t) at the SDOF's own frequency: steady-state |x| = a0 / (2 zeta w^2)
    # (static a0/w^2 times the dynamic amplification 1/(2 zeta); Chopra, Dynamics of
    # Structures, Sec. 3.2). From rest the response envelope grows as 1 - exp(-zeta w t)
    # (monotone), so the peak over a record of 60 s is the steady state to exp(-18.8) ~ 7e-9.
    # Linear interpolation of the sampled sine lowers the fundamental by (w dt)^2/12 = 3.3e-6
    # at dt = 0.001 s: tolerance 2e-5.
    a0, T, zeta, dt = 1.5, 1.0, 0.05, 0.001
    w = 2 * np.pi / T
    t = np.arange(0, 60.0 + dt / 2, dt)
    acc = a0 * np.sin(w * t)
    r = im.measures(acc, dt, periods=[T], damping=zeta)
    x_ss = a0 / (2 * zeta * w * w)
    assert r["sd_cm"][0] / 100 == pytest.approx(x_ss, rel=2e-5)
    assert r["sa_g"][0] * G == pytest.approx(a0 / (2 * zeta), rel=2e-5)   # w^2 x_ss
    assert r["sv_cm_s"][0] / 100 == pytest.approx(w * x_ss, rel=2e-5)      # steady |x'| = w |x|


def test_pgv_pgd_of_one_sine_pulse():
    # a = A sin(2 pi t / Tp) on [0, Tp], 0 after: v = A Tp/(2 pi) (1 - cos) -> PGV = A Tp / pi;
    # d(Tp) = A Tp^2 / (2 pi) and v = 0 after, so PGD = A Tp^2 / (2 pi). Trapezoidal error is
    # O((dt/Tp)^2) ~ 1e-6 here (dt = 0.001, Tp = 0.8): tolerance 1e-5.
    A, Tp, dt = 3.0, 0.8, 0.001
    t = np.arange(0, 3.0, dt)
    acc = np.where(t <= Tp, A * np.sin(2 * np.pi * t / Tp), 0.0)
    r = im.measures(acc, dt)
    assert r["pgv_cm_s"] == pytest.approx(100 * A * Tp / np.pi, rel=1e-5)
    assert r["pgd_cm"] == pytest.approx(100 * A * Tp ** 2 / (2 * np.pi), rel=1e-5)
    assert r["pga_g"] == pytest.approx(A / G, rel=1e-5)


def test_arias_of_sine():
    # pi/(2g) int_0^T A^2 sin^2 = A^2 T pi / (4 g) over whole cycles; the trapezoidal sum of
    # sin^2 at equally spaced samples over whole cycles is exact (discrete orthogonality).
    A, f, T, dt = 2.0, 2.0, 10.0, 0.005
    t = np.arange(0, T + dt / 2, dt)
    r = im.measures(A * np.sin(2 * np.pi * f * t), dt)
    assert r["arias_m_s"] == pytest.approx(A * A * T * np.pi / (4 * G), rel=1e-12)


def test_d5_95_of_constant_record():
    # constant amplitude: the Husid integral is linear in time, so D5-95 = 0.9 T exactly.
    dt, T = 0.01, 12.0
    acc = np.full(int(round(T / dt)) + 1, 0.3)
    r = im.measures(acc, dt)
    assert r["d5_95_s"] == pytest.approx(0.9 * T, rel=1e-12)
    assert r["t5_s"] == pytest.approx(0.05 * T, rel=1e-12)


def test_keys_and_defaults():
    r = im.measures(np.sin(np.linspace(0, 20, 2000)), 0.01)
    for k in ("pga_g", "pgv_cm_s", "pgd_cm", "sa_g", "sv_cm_s", "periods_s", "arias_m_s", "d5_95_s"):
        assert k in r
    assert tuple(r["periods_s"]) == (0.2, 0.5, 1.0, 2.0, 3.0)
    assert r["sa_g"].shape == (5,) and r["sv_cm_s"].shape == (5,)
    # a scalar period works too
    assert im.measures([0.0, 1.0, 0.0], 0.01, periods=1.0)["sa_g"].shape == (1,)


@pytest.mark.parametrize("kwargs, word", [
    ({"acc": [0.0, np.nan, 1.0]}, "nan"),
    ({"acc": [0.0, np.inf]}, "inf"),
    ({"acc": [[0.0, 1.0]]}, "acc"),
    ({"acc": []}, "acc"),
    ({"dt": 0.0}, "0.0"),
    ({"dt": -0.01}, "-0.01"),
    ({"dt": float("nan")}, "nan"),
    ({"periods": [0.5, 0.0]}, "0.0"),
    ({"periods": [-1.0]}, "-1.0"),
    ({"periods": [np.nan]}, "nan"),
    ({"damping": 1.0}, "1.0"),
    ({"damping": -0.05}, "-0.05"),
    ({"damping": "x"}, "'x'"),
])
def test_bad_input_names_the_value(kwargs, word):
    args = {"acc": [0.0, 1.0, 0.5], "dt": 0.01, "periods": (0.2, 1.0), "damping": 0.05}
    args.update(kwargs)
    with pytest.raises(ParameterError) as ei:
        im.measures(args["acc"], args["dt"], periods=args["periods"], damping=args["damping"])
    assert isinstance(ei.value, ValueError)
    assert word in str(ei.value)
