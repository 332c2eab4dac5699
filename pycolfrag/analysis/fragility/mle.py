"""Smooth lognormal fragility curves fitted by maximum likelihood over all runs, with a stratified
bootstrap band."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pycolfrag.analysis.fragility import degenerate as _degenerate
from pycolfrag.analysis.fragility.bootstrap import as_rng
from pycolfrag.analysis.fragility.degenerate import MIN_FIT_POINTS
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.scipy_on_first_use import optimize, special, stats
from pycolfrag.core.validate import float_array, integer, real
from pycolfrag.damage import _as_inputs, exceeded


@dataclass
class LognormalFragility:
    """Smooth fragility P(exceed | IM) = Phi(ln(IM / median) / beta), fitted by maximum likelihood.

    Attributes
    ----------
    median : float
        IM at 50 % probability (IM units).
    beta : float
        Lognormal dispersion (standard deviation of ln IM capacity).
    n, n_exceed : int
        Samples used and how many exceeded.
    loglik : float
        Maximised binomial log-likelihood.
    band_im, band_low, band_high : ndarray or None
        Bootstrap band of the curve on an IM grid (None without bootstrap).
    n_boot_degenerate : int
        Bootstrap resamples in which no sample or every sample exceeded. Their maximum-likelihood
        curve is the limit 0 (median +inf) or 1 (median 0) everywhere and enters the band and the
        median interval as such; their beta is undefined and is left out of ``beta_ci``.
    degenerate : str
        Why the fit is not an estimate, ``""`` when it is: fewer than :data:`MIN_FIT_POINTS` runs,
        outcomes separated by the IM (no finite maximum: beta runs to its bound), a parameter on
        the optimiser's bound, or a bootstrap that cannot vary (one run per stratum: the intervals
        are then NaN, not the zero width the resamples would give).
    """

    median: float
    beta: float
    n: int
    n_exceed: int
    loglik: float
    band_im: np.ndarray | None = None
    band_low: np.ndarray | None = None
    band_high: np.ndarray | None = None
    median_ci: tuple = (np.nan, np.nan)
    beta_ci: tuple = (np.nan, np.nan)
    n_boot_degenerate: int = 0
    degenerate: str = ""

    def __call__(self, im):
        """Probability of exceedance at ``im`` (array_like, IM units)."""
        im = np.asarray(im, dtype=float)
        with np.errstate(divide="ignore"):
            return stats.norm.cdf(np.log(im / self.median) / self.beta)


#: Bounds of the MLE dispersion (a separable sample would drive beta to 0).
BETA_MIN, BETA_MAX = 0.02, 5.0


def _mle(ln_im, y, x0=None):
    """Maximise sum y ln Phi(z) + (1 - y) ln Phi(-z), z = (ln IM - ln theta) / beta.

    Parameters are p = (ln theta, ln beta); L-BFGS-B with the analytic gradient
    (d ln Phi(z) / dz = phi(z) / Phi(z), evaluated in log space with ``scipy.special.log_ndtr``).
    Bounds keep separable (bootstrap) samples finite: beta in [BETA_MIN, BETA_MAX] and ln theta
    within 5 of the data's ln IM range.
    """
    sign = np.where(y, 1.0, -1.0)

    def nll(p):
        z = (ln_im - p[0]) * np.exp(-p[1])
        sz = sign * z
        lcdf = special.log_ndtr(sz)
        w = sign * np.exp(-0.5 * sz * sz - 0.5 * np.log(2 * np.pi) - lcdf)   # d ln Phi(sz) / dz
        grad = np.array([np.sum(w) * np.exp(-p[1]), np.sum(w * z)])          # of -loglik
        return -np.sum(lcdf), grad

    if x0 is None:
        # start: halfway between the median ln IM of the two outcomes, dispersion 0.5
        x0 = np.array([0.5 * (np.median(ln_im[y]) + np.median(ln_im[~y])), np.log(0.5)])
    bounds = _mle_bounds(ln_im)
    x0 = np.clip(x0, [b[0] for b in bounds], [b[1] for b in bounds])
    res = optimize.minimize(nll, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                            options={"gtol": 1e-9, "ftol": 1e-13})
    return res.x, -res.fun


def _mle_bounds(ln_im):
    """Bounds of (ln theta, ln beta) in the maximum-likelihood fits: beta in [BETA_MIN, BETA_MAX], ln theta
    within 5 of the data's ln IM range (so that separable samples stay finite)."""
    return [(ln_im.min() - 5.0, ln_im.max() + 5.0), (np.log(BETA_MIN), np.log(BETA_MAX))]


def _fit_reasons(ln_im, y, p, bounds) -> tuple[list, list]:
    """Why a maximum-likelihood fragility fit (parameters ``p`` = (ln theta, ln beta)) is not an
    estimate: (reasons, their causes as keys of ``degenerate.CAUSES``), both empty when it is (see
    :class:`LognormalFragility`)."""
    why, causes = [], []
    if y.size < MIN_FIT_POINTS:
        why.append(f"only {y.size} runs (fewer than {MIN_FIT_POINTS})")
        causes.append("few_runs")
    if np.ptp(ln_im) == 0:
        # Phi((ln x - ln theta) / beta) at one x is one number: every (theta, beta) giving it the observed
        # fraction maximises the likelihood, and the optimiser stops where it started
        why.append(f"every run is at one IM level ({np.exp(ln_im[0]):.4g}): the likelihood fixes the probability "
                   "there, not the median and beta (the numbers are where the optimiser stopped)")
        return why, causes + ["one_im_level"]
    lo_y, hi_y = ln_im[y], ln_im[~y]
    if lo_y.min() > hi_y.max() or lo_y.max() < hi_y.min():
        why.append("every exceeding run lies on one side of every other in IM: the likelihood has no finite "
                   "maximum")
        causes.append("separable")
    for value, (lo, hi), what in ((p[0], bounds[0], "median"), (p[1], bounds[1], "beta")):
        if min(value - lo, hi - value) < 1e-6:
            why.append(f"{what} = {np.exp(value):.3g} is on the optimiser's bound [{np.exp(lo):.3g}, {np.exp(hi):.3g}]")
            causes.append("on_bound")
    return why, causes


def _fit_degenerate(ln_im, y, p, bounds) -> str:
    """Why a maximum-likelihood fragility fit is not an estimate, ``""`` when it is (:func:`_fit_reasons`)."""
    return "; ".join(_fit_reasons(ln_im, y, p, bounds)[0])


def _strata(groups, n: int, n_boot: int, why: list, causes: list):
    """The index arrays of the bootstrap strata, or None when there is no bootstrap or it cannot vary
    (one run per stratum: every resample is the data itself, and a zero-width band would claim certainty)."""
    if not n_boot:
        return None
    strata = np.zeros(n, dtype=int) if groups is None else np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
    if strata.size != n:
        raise ParameterError(f"groups has length {strata.size}, expected {n}")
    members = [np.flatnonzero(strata == s) for s in np.unique(strata)]
    if all(m.size == 1 for m in members):
        why.append("one run per bootstrap stratum: the resamples cannot vary, no interval")
        causes.append("one_per_stratum")
        return None
    return members


def _bootstrap_band(fit, ln_im, y, members, n_boot, confidence, rng, band_im) -> None:
    """Refit on ``n_boot`` resamples stratified by ``members`` and store the band and the intervals on ``fit``."""
    ln_theta, ln_beta = np.log(fit.median), np.log(fit.beta)
    g = as_rng(rng)
    grid = (np.geomspace(np.exp(ln_im.min()), np.exp(ln_im.max()), 100) if band_im is None
            else np.asarray(band_im, dtype=float))
    curves, meds, betas = [], [], []
    for _ in range(int(n_boot)):
        idx = np.concatenate([g.choice(m, size=m.size, replace=True) for m in members])
        yb = y[idx]
        if yb.all() or not yb.any():  # the MLE's limit: a constant curve (see n_boot_degenerate)
            fit.n_boot_degenerate += 1
            meds.append(0.0 if yb.all() else np.inf)
            curves.append(np.full(grid.shape, 1.0 if yb.all() else 0.0))
            continue
        (a, b), _ll = _mle(ln_im[idx], yb, x0=np.array([ln_theta, ln_beta]))
        meds.append(np.exp(a))
        betas.append(np.exp(b))
        curves.append(stats.norm.cdf((np.log(grid) - a) / np.exp(b)))
    a = 100 * (1 - confidence) / 2
    fit.band_im = grid
    fit.band_low, fit.band_high = np.percentile(np.array(curves), [a, 100 - a], axis=0)
    # an infinite median (resample without exceedance) makes linear interpolation inf - inf = nan:
    # then take the empirical quantiles without interpolation
    fit.median_ci = tuple(np.percentile(meds, [a, 100 - a],
                                        method="inverted_cdf" if fit.n_boot_degenerate else "linear"))
    if betas:
        fit.beta_ci = tuple(np.percentile(betas, [a, 100 - a]))


def fit_lognormal_fragility(im, edp, collapsed, threshold, *, groups=None, n_boot=0, confidence=0.90,
                            rng=None, band_im=None) -> LognormalFragility:
    """Lognormal fragility function by maximum likelihood over all samples.

    Each sample is a Bernoulli trial y_i = [collapsed_i or EDP_i >= threshold] with
    P(y_i = 1) = Phi((ln IM_i - ln theta) / beta); the binomial log-likelihood
    sum y ln Phi + (1 - y) ln(1 - Phi) is maximised over (ln theta, ln beta) by
    ``scipy.optimize.minimize`` (L-BFGS-B, analytic gradient, bounded).  Both outcomes must occur (otherwise the
    maximum is at a boundary and ParameterError is raised).

    Parameters
    ----------
    im : array_like
        Intensity measure of each sample (> 0, IM units).
    edp, collapsed, threshold
        As in :func:`exceedance` (a collapsed sample counts as exceeding; its EDP is ignored, may be NaN).
    groups : array_like, optional
        Stratum of each sample (e.g. scenario index); the bootstrap resamples within each stratum
        (all samples form one stratum when omitted).
    n_boot : int
        Bootstrap refits for the band (0: no band).
    confidence : float
        Two-sided level of the band, in (0, 1).
    rng : None, int or numpy.random.Generator
    band_im : array_like, optional
        IM grid of the band (default: 100 points log-spaced over the data).
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
    n_boot = integer(n_boot, "n_boot", 0)
    if not 0 < real(confidence, "confidence") < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    im = float_array(im, "im", ndim=None, finite=False)
    if im.shape != edp.shape:
        raise ParameterError(f"im has length {im.size}, edp has {edp.size}")
    if not np.all(np.isfinite(im)) or np.any(im <= 0):
        raise ParameterError("IM values must be finite and positive for a lognormal fit")
    y = exceeded(edp, collapsed, threshold)
    if y.all() or not y.any():
        raise ParameterError(
            f"every sample {'exceeds' if y.all() else 'stays below'} {threshold:g}: "
            "the lognormal MLE has no interior maximum")
    ln_im = np.log(im)
    (ln_theta, ln_beta), ll = _mle(ln_im, y)
    fit = LognormalFragility(float(np.exp(ln_theta)), float(np.exp(ln_beta)), int(y.size), int(y.sum()),
                             float(ll))
    why, causes = _fit_reasons(ln_im, y, (ln_theta, ln_beta), _mle_bounds(ln_im))
    members = _strata(groups, y.size, n_boot, why, causes)
    fit.degenerate = "; ".join(why)
    if fit.degenerate:
        _degenerate.warn(f"fit_lognormal_fragility ({threshold:g}): {fit.degenerate}", causes)
    if members is not None:
        _bootstrap_band(fit, ln_im, y, members, n_boot, confidence, rng, band_im)
    return fit
