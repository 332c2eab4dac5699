"""The estimation error of a logic tree's reported quantiles and mean (docs/logic_tree.md, "The estimation error of
the quantiles"), by resampling each end branch's estimate from its stated standard deviation.

Each branch's estimate x_b with its estimation sd s_b is redrawn as a lognormal of mean x_b and sd s_b (a rate is
> 0; a branch of rate 0 or sd 0 stays as it is), ``n`` times, and the tree's weighted quantiles (OpenQuake's rule,
as :func:`pycolfrag.risk.tree_stats.weighted_quantile`) and mean are taken of every draw; the sd of each over the
draws is its estimation error. How the branches' errors are correlated is not known (they share their events:
common random numbers, re-weighted rows), so the draws are made twice -- independent between branches, and fully
correlated (one normal for every branch) -- and the larger sd of the two is stated. It is a resampling of the
stated errors (a parametric bootstrap), not of the runs: it is as good as the branches' sds (on the grid route
read from their 90 % intervals) and the lognormal form.
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.risk.tree_stats import QUANTILES, weights_of

__all__ = ["N_DRAWS", "quantile_errors"]

#: Draws of each of the two resamplings (the sd of an sd from n draws is uncertain by about 1 / sqrt(2 n): 2 %).
N_DRAWS = 1000


def _draws(x: np.ndarray, sd: np.ndarray, z: np.ndarray) -> np.ndarray:
    """x_b exp(sigma_b z - sigma_b^2 / 2), sigma_b^2 = log(1 + (sd_b / x_b)^2): lognormal of mean x_b, sd sd_b."""
    cov = np.divide(sd, x, out=np.zeros_like(x), where=x > 0)
    sig = np.sqrt(np.log1p(cov ** 2))
    return x * np.exp(sig * z - 0.5 * sig ** 2)


def _stats(draws: np.ndarray, w: np.ndarray, qs) -> np.ndarray:
    """Per draw (rows), the weighted quantiles qs (columns) by OpenQuake's rule, then the weighted mean, as
    deviations from the first draw's (their sd is theirs)."""
    out = np.empty((draws.shape[0], len(qs) + 1))
    q = np.asarray(qs, dtype=float)
    for i, d in enumerate(draws):
        order = np.argsort(d, kind="stable")
        out[i, :-1] = np.interp(q, np.cumsum(w[order]), d[order])
    out[:, -1] = draws @ w
    return out - out[0]          # deviations from the first draw: a statistic that never moves has sd 0 exactly


def quantile_errors(values, sds, weights, qs=QUANTILES, n: int = N_DRAWS, seed: int = 0) -> dict:
    """{"sd": {q: the larger estimation sd of the two resamplings}, "mean_sd": the same of the weighted mean,
    "independent" / "correlated": {q: sd} of each resampling, "n": n}. Every sd is NaN when a branch has no
    finite sd (a refused level)."""
    x = np.asarray(values, dtype=float)
    s = np.asarray(sds, dtype=float)
    w = weights_of(weights, x.shape[0])
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(x))):
        nan = {float(q): math.nan for q in qs}
        return {"sd": nan, "mean_sd": math.nan, "independent": nan, "correlated": nan, "n": int(n)}
    rng = np.random.default_rng(seed)
    ind = _stats(_draws(x, s, rng.standard_normal((n, x.shape[0]))), w, qs).std(axis=0, ddof=1)
    cor = _stats(_draws(x, s, rng.standard_normal((n, 1))), w, qs).std(axis=0, ddof=1)
    big = np.maximum(ind, cor)
    return {"sd": {float(q): float(v) for q, v in zip(qs, big)}, "mean_sd": float(big[-1]),
            "independent": {float(q): float(v) for q, v in zip(qs, ind)},
            "correlated": {float(q): float(v) for q, v in zip(qs, cor)}, "n": int(n)}
