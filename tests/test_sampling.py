"""The pulse sampling's numerical tools without scipy (pycolfrag/ground_motion/sampling.py) give scipy's
bits, and a grid rank starts without scipy.

The references are scipy itself (``scipy.stats.qmc.LatinHypercube``, ``scipy.optimize.minimize_scalar``
with ``method="bounded"``), called here on the same inputs: the twins must return the very same floats
(``==`` / ``array_equal``, no tolerance), since the grid's rows were computed with scipy's and must keep
their bits (docs/grid.md, "Rows are the same on any number of ranks").
"""
import ast
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy import optimize
from scipy.stats import qmc

from pycolfrag import ground_motion as gm
from pycolfrag.ground_motion import mavroeidis_papageorgiou_2003 as mp03
from pycolfrag.ground_motion.sampling import latin_hypercube, minimize_bounded


def _scipy_lhs(d, n, seed):
    return qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)


@pytest.mark.parametrize("d", [1, 2, 4, 5])
def test_latin_hypercube_is_scipys(d):
    # sizes from one point to the grid's 1000 samples; seeds as derive_seed makes them (32-bit) and small ones
    seeds = [0, 1, 2, 12345, 2**31 - 1, 2**32 - 1] + [int(s) for s in np.random.default_rng(7).integers(0, 2**32, 20)]
    for n in (1, 2, 3, 8, 100, 1000):
        for seed in seeds:
            ours, ref = latin_hypercube(d, n, seed), _scipy_lhs(d, n, seed)
            assert ours.shape == ref.shape == (n, d)
            assert np.array_equal(ours, ref), (d, n, seed)


def test_latin_hypercube_has_one_point_per_stratum():
    u = latin_hypercube(4, 50, 3)
    assert np.array_equal(np.sort(np.floor(u * 50), axis=0), np.tile(np.arange(50.0)[:, None], (1, 4)))


def _scipy_min(f, lo, hi, xatol):
    res = optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    return float(res.x), float(res.fun)


@pytest.mark.parametrize("f, lo, hi", [
    (lambda x: (x - 0.3) ** 2, -1.0, 2.0),                 # smooth: parabolic steps
    (lambda x: abs(x - 0.123456789), 0.0, 1.0),            # a kink: golden sections
    (lambda x: -math.cos(3 * x) * math.exp(-x * x), -2.0, 1.5),
    (lambda x: x, 0.0, 1.0),                               # minimum at a bound
    (lambda x: 1.0, -1.0, 1.0),                            # flat
    (lambda x: (x - 5.0) ** 4, 4.0, 4.0),                  # an empty interval
])
@pytest.mark.parametrize("xatol", [1e-5, 1e-12])
def test_bounded_search_is_scipys(f, lo, hi, xatol):
    assert minimize_bounded(f, lo, hi, xatol=xatol) == _scipy_min(f, lo, hi, xatol)


def _unit_shape(nu, gamma):
    """g(u) of _unit_peak: the unit pulse from the C kernel (csrc/pulse.c), the function it searches."""
    c = mp03._c()

    def g(x):
        xs = np.ascontiguousarray(np.atleast_1d(x), dtype=np.float64)
        out = np.empty_like(xs)
        c.check(c.lib.cf_pulse_unit_shape(nu, gamma, c.ptr(xs), xs.size, c.ptr(out)), what="unit pulse")
        return out if np.ndim(x) else float(out[0])
    return g


def test_unit_pulse_peak_is_that_of_scipys_search():
    """The unit pulse's peak (what fixes every record's envelope amplitude A) over 400 (nu, gamma) pairs
    of the sampled ranges (nu in [-pi/2, pi/2], gamma from 1 to 4): _unit_peak as it was written with
    scipy's search (the grid of 2001 points, the bracket around its best point, scipy on it) gives the
    same (u*, g(u*)) bits as _unit_peak now."""
    rng = np.random.default_rng(11)
    for nu, gamma in zip(rng.uniform(-math.pi / 2, math.pi / 2, 400), rng.uniform(1.0, 4.0, 400)):
        nu, gamma = float(nu), float(gamma)
        g = _unit_shape(nu, gamma)
        u = np.linspace(-gamma / 2, gamma / 2, 2001)
        k = int(np.argmax(np.abs(g(u))))
        lo, hi = u[max(k - 1, 0)], u[min(k + 1, u.size - 1)]
        x, fx = _scipy_min(lambda x: -abs(g(x)), lo, hi, 1e-12)  # noqa: B023 (minimised within this iteration)
        ub = x if -fx >= abs(g(u[k])) else float(u[k])
        mp03._unit_peak.cache_clear()
        assert mp03._unit_peak(nu, gamma) == (ub, float(g(ub))), (nu, gamma)


def test_the_grids_table_without_the_amplitude_keeps_every_other_bit():
    """sample_pulse_parameters(amplitude=False) -- what a grid's rank draws -- equals the full table on
    every other key, for the default and another pulse-period relation; a record made from a row of it
    is the record made from the full row (synthesize reads the row's inputs and finds A itself)."""
    for tp in ("rupakhety_2011", "baker_2007"):
        full = gm.sample_pulse_parameters(7.0, 10.0, 60, 99, tp_model=tp)
        lean = gm.sample_pulse_parameters(7.0, 10.0, 60, 99, tp_model=tp, amplitude=False)
        assert set(full) - set(lean) == {"A_cm_s"} and list(lean) == [k for k in full if k != "A_cm_s"]
        for k in lean:
            assert np.array_equal(full[k], lean[k]), k
    row_full = {k: float(v[5]) for k, v in full.items()}
    row_lean = {k: float(v[5]) for k, v in lean.items()}
    a = gm.synthesize(7.0, 10.0, 5, pulse=row_full)
    b = gm.synthesize(7.0, 10.0, 5, pulse=row_lean)
    assert np.array_equal(a.acc, b.acc) and a.meta["A_cm_s"] == b.meta["A_cm_s"] == row_full["A_cm_s"]


def test_a_grid_rank_starts_without_scipy_or_the_analysis():
    """Importing what every rank of a grid imports (the command, the driver) loads no scipy module and,
    of the analysis, only the fragility statistics ``import pycolfrag`` binds (whose scipy loads on first
    use): scipy was 0.9 s of a rank's 1.1 s start-up."""
    code = ("import sys, pycolfrag.cli.main, pycolfrag.cli.grid, pycolfrag.grid\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy' or m.startswith('pycolfrag.analysis')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    loaded = ast.literal_eval(out.stdout.strip())
    assert not [m for m in loaded if m.split(".")[0] == "scipy"], loaded
    assert {m.rsplit(".", 1)[0] for m in loaded if m.count(".") > 2} <= {"pycolfrag.analysis.fragility"}, loaded
    assert set(m for m in loaded if m.count(".") <= 2) == {"pycolfrag.analysis", "pycolfrag.analysis.fragility"}


def test_fragility_still_reaches_scipy_on_first_use():
    """The fragility statistics read scipy when first used: Eq. (2) (nothing collapsed) at the geometric
    mean of the EDPs 0.5 and 2 is 1 - Phi(0) = 1/2 exactly (ln 0.5 = -ln 2), through ``scipy.stats.norm``."""
    code = ("import sys, pycolfrag\n"
            "assert 'scipy.stats' not in sys.modules\n"
            "print(pycolfrag.fragility.exceedance([0.5, 2.0], [False, False], 1.0), 'scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0.5", "True"]


def test_a_grid_rank_draws_its_tables_without_the_amplitude():
    """The grid's row context asks for the lean table (a rank then searches only its own rows' peaks)."""
    from pycolfrag.grid import GridSpec
    ctx = GridSpec(mw=(7.0,), dist_km=(10.0,), samples=4).context()
    assert "A_cm_s" not in ctx.pulse(0, 1) and {"Vp_cm_s", "fp_hz", "nu_rad", "gamma"} <= set(ctx.pulse(0, 1))
