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
from scipy import optimize

from .estimate import exceedances

__all__ = ["RIDGE", "STEERING_DRAWS", "STREAM_STEER", "SteeringModel", "predicted_moments", "minimax_allocation",
           "batch_counts"]

#: Ridge penalty of the steering model's coefficients (not the intercept): keeps a level with 0-3
#: exceedances finite.
RIDGE = 1.0
#: Draws per stratum behind a predicted sigma_hl.
STEERING_DRAWS = 1000
#: Stream identifier of the steering draws (only steer: never a run's input).
STREAM_STEER = 4


def _features(mw, r_km, z=None) -> np.ndarray:
    cols = [np.ones_like(mw), mw - 6.0, np.log(r_km)]
    if z is not None:
        cols += [z[:, 0], z[:, 1], z[:, 1] ** 2]
    return np.column_stack(cols)


def _fit(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Ridge-penalised logistic regression (the intercept unpenalised)."""
    pen = np.full(X.shape[1], RIDGE)
    pen[0] = 0.0

    def nll(b):
        eta = X @ b
        f = float(np.sum(np.logaddexp(0.0, eta) - y * eta) + 0.5 * np.sum(pen * b * b))
        g = X.T @ (1.0 / (1.0 + np.exp(-eta)) - y) + pen * b
        return f, g

    b0 = np.zeros(X.shape[1])
    p = (y.sum() + 0.5) / (y.size + 1.0)
    b0[0] = math.log(p / (1 - p))
    return optimize.minimize(nll, b0, jac=True, method="L-BFGS-B").x


class SteeringModel:
    """P(level exceeded | event) per branch and level, fitted on the rows so far."""

    def __init__(self, cols: dict, quantities):
        ok = np.asarray(cols["status"]) == 0
        pulse = np.asarray(cols["pulse"], dtype=bool)
        self.beta = {}
        for branch in (True, False):
            sel = ok & (pulse == branch)
            if not np.any(sel):
                continue
            z = np.column_stack([np.asarray(cols["z_vp"])[sel], np.asarray(cols["z_fp"])[sel]]) if branch else None
            X = _features(np.asarray(cols["mw"], dtype=float)[sel], np.asarray(cols["dist_km"], dtype=float)[sel], z)
            sub = {k: np.asarray(v)[sel] for k, v in cols.items() if k in ("collapsed", "u_top", "u_d")}
            for q in quantities:
                self.beta[branch, q.label] = _fit(X, exceedances(sub, q).astype(float))

    def prob(self, branch: bool, label: str, mw, r_km, z=None) -> np.ndarray:
        b = self.beta.get((branch, label))
        if b is None:       # no row of this branch yet: say nothing about it
            return np.full(np.shape(mw), 0.5)
        return 1.0 / (1.0 + np.exp(-(_features(mw, r_km, z if branch else None) @ b)))


def predicted_moments(strata, mixture, model: SteeringModel, quantities, rng, draws: int = STEERING_DRAWS):
    """(E[w p], Var[w y]) of every stratum and level under the production proposal ``mixture``, by Monte
    Carlo over ``draws`` events of each stratum (w the run's weight, p the model's probability)."""
    H, L = len(strata), len(quantities)
    mean, var = np.zeros((H, L)), np.zeros((H, L))
    for h in range(H):
        st = strata[h]
        u = rng.standard_normal((draws, 2))
        mr = np.array([strata.place(h, a, b)[:2] for a, b in u])
        occ = np.asarray(strata.occurrence_weight(h, mr[:, 1]), dtype=float)
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
    """n_h = max(floor_h, kappa a_h) with sum n_h = total (kappa by bisection); floor when there is no room."""
    if floor.sum() >= total or not np.any(a > 0):
        return floor.astype(float)
    lo, hi = 0.0, total / a[a > 0].min()
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.maximum(floor, mid * a).sum() > total:
            hi = mid
        else:
            lo = mid
    return np.maximum(floor, lo * a)


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
