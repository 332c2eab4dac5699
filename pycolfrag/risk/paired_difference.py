"""The paired difference of two run settings simulated on the same events (common random numbers,
:func:`pycolfrag.rare.paired.simulate_paired`): per level, lambda_B - lambda_A with its own standard error and
interval (docs/restoration.md, "On the same events"; docs/logic_tree.md, "On the rare-event route").

Both settings ran the same rows -- the same (stage, stratum, index), Mw, R, noise seed and pulse normals, hence
the same weights w_i (:func:`check_same_events` refuses two sets of rows that are not, naming the first row and
field that differ). With v_i = w_i y_i of each setting (a failed run's imputed as the estimator imputes it,
w_i times its stratum's weighted exceedance share among the setting's successful rows) and d_i = v_Bi - v_Ai::

    D = sum_h W_h [(1/n_h) sum_i d_i - (b_Bh - b_Ah)(ubar_h - 1)]      V_D = sum_h W_h^2 s_h^2(d) / n_ok_h

(with the batches as pieces, v5 of the rare route: every (1/n_h) sum_i is (1/n_h) sum_i f_i, the factors of the
rows of both settings alike, :func:`pycolfrag.rare.estimate.piece_factors`; s_h^2(d) / n_ok_h is each batch's own
sample variance of the difference times a_b^2 over its rows, :func:`pycolfrag.rare.estimate.piece_variance`, and
a floor is times the stratum's design effect deff_h), b_Ah, b_Bh each setting's regression of v on the weights u = w (the control variate of
:mod:`pycolfrag.rare.estimate`, by its own rule: 0 where it takes the plain mean), s_h^2 that of
d_i - (b_Bh - b_Ah)(u_i - ubar_h) over the rows that succeeded in both (an imputed value is no observation),
n_ok_h their number. A stratum none of whose rows differ has s_h^2 = 0, as if 0 differing runs of n proved the
settings alike there: it takes a floor instead, as the estimate does for a stratum none of whose runs exceed --
the smaller of the Jeffreys pseudo-count's m2 p0 - p0^2 of a differing run (p0 = 0.5 / (n_ok_h + 1), m2 the mean
square weight, at least 1: :func:`pycolfrag.rare.estimate.jeffreys_run_variance`) and the sum of the two
settings' per-run variances there as their estimates state them (sample, regression or floor): Var(v_B - v_A)
<= Var(v_A) + Var(v_B) where the outcomes of one event under the two settings are not negatively correlated,
the premise of pairing; the pseudo-count alone would state a difference wider than two independent simulations
where two settings differ only in the pulse strata, as a pulse amplitude's. D is lambda_B - lambda_A of the stratified estimator of
:mod:`pycolfrag.rare.estimate` (the same rows, the same weights: equal to round-off when no run failed). The
interval is D +- z sqrt(V_D) (normal: a difference may have either sign). Beside it: V_A + V_B, the variances
the two settings' estimates state (floors included), which two independent simulations of the same runs would
give the difference, and their ratio (V_A + V_B) / V_D -- how many times the runs pairing saves for the same
precision of the difference --; the runs whose outcome differs between the two settings, Kong's
effective number of them (n_eff = (sum |c|)^2 / sum c^2 over their contributions c_i = W_h d_i / n_h); and
an upper bound on |D| (every stratum's largest weight times the Jeffreys 95 % upper limit of its share of
differing runs), the only number stated when no run differs. A difference resting on fewer than
``min_neff`` effective differing runs is marked ``few differing runs``: its interval is stated but, as a
level's with as few exceedances, not to be trusted. Failed runs bound D: every failed run of B as none and
of A as an exceedance (the low end), and the other way round.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError
from pycolfrag.rare.estimate import (
    DEFAULT_MIN_NEFF,
    estimate,
    exceedances,
    jeffreys_floor,
    jeffreys_run_variance,
    jeffreys_upper,
    piece_factors,
    piece_parts,
    piece_variance,
    piece_weights,
    regression,
    row_weights,
    stratum_run_variance,
)

__all__ = ["EVENT_FIELDS", "PairedDifference", "check_same_events", "common_batches", "paired_differences"]

#: The fields of a row that make its event: identical in both settings, row for row.
EVENT_FIELDS = ("stage", "stratum", "index", "source", "mw", "dist_km", "hf_seed", "pulse", "z_mw", "z_dist", "z_vp",
                "z_fp", "z_nu", "z_gamma", "occurrence_weight", "weight")


@dataclass
class PairedDifference:
    """One level's lambda_B - lambda_A on the same events (module docstring)."""

    label: str
    difference: float
    sd: float
    low: float
    high: float
    confidence: float
    status: str                  # "differs", "not distinguished", "few differing runs", "no differing run"
    bound: float                 # upper bound on |difference|
    pairs: int                   # rows finished in both
    differing: int               # rows whose outcome differs
    n_eff: float                 # effective number of differing rows
    var_independent: float       # V_A + V_B
    pairing_gain: float          # (V_A + V_B) / V_D
    failed: int = 0              # rows failed in either setting
    failed_low: float = math.nan
    failed_high: float = math.nan

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _order(cols) -> np.ndarray:
    return np.lexsort((np.asarray(cols["index"]), np.asarray(cols["stage"]), np.asarray(cols["stratum"])))


def check_same_events(cols_a: dict, cols_b: dict, names=("A", "B")) -> tuple:
    """(order of A's rows, order of B's rows) that pair them; ParameterError naming the first row and field
    that differ when the two sets of finished rows are not the same events."""
    done_a = np.asarray(cols_a["status"]) != _results.STATUS_PENDING
    done_b = np.asarray(cols_b["status"]) != _results.STATUS_PENDING
    a = {k: np.asarray(v)[done_a] for k, v in cols_a.items()}
    b = {k: np.asarray(v)[done_b] for k, v in cols_b.items()}
    if a["status"].size != b["status"].size:
        raise ParameterError(f"{names[0]} has {a['status'].size} finished runs and {names[1]} "
                             f"{b['status'].size}: not the same events (simulate both with simulate_paired)")
    ia, ib = _order(a), _order(b)
    for f in EVENT_FIELDS:
        if f not in a and f not in b:
            continue
        if f not in a or f not in b:
            raise ParameterError(f"field {f!r} is in the rows of {names[0] if f in a else names[1]} only")
        x, y = np.asarray(a[f])[ia], np.asarray(b[f])[ib]
        same = (x == y) | (np.isnan(x) & np.isnan(y)) if x.dtype.kind == "f" else x == y
        if not np.all(same):
            k = int(np.flatnonzero(~same)[0])
            raise ParameterError(
                f"run (stage {int(a['stage'][ia][k])}, stratum {int(a['stratum'][ia][k])}, index "
                f"{int(a['index'][ia][k])}): {f} is {x[k]!r} in {names[0]} and {y[k]!r} in {names[1]}: not the same "
                "events, so no paired difference (simulate both with one seed and site: simulate_paired)")
    return np.flatnonzero(done_a)[ia], np.flatnonzero(done_b)[ib]


def common_batches(run_a, run_b) -> tuple:
    """The two runs restricted to the batches both ran (``(run_a, run_b)`` themselves when they ran the same ones),
    each estimate recomputed on its part: a logic tree's run settings sit out the batches their share of the tree's
    error does not ask for (:class:`pycolfrag.risk.tree_rare.TreeShare`), and a batch both ran is the same events in
    both. Every batch is a piece of its own (unbiased given the batches before it), so the part is an estimate of
    both settings' rates on the same events; the runs' own variance floors stand (per run, as the estimate's)."""
    sa, sb = (np.asarray(r.cols["stage"], dtype=int) for r in (run_a, run_b))
    both = np.intersect1d(np.unique(sa), np.unique(sb))
    if both.size == np.unique(sa).size == np.unique(sb).size:
        return run_a, run_b
    out = []
    for r, st in ((run_a, sa), (run_b, sb)):
        keep = np.isin(st, both)
        cols = {k: np.asarray(v)[keep] for k, v in r.cols.items()}
        x = r.stop
        est = estimate(cols, r.strata, r.design, r.quantities, confidence=x.confidence, min_neff=x.min_neff,
                       max_share=x.max_share, target_cov=x.target_cov, floor=r.floor, pieces=True)
        out.append(replace(r, cols=cols, estimate=est))
    return tuple(out)


def _imputed(v, w, ok, h):
    """v with each failed row's value its weight times the stratum's weighted share among successful rows: the
    estimate's law (:func:`pycolfrag.rare.estimate._stratum_values`) on the rows of every stratum at once."""
    out = v.copy()
    for s in np.unique(h[~ok]):
        sel = h == s
        w_ok = math.fsum(w[sel & ok])
        share = math.fsum(v[sel & ok]) / w_ok if w_ok > 0 else 0.0
        out[sel & ~ok] = w[sel & ~ok] * share
    return out


def _run_variance(v, ok, r, floor) -> float:
    """A setting's per-run variance of its stratum as its estimate states it (the estimator's own rule,
    :func:`pycolfrag.rare.estimate.stratum_run_variance`: the regression's, the sample's, or the floor where none
    of its runs exceeds)."""
    return stratum_run_variance(v[ok], bool(np.any(v[ok] != 0)), r[2], floor)[0]


def _pieces(stage, h, both) -> tuple[np.ndarray, dict, dict]:
    """(every row's factor f, every stratum's design effect, every stratum's pieces -- None for one batch) of the
    rows' batches combined as pieces, as the estimate combines them (:func:`pycolfrag.rare.estimate.piece_factors`;
    the variance over the rows finished in both settings)."""
    a = piece_weights(stage)
    f, deff, parts = np.ones(h.size), {}, {}
    for s in np.unique(h):
        sel = h == s
        fs, deff[s] = piece_factors(stage[sel], ~both[sel], a)
        parts[s] = None if fs is None else piece_parts(stage[sel], a)
        if fs is not None:
            f[sel] = fs
    return f, deff, parts


def _paired_terms(va, vb, ya, yb, w, h, ok_a, ok_b, W, floors, f, deff, parts) -> tuple[float, float]:
    """(D, V_D): per stratum, each setting's mean by the rare estimator's regression on the weights (its own b,
    :func:`pycolfrag.rare.estimate.regression`, so that D is lambda_B - lambda_A), s^2 of the rows' difference
    less (b_B - b_A)(u - ubar) over the rows finished in both; a stratum none of whose rows differ takes the
    floor of the module docstring instead of 0. ``f``, ``deff``, ``parts``: the batches as pieces (:func:`_pieces`;
    where rows differ, each batch's own sample variance of the difference, :func:`pycolfrag.rare.estimate.
    piece_variance`)."""
    d_terms, v_terms = [], []
    for s in np.unique(h):
        sel = h == s
        u = w[sel]
        single = parts[s] is None                            # one batch: the plain means
        fs = None if single else f[sel]
        ra = regression(va[sel], u, ~ok_a[sel], int(np.sum(ya[sel])), fs)
        rb = regression(vb[sel], u, ~ok_b[sel], int(np.sum(yb[sel])), fs)
        n = int(sel.sum())
        dv = vb[sel] - va[sel] if single else fs * (vb[sel] - va[sel])
        d_terms.append(W[s] * (math.fsum(dv) / n - (rb[1] - ra[1])))
        both = (ok_a & ok_b)[sel]
        m = int(both.sum())
        if m < 2:
            v_terms.append(math.inf)
            continue
        x = (vb[sel] - va[sel])[both] - (rb[0] - ra[0]) * (u[both] - math.fsum(u[both]) / m)
        if np.any(ya[sel][both] != yb[sel][both]) and parts[s] is not None:
            r = (vb[sel] - va[sel]) - (rb[0] - ra[0]) * u
            v_terms.append(W[s] ** 2 * piece_variance(r, ~both, parts[s], float(np.var(x, ddof=1))))
        elif np.any(ya[sel][both] != yb[sel][both]):
            v_terms.append(W[s] ** 2 * float(np.var(x, ddof=1)) / m)
        else:
            m2 = math.fsum(u[both] ** 2) / m
            ind = (_run_variance(va[sel], ok_a[sel], ra, floors[0][s])
                   + _run_variance(vb[sel], ok_b[sel], rb, floors[1][s]))
            v_terms.append(W[s] ** 2 * min(float(jeffreys_run_variance(m2, m)), ind) / m * deff[s])
    return math.fsum(d_terms), math.fsum(v_terms)


def _sd_of(level) -> float:
    return level.cov * level.rate if math.isfinite(level.cov) else math.inf


def _level(q, a, b, w, h, ok_a, ok_b, W, confidence, min_neff, est, floors) -> PairedDifference:
    ya = np.where(ok_a, exceedances(a, q), False).astype(float)
    yb = np.where(ok_b, exceedances(b, q), False).astype(float)
    nh = np.bincount(h, minlength=W.size).astype(float)
    both = ok_a & ok_b
    f, deff, parts = _pieces(np.asarray(a["stage"]), h, both)
    scale = W[h] / nh[h] * f                                # W_h f_i / n_h of every row (f: the batches as pieces)
    va, vb = _imputed(w * ya, w, ok_a, h), _imputed(w * yb, w, ok_b, h)
    c = scale * (vb - va)
    diff, var = _paired_terms(va, vb, ya, yb, w, h, ok_a, ok_b, W, floors, f, deff, parts)
    var_ind = _sd_of(est[0].levels[q.label]) ** 2 + _sd_of(est[1].levels[q.label]) ** 2
    sd = math.sqrt(var)
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    differ = both & (ya != yb)
    cd = np.abs(c[differ])
    n_eff = math.fsum(cd) ** 2 / math.fsum(cd * cd) if cd.size else 0.0
    bound = math.fsum(W[s] * float(np.max(w[h == s])) * jeffreys_upper(int(np.sum(differ[h == s])),
                                                                          int(np.sum(h == s))) for s in np.unique(h))
    if not differ.any():
        status = "no differing run"
    elif n_eff < min_neff:
        status = "few differing runs"
    else:
        status = "differs" if abs(diff) > z * sd else "not distinguished"
    failed = int(np.sum(~(ok_a & ok_b)))
    lo = hi = math.nan
    if failed:
        lo = math.fsum(scale * (w * np.where(ok_b, yb, 0.0) - w * np.where(ok_a, ya, 1.0)))
        hi = math.fsum(scale * (w * np.where(ok_b, yb, 1.0) - w * np.where(ok_a, ya, 0.0)))
    return PairedDifference(q.label, diff, sd, diff - z * sd, diff + z * sd, confidence, status, bound, int(both.sum()),
                            int(differ.sum()), n_eff, var_ind, var_ind / var if var > 0 else math.inf, failed, lo, hi)


def paired_differences(run_a, run_b, quantities=None, *, confidence: float = 0.90,
                       min_neff: float = DEFAULT_MIN_NEFF, names=("A", "B")) -> dict:
    """label -> :class:`PairedDifference` of lambda_B - lambda_A for every level of ``quantities`` (default:
    ``run_a.quantities``), from two :class:`~pycolfrag.rare.driver.SiteRun` of the same events."""
    if not 0.0 < confidence < 1.0:
        raise ParameterError(f"the confidence must be in (0, 1), got {confidence!r}")
    ia, ib = check_same_events(run_a.cols, run_b.cols, names)
    a = {k: np.asarray(v)[ia] for k, v in run_a.cols.items()}
    b = {k: np.asarray(v)[ib] for k, v in run_b.cols.items()}
    w, _ = row_weights(a, run_a.strata, run_a.design)
    h = np.asarray(a["stratum"], dtype=int)
    ok_a = np.asarray(a["status"]) == _results.STATUS_OK
    ok_b = np.asarray(b["status"]) == _results.STATUS_OK
    W = np.asarray(run_a.strata.rates, dtype=float)
    quantities = quantities or run_a.quantities

    fa, fb = (np.asarray(jeffreys_floor(r.cols, r.strata, r.design, r.quantities) if r.floor is None else r.floor,
                         dtype=float) for r in (run_a, run_b))        # (H, L) each, read once
    col = {x.label: j for j, x in enumerate(run_a.quantities)}
    return {q.label: _level(q, a, b, w, h, ok_a, ok_b, W, confidence, min_neff, (run_a.estimate, run_b.estimate),
                            [fa[:, col[q.label]], fb[:, col[q.label]]]) for q in quantities}
