"""The stratified importance-sampling estimator of a site's rates, its variance and its diagnostics.

For every level l (a Table III/IV level or collapse) and the rows i of stratum h (n_h of them, weight
w_i = occurrence weight x phi_2 / q_s of the pulse normals under the mixture q_s of the row's own stage
(:mod:`pycolfrag.rare.proposal`); outcome y_il = collapsed or EDP >= threshold)::

    mu_hl   = (1 / n_h) sum_i w_i y_il            s_hl^2 = (1 / (n_h - 1)) sum_i (w_i y_il - mu_hl)^2
    lambda_l = sum_h W_h mu_hl                    V_l = sum_h W_h^2 s_hl^2 / n_h,   CoV_l = sqrt(V_l) / lambda_l
    interval: lambda_l exp(+-z sqrt(ln(1 + CoV_l^2)))   (log-normal, never below 0)

(Cochran 1977, ch. 5; Owen & Zhou 2000). Diagnostics of every level: the *effective number of
exceedances* n_eff = (sum c)^2 / sum c^2 over the rows' contributions c_i = W_h w_i y_il / n_h (Kong's
effective sample size of the level's exceeding runs; Kong 1992) and the largest contribution's share
of lambda; of every stratum, Kong's relative effective sample size of its weights. A level resting on
fewer than ``min_neff`` effective exceedances, or whose largest run carries more than ``max_share`` of
it, is *refused*: no CoV or interval is stated for it, only an upper bound (every stratum's largest
weight times the Jeffreys 95 % upper limit of its share of exceeding runs). A weight above its
mixture's defensive bound can only come from wrong density code: :class:`WeightError`.

Sums are :func:`math.fsum` over a stratum's rows, so the numbers do not depend on the order rows were
read in.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .. import results as _results
from ..analysis import fragility as _fragility
from ..errors import PycolfragError

__all__ = ["WeightError", "LevelEstimate", "Estimate", "exceedances", "row_weights", "estimate", "DEFAULT_MIN_NEFF",
           "DEFAULT_MAX_SHARE", "efficiency"]

#: Fewest effective exceedances a level's estimate may rest on (the stopping rule's floor too).
DEFAULT_MIN_NEFF = 10.0
#: Largest share of a level's rate one run may carry.
DEFAULT_MAX_SHARE = 0.25


class WeightError(PycolfragError, ArithmeticError):
    """A sampling weight above its proposal's defensive bound: the density code is wrong."""


def exceedances(cols: dict, q) -> np.ndarray:
    """y of every row for level ``q`` (``edp``, ``threshold``; collapse when ``edp`` is None): the exceedance of
    the fragility curves, collapsed or EDP >= threshold (:func:`pycolfrag.analysis.fragility.exceeded`, the one
    text of it; ``pcf.fragility``, loaded with the package)."""
    collapsed = np.asarray(cols["collapsed"], dtype=bool)
    if q.edp is None:
        return collapsed
    return _fragility.exceeded(np.asarray(cols[q.edp], dtype=float), collapsed, q.threshold)


def row_weights(cols: dict, strata, design) -> tuple[np.ndarray, dict]:
    """Every row's weight -- its occurrence weight times phi_2 / q of the mixture of its own stage (the
    balance heuristic over that mixture's components; ``design.mixture(design.proposal_of(stage))``) -- and,
    per stratum, the largest pulse factor over its bound 1/alpha_0 (at most 1)."""
    h_all = np.asarray(cols["stratum"])
    w = np.asarray(cols["occurrence_weight"], dtype=float).copy()
    kind = np.array([design.proposal_of(int(s)) for s in np.asarray(cols["stage"])], dtype=int)
    z = np.column_stack([np.asarray(cols["z_vp"], dtype=float), np.asarray(cols["z_fp"], dtype=float)])
    pulse = np.array([strata[int(h)].pulse for h in h_all], dtype=bool)
    ratio, bound = np.ones(h_all.size), np.ones(h_all.size)
    for k in np.unique(kind[pulse]):
        sel = pulse & (kind == k)
        m = design.mixture(int(k))
        ratio[sel], bound[sel] = m.ratio(z[sel]), m.bound
    bad = ratio > bound * (1.0 + 1e-9)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise WeightError(f"stratum {int(h_all[i])}, row of stage {int(np.asarray(cols['stage'])[i])} index "
                          f"{int(np.asarray(cols['index'])[i])}: pulse weight {ratio[i]:.6g} above its defensive "
                          f"bound {bound[i]:.6g} (wrong density code)")
    checks = {int(h): float(np.max(ratio[(h_all == h)] / bound[(h_all == h)])) for h in np.unique(h_all[pulse])}
    return w * ratio, checks


@dataclass
class LevelEstimate:
    """One level's estimate: rate (1/yr), CoV, interval, diagnostics, and what is said of it."""

    label: str
    rate: float
    cov: float
    low: float
    high: float
    n_eff: float
    max_share: float
    hits: int
    status: str            # "converged", "above target" or "refused"
    bound: float           # upper bound on the rate (the only number stated for a refused level)
    reason: str = ""

    def as_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Estimate:
    """The estimate from a set of rows."""

    levels: dict
    n_runs: int
    n_failed: int
    n_by_stratum: np.ndarray
    ess_relative: np.ndarray            # Kong's ESS of each stratum's weights / its rows
    max_ratio: dict
    contributions: dict = field(default_factory=dict)   # label -> W_h mu_hl per stratum
    confidence: float = 0.90

    def as_dict(self) -> dict:
        return {"levels": {k: v.as_dict() for k, v in self.levels.items()}, "n_runs": self.n_runs,
                "n_failed": self.n_failed, "confidence": self.confidence,
                "runs_by_stratum": self.n_by_stratum.tolist(),
                "kong_ess_relative_min": float(np.nanmin(self.ess_relative)) if self.ess_relative.size else None}


def _jeffreys_upper(k: int, n: int, level: float = 0.95) -> float:
    return 1.0 if k >= n else float(stats.beta.ppf(level, k + 0.5, n - k + 0.5))


def _level(q, W, groups, w, y, confidence, min_neff, max_share, target):
    """One level from the rows grouped by stratum: (LevelEstimate, per-stratum W_h mu_h)."""
    lam_terms, var_terms, contrib, bound_terms, per = [], [], [], [], np.zeros(W.size)
    for h, idx in groups:
        v = w[idx] * y[idx]
        n = idx.size
        mu = math.fsum(v) / n
        s2 = math.fsum((v - mu) ** 2) / (n - 1)
        per[h] = W[h] * mu
        lam_terms.append(per[h])
        var_terms.append(W[h] ** 2 * s2 / n)
        contrib.append(W[h] * v[v > 0] / n)
        bound_terms.append(W[h] * float(np.max(w[idx])) * _jeffreys_upper(int(np.sum(y[idx])), n))
    lam, var = math.fsum(lam_terms), math.fsum(var_terms)
    c = np.concatenate(contrib) if contrib else np.zeros(0)
    hits = int(sum(int(np.sum(y[idx])) for _, idx in groups))
    n_eff = math.fsum(c) ** 2 / math.fsum(c * c) if c.size else 0.0
    share = float(np.max(c)) / lam if lam > 0 else math.inf
    cov = math.sqrt(var) / lam if lam > 0 else math.inf
    zq = float(stats.norm.ppf(0.5 + confidence / 2))
    half = zq * math.sqrt(math.log1p(cov * cov)) if math.isfinite(cov) else math.inf
    low, high = (lam * math.exp(-half), lam * math.exp(half)) if lam > 0 else (0.0, math.inf)
    bound = math.fsum(bound_terms)
    if lam <= 0 or n_eff < min_neff or share > max_share:
        status = "refused"
        reason = (f"the estimate rests on {n_eff:.1f} effective exceedances ({hits} runs exceed), the largest run "
                  f"carries {100 * min(share, 1.0):.0f} % of it (needs >= {min_neff:g} and <= {100 * max_share:.0f} %); "
                  f"upper bound {bound:.3g} /yr")
    else:
        status = "converged" if target is None or cov <= target else "above target"
        reason = "" if status == "converged" else f"CoV {cov:.3f} above the target {target:g}"
    return LevelEstimate(q.label, lam, cov, low, high, n_eff, share, hits, status, bound, reason), per


def estimate(cols: dict, strata, design, quantities, *, confidence: float = 0.90, min_neff: float = DEFAULT_MIN_NEFF,
             max_share: float = DEFAULT_MAX_SHARE, target_cov: float | None = None, keep=None) -> Estimate:
    """The estimate of every level of ``quantities`` from the rows ``cols`` (columns of the event layout).

    ``keep``: a boolean mask over the strata (e.g. those inside a grid's range): only they enter (the
    rate of that part of the site). Rows not computed yet are ignored; failed rows are counted and left
    out (the rows of their stratum stand for it). Every stratum kept must hold at least two rows.
    """
    status = np.asarray(cols["status"])
    done = status != _results.STATUS_PENDING
    ok = status == _results.STATUS_OK
    keep = np.ones(len(strata), dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    sub = {k: np.asarray(v)[ok] for k, v in cols.items()}
    w, checks = row_weights(sub, strata, design) if ok.any() else (np.zeros(0), {})
    h_all = np.asarray(sub["stratum"]) if ok.any() else np.zeros(0, dtype=int)
    W = strata.rates
    order = np.lexsort((np.asarray(sub.get("index", h_all)), np.asarray(sub.get("stage", h_all)), h_all))
    n_by = np.bincount(h_all, minlength=len(strata)) if h_all.size else np.zeros(len(strata), dtype=int)
    short = [h for h in range(len(strata)) if keep[h] and n_by[h] < 2]
    if short:
        raise PycolfragError(f"strata {short[:10]} hold fewer than two finished runs: no estimate yet")
    groups = [(h, order[h_all[order] == h]) for h in range(len(strata)) if keep[h]]
    ess = np.full(len(strata), np.nan)
    for h, idx in groups:
        ess[h] = math.fsum(w[idx]) ** 2 / math.fsum(w[idx] ** 2) / idx.size
    levels, contributions = {}, {}
    for q in quantities:
        levels[q.label], contributions[q.label] = _level(q, W, groups, w, exceedances(sub, q), confidence, min_neff,
                                                         max_share, target_cov)
    return Estimate(levels, int(np.sum(done)), int(np.sum(done & ~ok)), n_by, ess, checks, contributions, confidence)


def efficiency(level: LevelEstimate, total_rate: float, runs: int) -> dict:
    """Crude Monte Carlo's runs for the same CoV, N = (1 - p) / (p CoV^2) with p = lambda / (the site's event
    rate) the probability per simulated event, and their ratio to the runs used."""
    if not (level.rate > 0 and math.isfinite(level.cov) and level.cov > 0):
        return {"p_per_event": level.rate / total_rate, "crude_runs": math.inf, "efficiency": math.nan}
    p = level.rate / total_rate
    n = (1.0 - p) / (p * level.cov ** 2)
    return {"p_per_event": p, "crude_runs": n, "efficiency": n / runs}
