"""Statistics over a logic tree (pycolfrag/risk/tree_stats.py; docs/logic_tree.md, "Statistics").

The surrogate: two branch sets whose end branches have exact rates lambda = lambda0 a b, a in {1, 2} with
weights (0.3, 0.7), b in {1, 3, 10} with weights (0.5, 0.25, 0.25), lambda0 = 1e-4. Every expected number
below is worked out by hand from these (written next to it); the tolerance 1e-12 relative is round-off of
sums of six terms (each exact number here has a short decimal form that binary floats carry to ~1e-16).
"""
import math

import numpy as np
import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.risk import logic_tree as lt
from pycolfrag.risk import tree_stats as ts

LAM0 = 1e-4
TREE = lt.tree_from_dict({"branch_sets": [
    {"name": "a", "choice": "rate_factor", "branches": [{"value": 1.0, "weight": 0.3}, {"value": 2.0, "weight": 0.7}]},
    {"name": "b", "choice": "vp_scale", "branches": [{"value": 1.0, "weight": 0.5}, {"value": 3.0, "weight": 0.25},
                                                     {"value": 10.0, "weight": 0.25}]}]})
ENDS = TREE.end_branches()
W = np.array([e.weight for e in ENDS])
IDX = np.array([e.index for e in ENDS])
SETS = [(s.name, len(s.branches)) for s in TREE.branch_sets]
NAMES = [[b.name for b in s.branches] for s in TREE.branch_sets]
LAM = np.array([LAM0 * e.branches[0].value * e.branches[1].value for e in ENDS])   # lambda0 x [1, 3, 10, 2, 6, 20]


def test_surrogate_mean_and_quantiles_are_exact_to_round_off():
    """Mean: lambda0 E[a] E[b] = lambda0 (0.3 + 1.4)(0.5 + 0.75 + 2.5) = 6.375 lambda0.
    Quantiles (OpenQuake's rule): sorted values lambda0 x (1, 2, 3, 6, 10, 20) with weights (0.15, 0.35, 0.075,
    0.175, 0.075, 0.175), cumulative (0.15, 0.5, 0.575, 0.75, 0.825, 1). q = 0.05 < 0.15: the first value, 1;
    q = 0.16: 1 + 0.01/0.35 = 1.0285714...; q = 0.5: at the second point, 2; q = 0.84: 10 + 10 x 0.015/0.175 =
    10.857142...; q = 0.95: 10 + 10 x 0.125/0.175 = 17.142857..."""
    assert LAM.tolist() == pytest.approx([LAM0 * x for x in (1, 3, 10, 2, 6, 20)], rel=1e-15)
    assert ts.weighted_mean(LAM, W) == pytest.approx(6.375 * LAM0, rel=1e-12)
    expected = {0.05: 1.0, 0.16: 1.0 + 0.01 / 0.35, 0.5: 2.0, 0.84: 10.0 + 10.0 * 0.015 / 0.175,
                0.95: 10.0 + 10.0 * 0.125 / 0.175}
    got = ts.quantiles(LAM, W)
    assert set(got) == set(ts.QUANTILES)
    for q, x in expected.items():
        assert got[q] == pytest.approx(x * LAM0, rel=1e-12), q


def test_surrogate_variance_split_and_tornado_by_hand():
    """In lambda0^2: E[lambda^2] = E[a^2] E[b^2] = 3.1 x 27.75 = 86.025, minus 6.375^2 = 40.640625: 45.384375.
    Main effect of a: conditional means 3.75 and 7.5 (weights 0.3, 0.7): 0.3 x 2.625^2 + 0.7 x 1.125^2 =
    2.953125. Of b: 1.7, 5.1, 17 (0.5, 0.25, 0.25): 0.5 x 4.675^2 + 0.25 x 1.275^2 + 0.25 x 10.625^2 =
    39.5569375. Interaction: 45.384375 - 2.953125 - 39.5569375 = 2.8743125. Tornado: b swings 17 - 1.7 =
    15.3, a 7.5 - 3.75 = 3.75: b first."""
    sp = ts.variance_split(LAM, W, IDX, SETS, estimation_var=np.full(6, 4e-10))
    assert sp.epistemic == pytest.approx(45.384375 * LAM0 ** 2, rel=1e-12)
    assert sp.per_set["a"] == pytest.approx(2.953125 * LAM0 ** 2, rel=1e-12)
    assert sp.per_set["b"] == pytest.approx(39.5569375 * LAM0 ** 2, rel=1e-12)
    assert sp.interaction == pytest.approx(2.8743125 * LAM0 ** 2, rel=1e-10)
    assert sp.estimation == pytest.approx(4e-10, rel=1e-15) and sp.total == pytest.approx(sp.epistemic + 4e-10)
    bars = ts.tornado(LAM, W, IDX, SETS, NAMES)
    assert [b["set"] for b in bars] == ["b", "a"]
    assert (bars[0]["low_branch"], bars[0]["high_branch"]) == ("1", "10")
    assert bars[0]["low"] == pytest.approx(1.7 * LAM0, rel=1e-12) and bars[0]["high"] == pytest.approx(17 * LAM0, rel=1e-12)
    assert bars[0]["swing"] == pytest.approx(15.3 * LAM0, rel=1e-12)
    assert bars[1]["swing"] == pytest.approx(3.75 * LAM0, rel=1e-12) and bars[1]["missing"] == []


def test_a_tree_of_identical_branches_gives_the_one_branch_value_exactly():
    """Every branch the same value, six branches of weight 1/6 (a sampled tree of six): the mean and every
    quantile are that value bit for bit (numpy.average's sum x/6 + ... + x/6 over the summed weights misses
    4.36e-6 and 0.3 by an ulp), the variances 0 and every swing 0."""
    x = np.array([4.36e-6, 0.3])
    v = np.tile(x, (6, 1))
    w = np.full(6, 1 / 6)
    assert np.array_equal(ts.weighted_mean(v, w), x)
    for q in ts.QUANTILES:
        assert np.array_equal(ts.weighted_quantile(q, v, w), x)
    idx = np.arange(6)[:, None]
    sp = ts.variance_split(v, w, idx, [("s", 6)])
    assert np.all(sp.epistemic == 0) and np.all(sp.per_set["s"] == 0) and np.all(sp.interaction == 0)
    assert ts.tornado(v[:, 0], w, idx, [("s", 6)])[0]["swing"] == 0.0


def test_equal_weights_interpolate_at_i_over_n():
    """OpenQuake's note: with equal weights the quantile is numpy.interp(q, [1/N, ..., N/N], sorted values);
    its doctest: quantile 0.8 of (.15, .25, .3, .4, .5, .6, .75, .8, .9) is 0.76."""
    arr = np.array([.15, .25, .3, .4, .5, .6, .75, .8, .9])
    assert ts.weighted_quantile(0.8, arr[::-1], np.full(9, 1 / 9)) == pytest.approx(0.76, rel=1e-12)


def test_the_estimation_sd_of_the_mean_independent_or_shared_runs():
    """sd 1 and 2 with weights 0.25, 0.75: independent sqrt(0.0625 + 2.25) = 1.5207, shared runs (full
    correlation bound) 0.25 + 1.5 = 1.75."""
    assert ts.mean_estimation_sd([1.0, 2.0], [0.25, 0.75], correlated=False) == pytest.approx(math.sqrt(2.3125))
    assert ts.mean_estimation_sd([1.0, 2.0], [0.25, 0.75], correlated=True) == 1.75


@pytest.mark.parametrize("call, match", [
    (lambda: ts.weighted_mean([1.0, 2.0], [0.5, 0.6]), "sum to 1.1"),
    (lambda: ts.weighted_mean([1.0, 2.0], [1.0]), "2 values need 2 weights"),
    (lambda: ts.weighted_mean([1.0, np.nan], [0.5, 0.5]), "finite"),
    (lambda: ts.weighted_quantile(1.5, [1.0], [1.0]), "got 1.5"),
    (lambda: ts.weighted_mean([1.0, 2.0], [1.5, -0.5]), r"> 0, got \[1.5, -0.5\]"),
    (lambda: ts.variance_split([1.0, 2.0], [0.5, 0.5], [[0], [2]], [("s", 2)]), "index must"),
])
def test_bad_statistics_input_is_refused(call, match):
    with pytest.raises(ParameterError, match=match):
        call()


def test_quantiles_agree_with_openquake():
    """openquake.hazardlib.stats.quantile_curve and mean_curve on the same numbers (random values and weights,
    curves of 7 levels); skipped where OpenQuake is not installed (docs/risk.md, "Installing OpenQuake")."""
    oq = pytest.importorskip("openquake.hazardlib.stats")
    rng = np.random.default_rng(3)
    v = rng.lognormal(-9.0, 1.0, (13, 7))
    w = rng.random(13)
    w /= w.sum()
    w[-1] = 1.0 - math.fsum(w[:-1].tolist())
    for q in ts.QUANTILES:
        np.testing.assert_allclose(ts.weighted_quantile(q, v, w), oq.quantile_curve(q, v, w), rtol=1e-14)
    np.testing.assert_allclose(ts.weighted_mean(v, w), oq.mean_curve(v, w), rtol=1e-13)
