"""combine() (paper steps 3-6, csrc/combine.c) from Python: exact cases, the
"larger of the two" behaviour of the Fourier amplitude, the pulse in the velocity,
and argument checks. The C unit test (tests/c/test_combine.c) covers the same
exact cases at the kernel level."""
from __future__ import annotations

import numpy as np
import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.ground_motion.combine import combine

DT = 0.005


def gabor_pulse(n, dt, t_peak, vp, fp, gamma=2.0, nu=0.0):
    """Mavroeidis-Papageorgiou-shaped velocity pulse (envelope 0.5(1 + cos(2 pi fp t/gamma))
    times cos(2 pi fp t + nu), centred at t_peak) and its exact derivative; written here
    so this test does not depend on the pulse module."""
    t = np.arange(n) * dt - t_peak
    inside = np.abs(t) <= gamma / (2 * fp)
    a, w = 2 * np.pi * fp / gamma, 2 * np.pi * fp
    env, denv = 0.5 * (1 + np.cos(a * t)), -0.5 * a * np.sin(a * t)
    vel = np.where(inside, vp * env * np.cos(w * t + nu), 0.0)
    acc = np.where(inside, vp * (denv * np.cos(w * t + nu) - env * w * np.sin(w * t + nu)), 0.0)
    return vel, acc


def velocity(acc, dt):
    return np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * dt)])


def test_zero_pulse_returns_hf():
    """|HF| - 0 with HF's phase is HF: equal to FFT rounding (1e-12 of max|HF|)."""
    hf, _ = as00.simulate(6.5, 10.0, 1, DT)
    out = combine(hf, np.zeros_like(hf))
    np.testing.assert_allclose(out, hf, rtol=0, atol=1e-12 * np.abs(hf).max())


def test_proportional_and_clipped():
    """pulse = c HF: c < 1 gives HF back ((1-c)HF + cHF); c > 1 clips the amplitude at 0
    (never negative), giving the pulse alone (an unclipped subtraction would give HF)."""
    hf, _ = as00.simulate(6.0, 20.0, 2, DT)
    tol = 1e-12 * np.abs(hf).max()
    np.testing.assert_allclose(combine(hf, 0.4 * hf), hf, rtol=0, atol=tol)
    np.testing.assert_allclose(combine(hf, 3.0 * hf), 3.0 * hf, rtol=0, atol=3 * tol)


def test_fourier_amplitude_follows_the_larger_part():
    """Mw 6.5 / 10 km HF record and a 0.5 Hz pulse of 60 cm/s: near 0.5 Hz the pulse
    dominates and the result's band amplitude is within 15 % of the pulse's; above 5 Hz
    the pulse is negligible and the result equals the HF record's within 5 % (the residual
    differences are the HF energy moved by truncating the modified record to n samples)."""
    hf, info = as00.simulate(6.5, 10.0, 3, DT)
    n = hf.size
    _, p = gabor_pulse(n, DT, info["window_start_s"] + 0.3 * info["window_s"], 0.6, 0.5)
    out = combine(hf, p)
    nf = 1 << (int(np.ceil(np.log2(n))) + 1)
    f = np.fft.rfftfreq(nf, DT)

    def band(x, lo, hi):
        s = np.abs(np.fft.rfft(x, nf))[(f >= lo) & (f < hi)]
        return np.sqrt(np.mean(s**2))

    assert band(p, 0.4, 0.6) > 3 * band(hf, 0.4, 0.6)
    assert band(out, 0.4, 0.6) == pytest.approx(band(p, 0.4, 0.6), rel=0.15)
    assert band(p, 5, 20) < 0.01 * band(hf, 5, 20)
    assert band(out, 5, 20) == pytest.approx(band(hf, 5, 20), rel=0.05)


@pytest.mark.parametrize("seed", range(8))
def test_velocity_shows_the_pulse(seed):
    """Paper step 2 then steps 3-6: the pulse's velocity peak placed at the HF record's
    velocity peak, with that peak's polarity. Then the combined peak velocity is >= the
    pulse's (the pulse must show in the record; over seeds 0-39 the ratio was 1.12-1.41). Without the
    polarity match the sum can interfere destructively: we measured ratios down to 0.87
    (seeds 0-39, same pulse, positive polarity), so the polarity matters to callers."""
    hf, _ = as00.simulate(7.0, 5.0, seed, DT)
    v_hf = velocity(hf, DT)
    i_peak = int(np.argmax(np.abs(v_hf)))
    vp = 0.8 * np.sign(v_hf[i_peak])
    vel_p, p = gabor_pulse(hf.size, DT, i_peak * DT, vp, 0.4)
    out = combine(hf, p)
    assert np.abs(velocity(out, DT)).max() >= np.abs(vel_p).max()
    assert out.shape == hf.shape and np.isfinite(out).all()


def test_bad_input():
    a = np.zeros(10)
    with pytest.raises(ParameterError, match="10 samples .* 9"):
        combine(a, np.zeros(9))
    b = a.copy()
    b[3] = np.nan
    with pytest.raises(ParameterError, match="pulse_acc has a non-finite value"):
        combine(a, b)
    with pytest.raises(ParameterError, match="hf_acc must be 1-D"):
        combine(np.zeros((2, 5)), np.zeros((2, 5)))
    with pytest.raises(ParameterError, match="hf_acc is empty"):
        combine([], [])
    assert combine([1.0, 2.0, 3.0], np.zeros(3)).dtype == np.float64
