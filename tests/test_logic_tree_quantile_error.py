"""The estimation error of a tree's quantiles and mean by resampling each branch's estimate from its sd
(pycolfrag/risk/tree_quantile_error.py; docs/logic_tree.md).

Expected numbers are the cases where the answer is known without the resampling: sd 0 gives 0 exactly (the
lognormal of sd 0 is its mean, x exp(0)); a tree of one branch has every quantile equal to that branch's
estimate, so every quantile's sd is the branch's sd; two branches far apart with weights 1/2 have the median at
the lower one (OpenQuake's rule: cumulative weights 0.5, 1), so the median's sd is the lower branch's; the mean's
sd is sqrt(Sum w^2 s^2) for independent draws and Sum w s for fully correlated ones (the larger stated); a
quantile between two branches' values, x1 + f (x2 - x1), has sd sqrt((1-f)^2 s1^2 + f^2 s2^2) independent and
(1-f) s1 + f s2 correlated. Tolerance 8 % relative:
the sd of a sample sd of n = 4000 lognormal draws of CoV 0.1 is about 1.2 %, so 8 % is over 6 of its sds.
"""
import math

import numpy as np
import pytest

from pycolfrag.risk.tree_quantile_error import quantile_errors
from pycolfrag.risk.tree_stats import QUANTILES


def test_no_estimation_error_gives_zero_exactly():
    d = quantile_errors([1e-5, 3e-5, 2e-5], [0.0, 0.0, 0.0], [0.2, 0.5, 0.3])
    assert all(v == 0.0 for v in d["sd"].values()) and d["mean_sd"] == 0.0


def test_one_branch_every_quantile_has_the_branch_sd():
    d = quantile_errors([1e-4], [1e-5], [1.0], n=4000)
    for q in QUANTILES:
        assert d["independent"][q] == pytest.approx(1e-5, rel=0.08), q
        assert d["sd"][q] == pytest.approx(1e-5, rel=0.08), q


def test_two_branches_median_and_mean():
    x, s, w = np.array([1e-5, 5e-5]), np.array([1e-6, 4e-6]), np.array([0.5, 0.5])
    d = quantile_errors(x, s, w, n=4000)
    assert d["independent"][0.5] == pytest.approx(1e-6, rel=0.08)
    # 95 %: x1 + 0.9 (x2 - x1) (cumulative weights 0.5, 1): independent draws give sqrt(0.1^2 s1^2 + 0.9^2 s2^2)
    assert d["independent"][0.95] == pytest.approx(math.hypot(0.1 * s[0], 0.9 * s[1]), rel=0.08)
    assert d["correlated"][0.95] == pytest.approx(0.1 * s[0] + 0.9 * s[1], rel=0.08)
    assert d["mean_sd"] == pytest.approx(float(w @ s), rel=0.08)          # the larger: fully correlated, Sum w s
    assert d["mean_sd"] > math.sqrt(float((w ** 2) @ (s ** 2)))


def test_a_branch_without_an_sd_leaves_the_errors_unstated():
    d = quantile_errors([1e-5, 2e-5], [1e-6, math.nan], [0.5, 0.5])
    assert math.isnan(d["mean_sd"]) and all(math.isnan(v) for v in d["sd"].values())


def test_same_seed_same_numbers():
    a = quantile_errors([1e-5, 2e-5], [1e-6, 3e-6], [0.4, 0.6])
    assert a == quantile_errors([1e-5, 2e-5], [1e-6, 3e-6], [0.4, 0.6])
