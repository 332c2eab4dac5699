"""Fits that are not estimates are said to be so (pycolfrag.analysis.fragility.DegenerateFitWarning, the
``degenerate`` fields, the report's marks), while the formulas' values stay what they are.

Expected numbers: the beta -> 0 limit of Eq. (4) (a step at the one standing EDP); Eq. (4) computed
here by hand from mean and ddof=0 standard deviation of ln x with math.erfc (the closed form of the
lognormal MLE); for separable outcomes the binomial likelihood has no finite maximum (it grows as
beta -> 0), so the optimiser must stop on the beta bound BETA_MIN."""
import math
import os
import sys
import warnings

import numpy as np
import pytest

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.fragility import DegenerateFitWarning

sys.path.insert(0, os.path.dirname(__file__))
from test_figures import write_results  # noqa: E402


def _no_warning(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateFitWarning)
        return fn(*a, **kw)


def test_exceedance_of_one_run_is_the_step_limit_and_says_it_is_no_estimate():
    with pytest.warns(DegenerateFitWarning, match="only 1 run in the group"):
        assert fr.exceedance([0.4], [False], 0.35) == 1.0       # step at 0.4, above 0.35
    with pytest.warns(DegenerateFitWarning):
        assert fr.exceedance([0.3], [False], 0.35) == 0.0       # step at 0.3, below 0.35
    with pytest.warns(DegenerateFitWarning, match="all equal"):
        assert fr.exceedance([0.2] * 8, [False] * 8, 0.15) == 1.0
    assert "all equal" in fr.eq4_degenerate([0.2] * 8, [False] * 8)


def test_the_fit_needs_min_fit_points_standing_runs():
    """Four standing runs with EDP > 0 beside six collapses are flagged, five are not (MIN_FIT_POINTS = 5)."""
    assert fr.MIN_FIT_POINTS == 5
    e4 = [0.1, 0.2, 0.3, 0.4] + [np.nan] * 6
    c4 = [False] * 4 + [True] * 6
    assert "4 standing runs with EDP > 0" in fr.eq4_degenerate(e4, c4)
    assert fr.eq4_degenerate([0.1, 0.2, 0.3, 0.4, 0.5] + [np.nan] * 5, [False] * 5 + [True] * 5) == ""


def test_a_well_posed_group_gives_eq4_without_a_warning():
    rng = np.random.default_rng(1)
    x = np.exp(rng.normal(np.log(0.2), 0.6, 100))
    c = rng.random(100) < 0.1
    p = _no_warning(fr.exceedance, x, c, 0.35)
    ln = np.log(x[~c])
    mu, beta = ln.mean(), ln.std()
    pc = c.mean()
    expected = pc + (1 - pc) * 0.5 * math.erfc((math.log(0.35) - mu) / beta / math.sqrt(2))
    assert p == pytest.approx(expected, rel=1e-12)          # same formula, round-off only


def test_separable_outcomes_put_beta_on_its_bound_and_are_flagged():
    im = np.geomspace(0.05, 1.0, 20)
    with pytest.warns(DegenerateFitWarning, match="no finite maximum"):
        fit = fr.fit_lognormal_fragility(im, im, np.zeros(20, bool), 0.3)
    assert fit.beta == pytest.approx(fr.BETA_MIN, rel=1e-6)
    assert "beta = 0.02 is on the optimiser's bound" in fit.degenerate


def test_one_run_per_stratum_gives_no_interval_instead_of_a_zero_width_one():
    """A --samples 1 grid: every scenario (bootstrap stratum) holds one run, so every resample is the
    data and the band would have zero width."""
    im = np.geomspace(0.05, 1.0, 30)
    y = im > 0.3
    y[[8, 12]], y[[20, 25]] = True, False                                 # overlapping outcomes
    edp = np.where(y, 1.0, 0.1)
    with pytest.warns(DegenerateFitWarning, match="one run per bootstrap stratum"):
        fit = fr.fit_lognormal_fragility(im, edp, np.zeros(30, bool), 0.5, groups=np.arange(30), n_boot=40, rng=0)
    assert np.all(np.isnan(fit.median_ci)) and np.all(np.isnan(fit.beta_ci)) and fit.band_low is None
    # the same runs in 3 strata of 10: a real interval, nothing flagged
    fit = _no_warning(fr.fit_lognormal_fragility, im, edp, np.zeros(30, bool), 0.5,
                      groups=np.arange(30) % 3, n_boot=40, rng=0)
    assert fit.degenerate == "" and fit.median_ci[1] > fit.median_ci[0]


def test_a_well_posed_fit_recovers_its_fragility_unflagged():
    """400 Bernoulli trials from Phi(ln(IM / 0.3) / 0.4): the MLE median is within 10 % of 0.3 (its
    standard error is about beta / sqrt(n p (1 - p) density) ~ 4 %), nothing flagged."""
    rng = np.random.default_rng(3)
    im = np.exp(rng.uniform(np.log(0.05), np.log(2.0), 400))
    p = 0.5 * np.vectorize(math.erfc)(-np.log(im / 0.3) / 0.4 / math.sqrt(2))
    y = rng.random(400) < p
    fit = _no_warning(fr.fit_lognormal_fragility, im, np.where(y, 1.0, 0.1), np.zeros(400, bool), 0.5)
    assert fit.degenerate == "" and fit.median == pytest.approx(0.3, rel=0.10)


def test_msa_on_separated_stripes_is_flagged():
    x, n = [0.1, 0.2, 0.4, 0.8], [10, 10, 10, 10]
    with pytest.warns(DegenerateFitWarning, match="on the optimiser's bound"):
        f = fr.msa_fragility(x, n, [0, 0, 10, 10])
    assert f.degenerate
    assert _no_warning(fr.msa_fragility, x, n, [1, 4, 7, 9]).degenerate == ""


def test_report_of_a_one_sample_per_scenario_grid_says_its_fits_are_degenerate(tmp_path):
    from pycolfrag.analysis import report
    res = write_results(tmp_path / "grid.h5", mws=(6.0, 6.5, 7.0, 7.5), dists=(5.0, 10.0, 20.0), n=1, n_failed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateFitWarning)    # marked in the text, not repeated as warnings
        text = open(report.write_report(res, tmp_path / "report.md", n_boot=20)).read()
    assert text.count("Degenerate fits (the numbers are what the formulas give, not estimates):") >= 2
    assert "- Mw 6, R 5 km, u_top: only 1 run in the group" in text
    assert "one run per bootstrap stratum: the resamples cannot vary, no interval" in text
    stats_rows = [ln for ln in text.splitlines() if ln.startswith("| 6 | 5 |")]
    assert stats_rows and all("(degenerate)" in ln for ln in stats_rows)
