"""Where the next batch's runs go: a minimax-CoV Neyman allocation over the strata, steered by a model.

Before every production batch a *steering model* -- one ridge-penalised logistic regression per level
and branch on all rows so far (with a pulse: Mw, ln R, z_vp, z_fp, z_fp^2, the last for the resonance of
the pulse period; without: Mw, ln R) -- predicts every stratum's standard deviation sigma_hl of w y
under the production proposal, by Monte Carlo over cheap draws of the stratum's events (no runs). The
batch is then split as Neyman (1934) would for several levels at once
(Cochran 1977, section 5.5): n_h proportional to W_h sqrt(sum_l c_l sigma_hl^2 / lambda_l^2), with the
level weights c_l moved towards the level whose predicted CoV is worst until the worst is smallest
(multiplicative updates). Each production batch's runs are so split on their own (v5, below), rounded by largest
remainder (ties by stratum index): integers, the same on every machine that computes the same model.

The estimate's variance floor comes from here too (:func:`variance_floor`): a stratum none of whose runs
exceeds a level is given the predicted Var[w y] of the smaller of the steering model's probability and a
demand model's (:class:`DemandModel`, ln EDP linear in the same features), at most the Jeffreys pseudo-count's
(:func:`pycolfrag.rare.estimate.jeffreys_floor`), so that the stopping rule sees it; and a stratum the
model predicts to carry at least :data:`MATTER_SHARE` of a requested level's rate, or that share of the site's event rate, keeps at least
:data:`~pycolfrag.rare.estimate.FEW_RUNS` runs (:func:`run_floor`). Before them, the example site's
no-pulse strata (86 % of its event rate) kept the pilot's 5 runs each while the rarest level drew the
batches (docs/rare_events.md).

The model steers and nothing more: every row is unbiased for its stratum's mean given the design it was drawn
under, and every batch's counts are fixed before it runs, so each batch is an unbiased stratified estimate given
the batches before it. v4 split the *total* (runs so far + the batch), every stratum keeping the rows it had, and
pooled each stratum's rows: a stratum whose rows were hit was sent more rows, and its mean over them was biased
low by O(1/n), little where the model's features foresee the hits and much where they do not (on the tests'
surrogate at 870 runs: collapse -5 % when u_top foretells it, -10 % to -31 % with collapses of a coin the features
cannot see; bench/rare_allocation_bias.py, docs/rare_events.md). v5 splits each *batch* on its own
(:func:`piece_allocation`: the same minimax-CoV Neyman rule over the batch's runs, at least
:data:`PIECE_MIN_RUNS` in every stratum, strata that matter their part of FEW_RUNS, :func:`piece_floor`), and the
estimate combines the batches as pieces (:mod:`pycolfrag.rare.estimate`, "Batches as pieces"): unbiased whatever
the steering, at a fixed budget. The plan it gives is stored
before the batch runs and a resume reads it back, never recomputes it (the fit is not guaranteed to be
bitwise the same across BLAS builds).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from pycolfrag.rare.estimate import FEW_RUNS, exceedances, jeffreys_floor
from pycolfrag.rare.proposal import COLLAPSE_FAMILY

__all__ = ["RIDGE", "STEERING_DRAWS", "STREAM_STEER", "MATTER_SHARE", "SteeringModel", "steering_events",
           "predicted_moments", "DemandModel", "variance_floor", "run_floor", "STREAM_FLOOR", "minimax_allocation", "batch_counts",
           "PIECE_MIN_RUNS", "piece_floor", "piece_allocation", "runs_left_unused"]

#: Ridge penalty of the steering model's coefficients (not the intercept): keeps a level with 0-3
#: exceedances finite.
RIDGE = 1.0
#: Draws per stratum behind a predicted sigma_hl.
STEERING_DRAWS = 500
#: Stream identifier of the steering draws (only steer: never a run's input).
STREAM_STEER = 4
#: The spawn key's second word of the variance floor's draws (the batches' are their stage, >= 1).
STREAM_FLOOR = 0
#: A stratum the steering model predicts to carry at least this share of a requested level's rate, or with this
#: share of the site's event rate, keeps at least FEW_RUNS runs.
MATTER_SHARE = 0.01
#: Every production batch gives every stratum at least this many runs: each batch is its own stratified estimate
#: (a piece, :func:`pycolfrag.rare.estimate.piece_factors`), which needs every stratum, and a variance two runs.
PIECE_MIN_RUNS = 2


def _features(mw, r_km, z=None) -> np.ndarray:
    cols = [np.ones_like(mw), mw - 6.0, np.log(r_km)]
    if z is not None:
        cols += [z[:, 0], z[:, 1], z[:, 1] ** 2]
    return np.column_stack(cols)


def _fit(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Ridge-penalised logistic regression (the intercept unpenalised), by Newton's method with step halving
    (the penalised log-likelihood is strictly concave: a few steps to convergence)."""
    pen = np.full(X.shape[1], RIDGE)
    pen[0] = 0.0
    b = np.zeros(X.shape[1])
    p0 = (y.sum() + 0.5) / (y.size + 1.0)
    b[0] = math.log(p0 / (1 - p0))

    def nll(b):
        eta = X @ b
        return float(np.sum(np.logaddexp(0.0, eta) - y * eta) + 0.5 * np.sum(pen * b * b))

    f = nll(b)
    for _ in range(50):
        p = 0.5 * (1.0 + np.tanh(0.5 * (X @ b)))          # the logistic function without overflow
        g = X.T @ (p - y) + pen * b
        H = (X * (p * (1 - p))[:, None]).T @ X + np.diag(pen + 1e-9)
        step = np.linalg.solve(H, g)
        t = 1.0
        while t > 1e-6 and nll(b - t * step) > f:
            t *= 0.5
        b = b - t * step
        f_new = nll(b)
        if f - f_new < 1e-10 * (1.0 + abs(f_new)):
            break
        f = f_new
    return b


class SteeringModel:
    """P(level exceeded | event) per branch and level, fitted on the rows so far."""

    def __init__(self, cols: dict, quantities):
        ok = np.asarray(cols["status"]) == 0
        pulse = np.asarray(cols["pulse"], dtype=bool)
        read = {"collapsed"} | {q.edp for q in quantities if q.edp}   # what the levels read: any stored EDP
        self.beta = {}
        for branch in (True, False):
            sel = ok & (pulse == branch)
            if not np.any(sel):
                continue
            z = np.column_stack([np.asarray(cols["z_vp"])[sel], np.asarray(cols["z_fp"])[sel]]) if branch else None
            X = _features(np.asarray(cols["mw"], dtype=float)[sel], np.asarray(cols["dist_km"], dtype=float)[sel], z)
            sub = {k: np.asarray(v)[sel] for k, v in cols.items() if k in read}
            for q in quantities:
                self.beta[branch, q.label] = _fit(X, exceedances(sub, q).astype(float))

    def prob(self, branch: bool, label: str, mw, r_km, z=None) -> np.ndarray:
        b = self.beta.get((branch, label))
        if b is None:       # no row of this branch yet: say nothing about it
            return np.full(np.shape(mw), 0.5)
        return 0.5 * (1.0 + np.tanh(0.5 * (_features(mw, r_km, z if branch else None) @ b)))


def steering_events(strata, rng, draws: int = STEERING_DRAWS) -> list:
    """``draws`` events (Mw, R km, occurrence weight) of every stratum, for :func:`predicted_moments` (drawn
    once per simulation: they depend on the strata only)."""
    out = []
    for h in range(len(strata)):
        mr = np.array([strata.place(h, a, b) for a, b in rng.standard_normal((draws, 2))])
        out.append((mr[:, 0], mr[:, 1], np.asarray(strata.occurrence_weight(h, mr[:, 1]), dtype=float)))
    return out


def predicted_moments(strata, mixture, model: SteeringModel, quantities, rng, events):
    """(E[w p], Var[w y]) of every stratum and level under the production proposal ``mixture``, by Monte
    Carlo over the ``events`` of each stratum (:func:`steering_events`) and pulse quantiles drawn from the
    mixture (w the run's weight, p the model's probability)."""
    H, L = len(strata), len(quantities)
    mean, var = np.zeros((H, L)), np.zeros((H, L))
    for h in range(H):
        st = strata[h]
        mw, r, occ = events[h]
        draws = mw.size
        mr = np.column_stack([mw, r])
        z = None
        w = occ
        if st.pulse:
            k = np.searchsorted(np.cumsum(mixture.alphas)[:-1], rng.random(draws), side="right")
            shifts = np.array([mixture.shift(int(c)) for c in range(len(mixture.alphas))])
            z = rng.standard_normal((draws, 2)) + shifts[k]
            w = occ * mixture.ratio(z)
        for j, q in enumerate(quantities):
            p = model.prob(st.pulse, q.label, mr[:, 0], mr[:, 1], z)
            mean[h, j] = float(np.mean(w * p))
            var[h, j] = max(float(np.mean(w * w * p)) - mean[h, j] ** 2, 0.0)
    return mean, var


class DemandModel:
    """P(EDP >= t | event) per branch and EDP from a linear regression of ln EDP on the steering model's
    features over the successful, standing rows with EDP > 0 (the cloud's probabilistic seismic demand model,
    ln EDP normal about a linear function: Cornell et al. 2002): Phi((mu(x) - ln t) / s), s the residuals'
    standard deviation. It reads the continuous EDP, which tells how far a stratum's runs fell short of a
    level; 0 of n exceedances alone cannot. Collapse is read as the top displacement reaching the largest
    one a standing run reached (a collapse passes through it). No model where fewer than 10 rows fit."""

    def __init__(self, cols: dict, quantities):
        ok = (np.asarray(cols["status"]) == 0) & ~np.asarray(cols["collapsed"], dtype=bool)
        pulse = np.asarray(cols["pulse"], dtype=bool)
        top = np.asarray(cols[COLLAPSE_FAMILY], dtype=float)[ok]
        top = top[np.isfinite(top)]
        self.collapse_at = float(np.max(top)) if top.size and np.max(top) > 0 else None
        self.fit = {}
        for branch in (True, False):
            for edp in {q.edp or COLLAPSE_FAMILY for q in quantities}:
                v = np.asarray(cols[edp], dtype=float)
                sel = ok & (pulse == branch) & (v > 0) & np.isfinite(v)
                z = np.column_stack([np.asarray(cols["z_vp"])[sel], np.asarray(cols["z_fp"])[sel]]) if branch else None
                X = _features(np.asarray(cols["mw"], dtype=float)[sel], np.asarray(cols["dist_km"], dtype=float)[sel], z)
                if X.shape[0] < max(10, X.shape[1] + 2):
                    continue
                b = np.linalg.lstsq(X, np.log(v[sel]), rcond=None)[0]
                r = np.log(v[sel]) - X @ b
                self.fit[branch, edp] = (b, max(float(np.sqrt(r @ r / (r.size - X.shape[1]))), 1e-3))

    def prob(self, branch: bool, q, mw, r_km, z=None):
        """P(q.edp >= q.threshold) at the events, or None where there is no model."""
        f = self.fit.get((branch, q.edp or COLLAPSE_FAMILY))
        t = q.threshold if q.edp else self.collapse_at
        if f is None or t is None or not 0 < t < math.inf:
            return None
        b, s = f
        return stats.norm.sf((math.log(t) - _features(mw, r_km, z if branch else None) @ b) / s)


class _Least:
    """The smaller of the steering model's and the demand model's probabilities."""

    def __init__(self, steer: SteeringModel, demand: DemandModel, quantities):
        self.steer, self.demand, self.q = steer, demand, {q.label: q for q in quantities}

    def prob(self, branch, label, mw, r_km, z=None):
        p = self.steer.prob(branch, label, mw, r_km, z)
        d = self.demand.prob(branch, self.q[label], mw, r_km, z)
        return p if d is None else np.minimum(p, d)


def variance_floor(cols: dict, strata, design, quantities, rng, events) -> np.ndarray:
    """(H, L): the estimate's per-run variance of a stratum none of whose runs exceeds a level (0 where one
    does): the predicted Var[w y] under the latest proposal (the production one once placed) of the smaller
    of the steering model's and the demand model's probabilities, at most the Jeffreys pseudo-count's
    (:func:`pycolfrag.rare.estimate.jeffreys_floor`)."""
    model = _Least(SteeringModel(cols, quantities), DemandModel(cols, quantities), quantities)
    mixture = design.latest if design.latest is not None else design.pilot
    _, var = predicted_moments(strata, mixture, model, quantities, rng, events)
    jf = jeffreys_floor(cols, strata, design, quantities)
    return np.where(jf > 0, np.minimum(var, jf), 0.0)


def run_floor(W: np.ndarray, mean: np.ndarray, done: np.ndarray, min_runs: int = FEW_RUNS,
              share: float = MATTER_SHARE) -> np.ndarray:
    """The fewest runs each stratum keeps: those it has, and ``min_runs`` where the predicted means ``mean``
    (H, L) put at least ``share`` of some level's rate sum_h W_h mean_hl in it, or where its rate W_h is at least
    ``share`` of the site's (a model fitted on few exceedances can miss where a frequent level lies)."""
    part = W[:, None] * mean
    lam = part.sum(axis=0)
    matters = np.any(part >= share * np.where(lam > 0, lam, np.inf), axis=1) | (W >= share * W.sum())
    return np.where(matters, np.maximum(done, min_runs), done)


def _waterfill(a: np.ndarray, floor: np.ndarray, total: float) -> np.ndarray:
    """n_h = max(floor_h, kappa a_h) with sum n_h = total; floor when there is no room. Exact: the strata held
    at their floor are found by moving those below it out of the free set until none is (at most H passes)."""
    if floor.sum() >= total or not np.any(a > 0):
        return floor.astype(float)
    free = a > 0
    while True:
        kappa = (total - floor[~free].sum()) / a[free].sum()
        below = free & (kappa * a < floor)
        if not below.any():
            return np.where(free, kappa * a, floor).astype(float)
        free &= ~below


def minimax_allocation(W: np.ndarray, var: np.ndarray, lam: np.ndarray, floor: np.ndarray, total: float,
                       iterations: int = 300) -> tuple[np.ndarray, np.ndarray]:
    """(n_h, the predicted CoV of each level): the split of ``total`` runs whose worst predicted CoV is
    smallest, every stratum keeping at least ``floor`` runs."""
    L = var.shape[1]
    rel = var / np.maximum(lam, 1e-300) ** 2            # sigma_hl^2 / lambda_l^2
    c = np.full(L, 1.0 / L)
    best, best_cov = None, None
    for _ in range(iterations):
        n = _waterfill(W * np.sqrt(rel @ c), floor.astype(float), total)
        cov2 = (W[:, None] ** 2 * rel / np.maximum(n, 1e-300)[:, None]).sum(axis=0)
        if best is None or cov2.max() < best_cov.max():
            best, best_cov = n, cov2
        c = c * (cov2 / cov2.max()) ** 2
        c = np.maximum(c / c.sum(), 1e-12)
    return best, np.sqrt(best_cov)


def batch_counts(n_target: np.ndarray, done: np.ndarray, batch: int) -> np.ndarray:
    """The batch's runs per stratum: the positive differences ``n_target - done`` scaled to ``batch`` and
    rounded by largest remainder, ties by stratum index (integers summing to ``batch``)."""
    extra = np.maximum(np.asarray(n_target, dtype=float) - done, 0.0)
    if extra.sum() <= 0:
        extra = np.asarray(n_target, dtype=float)
    share = extra * (batch / extra.sum())
    base = np.floor(share).astype(int)
    rest = batch - int(base.sum())
    order = sorted(range(share.size), key=lambda h: (-(share[h] - base[h]), h))
    for h in order[:rest]:
        base[h] += 1
    return base


def runs_left_unused(left: int, n_strata: int, what: str = "runs") -> str:
    """What is said when the ``left`` runs (or rows) of a budget are too few for a batch: every batch gives each
    stratum at least :data:`PIECE_MIN_RUNS`, so they are not run."""
    return (f"the {left} {what} left in the budget cannot give each of the {n_strata} strata {PIECE_MIN_RUNS}: "
            "not run")


def piece_floor(W: np.ndarray, mean: np.ndarray, used: int, size: int) -> np.ndarray:
    """The fewest runs each stratum gets in a batch of ``size`` after ``used`` runs: :data:`PIECE_MIN_RUNS`, and
    where :func:`run_floor` says the stratum matters, its part of FEW_RUNS, ceil(FEW_RUNS size / (used + size)),
    so that such a stratum reaches about FEW_RUNS runs over the batches; the latter dropped where both do not fit."""
    H = W.size
    matters = run_floor(W, mean, np.zeros(H)) > 0
    part = max(PIECE_MIN_RUNS, -(-FEW_RUNS * int(size) // max(int(used) + int(size), 1)))
    floor = np.where(matters, part, PIECE_MIN_RUNS)
    return floor if floor.sum() <= size else np.full(H, PIECE_MIN_RUNS)


def piece_allocation(W: np.ndarray, var: np.ndarray, lam: np.ndarray, mean: np.ndarray, used: int,
                     size: int) -> np.ndarray:
    """A production batch's ``size`` runs per stratum (integers): the batch's own minimax-CoV Neyman split of the
    predicted variances ``var`` (H, L) and rates ``lam`` (:func:`minimax_allocation` with ``size`` runs in all, no
    stratum keeping rows it has: the batch is a piece of its own), at least :func:`piece_floor`, rounded by largest
    remainder. ``mean``: the predicted means (H, L') behind the floor."""
    if size < PIECE_MIN_RUNS * W.size:
        raise ValueError(f"a batch of {size} runs cannot give each of {W.size} strata {PIECE_MIN_RUNS}")
    floor = piece_floor(W, mean, used, size)
    n, _ = minimax_allocation(W, var, lam, floor, size)
    counts = batch_counts(n, np.zeros(W.size), size)
    if np.any(counts < floor):         # a non-finite predicted variance or rate: the split means nothing
        raise ValueError(f"the batch's split {counts.tolist()} misses its floor {floor.tolist()} (predicted variances "
                         "or rates not finite?)")
    return counts
