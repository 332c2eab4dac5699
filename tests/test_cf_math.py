"""The library's own normal-distribution functions (csrc/cf_math.c: erfc, Phi, its inverse) and
the C mapping of the pulse-parameter LHS (csrc/pulse.c: cf_pulse_sample_map), against scipy.

exp, log, log10, pow, sin and cos are tested against glibc in tests/c/test_math.c; here the
reference is scipy.special (cephes: erfc, ndtr, ndtri) and scipy.stats (norm.ppf,
truncnorm.ppf), the implementations the Python code used before the mapping moved to C.
Tolerances, each from the error analysis of the two implementations being compared:

* ndtri: Wichura's AS 241 is accurate to about 1e-16 relative, cephes' ndtri to a few
  1e-16; measured agreement 7.8e-16 over 9000 points from 1e-300 to 1 - 1e-16, so 2e-15.
* erfc: against a 50-digit decimal evaluation written here (scipy's own erfc rounds x^2 and
  is 5.5e-14 off at x = 22.8; ours carries x^2 in double-double). 1 - erf near x = 1 costs
  1/erfc(1) = 6 roundings of 1: measured 2.2e-15, so 4e-15 (normal-range results only).
* Phi(x) = erfc(-x/sqrt 2)/2 inherits the rounding of x/sqrt 2 times 2 z^2 = x^2 <= 100 for
  |x| <= 10: 1.1e-14, so 2e-14 (the model only needs Phi(-2)).
* The mapped samples: Vp = 10^(m + s z) amplifies an error dz by ln(10) s |z| <= 1.5, gamma by
  sd |z| / gamma <= 1; 1e-14 relative covers it with a margin of 10.
"""
from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
import pytest
import scipy.special as sp
from scipy import stats

from pycolfrag.core.ffi import lib
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp
from pycolfrag.ground_motion import rupakhety_2011 as r11


def _vec(fn, x):
    return np.array([fn(float(v)) for v in x])


def test_ndtri_matches_scipy():
    p = np.concatenate([np.logspace(-300, -1, 3000), np.linspace(0.001, 0.999, 5001),
                        1.0 - np.logspace(-16, -1, 1000)])
    mine, ref = _vec(lib.cf_math_ndtri, p), sp.ndtri(p)
    big = np.abs(ref) > 1e-3
    np.testing.assert_allclose(mine[big], ref[big], rtol=2e-15, atol=0)
    np.testing.assert_allclose(mine[~big], ref[~big], rtol=0, atol=1e-18)   # p near 1/2: absolute


def test_ndtri_exact_values():
    """Phi^-1(1/2) = 0 by symmetry; Phi^-1(0) = -inf, Phi^-1(1) = +inf; NaN outside [0, 1]."""
    assert lib.cf_math_ndtri(0.5) == 0.0
    assert lib.cf_math_ndtri(0.0) == -math.inf and lib.cf_math_ndtri(1.0) == math.inf
    assert math.isnan(lib.cf_math_ndtri(-1e-300)) and math.isnan(lib.cf_math_ndtri(1.5))
    assert math.isnan(lib.cf_math_ndtri(math.nan))
    # 1.959963984540054 is the two-sided 5 % point of N(0, 1) (Abramowitz & Stegun Table 26.5
    # gives 1.959963985); to 1e-15 it is scipy's value
    assert lib.cf_math_ndtri(0.975) == pytest.approx(1.959963984540054, rel=1e-15)


D_PI = Decimal("3.14159265358979323846264338327950288419716939937510582097494459")


def _erfc_reference(x):
    """erfc to about 50 digits in decimal arithmetic: the all-positive series of erf for x < 3,
    Laplace's continued fraction (evaluated backwards from 4000 terms) beyond."""
    with localcontext() as ctx:
        ctx.prec = 60
        x = Decimal(x)
        if x < 3:
            t2, term, s, n = 2 * x * x, Decimal(1), Decimal(1), 1
            while term > Decimal(10) ** -60 * s:
                term *= t2 / (2 * n + 1)
                s += term
                n += 1
            return 1 - 2 * x * (-x * x).exp() * s / D_PI.sqrt()
        f = Decimal(0)
        for n in range(4000, 0, -1):
            f = (Decimal(n) / 2) / (x + f)
        return (-x * x).exp() / D_PI.sqrt() / (x + f)


def test_erfc_against_a_50_digit_reference():
    x = np.concatenate([np.linspace(-6.0, 26.0, 641), [0.99, 1.0, 1.01, 2.99, 3.0, 3.01]])
    ref = np.array([float(_erfc_reference(v)) for v in x])
    np.testing.assert_allclose(_vec(lib.cf_math_erfc, x), ref, rtol=4e-15, atol=0)


def test_phi_against_the_reference():
    z = np.linspace(-10.0, 8.0, 361)
    with localcontext() as ctx:
        ctx.prec = 60
        ref = np.array([float(_erfc_reference(-Decimal(v) / Decimal(2).sqrt()) / 2) for v in z])
    np.testing.assert_allclose(_vec(lib.cf_math_norm_cdf, z), ref, rtol=2e-14, atol=0)


def test_erfc_exact_values():
    """erfc(0) = 1, erfc(+inf) = 0, erfc(-inf) = 2, NaN propagates (definition)."""
    assert lib.cf_math_erfc(0.0) == 1.0
    assert lib.cf_math_erfc(math.inf) == 0.0 and lib.cf_math_erfc(-math.inf) == 2.0
    assert lib.cf_math_erfc(30.0) == 0.0
    assert math.isnan(lib.cf_math_erfc(math.nan))
    assert lib.cf_math_norm_cdf(0.0) == 0.5


def test_sample_map_matches_scipy_inverse_cdfs():
    """The C mapping equals what scipy's norm.ppf / truncnorm.ppf and 10** gave before."""
    rng = np.random.default_rng(5)
    u = rng.random((2000, 4))
    u[:4, 3] = [0.0, 1e-12, 0.5, 1.0 - 1e-12]            # the truncation point and the far tail
    log_vp, log_fp = lib.cf_math_log10(r11.mean_vp_cm_s(7.0, 10.0)), r11.log10_fp_mean(7.0)
    vp, fp, nu, gamma = (np.empty(u.shape[0]) for _ in range(4))
    from pycolfrag.core.ffi import ptr
    assert lib.cf_pulse_sample_map(mp._distribution(log_vp, log_fp, r11.SIGMA_LOG10_FP), ptr(np.ascontiguousarray(u)),
                                   u.shape[0], ptr(vp), ptr(fp), ptr(nu), ptr(gamma)) == 0
    a = (mp.GAMMA_MIN - mp.GAMMA_MEAN) / mp.GAMMA_SD
    np.testing.assert_allclose(vp, 10.0 ** stats.norm.ppf(u[:, 0], log_vp, r11.SIGMA_LOG10_VP), rtol=1e-14)
    np.testing.assert_allclose(fp, 10.0 ** stats.norm.ppf(u[:, 1], log_fp, r11.SIGMA_LOG10_FP), rtol=1e-14)
    np.testing.assert_array_equal(nu, mp.NU_RANGE_RAD[0] + (mp.NU_RANGE_RAD[1] - mp.NU_RANGE_RAD[0]) * u[:, 2])
    # scipy's truncnorm.ppf loses digits in the far upper tail (2e-7 relative at u = 1 - 1e-12,
    # where it forms 1 - p); there the reference is the closed form with scipy.special
    tail = u[:, 3] > 1 - 1e-6
    np.testing.assert_allclose(gamma[~tail], stats.truncnorm.ppf(u[~tail, 3], a, np.inf, loc=mp.GAMMA_MEAN,
                                                                 scale=mp.GAMMA_SD), rtol=1e-14)
    closed = mp.GAMMA_MEAN - mp.GAMMA_SD * sp.ndtri((1.0 - u[tail, 3]) * sp.ndtr(-a))
    np.testing.assert_allclose(gamma[tail], closed, rtol=1e-14)
    # u = 0 is the truncation point itself (to the rounding of ndtri(Phi(a)) = a); never below it
    assert gamma[0] == pytest.approx(mp.GAMMA_MIN, rel=1e-15) and gamma.min() >= mp.GAMMA_MIN


def test_sample_map_refuses_bad_uniforms():
    u = np.full((1, 4), 0.5)
    u[0, 2] = 1.5
    from pycolfrag.core.ffi import ptr
    out = [np.empty(1) for _ in range(4)]
    d = mp._distribution(1.0, -0.5, r11.SIGMA_LOG10_FP)
    assert lib.cf_pulse_sample_map(d, ptr(u), 1, *(ptr(o) for o in out)) == lib.CF_EINVAL
    u[0, 2] = math.nan
    assert lib.cf_pulse_sample_map(d, ptr(u), 1, *(ptr(o) for o in out)) == lib.CF_EINVAL


_DUMP_C = r"""
#include <stdio.h>
#include <string.h>
#include <stdint.h>
#include "cf_math.h"
static uint64_t st = 12345;
static double u01(void) { st = st * 6364136223846793005ULL + 1442695040888963407ULL;
                          return (double)(st >> 11) * 0x1.0p-53; }
static void out(double v) { uint64_t b; memcpy(&b, &v, 8); printf("%016llx\n", (unsigned long long)b); }
int main(void) {
    for (int i = 0; i < 20000; i++) {
        double x = 60.0 * u01() - 30.0, p = u01();
        out(cf_math_exp(x)); out(cf_math_log(p * 1e3)); out(cf_math_log10(p + 1e-9));
        out(cf_math_pow(10.0, x)); out(cf_math_pow(p * 100.0, 0.45)); out(cf_math_sin(x * 1e3));
        out(cf_math_cos(x)); out(cf_math_erfc(x / 5.0)); out(cf_math_ndtri(p));
    }
    return 0;
}
"""


def _dump(tmp_path, flags):
    import shutil
    if shutil.which("gcc") is None:
        pytest.skip("no gcc")
    import os
    csrc = os.path.join(os.path.dirname(__file__), "..", "csrc")
    src = tmp_path / "dump.c"
    src.write_text(_DUMP_C)
    exe = tmp_path / ("dump" + "".join(f.replace("=", "").replace("-", "_") for f in flags))
    import subprocess
    subprocess.run(["gcc", "-std=c99", *flags, "-I", csrc, "-o", str(exe), str(src),
                    os.path.join(csrc, "cf_math.c"), "-lm"], check=True, capture_output=True)
    return subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout


def test_same_bits_from_every_optimisation_level(tmp_path):
    """cf_math gives the same bits whatever the optimisation level or target ISA, as long as
    floating-point contraction stays off (the library's flags): -O0 against -O3, and -O3
    -march=native (FMA and AVX-512 instructions allowed) against both. 180,000 results."""
    ref = _dump(tmp_path, ["-O0", "-ffp-contract=off"])
    assert len(ref.split()) == 180000
    assert _dump(tmp_path, ["-O3", "-ffp-contract=off", "-fno-math-errno"]) == ref
    assert _dump(tmp_path, ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno"]) == ref
    # the comparison can see a difference: with contraction allowed, gcc fuses a*b + c into FMA
    # on a CPU that has it, and 72,889 of the 180,000 results changed when measured (AMD EPYC)
    with open("/proc/cpuinfo") as fh:
        has_fma = " fma" in fh.read()
    if has_fma:
        fused = _dump(tmp_path, ["-O3", "-march=native", "-ffp-contract=fast"])
        assert fused != ref
