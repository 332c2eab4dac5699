"""The rare route's batches as pieces (pycolfrag.rare.estimate ``pieces``, .allocation ``piece_allocation``; v5).

Where the expected numbers come from:

* an allocation that reads the outcomes (a stratum hit in the first batch gets more of the second) leaves every
  batch a stratified sample of counts fixed before it runs, so each batch's stratum mean is unbiased given the
  past and a combination with weights fixed in advance (the batches' sizes) is unbiased -- a martingale argument
  (docs/rare_events.md, "Batches as pieces"). Checked exactly, by enumerating every outcome of a two-stratum
  design of Bernoulli runs: the expectation of the pieces' estimate is sum_h W_h p_h to round-off, while that of
  the pooled means (v4's) is below it, computed here by plain loops over the same outcomes;
* the pieces' factors and design effect written out by hand for a small stratum: a_b the batch's share of all
  finished runs, f = a_b n / n_b, deff = n_ok sum_b a_b^2 / n_ok,b (the variance of sum_b a_b mean_b with a common
  per-run variance s^2 is s^2 sum_b a_b^2 / n_b); the stated variance sum_b a_b^2 s_b^2 / n_b of the batches' own
  sample variances, whose expectation over every outcome of the design is the estimate's true variance exactly
  (each s_b^2 unbiased given the batches before, its counts fixed), where a variance pooled over the batches is low;
* with one batch the pieces are the pooled mean, bit for bit.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from pycolfrag.rare import allocation
from pycolfrag.rare.estimate import estimate, piece_factors, piece_weights
from pycolfrag.rare.proposal import Design
from test_rare_floor import _Q, _Strata  # the floor tests' level and two no-pulse strata of rates 1 and 9 /yr


def _cols(h, stage, y):
    n = len(h)
    return {"status": np.zeros(n, np.int32), "stratum": np.asarray(h), "stage": np.asarray(stage),
            "index": np.arange(n), "occurrence_weight": np.ones(n), "z_vp": np.full(n, np.nan),
            "z_fp": np.full(n, np.nan), "collapsed": np.asarray(y, np.uint8), "pulse": np.zeros(n, np.uint8)}


P = (0.3, 0.1)            # each stratum's exceedance probability per run
FIRST, SECOND = 2, 6      # the first batch's runs per stratum; the second batch's size


def _second_batch(hits0):
    """The outcome-reading allocation: of the second batch's 6 runs, 4 to the stratum hit in the first batch when
    only one is, else 3 each."""
    if (hits0[0] > 0) == (hits0[1] > 0):
        return 3, 3
    return (4, 2) if hits0[0] > 0 else (2, 4)


def _outcomes():
    """Every outcome of the design with its probability: (rows' strata, stages, outcomes, probability)."""
    for y0 in itertools.product((0, 1), repeat=2 * FIRST):
        hits0 = (sum(y0[:FIRST]), sum(y0[FIRST:]))
        n1 = _second_batch(hits0)
        for y1 in itertools.product((0, 1), repeat=SECOND):
            h = [0] * FIRST + [1] * FIRST + [0] * n1[0] + [1] * n1[1]
            stage = [0] * (2 * FIRST) + [1] * SECOND
            y = list(y0) + list(y1)
            prob = math.prod(P[s] if v else 1 - P[s] for s, v in zip(h, y))
            yield h, stage, y, prob


def test_an_allocation_that_reads_the_outcomes_leaves_the_pieces_unbiased_and_the_pooled_means_low():
    lam = float(_Strata.rates @ np.array(P))                 # 1.2 /yr
    e_pieces = e_pooled = e_hand = total = 0.0
    for h, stage, y, prob in _outcomes():
        cols = _cols(h, stage, y)
        e_pieces += prob * estimate(cols, _Strata(), Design(), [_Q()], pieces=True).levels["collapse"].rate
        e_pooled += prob * estimate(cols, _Strata(), Design(), [_Q()]).levels["collapse"].rate
        # the pooled means by plain loops: every stratum's hits over its rows
        e_hand += prob * sum(_Strata.rates[s] * sum(v for hh, v in zip(h, y) if hh == s) / h.count(s) for s in (0, 1))
        total += prob
    assert total == pytest.approx(1.0, abs=1e-12)
    assert e_pieces == pytest.approx(lam, rel=1e-12)
    assert e_pooled == pytest.approx(e_hand, rel=1e-12)
    assert e_pooled == pytest.approx(1.128276, rel=1e-6)       # v4's pooled means: -6.0 %, below lambda by 0.0717


def test_the_pieces_factors_and_design_effect_by_hand():
    # a stratum of 3 pilot rows (stage 0) and 5 of batch 1, one of them failed; all finished runs: 10 of stage 0,
    # 30 of stage 1 (a_0 = 1/4, a_1 = 3/4)
    a = piece_weights([0] * 10 + [1] * 30)
    assert a == {0: 0.25, 1: 0.75}
    stage = np.array([0, 0, 0, 1, 1, 1, 1, 1])
    failed = np.array([False] * 7 + [True])
    f, deff = piece_factors(stage, failed, a)
    assert f.tolist() == pytest.approx([0.25 * 8 / 3] * 3 + [0.75 * 8 / 5] * 5, rel=1e-15)
    assert deff == pytest.approx(7 * (0.25 ** 2 / 3 + 0.75 ** 2 / 4), rel=1e-15)
    # a stratum that missed batch 1 (a prefix cut by the budget): its batches' weights rescaled to sum to 1
    f, deff = piece_factors(np.array([0, 0, 0]), np.zeros(3, bool), a)
    assert f is None and deff == 1.0


def test_with_one_batch_the_pieces_are_the_pooled_means_bit_for_bit():
    rng = np.random.default_rng(3)
    h = rng.integers(0, 2, 40)
    cols = _cols(h, np.zeros(40, int), rng.random(40) < 0.3)
    one = estimate(cols, _Strata(), Design(), [_Q()]).levels["collapse"]
    pieces = estimate(cols, _Strata(), Design(), [_Q()], pieces=True).levels["collapse"]
    assert one.as_dict() == pieces.as_dict()


def test_the_stated_variance_is_the_pieces_variance():
    """The CoV with pieces: sum_h W_h^2 sum_b a_b^2 s_hb^2 / n_hb, s_hb^2 the sample variance of batch b's rows of
    stratum h (plain loops)."""
    h = [0] * 4 + [1] * 4 + [0] * 10 + [1] * 2
    stage = [0] * 8 + [1] * 12
    y = [1, 0, 0, 0, 0, 1, 0, 0] + [1, 1, 0, 0, 0, 0, 0, 1, 0, 0] + [0, 1]
    e = estimate(_cols(h, stage, y), _Strata(), Design(), [_Q()], pieces=True).levels["collapse"]
    a = (8 / 20, 12 / 20)
    lam = var = 0.0
    for s in (0, 1):
        for b in (0, 1):
            yb = [v for hh, st, v in zip(h, stage, y) if hh == s and st == b]
            m = sum(yb) / len(yb)
            lam += _Strata.rates[s] * a[b] * m
            var += _Strata.rates[s] ** 2 * a[b] ** 2 * sum((v - m) ** 2 for v in yb) / (len(yb) - 1) / len(yb)
    assert e.rate == pytest.approx(lam, rel=1e-12)
    assert e.cov == pytest.approx(math.sqrt(var) / lam, rel=1e-12)


def test_the_stated_variance_is_unbiased_where_a_pooled_one_is_low():
    """Over every outcome of the outcome-reading design: the expectation of the stated variance (the pieces' own
    sample variances) is the estimate's true variance E[lambda^2] - lambda^2, to round-off; a per-run variance
    pooled over the batches (the stratum's s^2 x sum_b a_b^2 / n_hb, plain loops) is low -- its rows' counts follow
    the outcomes, the flaw the pieces mend in the mean."""
    lam = float(_Strata.rates @ np.array(P))
    e2 = e_var = e_pooled = 0.0
    for h, stage, y, prob in _outcomes():
        est = estimate(_cols(h, stage, y), _Strata(), Design(), [_Q()], pieces=True).levels["collapse"]
        e2 += prob * est.rate ** 2
        e_var += prob * ((est.cov * est.rate) ** 2 if est.rate > 0 else 0.0)   # no hit: CoV infinite, variance 0
        pooled = 0.0
        for s in (0, 1):
            ys = [v for hh, v in zip(h, y) if hh == s]
            n_b = [sum(1 for hh, st in zip(h, stage) if hh == s and st == b) for b in (0, 1)]
            m = sum(ys) / len(ys)
            s2 = sum((v - m) ** 2 for v in ys) / (len(ys) - 1)
            pooled += _Strata.rates[s] ** 2 * s2 * ((2 * FIRST / 10) ** 2 / n_b[0] + (SECOND / 10) ** 2 / n_b[1])
        e_pooled += prob * pooled
    true_var = e2 - lam ** 2
    assert e_var == pytest.approx(true_var, rel=1e-9)
    assert e_pooled == pytest.approx(0.87544 * true_var, rel=1e-4)     # measured by these loops: 12.5 % low


def test_a_batch_gives_every_stratum_its_floor_and_the_rest_by_neyman():
    W = np.array([1.0, 2.0, 0.01, 5.0])
    var = np.array([[1.0], [4.0], [1e-6], [0.0]])
    mean = np.array([[0.1], [0.3], [1e-6], [0.0]])
    lam = W @ mean
    n = allocation.piece_allocation(W, var, lam, mean, used=100, size=40)
    assert n.sum() == 40 and n.min() >= allocation.PIECE_MIN_RUNS
    floor = allocation.piece_floor(W, mean, 100, 40)
    # ceil(20 x 40 / 140) = 6 where a stratum matters (1 % of the rate or of the level), 2 elsewhere
    assert floor.tolist() == [6, 6, 2, 6] and np.all(n >= floor)
    # n_h = max(floor_h, kappa W_h sigma_h), W_h sigma_h = 1, 4, 1e-5, 0: the last two at their floors, kappa =
    # (40 - 2 - 6) / 5 = 6.4, n = (6.4, 25.6, 2, 6), rounded by largest remainder
    assert n.tolist() == [6, 26, 2, 6]
    with pytest.raises(ValueError, match="cannot give each of 4 strata 2"):
        allocation.piece_allocation(W, var, lam, mean, used=100, size=7)
