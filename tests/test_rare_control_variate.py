"""The rare route's control variate: the weights' known mean (1 per stratum) in the estimate of every level
(pycolfrag/rare/estimate.py, docs/rare_events.md; the sampled normals' known means were tried as further controls
and not kept, docs/risk.md).

Where the expected numbers come from:

* the regression estimator with one control u of known mean 1 is the least-squares line of v on u read at u = 1,
  its variance the residuals' sum of squares over n - 2, over n (Cochran 1977, 7.1-7.3; Owen 2013, 8.9): the line
  here is numpy.polyfit's, not the module's code;
* a level every run of a stratum exceeds has v = w exactly linear in the control: the regression would give the
  stratum's rate W_h itself with zero variance, as if n of n proved p = 1, so the rule keeps the plain mean
  W_h mean(w) and its variance from the weights' spread there;
* the rule at few runs: below CV_MIN_RUNS (100) successful runs or CV_MIN_HITS (5) exceedances the plain mean
  and sample variance stand, bit for bit those of ``control=False``.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from pycolfrag.rare.estimate import CV_MIN_HITS, CV_MIN_RUNS, estimate
from pycolfrag.rare.proposal import Design
from test_rare_floor import _Q, _Strata


def _one_stratum(y, occ):
    """Stratum A only (rate 1 /yr): rows with outcomes ``y`` and occurrence weights ``occ`` (no pulse: w = occ);
    stratum B left out by ``keep``."""
    n = len(y)
    return {"status": np.zeros(n, np.int32), "stratum": np.zeros(n, int), "stage": np.zeros(n, int),
            "index": np.arange(n), "occurrence_weight": np.asarray(occ, float), "z_vp": np.full(n, np.nan),
            "z_fp": np.full(n, np.nan), "collapsed": np.asarray(y, np.uint8), "pulse": np.zeros(n, np.uint8)}


KEEP = np.array([True, False])


def _est(cols, **kw):
    return estimate(cols, _Strata(), Design(), [_Q()], keep=KEEP, **kw).levels["collapse"]


def test_a_level_every_run_exceeds_keeps_the_plain_estimator_and_a_variance():
    n = CV_MIN_RUNS + 20
    occ = np.random.default_rng(5).uniform(0.6, 1.5, n)       # mean about 1.05, not 1: the sample's
    cols = _one_stratum(np.ones(n), occ)
    e, plain = _est(cols), _est(cols, control=False)
    assert e.as_dict() == plain.as_dict()
    assert plain.rate == pytest.approx(occ.mean(), rel=1e-14)
    assert plain.cov == pytest.approx(occ.std(ddof=1) / math.sqrt(n) / occ.mean(), rel=1e-12) and plain.cov > 0.01


def test_the_estimate_is_the_least_squares_line_at_the_known_mean():
    rng = np.random.default_rng(11)
    n = CV_MIN_RUNS + 20
    occ = rng.uniform(0.5, 1.6, n)
    y = rng.uniform(size=n) < 0.3 + 0.4 * (occ - 0.5)         # exceedance more likely at larger weights
    assert y.sum() >= CV_MIN_HITS
    v = occ * y
    slope, intercept = np.polyfit(occ, v, 1)
    resid = v - (intercept + slope * occ)
    e = _est(_one_stratum(y, occ))
    assert e.rate == pytest.approx(intercept + slope * 1.0, rel=1e-12)
    assert e.cov == pytest.approx(math.sqrt(np.sum(resid ** 2) / (n - 2) / n) / e.rate, rel=1e-10)
    plain = _est(_one_stratum(y, occ), control=False)
    assert plain.rate == pytest.approx(v.mean(), rel=1e-14) and plain.rate != pytest.approx(e.rate, rel=1e-3)


def test_below_the_run_and_hit_counts_the_plain_estimator_stands():
    rng = np.random.default_rng(2)
    occ = rng.uniform(0.5, 1.6, CV_MIN_RUNS - 1)
    few_runs = _one_stratum(np.ones(CV_MIN_RUNS - 1), occ)
    assert _est(few_runs).as_dict() == _est(few_runs, control=False).as_dict()
    n = CV_MIN_RUNS + 20
    y = np.zeros(n)
    y[: CV_MIN_HITS - 1] = 1
    few_hits = _one_stratum(y, rng.uniform(0.5, 1.6, n))
    assert _est(few_hits).as_dict() == _est(few_hits, control=False).as_dict()
    y[: CV_MIN_HITS] = 1
    enough = _one_stratum(y, rng.uniform(0.5, 1.6, n))
    assert _est(enough).rate != _est(enough, control=False).rate


def test_a_folder_of_an_older_algorithm_is_not_resumed(monkeypatch):
    """The batches as pieces (v5) change the allocation and the estimates, as the control variate (v4) did: a folder
    planned by v4 (pooled means) is refused on resume, naming the algorithm."""
    import io
    from contextlib import redirect_stdout

    from pycolfrag.core.errors import ResultsFileError
    from pycolfrag.rare import driver
    from pycolfrag.risk.site_risk import QUANTITIES
    from rare_surrogate import SurrogateEvaluator
    from test_rare_site import SMALL, small_site
    assert driver.ALGORITHM.endswith("; v5")
    ev = SurrogateEvaluator()
    settings, stop = driver.SiteSettings(seed=4, batch=100, **SMALL), driver.StopRule(0.5, 200)
    with monkeypatch.context() as m, redirect_stdout(io.StringIO()):
        m.setattr(driver, "ALGORITHM", "stratified site simulation, defensive mixture, cross-entropy steps; v4")
        driver.simulate_site(small_site(), settings, stop, ev, QUANTITIES, log=lambda s: None)
    with pytest.raises(ResultsFileError, match="algorithm"), redirect_stdout(io.StringIO()):
        driver.simulate_site(small_site(), settings, stop, ev, QUANTITIES, log=lambda s: None)
