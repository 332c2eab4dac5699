"""Record-suite analysis in pycolfrag.analysis.fragility: cloud regression, logistic collapse, MSA (Baker 2015),
stripes over a suite table.

Recovery tests draw synthetic data from known parameters. One draw can sit 3 standard errors away
by chance, so each test repeats the draw (seeded) and checks what the sampling error implies: the
estimate falls within 1.96 of its own standard errors in about 95 % of repetitions (binomial
standard deviation of that fraction over 200 repetitions: 1.5 %, so [0.90, 0.99] is 3 of them), and
the standardised errors average about 0 (standard deviation of their mean 1/sqrt(200) = 0.07).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import special, stats

from pycolfrag.analysis import fragility as fr
from pycolfrag.core.errors import ParameterError

REPS = 200


def _check_coverage(t):
    """t: (REPS, k) standardised errors (estimate - truth) / standard error."""
    t = np.asarray(t)
    cover = np.mean(np.abs(t) < 1.96, axis=0)
    assert np.all((cover > 0.90) & (cover < 0.99)), cover
    assert np.all(np.abs(t.mean(axis=0)) < 0.3), t.mean(axis=0)


def test_cloud_recovers_regression_and_dispersion():
    """ln EDP = a + b ln IM + beta eps with a = -1.5, b = 1.2, beta = 0.4, 60 runs; beta's standard
    error is beta / sqrt(2 (n - 2)) (normal residuals)."""
    rng = np.random.default_rng(7)
    a, b, beta, n = -1.5, 1.2, 0.4, 60
    t = []
    for _ in range(REPS):
        im = np.exp(rng.uniform(np.log(0.05), np.log(1.5), n))
        edp = np.exp(a + b * np.log(im) + beta * rng.normal(size=n))
        f = fr.cloud_analysis(im, edp)
        t.append([(f.a - a) / f.se_a, (f.b - b) / f.se_b, (f.beta - beta) / (f.beta / np.sqrt(2 * (n - 2)))])
    _check_coverage(t)


def test_cloud_with_collapses_and_exceedance():
    """Collapsed runs stay out of the regression and enter through P(C | IM); exceedance = Eq. (4) form."""
    rng = np.random.default_rng(8)
    im = np.exp(rng.uniform(np.log(0.05), np.log(1.5), 400))
    edp = np.exp(-1.0 + 1.0 * np.log(im) + 0.3 * rng.normal(size=im.size))
    coll = rng.uniform(size=im.size) < special.expit(2.0 + 3.0 * np.log(im))
    edp[coll] = np.nan
    f = fr.cloud_analysis(im, edp, coll)
    assert f.n == int((~coll).sum()) and f.n_collapsed == int(coll.sum())
    assert f.collapse is not None
    x = np.array([0.1, 0.5])
    pc = f.collapse(x)
    tail = stats.norm.sf((np.log(0.2) - f.a - f.b * np.log(x)) / f.beta)
    np.testing.assert_allclose(f.exceedance(x, 0.2), pc + (1 - pc) * tail, rtol=1e-12)
    with pytest.raises(ParameterError, match="at least 3 standing runs"):
        fr.cloud_analysis([0.1, 0.2, 0.3], [0.1, np.nan, 0.2], [False, True, False])


def test_logistic_collapse_recovers_parameters():
    """P(C | IM) = expit(c0 + c1 ln IM), c0 = 1.0, c1 = 2.5, 300 runs; SEs from the Hessian."""
    rng = np.random.default_rng(9)
    c0, c1 = 1.0, 2.5
    t = []
    for _ in range(REPS):
        im = np.exp(rng.uniform(np.log(0.05), np.log(2.0), 300))
        y = rng.uniform(size=im.size) < special.expit(c0 + c1 * np.log(im))
        f = fr.fit_logistic_collapse(im, y)
        se0, se1 = f.se
        t.append([(f.c0 - c0) / se0, (f.c1 - c1) / se1])
    _check_coverage(t)
    with pytest.raises(ParameterError, match="separated by the IM"):
        fr.fit_logistic_collapse([0.1, 0.2, 0.3, 0.4], [0, 0, 1, 1])


def test_msa_recovers_median_and_dispersion():
    """Baker (2015) setting: 8 stripes of 40 runs, theta = 0.4, beta = 0.5; SEs from the Fisher
    information of (ln theta, ln beta)."""
    rng = np.random.default_rng(1)
    x = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0])
    n = np.full(x.size, 40)
    t = []
    for _ in range(REPS):
        z = rng.binomial(n, stats.norm.cdf(np.log(x / 0.4) / 0.5))
        m = fr.msa_fragility(x, n, z)
        se = np.sqrt(np.diag(m.cov_ln))
        t.append([(np.log(m.median) - np.log(0.4)) / se[0], (np.log(m.beta) - np.log(0.5)) / se[1]])
    _check_coverage(t)


def test_msa_equals_the_bernoulli_mle():
    """The binomial likelihood over stripes differs from the per-run Bernoulli likelihood of
    fit_lognormal_fragility by constants only: the two maxima coincide (optimiser tolerance, 1e-6)."""
    rng = np.random.default_rng(2)
    x = np.array([0.1, 0.2, 0.3, 0.5, 0.8])
    n = np.array([30, 30, 25, 30, 20])
    z = rng.binomial(n, stats.norm.cdf(np.log(x / 0.3) / 0.6))
    m = fr.msa_fragility(x, n, z)
    im = np.repeat(x, n)
    y = np.concatenate([np.arange(k) < j for k, j in zip(n, z)])
    b = fr.fit_lognormal_fragility(im, np.zeros(im.size), y, 1.0)
    assert m.median == pytest.approx(b.median, rel=1e-6) and m.beta == pytest.approx(b.beta, rel=1e-6)
    with pytest.raises(ParameterError, match="no interior maximum"):
        fr.msa_fragility(x, n, np.zeros(x.size, dtype=int))


def _suite_table(rng, n=240):
    scale = np.repeat([0.5, 1.0, 2.0], n // 3)
    pga = scale * np.exp(rng.normal(np.log(0.2), 0.3, n))
    u_top = np.exp(np.log(pga) + 0.3 * rng.normal(size=n))
    coll = u_top > 1.5
    periods = np.array([0.5, 1.0])
    return {"status": np.zeros(n, dtype=int), "collapsed": coll.astype(np.uint8), "u_top": u_top,
            "u_d": 0.01 * u_top, "pga_g": pga, "pgv_cm_s": 100 * pga, "sa_g": np.column_stack([2 * pga, 1.5 * pga]),
            "sv_cm_s": np.column_stack([50 * pga, 80 * pga]), "periods_s": periods, "scale": scale}


def test_stripe_analysis_reuses_stripe_curve():
    """Every IM x level is fr.stripe_curve on the right column (SA at 1 s is the second column)."""
    rng = np.random.default_rng(3)
    tab = _suite_table(rng)
    tab["status"][:5] = 3                       # failed runs are left out
    lev = fr.U_TOP_LEVELS[1]
    out = fr.stripe_analysis(tab, levels=[lev], n_boot=20, rng=0)
    assert set(out) == {(im, lev.label) for im in ("pga_g", "pgv_cm_s", "sa_g", "sv_cm_s")}
    ok = slice(5, None)
    ref = fr.stripe_curve(tab["sa_g"][ok, 1], tab["u_top"][ok], tab["collapsed"][ok].astype(bool), lev.threshold,
                          n_boot=20, rng=0)
    np.testing.assert_array_equal(out[("sa_g", lev.label)].p, ref.p)
    np.testing.assert_array_equal(out[("sa_g", lev.label)].n, ref.n)
    with pytest.raises(ParameterError, match="not stored"):
        fr.table_im(tab, "sa_g", 2.0)


def test_msa_from_table_groups_by_scale():
    rng = np.random.default_rng(4)
    tab = _suite_table(rng)
    lev = fr.U_TOP_LEVELS[1]
    m = fr.msa_from_table(tab, "pga_g", lev)
    assert list(m.n_trials) == [80, 80, 80]
    for j, s in enumerate([0.5, 1.0, 2.0]):
        sel = tab["scale"] == s
        assert m.im_levels[j] == pytest.approx(np.exp(np.mean(np.log(tab["pga_g"][sel]))))
        assert m.n_exceed_stripe[j] == int(np.sum(fr.exceeded(tab["u_top"][sel], tab["collapsed"][sel].astype(bool),
                                                              lev.threshold)))
