"""Subset simulation (pycolfrag.rare.subset) against limit states whose probability is known exactly, against
the crude reference of the real problem, and its replay from the seed.

Where the expected numbers come from:

* the linear limit state ``sum(x) / sqrt(d) >= beta`` in N(0, I_d) has ``P = Phi(-beta)`` exactly (a
  standard normal), whatever d; ``max(x_0..x_3) >= t`` has ``1 - Phi(t)^4``: only four of the d
  normals matter, like the pulse's quantiles among the noise;
* the crude reference is ``tests/data/rare_subset_reference.json``: counts of 1e5 runs of the real
  problem (the monolithic Parthenon column under Mw 6.25, 10 km pulse records), made by
  ``bench/rare_subset.py crude`` (its provenance is in the file);
* the chains' correlation factor has a closed form for chains that never move (below).

Why the tolerances: subset simulation is biased by O(1/N) (its thresholds are estimated from the runs
they then condition): for ideal conditional sampling the relative bias is about m (1 - p0) / (N p0)
(Cerou, Del Moral, Furon & Guyader 2012, m the levels: 5 % here), more with correlated chains; with
N = 500 it measured +9 % on both analytic limit states (400 repetitions, bench output in
docs/rare_events.md), a quarter of the CoV. The tests allow 0 to +20 % of bias plus three standard
errors of the mean. The stated CoV is held to within 25 % of the observed spread of the repetitions
(the issue's criterion); with 160 repetitions the observed CoV is itself within [0.9, 1.1] of the true
one at 90 %, so a correct CoV passes with room and one that drops the chains' correlation (Au & Beck's
sum with gamma = 0: 0.66 of the observed here) fails. The stated CoV includes the correlation between levels (genealogical
estimate, pycolfrag.rare.subset_cov); Au & Beck's sum over uncorrelated levels, the stated CoV before,
measured on these same repetitions 0.91 and 0.97 of the observed CoV with interval coverage 0.86 and 0.86
at 1e-3, and 0.79 with coverage 0.84 on the max of four at 1e-5 (N = 200, five to six levels), against
0.95, 1.02 and 0.90 with coverage 0.88, 0.89 and 0.865 now: the coverage floors below (0.87 at 1e-3,
0.85 and a ratio >= 0.85 at 1e-5) pass the correlated CoV and fail the sum. The repetitions' seeds are
fixed, so these are deterministic checks of the numbers measured, not of a probability.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import pycolfrag as pcf
from pycolfrag.core.errors import ParameterError, RareEventError
from pycolfrag.rare import subset as sus

REFERENCE = Path(__file__).parent / "data" / "rare_subset_reference.json"


class Analytic:
    """A limit state of the normals alone: the problem interface of subset_simulation."""

    def __init__(self, d, threshold, fn):
        self.dimension, self.threshold, self.fn = d, threshold, fn

    def run_input(self, x, level, chain, step):
        return {"normals": x, "level": level, "chain": chain, "step": step}

    def score(self, row):
        return sus.score(row, "u_top")

    def evaluate(self, batch):
        return [{"status": 0, "collapsed": 0, "u_top": self.fn(b["normals"]), "level": b["level"],
                 "chain": b["chain"], "step": b["step"]} for b in batch]


def _linear(d, beta):
    return Analytic(d, beta, lambda x: float(np.sum(x)) / math.sqrt(d))


def _max4(d, t):
    return Analytic(d, t, lambda x: float(np.max(x[:4])))


def _repeat(problem, reps, n=500):
    out = [sus.subset_simulation(problem, problem.evaluate, seed=1000 + r, n=n) for r in range(reps)]
    return np.array([r.probability for r in out]), np.array([r.cov for r in out]), out


@pytest.mark.parametrize("make, t, p_true", [
    (_linear, 3.09, stats.norm.sf(3.09)),
    (_max4, 3.48, 1.0 - stats.norm.cdf(3.48) ** 4),
])
def test_estimate_and_stated_cov_against_known_probability(make, t, p_true):
    reps = 160
    ps, covs, results = _repeat(make(300, t), reps)
    mean, observed = ps.mean(), ps.std(ddof=1) / ps.mean()
    se = observed / math.sqrt(reps)
    assert -3 * se <= mean / p_true - 1 <= 0.20 + 3 * se, (mean, p_true)
    stated = math.sqrt(np.mean(covs ** 2))
    assert abs(stated / observed - 1) <= 0.25, (stated, observed)
    # the runs: N at level 0 and N (1 - p0) per further level; p = 1e-3 = p0^3 lies on the border of
    # three and four levels (the last needs a fraction >= p0 above the threshold)
    assert all(r.runs == 500 + (len(r.levels) - 1) * 450 and r.converged for r in results)
    assert {len(r.levels) for r in results} == {3, 4}
    # the stated 90 % interval holds the truth in most repetitions (the O(1/N) bias makes it hold a little
    # less than 90 %: 0.88 and 0.89 measured; Au & Beck's sum over uncorrelated levels: 0.86 and 0.86)
    cover = np.mean([r.interval[0] <= p_true <= r.interval[1] for r in results])
    assert cover >= 0.87, cover


def test_stated_cov_with_many_levels():
    """p = 1e-5 on the max of four normals among 300, N = 200 (20 chains, five to six levels, where the
    levels' correlation weighs most): stated / observed 0.90 and coverage 0.865 measured (Au & Beck's
    sum: 0.79 and 0.84; module docstring)."""
    t = 4.4
    p_true = 1.0 - stats.norm.cdf(t) ** 4
    ps, covs, results = _repeat(_max4(300, t), 200, n=200)
    observed = ps.std(ddof=1) / ps.mean()
    stated = math.sqrt(np.mean(covs ** 2))
    assert 0.85 <= stated / observed <= 1.25, (stated, observed)
    cover = np.mean([r.interval[0] <= p_true <= r.interval[1] for r in results])
    assert cover >= 0.85, cover


def test_lower_levels_of_the_same_runs():
    """``at(t)``: P(sum/sqrt(d) >= t) for t below the level asked, from the same runs, within its own CoV
    (z = 3) of Phi(-t); above the levels reached it is refused."""
    res = sus.subset_simulation(_linear(300, 3.5), _linear(300, 3.5).evaluate, seed=5, n=500)
    for t in (1.0, 2.0, 2.8, 3.5):
        p, cov = res.at(t)
        assert abs(math.log(p / stats.norm.sf(t))) <= 3 * cov, (t, p, cov)
    assert res.at(3.5) == (res.probability, res.cov)
    with pytest.raises(ParameterError, match="above the level"):
        res.at(3.6)


def test_gamma_closed_forms():
    """Chains that never move: every state of a chain equals its first, R_k = R_0 for all lags, so Au &
    Beck's factor is 2 sum_{k=1}^{Ns-1} (1 - k/Ns) = Ns - 1 (9 for 10 states); independent states give
    about 0 (|gamma| below 4 sd of its sampling error, sqrt(2 Ns / N) scale: 0.5 here)."""
    rng = np.random.default_rng(0)
    first = (rng.random(50) < 0.3).astype(float)
    assert sus._gamma(np.tile(first, (10, 1))) == pytest.approx(9.0, abs=1e-12)
    assert abs(sus._gamma((rng.random((10, 50)) < 0.3).astype(float))) < 0.5
    assert sus._gamma(np.zeros((10, 50))) == 0.0


class _Lv:
    def __init__(self, scores, eves, next_threshold):
        self.scores, self.eves, self.next_threshold = np.asarray(scores, float), np.asarray(eves), next_threshold


def test_genealogical_cov_by_hand():
    """Three levels, indicators chosen (threshold 0.5 on 0/1 scores): level 0 runs [1, 1, 0, 0] (p = 1/2,
    each run its own eve); level 1, chains (columns) from eves [0, 1]: [[1, 0], [1, 0]] (p = 1/2); level 2
    from eves [0, 1]: the same. Each term is (indicator - p) / (N p) = +-1/4 per state, so eve 0 sums
    1/4 + 2/4 + 2/4 = 5/4, eve 1 1/4 - 2/4 - 2/4 = -3/4, eves 2 and 3 -1/4: sum of squares
    (25 + 9 + 1 + 1)/16 = 2.25. Au & Beck's sum: 1/4 at level 0, (1/4)(1 + gamma) with gamma = Ns - 1 = 1
    (chains that never move) at levels 1 and 2: 1.25; their bound (1/2 + 2 sqrt(1/2))^2. Eve 0's family
    succeeds on every level: the levels are positively correlated, the variance above the uncorrelated
    sum. With level 2's successes in the other family (its chains from eves [1, 0]) they are negatively
    correlated: eves 0 and 1 sum 1/4 + 2/4 - 2/4 = 1/4 each, so 4/16 = 0.25, below the sum."""
    from pycolfrag.rare.subset_cov import correlated_bound_cov2, genealogy_cov2, uncorrelated_cov2
    lv0 = _Lv([1, 1, 0, 0], np.arange(4), 0.5)
    lv1 = _Lv([[1, 0], [1, 0]], [0, 1], 0.5)
    assert genealogy_cov2([lv0, lv1, _Lv([[1, 0], [1, 0]], [0, 1], 0.5)]) == 2.25
    assert genealogy_cov2([lv0, lv1, _Lv([[1, 0], [1, 0]], [1, 0], 0.5)]) == 0.25
    assert genealogy_cov2([lv0]) == 0.25 == (1 - 0.5) / (4 * 0.5)              # level 0 alone: binomial
    assert genealogy_cov2([lv0, lv1], thresholds=[0.5, 2.0]) == math.inf       # a fraction of 0
    covs = [0.5, math.sqrt(0.5), math.sqrt(0.5)]
    assert uncorrelated_cov2(covs) == pytest.approx(1.25, rel=1e-15)
    assert correlated_bound_cov2(covs) == pytest.approx((0.5 + 2 * math.sqrt(0.5)) ** 2, rel=1e-15)


def test_stated_cov_is_the_genealogical_one():
    """The result states sqrt(exp(V) - 1), V the genealogical variance of ln P (its interval then
    P exp(-/+ z sqrt(V))), keeps Au & Beck's sum as ``cov_uncorrelated``; the eves are the level-0 runs
    the chains descend from (level 1's: the N p0 best runs of level 0)."""
    from pycolfrag.rare.subset_cov import genealogy_cov2
    prob = _linear(50, 3.0)
    res = sus.subset_simulation(prob, prob.evaluate, seed=4, n=200)
    v = genealogy_cov2(res.levels)
    assert res.cov == pytest.approx(math.sqrt(math.expm1(v)), rel=1e-12)
    assert res.interval[1] / res.probability == pytest.approx(math.exp(1.6448536269514722 * math.sqrt(v)), rel=1e-12)
    assert res.cov_uncorrelated == pytest.approx(math.sqrt(sum(lv.cov ** 2 for lv in res.levels)), rel=1e-15)
    top = np.argsort(-res.levels[0].scores, kind="stable")[:20]
    assert list(res.levels[1].eves) == list(top)
    assert all(set(lv.eves) <= set(top) for lv in res.levels[1:])


def test_lognormal_interval():
    """p exp(-/+ 1.6449 sqrt(ln(1 + CoV^2))): for p = 1e-3, CoV 0.3, s = 0.293560, exp(1.64485 s) =
    1.62071, so [6.1701e-4, 1.62071e-3] (hand-evaluated); the 95 % interval uses z = 1.95996."""
    lo, hi = sus.lognormal_interval(1e-3, 0.3)
    s = math.sqrt(math.log(1.09))
    assert lo == pytest.approx(1e-3 * math.exp(-1.6448536269514722 * s), rel=1e-13)
    assert hi == pytest.approx(1e-3 * math.exp(1.6448536269514722 * s), rel=1e-13)
    assert lo == pytest.approx(6.1701e-4, rel=1e-4) and hi == pytest.approx(1.62071e-3, rel=1e-5)
    assert sus.lognormal_interval(1e-3, 0.3, 0.95)[1] == pytest.approx(1e-3 * math.exp(1.959963984540054 * s))
    assert sus.lognormal_interval(0.0, math.inf) == (0.0, math.inf)


# ------------------------------------------------------------------------------ the real problem
def _problem(threshold):
    return sus.SubsetProblem(pcf.Column.parthenon(), 6.25, 10.0, threshold=threshold,
                             solver_options={"monolithic": True})


def _same(a, b) -> bool:
    """Bitwise the same value (NaN equals NaN; arrays element by element; strings and ints by ==)."""
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return np.array_equal(np.asarray(a, dtype=float).view(np.uint64), np.asarray(b, dtype=float).view(np.uint64))


def test_tiny_real_problem_replays_bitwise():
    """N = 20 (2 chains of 10 states) to u_top >= 0.35 on the solver: the same seed gives the same rows bit
    for bit, serially and over two processes; a row is the run of its input alone; another seed differs;
    crude Monte Carlo's run i is level 0's run i."""
    prob = _problem(0.35)
    a = sus.subset_simulation(prob, seed=11, n=20)
    b = sus.subset_simulation(prob, seed=11, n=20)
    assert a.runs == 20 + 18 * (len(a.levels) - 1) and len(a.levels) >= 2
    with sus.PoolEvaluator(2) as pool:
        c = sus.subset_simulation(prob, pool, seed=11, n=20)
    for other in (b, c):
        assert (other.probability, other.cov, other.interval) == (a.probability, a.cov, a.interval)
        assert len(other.rows) == len(a.rows)
        for ra, ro in zip(a.rows, other.rows):
            assert ra.keys() == ro.keys() and all(_same(ra[k], ro[k]) for k in ra), (ra, ro)
    i = 7
    x = sus.run_normals(11, (0, i, 0), prob.dimension)
    alone = sus.run_batch([prob.run_input(x, 0, i, 0)])[0]
    assert all(_same(alone[k], a.rows[i][k]) for k in alone)
    assert sus.crude_monte_carlo(prob, seed=11, n=3, start=6)[1] == a.rows[i]["score"]
    assert sus.subset_simulation(prob, seed=12, n=20).probability != a.probability or \
        sus.subset_simulation(prob, seed=12, n=20).rows[0]["u_top"] != a.rows[0]["u_top"]


def test_real_problem_against_the_crude_reference():
    """u_top >= 0.6 (p about 7e-3 from the 1e5 crude runs; three levels at N = 200) and, from the same
    runs, u_top >= 0.35 (about 5.5e-2): each within 2.58 of their combined sd on the log scale
    (sqrt(CoV_SuS^2 + CoV_crude^2); 99 %, one fixed seed: a correct estimate fails 1 time in 100)."""
    ref = json.loads(REFERENCE.read_text())
    n_ref = ref["n"]
    res = sus.subset_simulation(_problem(0.6), seed=3, n=200)
    for t, key in ((0.6, "u_top>=0.6"), (0.35, "u_top>=0.35")):
        k = ref["counts"][key]
        p_crude, cov_crude = k / n_ref, math.sqrt((1 - k / n_ref) / k)
        p, cov = res.at(t)
        assert abs(math.log(p / p_crude)) <= 2.58 * math.sqrt(cov ** 2 + cov_crude ** 2), (t, p, p_crude, cov)
    assert res.failed == 0 and all(r["status"] == 0 for r in res.rows)


# ------------------------------------------------------------------------------ refusals
def test_bad_settings_are_refused():
    prob = _linear(10, 2.0)
    for kw, word in (({"n": 505}, "whole number of chains"), ({"p0": 0.0}, "p0 must be"), ({"p0": 0.7}, "p0 must be"),
                     ({"n": 10}, "n must be"), ({"seed": -1}, "seed"), ({"max_levels": 0}, "max_levels"),
                     ({"confidence": 1.0}, "confidence")):
        args = {"seed": 1, **kw}
        with pytest.raises(ParameterError, match=word):
            sus.subset_simulation(prob, prob.evaluate, **args)
    col = pcf.Column.parthenon()
    with pytest.raises(ParameterError, match="edp must be one of"):
        sus.SubsetProblem(col, 6.25, 10.0, edp="pga_g")
    with pytest.raises(ParameterError, match="threshold must be > 0"):
        sus.SubsetProblem(col, 6.25, 10.0, threshold=0.0)
    with pytest.raises(ParameterError, match="Mw"):
        sus.SubsetProblem(col, 9.0, 10.0)
    with pytest.raises(ParameterError, match="unknown pulse shape"):
        sus.SubsetProblem(col, 6.25, 10.0, shape="ricker")


def test_an_evaluator_that_loses_rows_or_a_level_that_cannot_rise():
    prob = _linear(10, 2.0)
    with pytest.raises(RareEventError, match="returned 19 rows for a batch of 20"):
        sus.subset_simulation(prob, lambda batch: prob.evaluate(batch)[:-1], seed=1, n=20)
    flat = Analytic(10, 2.0, lambda x: 1.0)          # every run scores the same: no level above it
    with pytest.raises(RareEventError, match="stopped rising at level 1"):
        sus.subset_simulation(flat, flat.evaluate, seed=1, n=20)


def test_failed_runs_are_counted_and_never_exceed():
    """A run whose row failed scores -inf: never in a failure domain, counted in ``failed``."""
    prob = _linear(10, 1.0)

    def evaluate(batch):
        rows = prob.evaluate(batch)
        for r, b in zip(rows, batch):
            if b["normals"][0] > 1.5:                  # P = 0.067 of the runs fail
                r["status"] = 3
        return rows

    res = sus.subset_simulation(prob, evaluate, seed=2, n=200)
    bad = [r for r in res.rows if r["status"] != 0]
    assert res.failed == len(bad) > 0 and all(r["score"] == -math.inf for r in bad)
    assert sus.score({"status": 0, "collapsed": 1, "u_top": 0.1}, "u_top") == math.inf
    assert sus.score({"status": 0, "collapsed": 0, "u_d": math.nan}, "u_d") == -math.inf
