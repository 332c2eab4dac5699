"""The stratified importance-sampling estimator of a site's rates, its variance and its diagnostics.

For every level l (a Table III/IV level or collapse) and the rows i of stratum h (n_h of them, weight
w_i = occurrence weight x phi_2 / q_s of the pulse normals under the mixture q_s of the row's own stage
(:mod:`pycolfrag.rare.proposal`); outcome y_il = collapsed or EDP >= threshold)::

    mu_hl   = (1 / n_h) sum_i w_i y_il            s_hl^2 = (1 / (n_h - 1)) sum_i (w_i y_il - mu_hl)^2
    lambda_l = sum_h W_h mu_hl                    V_l = sum_h W_h^2 s_hl^2 / n_h,   CoV_l = sqrt(V_l) / lambda_l
    interval: lambda_l exp(+-z sqrt(ln(1 + CoV_l^2)))   (log-normal, never below 0)

(Cochran 1977, ch. 5; Owen & Zhou 2000).

**The weights' known mean as a control variate** (v4 of the route's algorithm). Every stratum's weights have
mean 1 under its proposal (the occurrence weight over its bin, phi_2 / q under q), so the stratum's mean is
estimated by the regression estimator with u_i = w_i as control variate (Owen 2013, ch. 8.9; Cochran 1977, 7.1;
Hesterberg 1995)::

    b_hl = sum_i (v_i - vbar)(u_i - ubar) / sum_i (u_i - ubar)^2,      v_i = w_i y_il
    mu_hl = vbar - b_hl (ubar - 1)        s_hl^2 = (1 / (n_h - 2)) sum_i (v_i - vbar - b_hl (u_i - ubar))^2

It keeps what is known (E[u] = 1) where the self-normalised sum(w y) / sum(w) (the same form with b = mu) has an
O(1/n) bias and is the best b only by chance; the regression's b is asymptotically the best, its bias O(1/n)
too. It gains where v follows the weight; measured on the tests' surrogate the gain is small (efficiency x 0.98
to 1.12 by level, docs/risk.md): the frequent levels' variance lies in no-pulse strata of nearly equal weights. **The rule at few runs**: with few runs or few exceedances b is a ratio of
noise, so the plain mean and s_hl^2 above stand in a stratum with fewer than :data:`CV_MIN_RUNS` successful runs,
fewer than :data:`CV_MIN_HITS` of them exceeding or all of them (v = u: the residuals and the stated variance would be
0, as if n of n proved p = 1), weights all equal, or where the regression would make the
stratum's mean negative -- a stated rule of the estimator, not a fallback. ``control=False`` gives the plain
estimator everywhere (v3's). A logic tree's re-weighted branch (``reweight`` rho, the branch's
density over the simulated one) estimates the mean of w rho y with the same control u = w (mean 1 whatever
the branch). Failed rows keep their imputed v; b and s^2 come from the successful rows, ubar from every
finished row (their weights are known); the failed runs' bounds move with mu_hl by the same b (ubar - 1).

**Batches as pieces** (v5; ``pieces=True``, the driver's). The allocation of every production batch reads the
rows before it (the steering model), so a stratum's count of rows follows its outcomes: a stratum hit early gets
more of the later rows, and its mean over all of them -- a mean over n rows where n grows after a hit -- is biased
low (-5 % to -31 % on the tests' surrogates, docs/rare_events.md). But every batch b, given the batches before it,
is a stratified sample of counts n_hb fixed before it runs: its stratum means are unbiased given the past, and so
is any combination of them whose weights are fixed in advance. The estimate combines them with the batches' shares
of the runs, a_b = (runs of batch b) / (all runs) -- the sizes its plans fix (``batch``, the pilot's, the last
one's from the budget)::

    mu_hl = sum_b a_b mean_b(w y)  =  (1 / n_h) sum_i f_i w_i y_il,    f_i = a_b n_h / n_hb
    V_l   = sum_h W_h^2 sum_b a_b^2 s_hbl^2 / n_hb

(:func:`piece_weights`, :func:`piece_factors`, :func:`piece_variance`; a_b rescaled over the batches a stratum has
-- all of them, as every batch gives every stratum at least two runs; a batch cut by the budget may not). s_hbl^2
is the sample variance of w y over batch b's successful rows of the stratum (of the control variate's residuals
w y - b w where its rule takes the stratum, b the stratum's from all its rows): unbiased given the batches before,
as the batch's mean is. A variance pooled over the batches is not -- its rows' counts follow the outcomes, the
mean's v4 flaw again (on the tests' two-stratum enumeration, 0.875 of the true variance, the batches' own 1.000). A stratum none of whose
runs exceeds takes the floor below as its per-run variance, s_hl^2 sum_b a_b^2 / n_hb = s_hl^2 / n_h x deff_h,
deff_h = n_h sum_b a_b^2 / n_hb >= 1, equal to 1 where the batches split the stratum in proportion to their sizes:
what pieces cost against pooling at the same counts (:func:`piece_factors`). The control variate's ubar is the
pieces' (1 / n_h) sum f_i u_i; the failed runs' bounds, n_eff and the largest run's share take the rows'
contributions W_h f_i w_i y_i / n_h. With one batch f = 1 and every number is the pooled one, bit for bit.
**At a fixed budget.** The weights a_b are fixed by the plans given the number of batches; the stopping rule on
``target_cov`` chooses that number from the estimates, which biases a mean stopped on its own estimate high by
O(1/n) (Siegmund 1985; measured, docs/rare_events.md).

Diagnostics of every level: the *effective number of
exceedances* n_eff = (sum c)^2 / sum c^2 over the rows' contributions c_i = W_h w_i y_il / n_h (Kong's
effective sample size of the level's exceeding runs; Kong 1992) and the largest contribution's share
of lambda; of every stratum, Kong's relative effective sample size of its weights. A level resting on
fewer than ``min_neff`` effective exceedances, or whose largest run carries more than ``max_share`` of
it, is *refused*: no CoV or interval is stated for it, only an upper bound (every stratum's largest
weight times the Jeffreys 95 % upper limit of its share of exceeding runs, failed runs counted as
exceeding). A weight above its mixture's defensive bound can only come from wrong density code:
:class:`WeightError`.

Failed runs (status not 0: the record, the IMs or the solver raised) are not non-exceedances: their
outcome is unknown. They keep their place in their stratum (n_h counts every finished run), and every
level is bounded by what they could have been, each weighted as the estimator weights a row::

    lambda_lo = sum_h W_h (1 / n_h) sum_{i ok} w_i y_il                  (every failed run as no exceedance)
    lambda_hi = lambda_lo + sum_h W_h (1 / n_h) sum_{i failed} w_i      (every failed run as an exceedance)

In mu_hl and s_hl^2 a failed row's w_i y_il is imputed as w_i p_hl, p_hl = sum_ok w y / sum_ok w the
stratum's weighted exceedance share among its successful rows (0 when none succeeded), so lambda_l lies
between the two bounds. A level with failed runs whose spread lambda_hi - lambda_lo exceeds
CoV_l x lambda_l (its own statistical error) is *unresolved* (:data:`UNRESOLVED`): the failed runs could
move it further than its CoV says, so it is not converged, whatever its CoV; more runs do not help, as
the spread shrinks no faster than the rate. Without failed runs every number is the one above, bit for bit.

A stratum whose n_h successful runs all miss a level has s_hl^2 = 0: it would add nothing to V_l, as if
0 of n_h proved the level impossible there (at the example site the no-pulse strata, 86 % of the event
rate, kept 5 runs each and the frequent levels' stated CoV was half the crude one). Given ``floor`` (the
driver's, :func:`pycolfrag.rare.allocation.variance_floor`), such a stratum's s_hl^2 is that per-run
variance instead: the steering model's predicted Var[w y] of the stratum, at most the Jeffreys pseudo-count's

    m2_h p0 - p0^2,   p0 = 0.5 / (n_h + 1),   m2_h = max(1, (1 / n_h) sum_i w_i^2)   (:func:`jeffreys_floor`)

p0 the posterior mean of Beta(0.5, n_h + 0.5), Jeffreys' prior after 0 of n_h (Brown, Cai & DasGupta 2001),
and m2 p0 - p0^2 the variance of w y with E[w] = 1 (every stratum's weights have mean 1). The pseudo-count
alone would be honest without a model and far too wide for the rare levels (0 of 256 runs of a large
no-pulse stratum leaves collapse's CoV at 4 where 0.5 is observed: the surrogate of the tests); the model,
fitted on every stratum's rows, says where a level is out of reach. Strata with exceedances keep their
sample variance, bit for bit. Every level says how much of its rate rests on strata of fewer than
:data:`FEW_RUNS` runs (``few_runs_rate_share``), what share of its variance is the floor's
(``floor_variance_share``), and the estimate the share of the site's event rate in such strata.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pycolfrag import damage as _damage
from pycolfrag import results as _results
from pycolfrag.core.errors import PycolfragError

__all__ = ["WeightError", "LevelEstimate", "Estimate", "exceedances", "row_weights", "estimate", "DEFAULT_MIN_NEFF",
           "DEFAULT_MAX_SHARE", "UNRESOLVED", "efficiency", "FEW_RUNS", "jeffreys_floor", "jeffreys_p0",
           "jeffreys_run_variance", "jeffreys_upper", "CV_MIN_RUNS", "CV_MIN_HITS", "regression",
           "stratum_run_variance", "piece_weights", "piece_factors", "piece_parts", "piece_variance"]

#: Fewest effective exceedances a level's estimate may rest on (the stopping rule's floor too).
DEFAULT_MIN_NEFF = 10.0
#: Largest share of a level's rate one run may carry.
DEFAULT_MAX_SHARE = 0.25
#: The status of a level whose failed runs could move it by more than its CoV (module docstring).
UNRESOLVED = "unresolved"
#: A stratum with fewer finished runs than this rests on *few* runs: the rate on such strata is said in every
#: output, and the allocation gives a stratum the steering model predicts to matter at least this many.
FEW_RUNS = 20
#: The control variate stands in a stratum with at least this many successful runs (module docstring): b's
#: correlation with ubar gives the regression estimator an O(1/n) bias, which adds up over strata while the total's
#: SE shrinks -- measured on a pulse stratum (defensive share 0.3, shift (+2.5, -1), P(z_vp > 1), 40 000
#: repetitions): +4.6 % at 20 runs, +2.6 % at 30, +0.6 % at 100 (the plain mean unbiased) ...
CV_MIN_RUNS = 100
#: ... and at least this many of them exceeding the level: below, b would rest on a handful of values.
CV_MIN_HITS = 5


def jeffreys_p0(n) -> np.ndarray:
    """The posterior mean of an exceedance probability after 0 exceedances in ``n`` runs under Jeffreys'
    prior Beta(1/2, 1/2): 0.5 / (n + 1)."""
    return 0.5 / (np.asarray(n, dtype=float) + 1.0)


def jeffreys_run_variance(m2, n):
    """The Jeffreys pseudo-count's per-run variance of w y in a stratum of ``n`` runs none of which exceeds
    (module docstring): m2 p0 - p0^2, m2 the mean square weight, taken at least 1: weights of mean 1 have
    E[w^2] >= E[w]^2 = 1 (Jensen), so a sample mean square below 1 is the sample's shortfall, and below p0 it
    would make the floor 0 -- the flaw the floor mends. Every floor (the rare route's, the paired difference's,
    the rare sequences') takes it from here."""
    p0 = jeffreys_p0(n)
    return np.maximum(np.maximum(np.asarray(m2, dtype=float), 1.0) * p0 - p0 * p0, 0.0)


class WeightError(PycolfragError, ArithmeticError):
    """A sampling weight above its proposal's defensive bound: the density code is wrong."""


def exceedances(cols: dict, q) -> np.ndarray:
    """y of every row for level ``q`` (``edp``, ``threshold``; collapse when ``edp`` is None): the exceedance of
    the fragility curves, collapsed or EDP >= threshold (:func:`pycolfrag.damage.exceeded`, the one
    text of it; ``pcf.fragility``, loaded with the package)."""
    collapsed = np.asarray(cols["collapsed"], dtype=bool)
    if q.edp is None:
        return collapsed
    return _damage.exceeded(np.asarray(cols[q.edp], dtype=float), collapsed, q.threshold)


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
    status: str            # "converged", "above target", "unresolved" or "refused"
    bound: float           # upper bound on the rate (the only number stated for a refused level)
    reason: str = ""
    failed: int = 0        # failed runs in the level's strata
    failed_low: float = math.nan    # the rate with every failed run counted as no exceedance
    failed_high: float = math.nan   # ... and as an exceedance
    few_runs_rate_share: float = 0.0    # share of the rate from strata with fewer than FEW_RUNS runs
    floor_variance_share: float = 0.0   # share of the variance from the floor of strata none of whose runs exceed
    floored_strata: int = 0             # strata none of whose runs exceed the level (floored when a floor is given)

    @property
    def failed_spread(self) -> float:
        """How far the failed runs could move the rate: ``failed_high - failed_low``."""
        return self.failed_high - self.failed_low

    def as_dict(self) -> dict:
        return {**self.__dict__, "failed_spread": self.failed_spread}


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
    failed_by_stratum: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    few_runs_strata: int = 0            # strata kept with fewer than FEW_RUNS finished runs
    few_runs_event_share: float = 0.0   # their share of the kept strata's event rate

    def as_dict(self) -> dict:
        return {"levels": {k: v.as_dict() for k, v in self.levels.items()}, "n_runs": self.n_runs,
                "few_runs": FEW_RUNS, "few_runs_strata": self.few_runs_strata,
                "few_runs_event_share": self.few_runs_event_share,
                "n_failed": self.n_failed, "confidence": self.confidence,
                "runs_by_stratum": self.n_by_stratum.tolist(), "failed_runs_by_stratum": self.failed_by_stratum.tolist(),
                "kong_ess_relative_min": float(np.nanmin(self.ess_relative)) if self.ess_relative.size else None}


def jeffreys_upper(k: int, n: int, level: float = 0.95) -> float:
    """Jeffreys' upper ``level`` limit of a proportion after k of n (1 when k = n)."""
    return 1.0 if k >= n else float(stats.beta.ppf(level, k + 0.5, n - k + 0.5))


@dataclass(frozen=True)
class _Group:
    """The finished rows of one stratum (``rows``, in a fixed order), which of them failed and, where the stratum's
    rows come from several batches combined as pieces (:func:`piece_factors`), every row's factor ``f`` (None: one
    piece, the plain mean) and the variance's design effect ``deff`` (1 for one piece)."""

    h: int
    rows: np.ndarray
    failed: np.ndarray          # bool over rows
    f: np.ndarray | None = None
    deff: float = 1.0
    parts: tuple | None = None  # (every row's piece, the pieces' rescaled weights): :func:`piece_parts`


def piece_weights(stage) -> dict:
    """``{stage: a_b}``: every batch's weight in the combination of pieces, its share of the finished runs
    ``stage`` (one entry per finished row) -- the batches' sizes, which the plans fix before their runs."""
    stage = np.asarray(stage)
    keys, counts = np.unique(stage, return_counts=True)
    return {int(k): float(c) / float(stage.size) for k, c in zip(keys, counts)}


def piece_parts(stage, a: dict) -> tuple[np.ndarray, np.ndarray]:
    """(every row's piece, 0, 1, ... in the order of the batches present; their weights a_b rescaled to sum to 1)
    of one stratum's rows ``stage``."""
    keys, inverse = np.unique(np.asarray(stage), return_inverse=True)
    share = np.array([a[int(k)] for k in keys], dtype=float)
    return inverse, share / math.fsum(share)


def piece_variance(r, failed, parts, fallback: float) -> float:
    """sum_b a_b^2 s_b^2 / n_ok,b: the variance of one stratum's combination of pieces, s_b^2 the sample variance of
    ``r`` (w y, or the control variate's residuals w y - b w) over the batch's successful rows -- unbiased given the
    batches before it, its counts fixed before it ran (v5; a variance pooled over the batches is not: its rows'
    counts follow the outcomes). A batch with fewer than two successful rows takes the per-run variance
    ``fallback`` over its finished rows (its failed runs are no observation)."""
    part, share = parts
    r = np.asarray(r, dtype=float)
    good = ~np.asarray(failed, dtype=bool)
    terms = []
    for b in range(share.size):
        sel = part == b
        x = r[sel & good]
        if x.size >= 2:
            m = math.fsum(x) / x.size
            terms.append(share[b] ** 2 * math.fsum((x - m) ** 2) / (x.size - 1) / x.size)
        else:
            terms.append(share[b] ** 2 * fallback / max(x.size, int(np.sum(sel)), 1))
    return math.fsum(terms)


def piece_factors(stage, failed, a: dict) -> tuple[np.ndarray | None, float]:
    """(f, deff) of one stratum's rows in the combination of pieces (module docstring): its mean
    sum_b a_b mean_b = (1 / n) sum_i f_i v_i with f_i = a_b n / n_b over the batches b present (their a_b
    rescaled to sum to 1), and the design effect deff = n_ok sum_b a_b^2 / n_ok,b (1 for one batch: the plain mean,
    bit for bit) by which a common per-run variance -- the floor of a stratum none of whose runs exceeds -- is
    that of the combination, s^2 / n_ok x deff (with exceedances the batches' own variances stand:
    :func:`piece_variance`). A batch whose every run failed counts as one run here: deff may then fall below 1."""
    inverse, share = piece_parts(stage, a)
    if share.size == 1:
        return None, 1.0
    n = inverse.size
    f = (share * (n / np.bincount(inverse, minlength=share.size)))[inverse]
    ok = np.bincount(inverse[~np.asarray(failed, dtype=bool)], minlength=share.size)
    n_ok = int(ok.sum())
    deff = n_ok * math.fsum(share ** 2 / np.maximum(ok, 1)) if n_ok else 1.0
    return f, deff


def _status(lam, cov, n_eff, share, hits, bound, spread, failed, limits):
    """(status, reason) of a level: refused (too few effective exceedances, or one run too large a share),
    unresolved (failed runs that could move it beyond its CoV), converged or above the target."""
    min_neff, max_share, target = limits
    if lam <= 0 or n_eff < min_neff or share > max_share:
        return "refused", (f"the estimate rests on {n_eff:.1f} effective exceedances ({hits} runs exceed), the largest "
                           f"run carries {100 * min(share, 1.0):.0f} % of it (needs >= {min_neff:g} and <= "
                           f"{100 * max_share:.0f} %); upper bound {bound:.3g} /yr"
                           + (f" (its {failed} failed runs counted as exceeding)" if failed else ""))
    if failed and spread > cov * lam:
        return UNRESOLVED, (f"{failed} failed runs: counted as exceedances or as none they move the rate over "
                            f"{spread:.3g} /yr, more than its CoV x rate ({cov * lam:.3g} /yr); the failed runs, not "
                            "the number of runs, limit what is known of it")
    status = "converged" if target is None or cov <= target else "above target"
    return status, ("" if status == "converged" else f"CoV {cov:.3f} above the target {target:g}")


def _stratum_values(g, w, y) -> tuple[np.ndarray, float, float]:
    """(w_i y_i of the stratum's rows, a failed row's imputed, as its weight times the stratum's weighted
    exceedance share among its successful rows; sum of w y over the successful rows; of w over the failed)."""
    v = w[g.rows] * y[g.rows]
    if not g.failed.any():
        return v, math.fsum(v), 0.0
    good = ~g.failed
    s_ok, w_ok = math.fsum(v[good]), math.fsum(w[g.rows][good])
    v[g.failed] = w[g.rows][g.failed] * (s_ok / w_ok if w_ok > 0 else 0.0)
    return v, s_ok, math.fsum(w[g.rows][g.failed])


def regression(v, u, failed, hits: int, f=None) -> tuple[float, float, float | None]:
    """(b, b (ubar - 1), s^2 of the regression's residuals) of one stratum's values v = w y (a failed row's
    imputed) on its control variate u (the sampling weights, mean 1; module docstring), ``failed`` the failed rows,
    ``hits`` the successful rows that exceed; (0, 0, None) where the rule leaves the plain estimator. ``f``: the
    rows' factors where the stratum's mean combines pieces (:func:`piece_factors`; ubar and vbar their weighted
    means, b and s^2 from every row)."""
    real, u_ok = v[~failed], u[~failed]
    n_ok = real.size
    if n_ok < CV_MIN_RUNS or hits < CV_MIN_HITS or hits == n_ok:
        # every run exceeding: v = u exactly, the residuals 0, a stated variance of 0 -- n of n does not prove p = 1
        return 0.0, 0.0, None
    du = u_ok - math.fsum(u_ok) / n_ok
    suu = math.fsum(du * du)
    if not suu > 1e-12 * n_ok:
        return 0.0, 0.0, None
    dv = real - math.fsum(real) / n_ok
    b = math.fsum(dv * du) / suu
    fu, fv = (u, v) if f is None else (f * u, f * v)
    shift = b * (math.fsum(fu) / u.size - 1.0)
    if math.fsum(fv) / v.size - shift < 0:
        return 0.0, 0.0, None
    return b, shift, math.fsum((dv - b * du) ** 2) / (n_ok - 2)


def stratum_run_variance(real, hit: bool, s2, floor_h) -> tuple[float, bool]:
    """(the per-run variance of w y in one stratum as the estimate states it, whether it is the floor), from the
    successful runs' values ``real``: the control variate's residual variance ``s2`` where its rule took the
    stratum (not None); else the sample variance where one of them exceeds (``hit``); else, every run missing,
    the floor ``floor_h`` (None: 0; module docstring); infinite with fewer than 2 runs. One text for the
    estimate and the paired difference (:mod:`pycolfrag.risk.paired_difference`)."""
    n = real.size
    if s2 is not None:
        return float(s2), False
    if n >= 2 and hit:
        mu = math.fsum(real) / n
        return math.fsum((real - mu) ** 2) / (n - 1), False
    if n >= 2:
        return (0.0 if floor_h is None else float(floor_h)), True
    return math.inf, False


def _level(q, W, groups, w, y, confidence, limits, floor=None, u=None):
    """One level from the rows grouped by stratum: (LevelEstimate, per-stratum W_h mu_h); ``floor``: the
    per-run variance of every stratum none of whose runs exceeds (None: 0); ``u``: every row's control variate
    of mean 1 (None: the plain estimator)."""
    lam_terms, var_terms, contrib, bound_terms, lo_terms, fail_terms = [], [], [], [], [], []
    floor_terms, few_terms = [], []
    per = np.zeros(W.size)
    for g in groups:
        v, s_ok, w_failed = _stratum_values(g, w, y)
        n = g.rows.size
        b, shift, s2 = (0.0, 0.0, None) if u is None else regression(v, u[g.rows], g.failed,
                                                                      int(np.sum(y[g.rows][~g.failed])), g.f)
        fv = v if g.f is None else g.f * v                   # the pieces' combination (module docstring)
        if g.f is not None:
            s_ok = math.fsum(fv[~g.failed])
            w_failed = math.fsum(g.f[g.failed] * w[g.rows][g.failed])
        mu = math.fsum(fv) / n - shift
        per[g.h] = W[g.h] * mu
        lam_terms.append(per[g.h])
        # the variance from the successful runs alone: an imputed value is no observation, and counting it
        # would shrink the CoV by about n_ok / n (0.086 for 0.107 at 20 % failed); with no failure, the same bits
        real = v[~g.failed]
        n_ok = real.size
        s2, floored = stratum_run_variance(real, bool(np.any(y[g.rows][~g.failed])), s2,
                                           None if floor is None else floor[g.h])
        if g.parts is not None and not floored and math.isfinite(s2):   # the pieces' own variances (v5)
            r = v if b == 0.0 else v - b * u[g.rows]
            var_terms.append(W[g.h] ** 2 * piece_variance(r, g.failed, g.parts, s2))
        else:
            var_terms.append(W[g.h] ** 2 * s2 / n_ok * g.deff if math.isfinite(s2) else math.inf)
        if floored:
            floor_terms.append(var_terms[-1])
        if n < FEW_RUNS:
            few_terms.append(per[g.h])
        contrib.append(W[g.h] * fv[~g.failed][real > 0] / n)
        lo_terms.append(W[g.h] * (s_ok / n - shift))        # as per[h] when no run failed: the same bits
        fail_terms.append(W[g.h] * (w_failed / n))
        k = int(np.sum(y[g.rows])) + int(np.sum(g.failed))   # failed runs counted as exceeding
        bound_terms.append(W[g.h] * float(np.max(w[g.rows])) * jeffreys_upper(k, n))
    lam, var = math.fsum(lam_terms), math.fsum(var_terms)
    c = np.concatenate(contrib) if contrib else np.zeros(0)
    hits = int(sum(int(np.sum(y[g.rows])) for g in groups))
    failed = int(sum(int(np.sum(g.failed)) for g in groups))
    n_eff = math.fsum(c) ** 2 / math.fsum(c * c) if c.size else 0.0
    share = float(np.max(c)) / lam if lam > 0 else math.inf
    cov = math.sqrt(var) / lam if lam > 0 else math.inf
    zq = float(stats.norm.ppf(0.5 + confidence / 2))
    half = zq * math.sqrt(math.log1p(cov * cov)) if math.isfinite(cov) else math.inf
    low, high = (lam * math.exp(-half), lam * math.exp(half)) if lam > 0 else (0.0, math.inf)
    bound = math.fsum(bound_terms)
    f_lo = math.fsum(lo_terms)
    f_hi = f_lo + math.fsum(fail_terms)
    status, reason = _status(lam, cov, n_eff, share, hits, bound, f_hi - f_lo, failed, limits)
    few = math.fsum(few_terms) / lam if lam > 0 else 0.0
    floor = math.fsum(floor_terms) / var if var > 0 and math.isfinite(var) else 0.0
    return LevelEstimate(q.label, lam, cov, low, high, n_eff, share, hits, status, bound, reason, failed, f_lo,
                         f_hi, few, floor, len(floor_terms)), per


def _groups(h_all, ok, order, strata, keep, stage=None, a=None) -> list:
    """The :class:`_Group` of every stratum kept (an error when one has fewer than two finished runs); ``stage``
    and ``a`` (:func:`piece_weights`): every row's batch and the batches' weights, where the pieces combine."""
    groups, short = [], []
    for h in range(len(strata)):
        if not keep[h]:
            continue
        rows = order[h_all[order] == h]
        if rows.size < 2:
            short.append(h)
            continue
        f, deff = (None, 1.0) if a is None else piece_factors(stage[rows], ~ok[rows], a)
        groups.append(_Group(h, rows, ~ok[rows], f, deff, None if f is None else piece_parts(stage[rows], a)))
    if short:
        raise PycolfragError(f"strata {short[:10]} hold fewer than two finished runs: no estimate yet")
    return groups


def estimate(cols: dict, strata, design, quantities, *, confidence: float = 0.90, min_neff: float = DEFAULT_MIN_NEFF,
             max_share: float = DEFAULT_MAX_SHARE, target_cov: float | None = None, keep=None,
             floor=None, control: bool = True, reweight=None, pieces: bool = False) -> Estimate:
    """The estimate of every level of ``quantities`` from the rows ``cols`` (columns of the event layout).

    ``keep``: a boolean mask over the strata (e.g. those inside a grid's range): only they enter (the
    rate of that part of the site). Rows not computed yet are ignored; failed rows are counted, left out
    of a stratum's mean (its successful rows stand for it) and bound every level (module docstring:
    a level they could move beyond its CoV is unresolved). Every stratum kept must hold at least two
    finished rows. ``floor``: (H, L) per-run variances of the strata none of whose runs exceed a level, in
    the order of ``quantities`` (module docstring; :func:`pycolfrag.rare.allocation.variance_floor`); None:
    such a stratum adds nothing to the variance. ``control``: the weights' known mean as a control variate
    (module docstring; False: the plain estimator). ``reweight``: a factor rho of every row's weight (a logic
    tree's re-weighted branch, :mod:`pycolfrag.risk.tree_rare`); the control variate stays the sampling weight.
    ``pieces``: every batch (the rows' ``stage``) its own stratified estimate, combined with the batches' shares
    of the runs (module docstring, "Batches as pieces"); False: every stratum's rows pooled.
    """
    status = np.asarray(cols["status"])
    done = status != _results.STATUS_PENDING
    keep = np.ones(len(strata), dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    sub = {k: np.asarray(v)[done] for k, v in cols.items()}
    ok = np.asarray(sub["status"]) == _results.STATUS_OK
    u, checks = row_weights(sub, strata, design) if done.any() else (np.zeros(0), {})
    w = u if reweight is None else u * np.asarray(reweight, dtype=float)[done]
    h_all = np.asarray(sub["stratum"]) if done.any() else np.zeros(0, dtype=int)
    W = strata.rates
    order = np.lexsort((np.asarray(sub.get("index", h_all)), np.asarray(sub.get("stage", h_all)), h_all))
    n_by = np.bincount(h_all[ok], minlength=len(strata)) if h_all.size else np.zeros(len(strata), dtype=int)
    failed_by = np.bincount(h_all[~ok], minlength=len(strata)) if h_all.size else np.zeros(len(strata), dtype=int)
    stage = np.asarray(sub["stage"]) if pieces and h_all.size else None
    groups = _groups(h_all, ok, order, strata, keep, stage, piece_weights(stage) if stage is not None else None)
    ess = np.full(len(strata), np.nan)
    for g in groups:
        w2 = math.fsum(w[g.rows] ** 2)     # 0: every weight 0 (a re-weighted logic-tree branch outside this stratum)
        ess[g.h] = math.fsum(w[g.rows]) ** 2 / w2 / g.rows.size if w2 > 0 else math.nan
    levels, contributions = {}, {}
    for j, q in enumerate(quantities):
        y = np.where(ok, exceedances(sub, q), False)      # a failed row's outcome is unknown: bounded, not counted
        levels[q.label], contributions[q.label] = _level(q, W, groups, w, y, confidence,
                                                         (min_neff, max_share, target_cov),
                                                         None if floor is None else np.asarray(floor)[:, j],
                                                         u if control else None)
    few = [g.h for g in groups if g.rows.size < FEW_RUNS]
    kept_rate = math.fsum(W[g.h] for g in groups)
    return Estimate(levels, int(np.sum(done)), int(np.sum(~ok)), n_by, ess, checks, contributions, confidence,
                    failed_by, len(few), math.fsum(W[few]) / kept_rate if kept_rate > 0 else 0.0)


def jeffreys_floor(cols: dict, strata, design, quantities) -> np.ndarray:
    """(H, L): the Jeffreys pseudo-count's per-run variance of w y of every stratum and level none of whose
    successful runs exceeds it, m2 p0 - p0^2 (module docstring), 0 where one does (a stratum without rows:
    that of 0 runs with m2 = 1, 1/4; m2 at least 1: :func:`jeffreys_run_variance`)."""
    status = np.asarray(cols["status"])
    ok = status == _results.STATUS_OK
    sub = {k: np.asarray(v)[ok] for k, v in cols.items()}
    H = len(strata)
    h = np.asarray(sub["stratum"], dtype=int)
    w, _ = row_weights(sub, strata, design) if ok.any() else (np.zeros(0), {})
    n = np.bincount(h, minlength=H).astype(float)
    m2 = np.where(n > 0, np.bincount(h, weights=w * w, minlength=H) / np.maximum(n, 1.0), 1.0)
    base = jeffreys_run_variance(m2, n)
    out = np.zeros((H, len(quantities)))
    for j, q in enumerate(quantities):
        hits = np.bincount(h, weights=exceedances(sub, q).astype(float), minlength=H)
        out[:, j] = np.where(hits > 0, 0.0, base)
    return out


def efficiency(level: LevelEstimate, total_rate: float, runs: int) -> dict:
    """Crude Monte Carlo's runs for the same CoV, N = (1 - p) / (p CoV^2) with p = lambda / (the site's event
    rate) the probability per simulated event, and their ratio to the runs used."""
    if not (level.rate > 0 and math.isfinite(level.cov) and level.cov > 0):
        return {"p_per_event": level.rate / total_rate, "crude_runs": math.inf, "efficiency": math.nan}
    p = level.rate / total_rate
    n = (1.0 - p) / (p * level.cov ** 2)
    return {"p_per_event": p, "crude_runs": n, "efficiency": n / runs}
