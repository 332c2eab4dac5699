"""Statistics over a logic tree's end branches (docs/logic_tree.md, "Statistics").

Every function takes the end branches' values (``values``: shape (n_branches, ...), e.g. one level's annual
rate, or a rate curve per branch) and their weights (summing to 1), and works element by element along the
trailing axes:

* :func:`weighted_mean` -- the weighted mean, summed as deviations from the first branch's value, so that a
  tree whose branches all give one value gives that value exactly (bit for bit);
* :func:`weighted_quantile` -- OpenQuake's weighted quantile (``openquake.hazardlib.stats.quantile_curve``):
  the values sorted in increasing order, their weights accumulated in that order, and the quantile q read
  off the piecewise-linear function through the points (cumulative weight, value) -- ``numpy.interp``,
  which holds the first value for q below the first cumulative weight and the last above the last. With
  equal weights 1/N that is interpolation at 1/N, 2/N, ..., 1 (OpenQuake's own note);
* :func:`variance_split` -- the variance of the branches' values over the tree split into each branch
  set's main effect (the variance of the conditional means given that set's alternative: Sobol's first
  order) and the rest (interactions), beside the estimation variance of the branches' estimates;
* :func:`tornado` -- each branch set's swing: its alternatives' conditional means with the other sets at
  their weights, lowest and highest, sorted by swing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError

__all__ = ["QUANTILES", "weights_of", "weighted_mean", "weighted_quantile", "quantiles", "VarianceSplit",
           "variance_split", "tornado", "mean_estimation_sd"]

#: The quantiles reported: 5, 16, 50, 84, 95 %.
QUANTILES = (0.05, 0.16, 0.50, 0.84, 0.95)
#: How far the weights may sum from 1.
_WEIGHT_TOL = 1e-9


def weights_of(weights, n: int) -> np.ndarray:
    """The weights as an array of n finite positive numbers summing to 1 within 1e-9, else ParameterError."""
    w = np.asarray(weights, dtype=float)
    if w.shape != (n,):
        raise ParameterError(f"{n} values need {n} weights, got {w.shape[0] if w.ndim == 1 else w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ParameterError(f"weights must be finite and > 0, got {w.tolist()}")
    total = math.fsum(w.tolist())
    if abs(total - 1.0) > _WEIGHT_TOL:
        raise ParameterError(f"weights must sum to 1 (within {_WEIGHT_TOL:g}), they sum to {total!r}")
    return w


def _values(values) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.ndim == 0 or v.shape[0] == 0:
        raise ParameterError(f"values must have one entry per end branch along the first axis, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ParameterError("values must be finite (a branch without an estimate has no place in the statistics)")
    return v


def weighted_mean(values, weights) -> np.ndarray:
    """Sum_b w_b x_b along the first axis, as x_0 + Sum_b w_b (x_b - x_0) / Sum_b w_b: exact when every x_b is x_0."""
    v = _values(values)
    w = weights_of(weights, v.shape[0])
    d = v - v[0]
    return v[0] + np.tensordot(w, d, axes=1) / w.sum()


def weighted_quantile(q: float, values, weights) -> np.ndarray:
    """The q-quantile (0 <= q <= 1) of the values along the first axis by OpenQuake's rule (module docstring)."""
    if isinstance(q, bool) or not isinstance(q, (int, float)) or not 0.0 <= q <= 1.0:
        raise ParameterError(f"a quantile must be a number in [0, 1], got {q!r}")
    v = _values(values)
    w = weights_of(weights, v.shape[0])
    flat = v.reshape(v.shape[0], -1)
    out = np.empty(flat.shape[1])
    for j in range(flat.shape[1]):
        order = np.argsort(flat[:, j], kind="stable")
        out[j] = np.interp(q, np.cumsum(w[order]), flat[order, j])
    return out.reshape(v.shape[1:])


def quantiles(values, weights, qs=QUANTILES) -> dict:
    """{q: the q-quantile} for every q of ``qs``."""
    return {float(q): weighted_quantile(q, values, weights) for q in qs}


def _conditional(v, w, index, k: int, n_alt: int):
    """Per alternative a of set k: (its total weight, the conditional mean of the values), for the alternatives
    some end branch takes (a sampled tree may miss one)."""
    out = {}
    for a in range(n_alt):
        sel = index[:, k] == a
        if np.any(sel):
            wa = w[sel].sum()
            out[a] = (wa, v[sel][0] + np.tensordot(w[sel], v[sel] - v[sel][0], axes=1) / wa)
    return out


@dataclass(frozen=True)
class VarianceSplit:
    """The variance of the end branches' values over the tree (``epistemic``), each set's main effect
    (``per_set``, by set name), the rest (``interaction`` = epistemic - sum of main effects: >= 0 for a fully
    enumerated tree, whose sets are independent) and the mean estimation variance of the branches' estimates
    (``estimation``, None when not given)."""

    epistemic: np.ndarray
    per_set: dict
    interaction: np.ndarray
    estimation: np.ndarray | None

    @property
    def total(self) -> np.ndarray:
        """Epistemic plus estimation variance: of one end branch's estimate drawn by the weights."""
        return self.epistemic + (0.0 if self.estimation is None else self.estimation)


def _index(index, n: int, sizes) -> np.ndarray:
    idx = np.asarray(index, dtype=int)
    if idx.shape != (n, len(sizes)) or np.any(idx < 0) or np.any(idx >= np.asarray(sizes)):
        raise ParameterError(f"index must give each of the {n} end branches an alternative of each of the "
                             f"{len(sizes)} sets (sizes {list(sizes)}), got shape {idx.shape}")
    return idx


def variance_split(values, weights, index, sets, estimation_var=None) -> VarianceSplit:
    """The variance split of the values over the tree.

    ``index``: (n_branches, n_sets) positions of each end branch's alternatives; ``sets``: (name, number of
    alternatives) per set (a :class:`~pycolfrag.risk.logic_tree.BranchSet` gives ``(s.name, len(s.branches))``);
    ``estimation_var``: each branch's estimation variance (same shape as ``values``), whose weighted mean
    is the estimation part."""
    v = _values(values)
    w = weights_of(weights, v.shape[0])
    idx = _index(index, v.shape[0], [n for _, n in sets])
    mean = weighted_mean(v, w)
    epistemic = np.tensordot(w, (v - mean) ** 2, axes=1)
    per_set = {}
    for k, (name, n_alt) in enumerate(sets):
        cond = _conditional(v, w, idx, k, n_alt)
        per_set[name] = sum(wa * (m - mean) ** 2 for wa, m in cond.values())
    interaction = epistemic - sum(per_set.values())
    est = None if estimation_var is None else np.tensordot(w, np.asarray(estimation_var, dtype=float), axes=1)
    return VarianceSplit(epistemic, per_set, interaction, est)


def tornado(values, weights, index, sets, names=None) -> list:
    """Each set's swing (scalar values): its alternatives' conditional means (the other sets at their weights),
    the lowest and the highest with their alternatives' names, largest swing first. ``names``: per set, its
    alternatives' names (default their positions)."""
    v = _values(values)
    if v.ndim != 1:
        raise ParameterError(f"a tornado is of one number per end branch, got values of shape {v.shape}")
    w = weights_of(weights, v.shape[0])
    idx = _index(index, v.shape[0], [n for _, n in sets])
    bars = []
    for k, (name, n_alt) in enumerate(sets):
        cond = {a: float(m) for a, (_, m) in _conditional(v, w, idx, k, n_alt).items()}
        lo, hi = min(cond, key=cond.__getitem__), max(cond, key=cond.__getitem__)
        label = list(names[k]) if names is not None else [str(a) for a in range(n_alt)]
        bars.append({"set": name, "low": cond[lo], "low_branch": label[lo], "high": cond[hi], "high_branch": label[hi],
                     "swing": cond[hi] - cond[lo], "means": {label[a]: m for a, m in cond.items()},
                     "missing": [label[a] for a in range(n_alt) if a not in cond]})
    return sorted(bars, key=lambda b: -b["swing"])


def mean_estimation_sd(sd, weights, correlated: bool) -> np.ndarray:
    """The estimation standard deviation of the weighted mean from the branches' own: sqrt(Sum w_b^2 sd_b^2)
    for independent estimates; Sum w_b sd_b when they share their runs (re-weighted, or common random
    numbers): the bound at full correlation (Minkowski), which no correlation exceeds."""
    s = _values(sd)
    w = weights_of(weights, s.shape[0])
    if correlated:
        return np.tensordot(w, s, axes=1)
    return np.sqrt(np.tensordot(w ** 2, s ** 2, axes=1))
