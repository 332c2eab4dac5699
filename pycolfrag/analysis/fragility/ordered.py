"""Nested limit states fitted together: one median each and a common dispersion.

Separate maximum-likelihood fits (:func:`~pycolfrag.analysis.fragility.fit_lognormal_fragility`) of
nested limit states -- every run that exceeds a more severe state exceeds the less severe ones too, as a
collapse exceeds every level -- can cross: two lognormal curves with different dispersions cross
somewhere, and there the more severe state is the more probable one, which makes the damage state
between them negative. Curves with one common dispersion never cross. This is the cumulative probit
model of ordered outcomes: a run's outcome is the number c of states it exceeds, and

    P(c >= k | x) = Phi((ln x - ln theta_k) / beta),   theta_1 <= ... <= theta_K,

so P(c = k) = Phi(z_k) - Phi(z_{k+1}) (Phi(z_0) = 1, Phi(z_{K+1}) = 0). The log-likelihood
sum_i ln P(c_i) is maximised over (ln theta_1, the gaps ln theta_k - ln theta_{k-1} >= 0, ln beta)
with ``scipy.optimize.minimize`` (L-BFGS-B, bounded as the separate fits are). With one state it is
the separate fit's likelihood. Giving nested damage states one dispersion so that they cannot
intersect is common practice (FEMA P-58's fragility functions of sequential damage states).
"""
from __future__ import annotations

import numpy as np

from pycolfrag.analysis.fragility import degenerate as _degenerate
from pycolfrag.analysis.fragility.mle import BETA_MAX, BETA_MIN, LognormalFragility, _fit_reasons, _mle_bounds
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.scipy_on_first_use import optimize, special
from pycolfrag.core.validate import float_array


def _log_prob_between(u, v):
    """ln(Phi(u) - Phi(v)) for u >= v (arrays), accurate in both tails (``scipy.special.log_ndtr``)."""
    upper = v > 0     # both in the upper tail: Phi(u) - Phi(v) = Phi(-v) - Phi(-u)
    a = np.where(upper, -v, u)
    b = np.where(upper, -u, v)
    la, lb = special.log_ndtr(a), special.log_ndtr(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        return la + np.log1p(-np.exp(np.minimum(lb - la, 0.0)))


def _nll(p, ln_im, c, k_states):
    a = p[0] + np.concatenate([[0.0], np.cumsum(p[1:k_states])])      # ln theta_1 .. ln theta_K
    beta = np.exp(p[k_states])
    z = (ln_im[None, :] - a[:, None]) / beta                            # (K, n)
    inf = np.full((1, ln_im.size), np.inf)
    zz = np.concatenate([inf, z, -inf])                                 # z_0 = +inf, z_{K+1} = -inf
    cols = np.arange(ln_im.size)
    lp = _log_prob_between(zz[c, cols], zz[c + 1, cols])
    return -np.sum(np.maximum(lp, -745.0))    # a run in an empty-width category: finite, very unlikely


def fit_ordered_fragility(im, exceed, x0=None) -> list:
    """Lognormal fragility curves of nested limit states with one common dispersion, by maximum likelihood.

    Parameters
    ----------
    im : array_like (n,)
        IM of each run (> 0, IM units).
    exceed : array_like of bool (K, n)
        ``exceed[k, i]``: run i exceeds limit state k; states in increasing severity and nested
        (``exceed[k + 1]`` implies ``exceed[k]``), else ParameterError.
    x0 : (medians, beta), optional
        Start (default: the medians' sorted values and the geometric mean of ``beta`` are taken from
        the caller's separate fits when given, else the outcomes' median IMs and 0.5).

    Returns
    -------
    list of :class:`LognormalFragility`, one per state, all with the common ``beta``; ``loglik`` is
    each state's own binomial log-likelihood at the joint parameters, ``degenerate`` its reasons
    (:func:`~pycolfrag.analysis.fragility.mle._fit_reasons` at the joint parameters).
    """
    x = float_array(im, "im", ndim=1)
    if np.any(x <= 0):
        raise ParameterError("IM values must be positive for a lognormal fit")
    y = np.asarray(exceed, dtype=bool)
    if y.ndim != 2 or y.shape[1] != x.size:
        raise ParameterError(f"exceed must have shape (states, {x.size}), got {y.shape}")
    if np.any(y[1:] & ~y[:-1]):
        k = int(np.argmax(np.any(y[1:] & ~y[:-1], axis=1)))
        raise ParameterError(f"limit states {k} and {k + 1} are not nested (a run exceeds the more severe one "
                             "without the other): order them by severity")
    k_states = y.shape[0]
    for k in range(k_states):
        if y[k].all() or not y[k].any():
            raise ParameterError(f"limit state {k}: every run {'exceeds' if y[k].all() else 'stays below'} it: "
                                 "no interior maximum")
    ln_im = np.log(x)
    c = y.sum(axis=0)
    (lo_a, hi_a), _ = _mle_bounds(ln_im)
    if x0 is None:
        meds = [np.median(ln_im[y[k]]) for k in range(k_states)]
        start_a, start_lb = np.maximum.accumulate(meds), np.log(0.5)
    else:
        start_a, start_lb = np.maximum.accumulate(np.log(np.asarray(x0[0], dtype=float))), np.log(float(x0[1]))
    p0 = np.concatenate([[start_a[0]], np.diff(start_a), [start_lb]])
    bounds = ([(lo_a, hi_a)] + [(0.0, hi_a - lo_a)] * (k_states - 1) + [(np.log(BETA_MIN), np.log(BETA_MAX))])
    p0 = np.clip(p0, [b[0] for b in bounds], [b[1] for b in bounds])
    res = optimize.minimize(_nll, p0, args=(ln_im, c, k_states), method="L-BFGS-B", bounds=bounds,
                            options={"ftol": 1e-14, "gtol": 1e-9, "maxiter": 2000})
    return _fits(res.x, ln_im, y, k_states)


def _fits(p, ln_im, y, k_states) -> list:
    a = p[0] + np.concatenate([[0.0], np.cumsum(p[1:k_states])])
    ln_beta = p[k_states]
    out = []
    for k in range(k_states):
        z = (ln_im - a[k]) / np.exp(ln_beta)
        ll = float(np.sum(np.where(y[k], special.log_ndtr(z), special.log_ndtr(-z))))
        fit = LognormalFragility(float(np.exp(a[k])), float(np.exp(ln_beta)), int(y[k].size), int(y[k].sum()), ll)
        why, causes = _fit_reasons(ln_im, y[k], (a[k], ln_beta), _mle_bounds(ln_im))
        fit.degenerate = "; ".join(why)
        if fit.degenerate:
            _degenerate.warn(f"fit_ordered_fragility (state {k}): {fit.degenerate}", causes, stacklevel=3)
        out.append(fit)
    return out
