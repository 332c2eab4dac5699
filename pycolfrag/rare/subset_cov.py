"""The CoV of a subset-simulation estimate with the correlation between its levels (docs/rare_events.md,
"Precision: the stated CoV, the interval, the bias").

Au & Beck (2001, Eqs. 27-29) give each level's CoV delta_j (its chains' correlation in gamma_j) and
then bound the estimate's: ``sum_j delta_j^2 <= delta^2 <= sum_i sum_j delta_i delta_j``, the sum on the
left treating the levels' fractions as uncorrelated, the one on the right as fully correlated. Neither
is right: the chains of level j + 1 start from level j's states above its threshold, so a level's
fraction and the next level's move together, and the left sum understates the spread (0.85-0.98 of
it over 400 repetitions of a limit state with exact P) while the right overstates it by up to
sqrt(levels).

The estimate here is the genealogical ("eve") variance estimator of sequential Monte Carlo (Chan &
Lai 2013; Lee & Whiteley 2018), applied to subset simulation as the sequential Monte Carlo method it
is (adaptive multilevel splitting: Cérou & Guyader 2016; Cérou, Del Moral, Furon & Guyader 2012).
Every state of every level descends
from one run of level 0, its *eve* (a chain's seed is a state of the level below; a chain's states all
share its seed's eve). On the log scale, ``ln P = sum_j ln p_j`` and to first order

    ln P^ - ln P = sum_j (p^_j - p_j) / p_j = sum_e Z_e,
    Z_e = sum_j sum_{states s of level j descending from e} (1{g_s >= b_{j+1}} - p^_j) / (N p^_j),

a sum over the N eves of terms that are uncorrelated between eves (level 0's runs are independent, and
all of a family's correlation -- along one chain, and between a level and the levels its states seed --
stays inside its Z_e). So ``delta^2 = sum_e Z_e^2`` (math.fsum), a single run's estimate of the
variance of ln P^, i.e. of the squared CoV. With independent levels and no chain correlation it is
Au & Beck's sum (level 0 alone gives (1 - p_0)/(N p_0) exactly); the chains' correlation enters as the
sum over a chain of its indicators (a batch mean, where Au & Beck's gamma takes the lagged
correlations), and the levels' correlation as the cross terms between a family's levels. Like every
genealogical estimator it sees only the families that survive: when few eves hold the last level it
can fall short (Lee & Whiteley 2018, Sect. 4); it is a first-order (delta-method) estimate like Au &
Beck's and says nothing of the O(1/N) bias.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["genealogy_cov2", "uncorrelated_cov2", "correlated_bound_cov2"]


def _indicators(scores: np.ndarray, threshold: float) -> tuple[np.ndarray, float]:
    ind = (np.asarray(scores) >= threshold).astype(np.float64)
    return ind, math.fsum(ind.ravel()) / ind.size


def genealogy_cov2(levels: Sequence, thresholds: Sequence[float] | None = None) -> float:
    """``sum_e Z_e^2`` (module docstring) over ``levels``: objects with ``scores`` (level 0: the N runs'
    scores, flat; level j >= 1: steps x chains), ``eves`` (level 0: ``arange(N)``; level j: the level-0
    run each chain descends from) and ``next_threshold``; ``thresholds`` replaces the levels'
    ``next_threshold`` (``SubsetResult.at``: the last one lower). ``inf`` when a fraction is 0."""
    ths = [lv.next_threshold for lv in levels] if thresholds is None else list(thresholds)
    n0 = int(np.asarray(levels[0].scores).size)
    z: list[list[float]] = [[] for _ in range(n0)]      # each eve's terms, summed by fsum at the end
    for lv, b in zip(levels, ths):
        ind, p = _indicators(lv.scores, b)
        if p <= 0.0:
            return math.inf
        scale = ind.size * p
        if ind.ndim == 1:                              # level 0: one run per eve
            for e, v in zip(np.asarray(lv.eves), ind):
                z[int(e)].append((float(v) - p) / scale)
        else:                                          # chains: column c descends from eves[c]
            for c, e in enumerate(np.asarray(lv.eves)):
                z[int(e)].extend(((ind[:, c] - p) / scale).tolist())
    return math.fsum(math.fsum(t) ** 2 for t in z)


def uncorrelated_cov2(covs: Sequence[float]) -> float:
    """Au & Beck (2001)'s sum ``sum_j delta_j^2``: the levels' fractions taken as uncorrelated."""
    return math.fsum(c * c for c in covs)


def correlated_bound_cov2(covs: Sequence[float]) -> float:
    """Au & Beck (2001)'s upper bound ``sum_i sum_j delta_i delta_j = (sum_j delta_j)^2``: the levels'
    fractions taken as fully correlated."""
    s = math.fsum(covs)
    return s * s
