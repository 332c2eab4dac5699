"""Where the next batch's runs go: a minimax-CoV Neyman allocation over the strata, steered by a model.

Before every production batch a *steering model* -- one ridge-penalised logistic regression per level
and branch on all rows so far (with a pulse: Mw, ln R, z_vp, z_fp, z_fp^2, the last for the resonance of
the pulse period; without: Mw, ln R) -- predicts every stratum's standard deviation sigma_hl of w y
under the production proposal, by Monte Carlo over cheap draws of the stratum's events (no runs). The
total n = runs so far + the batch is then split as Neyman (1934) would for several levels at once
(Cochran 1977, section 5.5): n_h proportional to W_h sqrt(sum_l c_l sigma_hl^2 / lambda_l^2), with the
level weights c_l moved towards the level whose predicted CoV is worst until the worst is smallest
(multiplicative updates), every stratum keeping at least the rows it has. The batch is the positive
differences, scaled to its size and rounded by largest remainder (ties by stratum index): integers,
the same on every machine that computes the same model.

The model steers and nothing more: the estimate (:mod:`pycolfrag.rare.estimate`) is design-based and
unbiased whatever the model gets wrong; a poor model only costs runs. The plan it gives is stored
before the batch runs and a resume reads it back, never recomputes it (the fit is not guaranteed to be
bitwise the same across BLAS builds).
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.rare.estimate import exceedances

__all__ = ["RIDGE", "STEERING_DRAWS", "STREAM_STEER", "SteeringModel", "steering_events", "predicted_moments", "minimax_allocation",
           "batch_counts"]

#: Ridge penalty of the steering model's coefficients (not the intercept): keeps a level with 0-3
#: exceedances finite.
RIDGE = 1.0
#: Draws per stratum behind a predicted sigma_hl.
STEERING_DRAWS = 500
#: Stream identifier of the steering draws (only steer: never a run's input).
STREAM_STEER = 4


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
