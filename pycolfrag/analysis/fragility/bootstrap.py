"""Eq. (4) as a vectorised statistic, and percentile-bootstrap intervals of a group statistic."""
from __future__ import annotations

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.scipy_on_first_use import stats
from pycolfrag.core.validate import integer, real
from pycolfrag.damage import _as_inputs, exceeded


def eq4_statistic(threshold):
    """Eq. (4) as a vectorised statistic: ``statistic(edp, collapsed, axis=-1)`` gives P(EDP > threshold)
    of every batch along ``axis`` at once -- the form :func:`scipy.stats.bootstrap` takes, and what
    the site risk draws its resampled probabilities with.

    Uses the closed form of the lognormal MLE (mean and ddof=0 std of ln x), which is what
    ``scipy.stats.lognorm.fit(x, floc=0)`` returns; ``tests/test_fragility.py`` checks the two agree.
    """
    ln_t = np.log(threshold)

    def statistic(edp, collapsed, axis=-1):
        edp = np.moveaxis(np.asarray(edp, dtype=float), axis, -1)
        c = np.moveaxis(np.asarray(collapsed), axis, -1).astype(bool)
        n = edp.shape[-1]
        pos = (~c) & (np.nan_to_num(edp, nan=0.0) > 0)
        n_ok = np.sum(~c, axis=-1)
        n_pos = np.sum(pos, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            ln_x = np.where(pos, np.log(np.where(pos, edp, 1.0)), 0.0)
            mu = np.sum(ln_x, axis=-1) / n_pos
            var = np.sum(np.where(pos, (ln_x - mu[..., None]) ** 2, 0.0), axis=-1) / n_pos
            beta = np.sqrt(var)
            z = (ln_t - mu) / beta
            tail = np.where(beta > 1e-12 * np.maximum(1.0, np.abs(mu)), stats.norm.sf(z),
                            (mu >= ln_t).astype(float))
            q = n_pos / n_ok
        pc = 1.0 - n_ok / n
        tail = np.where(n_pos > 0, q * tail, 0.0)
        return np.where(n_ok > 0, pc + (1.0 - pc) * tail, 1.0)

    return statistic


def _empirical_vectorised(threshold):
    def statistic(edp, collapsed, axis=-1):
        return np.mean(exceeded(edp, collapsed, threshold), axis=axis)

    return statistic


def _mean_ok_vectorised(edp, collapsed, axis=-1):
    """Mean EDP of the non-collapsed runs (paper Fig. 8a, b) over the last axis."""
    edp = np.moveaxis(np.asarray(edp, dtype=float), axis, -1)
    ok = ~np.moveaxis(np.asarray(collapsed), axis, -1).astype(bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sum(np.where(ok, np.nan_to_num(edp), 0.0), axis=-1) / np.sum(ok, axis=-1)


def as_rng(rng) -> np.random.Generator:
    """The generator of an ``rng`` argument: None (fresh entropy) or an int seed -> a new
    :func:`numpy.random.default_rng`; a Generator itself; anything else -> ParameterError."""
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(rng)
    if isinstance(rng, np.random.Generator):
        return rng
    raise ParameterError(f"rng must be None, an int seed or a numpy Generator, got {type(rng).__name__}")


def boot_settings(n_boot, confidence) -> tuple[int, float]:
    """``(n_boot, confidence)`` checked: an integer number of resamples >= 2 (a bool is refused) and a
    two-sided level in (0, 1); :class:`ParameterError` naming a bad one."""
    n_boot = integer(n_boot, "n_boot", 2)
    if not 0 < real(confidence, "confidence") < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    return n_boot, float(confidence)


def bootstrap_interval(edp, collapsed, threshold=None, *, statistic="eq4", n_boot=1000,
                       confidence=0.90, rng=None) -> tuple[float, float]:
    """Percentile bootstrap interval of a group statistic (``scipy.stats.bootstrap``, paired).

    Parameters
    ----------
    edp, collapsed : array_like
        The group's samples (one scenario or one stripe); rows are resampled with replacement.
        EDPs of collapsed rows are ignored (may be NaN).
    threshold : float, optional
        Performance-level threshold (needed for ``"eq4"`` and ``"empirical"``).
    statistic : {"eq4", "empirical", "mean", "collapse"}
        Eq. (4), the empirical ratio, the mean non-collapsed EDP, or Eq. (3).
    n_boot : int
        Bootstrap resamples.
    confidence : float
        Two-sided confidence level (0.90 gives the 5 % and 95 % percentiles).
    rng : None, int or numpy.random.Generator
        Seed or generator (reproducible bands).

    Returns
    -------
    (low, high) : tuple of float
        NaN when the group has fewer than 2 samples.
    """
    if statistic in ("eq4", "empirical"):
        edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
        fun = eq4_statistic(threshold) if statistic == "eq4" else _empirical_vectorised(threshold)
    elif statistic == "mean":
        edp, collapsed = _as_inputs(edp, collapsed)
        if np.all(collapsed):
            return (np.nan, np.nan)
        fun = _mean_ok_vectorised
    elif statistic == "collapse":
        edp, collapsed = _as_inputs(edp, collapsed)

        def fun(e, c, axis=-1):
            return np.mean(np.asarray(c, dtype=float), axis=axis)
    else:
        raise ParameterError(f"unknown statistic {statistic!r}")
    n_boot, confidence = boot_settings(n_boot, confidence)
    if edp.size < 2:
        return (np.nan, np.nan)
    if statistic == "mean":
        # a resample may hold only collapsed rows: its mean is undefined; the percentile of the
        # rest is what we want, so draw the indices here and use nanpercentile.
        g = as_rng(rng)
        idx = g.integers(0, edp.size, size=(int(n_boot), edp.size))
        vals = fun(edp[idx], collapsed[idx])
        a = 100 * (1 - confidence) / 2
        lo, hi = np.nanpercentile(vals, [a, 100 - a])
        return float(lo), float(hi)
    res = stats.bootstrap((np.nan_to_num(edp, nan=0.0), collapsed.astype(float)), fun, paired=True,
                          vectorized=True, n_resamples=int(n_boot), confidence_level=confidence,
                          method="percentile", random_state=as_rng(rng))
    ci = res.confidence_interval
    return float(ci.low), float(ci.high)


