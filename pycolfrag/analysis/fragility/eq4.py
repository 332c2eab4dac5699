"""Paper Eqs. (1)-(4): collapse probability, lognormal parameters, Eq. (4) and the empirical ratio."""
from __future__ import annotations

import numpy as np

from pycolfrag.analysis.fragility import degenerate as _degenerate
from pycolfrag.analysis.fragility.degenerate import MIN_FIT_POINTS
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.scipy_on_first_use import stats
from pycolfrag.core.validate import float_array, integer, real
from pycolfrag.damage import _as_flags, _as_inputs, exceeded


def collapse_probability(collapsed) -> float:
    """Paper Eq. (3): number of collapsed simulations over the total.

    Parameters
    ----------
    collapsed : array_like of bool
        One flag per simulation of the group (scenario or stripe).

    Returns
    -------
    float
        P(C) in [0, 1].
    """
    c = np.asarray(collapsed)
    if c.ndim != 1 or c.size == 0:
        raise ParameterError("collapsed must be a non-empty 1-D array (empty group?)")
    return float(np.mean(_as_flags(c)))


def binomial_ci(k: int, n: int, confidence: float = 0.90) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a proportion k/n, e.g. Eq. (3) (``scipy.stats.binomtest``).

    Unlike the bootstrap it stays informative at 0 of n (upper limit ``1 - ((1 - confidence)/2)**(1/n)``).
    (NaN, NaN) for 0 of 0 (no trial, no interval). ``k`` and ``n`` must be integers with 0 <= k <= n and
    ``confidence`` in (0, 1); anything else is refused with :class:`ParameterError` naming it.
    """
    k = integer(k, "k (successes)", 0)
    n = integer(n, "n (trials)", 0)
    if k > n:
        raise ParameterError(f"binomial_ci: k = {k} successes out of n = {n} trials (k must not exceed n)")
    if not 0 < real(confidence, "confidence") < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    if n == 0:
        return (np.nan, np.nan)
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def lognormal_parameters(edp) -> tuple[float, float]:
    """Maximum-likelihood lognormal parameters of positive EDP values.

    Parameters
    ----------
    edp : array_like
        Positive EDP values (dimensionless), e.g. the non-collapsed ones of a scenario.

    Returns
    -------
    (mu_ln, beta_ln) : tuple of float
        Mean and dispersion of ``ln EDP`` (``scipy.stats.lognorm.fit(edp, floc=0)``:
        ``beta = s``, ``mu = ln(scale)``; equal to ``mean(ln x)`` and ``std(ln x, ddof=0)``).
    """
    x = float_array(edp, "edp", ndim=None, allow_empty=True, finite=False)
    if x.ndim != 1 or x.size == 0:
        raise ParameterError("lognormal_parameters needs a non-empty 1-D array (empty group?)")
    if not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise ParameterError("lognormal_parameters needs finite positive values")
    if x.size == 1 or np.all(x == x[0]):
        return float(np.log(x[0])), 0.0
    s, _loc, scale = stats.lognorm.fit(x, floc=0)
    return float(np.log(scale)), float(s)


def _lognormal_sf(threshold, mu, beta):
    """1 - Phi((ln threshold - mu) / beta) with the beta = 0 limit (a step at exp(mu))."""
    if beta > 0:
        return float(stats.norm.sf((np.log(threshold) - mu) / beta))
    return 1.0 if mu >= np.log(threshold) else 0.0


def exceedance(edp, collapsed, threshold) -> float:
    """Paper Eq. (4) (Eq. (2) when nothing collapsed): P(EDP >= threshold) of one group.

    Parameters
    ----------
    edp : array_like of float
        EDP of each simulation (dimensionless); values of collapsed runs are ignored (may be NaN).
    collapsed : array_like of bool
        Collapse flag of each simulation, same length.
    threshold : float
        The performance-level threshold ``edp`` (> 0, dimensionless).

    Returns
    -------
    float
        ``P(C) + (1 - P(C)) * (1 - Phi((ln threshold - mu) / beta))`` with ``mu``, ``beta`` the
        lognormal parameters of the non-collapsed data (see the module docstring for zeros).

    Warns
    -----
    DegenerateFitWarning
        When :func:`eq4_degenerate` finds the group too small for the number to be an estimate
        (fewer than :data:`MIN_FIT_POINTS` runs, or standing runs with EDP > 0, or all of them
        equal); the formula's value is still returned.
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
    p = _exceedance(edp, collapsed, threshold)
    why, causes = _eq4_reasons(edp, collapsed)
    if why:
        _degenerate.warn(f"exceedance: {why}; Eq. (4) gives {p:.3g}, which is not an estimate", causes)
    return p


def eq4_degenerate(edp, collapsed) -> str:
    """Why Eq. (4) of a group is not an estimate, or ``""`` when it is.

    The group has fewer than :data:`MIN_FIT_POINTS` runs (one run gives P = 0 or 1 whatever the
    column's fragility), or its lognormal part rests on fewer than :data:`MIN_FIT_POINTS` standing
    runs with EDP > 0, or on values that are all equal (beta = 0: the lognormal part is a step at
    that value). A group whose runs all collapsed, or whose standing runs are all at EDP = 0, has
    no lognormal part and is judged by its size alone. Same arguments as :func:`exceedance`.
    """
    edp, collapsed = _as_inputs(edp, collapsed)
    return _eq4_why(edp, collapsed)


def _eq4_why(edp, collapsed) -> str:
    return _eq4_reasons(edp, collapsed)[0]


def _eq4_reasons(edp, collapsed) -> tuple[str, tuple]:
    """(why Eq. (4) of the group is not an estimate, its causes as keys of ``degenerate.CAUSES``)."""
    ok = edp[~collapsed]
    pos = ok[ok > 0]
    few, causes = [], []
    if edp.size < MIN_FIT_POINTS:
        few.append(f"{edp.size} run{'s' if edp.size != 1 else ''} in the group")
        causes.append("few_runs")
    if 0 < pos.size < MIN_FIT_POINTS:
        few.append(f"{pos.size} standing run{'s' if pos.size != 1 else ''} with EDP > 0 behind the lognormal part")
        causes.append("few_standing")
    if few:
        return f"only {' and '.join(few)} (fewer than {MIN_FIT_POINTS})", tuple(causes)
    if pos.size and np.all(pos == pos[0]):
        return f"the {pos.size} standing EDPs are all equal (beta = 0: the lognormal part is a step)", ("equal_edps",)
    return "", ()


def _exceedance(edp, collapsed, threshold) -> float:
    """Eq. (4) of arrays already checked by :func:`_as_inputs`."""
    pc = float(np.mean(collapsed))
    ok = edp[~collapsed]
    if ok.size == 0:
        return 1.0
    pos = ok[ok > 0]
    if pos.size == 0:
        return pc
    q = pos.size / ok.size
    mu, beta = lognormal_parameters(pos)
    return pc + (1.0 - pc) * q * _lognormal_sf(threshold, mu, beta)


def empirical_exceedance(edp, collapsed, threshold) -> float:
    """Empirical ratio of Eq. (1): (collapsed or EDP >= threshold) / total.

    Same arguments as :func:`exceedance`.
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
    return float(np.mean(exceeded(edp, collapsed, threshold)))
