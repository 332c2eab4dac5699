"""Fragility analysis: paper Eqs. (1)-(4), surfaces over (Mw, R), stripe curves, MLE curves, bootstrap.

Psycharis, Fragiadakis & Stefanou, "Seismic reliability assessment of classical columns subjected to
near-fault ground motions", section "Fragility assessment":

* Eq. (1)  F_R(Mw, R) = P(EDP >= edp | Mw, R)
* Eq. (2)  F_R = 1 - Phi((ln edp - mu_lnEDP) / beta_lnEDP)               (no collapses)
* Eq. (3)  P(C | Mw, R) = collapsed / total
* Eq. (4)  P(EDP >= edp) = P(C) + (1 - P(C)) (1 - Phi((ln edp - mu) / beta)),  mu, beta of the
  non-collapsed data.

``mu`` and ``beta`` are the maximum-likelihood lognormal parameters of the non-collapsed EDPs
(``scipy.stats.lognorm.fit(x, floc=0)``, i.e. the mean and the ``ddof=0`` standard deviation of
``ln x``).  Non-collapsed EDPs that are exactly zero (a run that never moved) cannot enter a
lognormal fit; they are counted as "below every positive threshold", so Eq. (4) becomes
``P(C) + (1 - P(C)) q (1 - Phi(...))`` with ``q`` the fraction of positive non-collapsed EDPs and
the fit done on the positive ones (for data without zeros this is exactly Eq. (4)).

Collapsed runs: their EDP values are never used (collapse counts as exceeding every level, and
means and fits take the non-collapsed runs only), so they may be NaN -- ``u_d`` of a collapsed run
is NaN by definition (it has no residual state). Every function here gives the same result whatever
the collapsed rows hold; only the EDPs of non-collapsed runs must be finite and non-negative.

Beyond the paper:

* the empirical ratio of Eq. (1) (``empirical_exceedance``), reported next to Eq. (4);
* stripe curves accept equal-width (paper, 12 stripes) or equal-count stripes;
* a smooth lognormal fragility function fitted by maximum likelihood over all samples
  (``fit_lognormal_fragility``): each sample contributes a Bernoulli outcome
  y = [collapsed or EDP >= edp] with P(y = 1 | IM) = Phi((ln IM - ln theta) / beta);
  the binomial log-likelihood is maximised over (ln theta, ln beta) with scipy.optimize;
* for record suites (docs/records.md): stripe curves on every IM of a suite table
  (``stripe_analysis``), a cloud analysis (ln EDP regressed on ln IM, collapse by logistic
  regression: ``cloud_analysis``) and multiple-stripe fragility by the binomial likelihood of
  Baker (2015) (``msa_fragility``, ``msa_from_table``);
* percentile-bootstrap confidence intervals (``scipy.stats.bootstrap``, resampling within each
  scenario or stripe; stratified over scenarios for the MLE curve), with a seeded Generator.

Every EDP here is dimensionless (u_top and u_d of the paper); IMs are in the units of the results
file (PGA in g, PGV in cm/s, SA in g, SV in cm/s).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import importlib

import numpy as np

from .. import names as _names
from .._validate import float_array, integer, positive_float, real
from ..errors import ParameterError


class _OnFirstUse:
    """A scipy module imported when one of its names is first read: ``import pycolfrag`` binds this
    module (``pcf.fragility``), and every rank of a grid imports pycolfrag without ever calling it --
    scipy.stats alone took 0.8 s of a rank's start-up."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr):
        return getattr(importlib.import_module(self._name), attr)


optimize, special, stats = _OnFirstUse("scipy.optimize"), _OnFirstUse("scipy.special"), _OnFirstUse("scipy.stats")

__all__ = [
    "PerformanceLevel",
    "PERFORMANCE_LEVELS",
    "U_TOP_LEVELS",
    "U_D_LEVELS",
    "collapse_probability",
    "binomial_ci",
    "lognormal_parameters",
    "exceedance",
    "eq4_statistic",
    "as_rng",
    "ok_rows",
    "empirical_exceedance",
    "bootstrap_interval",
    "ScenarioRow",
    "scenario_table",
    "Surface",
    "exceedance_surface",
    "mean_edp_surface",
    "collapse_surface",
    "StripeCurve",
    "stripe_curve",
    "LognormalFragility",
    "fit_lognormal_fragility",
    "exceeded",
    "DegenerateFitWarning",
    "MIN_FIT_POINTS",
    "eq4_degenerate",
    # record suites (docs/records.md)
    "table_im",
    "stripe_analysis",
    "LogisticCollapse",
    "fit_logistic_collapse",
    "CloudFit",
    "cloud_analysis",
    "MSAFragility",
    "msa_fragility",
    "msa_from_table",
]


@dataclass(frozen=True)
class PerformanceLevel:
    """One performance level of paper Tables III and IV.

    Attributes
    ----------
    edp : str
        ``"u_top"`` (max capital displacement / base diameter) or ``"u_d"`` (max residual drum
        dislocation / joint diameter); both dimensionless.
    threshold : float
        Exceedance threshold ``edp`` of Eq. (1) (dimensionless).
    name : str
        The paper's name of the level.
    """

    edp: str
    threshold: float
    name: str

    @property
    def label(self) -> str:
        """Plot/table label, e.g. ``u_top > 0.35``."""
        return f"{self.edp} > {self.threshold:g}"


#: Table III (risk of collapse).
U_TOP_LEVELS = (
    PerformanceLevel("u_top", 0.15, "Damage limitation"),
    PerformanceLevel("u_top", 0.35, "Significant damage"),
    PerformanceLevel("u_top", 1.0, "Near collapse"),
)
#: Table IV (residual drum dislocations).
U_D_LEVELS = (
    PerformanceLevel("u_d", 0.005, "Limited deformation"),
    PerformanceLevel("u_d", 0.01, "Light deformation"),
    PerformanceLevel("u_d", 0.02, "Significant deformation"),
)
PERFORMANCE_LEVELS = U_TOP_LEVELS + U_D_LEVELS

#: Fewest values a fit is called well-posed on: the standing runs with EDP > 0 behind the lognormal
#: part of Eq. (4), or the runs of a maximum-likelihood fragility curve (two parameters). The stripe
#: curves' ``min_count`` default is the same number.
MIN_FIT_POINTS = 5


class DegenerateFitWarning(UserWarning):
    """A fit that rests on too few values, sits on a bound of its optimiser, or has no interior
    maximum: the number is returned (it is what the formula gives) but it is not an estimate."""


# --------------------------------------------------------------------------- input checks

def _as_flags(collapsed) -> np.ndarray:
    """Collapse flags as a bool array; 0/1 integers accepted, anything else refused."""
    collapsed = np.asarray(collapsed)
    if collapsed.dtype != bool:
        if collapsed.dtype.kind not in "iuf" or not np.all(np.isin(collapsed, (0, 1))):
            bad = collapsed.ravel()[~np.isin(collapsed.ravel(), (0, 1))] if collapsed.dtype.kind in "iuf" \
                else collapsed.ravel()
            raise ParameterError(f"collapsed must hold booleans (or 0/1), got {bad[0]!r}" if bad.size
                                 else "collapsed must hold booleans (or 0/1)")
        collapsed = collapsed.astype(bool)
    return collapsed


def _as_inputs(edp, collapsed, threshold=None):
    """Validate (edp, collapsed[, threshold]) and return float/bool arrays (and the threshold)."""
    edp = float_array(edp, "edp", ndim=None, allow_empty=True, finite=False)
    collapsed = np.asarray(collapsed)
    if edp.ndim != 1 or collapsed.ndim != 1:
        raise ParameterError(f"edp and collapsed must be 1-D, got shapes {edp.shape} and {collapsed.shape}")
    if edp.shape != collapsed.shape:
        raise ParameterError(
            f"edp and collapsed have mismatched lengths {edp.size} and {collapsed.size}")
    if edp.size == 0:
        raise ParameterError("empty group: no samples to compute a probability from")
    collapsed = _as_flags(collapsed)
    ok = edp[~collapsed]
    if not np.all(np.isfinite(ok)):
        raise ParameterError("non-collapsed EDPs must be finite (NaN/inf found)")
    if np.any(ok < 0):
        raise ParameterError(f"EDPs must be non-negative, got min {ok.min()!r}")
    if threshold is None:
        return edp, collapsed
    return edp, collapsed, positive_float(threshold, "threshold")


# --------------------------------------------------------------------------- Eqs. (1)-(4)

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
    (NaN, NaN) when ``n`` is 0.
    """
    if n <= 0:
        return (np.nan, np.nan)
    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
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
    why = _eq4_why(edp, collapsed)
    if why:
        warnings.warn(f"exceedance: {why}; Eq. (4) gives {p:.3g}, which is not an estimate",
                      DegenerateFitWarning, stacklevel=2)
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
    ok = edp[~collapsed]
    pos = ok[ok > 0]
    few = []
    if edp.size < MIN_FIT_POINTS:
        few.append(f"{edp.size} run{'s' if edp.size != 1 else ''} in the group")
    if 0 < pos.size < MIN_FIT_POINTS:
        few.append(f"{pos.size} standing run{'s' if pos.size != 1 else ''} with EDP > 0 behind the lognormal part")
    if few:
        return f"only {' and '.join(few)} (fewer than {MIN_FIT_POINTS})"
    if pos.size and np.all(pos == pos[0]):
        return f"the {pos.size} standing EDPs are all equal (beta = 0: the lognormal part is a step)"
    return ""


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


def exceeded(edp, collapsed, threshold) -> np.ndarray:
    """Bernoulli outcome of each simulation: collapsed or EDP >= threshold (bool array)."""
    edp = float_array(edp, "edp", ndim=None, allow_empty=True, finite=False)
    collapsed = _as_flags(collapsed)
    threshold = positive_float(threshold, "threshold")
    with np.errstate(invalid="ignore"):
        return collapsed | (np.nan_to_num(edp, nan=-np.inf) >= threshold)


# --------------------------------------------------------------------------- vectorised statistics

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
    if not 0 < real(confidence, "confidence") < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    n_boot = integer(n_boot, "n_boot", 2)
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


# --------------------------------------------------------------------------- scenarios and surfaces

@dataclass
class ScenarioRow:
    """Per-scenario summary (one row of the report's tables).

    ``exceedance``, ``empirical`` and ``ci`` are keyed by the level label (``"u_top > 0.35"``);
    ``ci`` holds the bootstrap interval of Eq. (4).  ``mu_ln``/``beta_ln`` are keyed by EDP name
    (lognormal parameters of the positive non-collapsed values); ``degenerate``, keyed by EDP name,
    says why that EDP's Eq. (4) values of the scenario are not estimates (:func:`eq4_degenerate`;
    ``""`` when they are).
    """

    mw: float
    dist_km: float
    n: int
    n_collapsed: int
    p_collapse: float
    p_collapse_ci: tuple
    mean: dict = field(default_factory=dict)
    mu_ln: dict = field(default_factory=dict)
    beta_ln: dict = field(default_factory=dict)
    exceedance: dict = field(default_factory=dict)
    empirical: dict = field(default_factory=dict)
    ci: dict = field(default_factory=dict)
    degenerate: dict = field(default_factory=dict)


def _groups(mw, dist_km):
    mw = float_array(mw, "mw", ndim=None)
    dist_km = float_array(dist_km, "dist_km", ndim=None)
    if mw.shape != dist_km.shape or mw.ndim != 1:
        raise ParameterError(f"mw and dist_km must be 1-D of equal length, got {mw.shape} and {dist_km.shape}")
    mws = np.unique(mw)
    ds = np.unique(dist_km)
    return mw, dist_km, mws, ds


def scenario_table(mw, dist_km, edps: dict, collapsed, levels=PERFORMANCE_LEVELS, *, n_boot=1000,
                   confidence=0.90, rng=None) -> list[ScenarioRow]:
    """Per-scenario collapse probability, ln-EDP statistics and exceedance of every level.

    Parameters
    ----------
    mw, dist_km : array_like
        Scenario of each sample (magnitude, distance in km).
    edps : dict of str -> array_like
        EDP arrays by name (``{"u_top": ..., "u_d": ...}``), one value per sample; values of
        collapsed samples are ignored (may be NaN).
    collapsed : array_like of bool
        Collapse flag of each sample.
    levels : sequence of PerformanceLevel
    n_boot, confidence, rng
        Bootstrap settings (resampling within the scenario).

    Returns
    -------
    list of ScenarioRow, ordered by (mw, dist_km).
    """
    mw, dist_km, mws, ds = _groups(mw, dist_km)
    collapsed = np.asarray(collapsed).astype(bool)
    edps = {k: float_array(v, k, ndim=None, finite=False) for k, v in edps.items()}
    for k, v in edps.items():
        if v.shape != mw.shape:
            raise ParameterError(f"{k} has length {v.size}, expected {mw.size}")
    if collapsed.shape != mw.shape:
        raise ParameterError(f"collapsed has length {collapsed.size}, expected {mw.size}")
    g = as_rng(rng)
    rows = []
    for m in mws:
        for d in ds:
            sel = (mw == m) & (dist_km == d)
            if not np.any(sel):
                continue
            c = collapsed[sel]
            row = ScenarioRow(float(m), float(d), int(sel.sum()), int(c.sum()), float(c.mean()),
                              bootstrap_interval(np.zeros(c.size), c, statistic="collapse",
                                                 n_boot=n_boot, confidence=confidence, rng=g))
            for name, e in edps.items():
                ok = e[sel][~c]
                pos = ok[ok > 0]
                row.mean[name] = float(np.mean(ok)) if ok.size else np.nan
                if pos.size:
                    row.mu_ln[name], row.beta_ln[name] = lognormal_parameters(pos)
                else:
                    row.mu_ln[name] = row.beta_ln[name] = np.nan
                row.degenerate[name] = eq4_degenerate(e[sel], c)
            for lev in levels:
                e = edps[lev.edp][sel]
                row.exceedance[lev.label] = _exceedance(*_as_inputs(e, c, lev.threshold))
                row.empirical[lev.label] = empirical_exceedance(e, c, lev.threshold)
                row.ci[lev.label] = bootstrap_interval(e, c, lev.threshold, n_boot=n_boot,
                                                       confidence=confidence, rng=g)
            rows.append(row)
    return rows


@dataclass
class Surface:
    """A quantity over the (Mw, R) grid with its bootstrap interval.

    Attributes
    ----------
    mw : ndarray (n_mw,)
    dist_km : ndarray (n_dist,)
    value, low, high : ndarray (n_mw, n_dist)
        Estimate and confidence limits; NaN where the grid has no samples.
    n : ndarray of int (n_mw, n_dist)
        Samples per scenario.
    label : str
    """

    mw: np.ndarray
    dist_km: np.ndarray
    value: np.ndarray
    low: np.ndarray
    high: np.ndarray
    n: np.ndarray
    label: str = ""

    def at(self, mw: float, dist_km: float) -> tuple[float, float, float, int]:
        """(value, low, high, n) at one scenario; ParameterError if it is not on the grid."""
        i = np.flatnonzero(np.isclose(self.mw, mw))
        j = np.flatnonzero(np.isclose(self.dist_km, dist_km))
        if i.size == 0 or j.size == 0:
            raise ParameterError(f"scenario Mw {mw}, R {dist_km} km is not on the grid")
        i, j = i[0], j[0]
        return (float(self.value[i, j]), float(self.low[i, j]), float(self.high[i, j]),
                int(self.n[i, j]))


def _surface(mw, dist_km, edp, collapsed, point, interval, label):
    mw, dist_km, mws, ds = _groups(mw, dist_km)
    edp, collapsed = _as_inputs(edp, collapsed)
    if edp.shape != mw.shape:
        raise ParameterError(f"EDP has length {edp.size}, expected {mw.size} (one per sample)")
    shape = (mws.size, ds.size)
    val, lo, hi = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
    n = np.zeros(shape, dtype=int)
    for i, m in enumerate(mws):
        for j, d in enumerate(ds):
            sel = (mw == m) & (dist_km == d)
            n[i, j] = sel.sum()
            if n[i, j] == 0:
                continue
            val[i, j] = point(edp[sel], collapsed[sel])
            lo[i, j], hi[i, j] = interval(edp[sel], collapsed[sel])
    return Surface(mws, ds, val, lo, hi, n, label)


def exceedance_surface(mw, dist_km, edp, collapsed, threshold, *, method="eq4", n_boot=1000,
                       confidence=0.90, rng=None, label="") -> Surface:
    """Fragility surface F_R(Mw, R) = P(EDP >= threshold | Mw, R) (paper Figs. 12, 13).

    Parameters
    ----------
    mw, dist_km, edp, collapsed : array_like
        One value per sample (magnitude, km, dimensionless, bool); EDPs of collapsed samples are
        ignored (may be NaN).
    threshold : float
        Performance-level threshold (> 0).
    method : {"eq4", "empirical"}
        Eq. (4) with the lognormal fit, or the empirical ratio.
    n_boot, confidence, rng
        Bootstrap within each scenario.
    """
    if method not in ("eq4", "empirical"):
        raise ParameterError(f"method must be 'eq4' or 'empirical', got {method!r}")
    _ = _as_inputs(edp, collapsed, threshold)
    g = as_rng(rng)
    fn = exceedance if method == "eq4" else empirical_exceedance
    return _surface(mw, dist_km, edp, collapsed, lambda e, c: fn(e, c, threshold),
                    lambda e, c: bootstrap_interval(e, c, threshold, statistic=method, n_boot=n_boot,
                                                    confidence=confidence, rng=g),
                    label or f"P(EDP >= {threshold:g})")


def mean_edp_surface(mw, dist_km, edp, collapsed, *, n_boot=1000, confidence=0.90, rng=None,
                     label="") -> Surface:
    """Mean EDP of the non-collapsed samples over (Mw, R) (paper Fig. 8a, b); NaN if all collapsed.

    EDPs of collapsed samples are ignored (may be NaN)."""
    g = as_rng(rng)
    return _surface(mw, dist_km, edp, collapsed, lambda e, c: float(_mean_ok_vectorised(e, c)),
                    lambda e, c: bootstrap_interval(e, c, statistic="mean", n_boot=n_boot,
                                                    confidence=confidence, rng=g),
                    label or "mean EDP (non-collapsed)")


def collapse_surface(mw, dist_km, collapsed, *, n_boot=1000, confidence=0.90, rng=None) -> Surface:
    """Collapse probability, Eq. (3), over (Mw, R) (paper Fig. 8c)."""
    g = as_rng(rng)
    c = np.asarray(collapsed)
    return _surface(mw, dist_km, np.zeros(c.shape), c, lambda e, c: float(np.mean(c)),
                    lambda e, c: bootstrap_interval(e, c, statistic="collapse", n_boot=n_boot,
                                                    confidence=confidence, rng=g),
                    "P(collapse)")


# --------------------------------------------------------------------------- stripes (paper Fig. 3)

@dataclass
class StripeCurve:
    """Fragility curve P(EDP >= threshold | IM) by the stripe method (paper Fig. 3, Fig. 16).

    Attributes
    ----------
    edges : ndarray (n_stripes + 1,)
        Stripe limits on the IM axis (IM units).
    im : ndarray (n_stripes,)
        IM value of each stripe (mid-point for equal-width stripes, median IM for equal-count).
    n, n_collapsed : ndarray of int
    p, p_empirical, low, high : ndarray
        Eq. (4) inside each stripe, the empirical ratio, and the bootstrap interval of Eq. (4);
        NaN where a stripe holds fewer than ``min_count`` samples.
    degenerate : ndarray of bool
        Stripes whose Eq. (4) value is not an estimate (:func:`eq4_degenerate`: with a ``min_count``
        below :data:`MIN_FIT_POINTS`, or too few standing runs with EDP > 0).
    """

    edges: np.ndarray
    im: np.ndarray
    n: np.ndarray
    n_collapsed: np.ndarray
    p: np.ndarray
    p_empirical: np.ndarray
    low: np.ndarray
    high: np.ndarray
    threshold: float
    stripes: str
    degenerate: np.ndarray | None = None


def stripe_edges(im, n_stripes=12, stripes="equal-width", im_range=None) -> np.ndarray:
    """Stripe limits: ``n_stripes`` equal-width intervals (paper: 12) or equal-count quantiles."""
    im = float_array(im, "im", ndim=None, allow_empty=True, finite=False)
    n_stripes = integer(n_stripes, "n_stripes", 1)
    if im.size == 0:
        raise ParameterError("empty IM array")
    if stripes == "equal-width":
        lo, hi = (np.min(im), np.max(im)) if im_range is None else map(float, im_range)
        if not hi > lo:
            raise ParameterError(f"IM range must be increasing, got {lo}..{hi}")
        return np.linspace(lo, hi, int(n_stripes) + 1)
    if stripes == "equal-count":
        return np.quantile(im, np.linspace(0, 1, int(n_stripes) + 1))
    raise ParameterError(f"stripes must be 'equal-width' or 'equal-count', got {stripes!r}")


def stripe_curve(im, edp, collapsed, threshold, *, n_stripes=12, stripes="equal-width",
                 im_range=None, min_count=5, n_boot=1000, confidence=0.90, rng=None) -> StripeCurve:
    """Stripe-method fragility curve (paper Fig. 3): Eq. (4) using only the data in each IM stripe.

    Parameters
    ----------
    im : array_like
        Intensity measure of each sample (PGA in g, PGV in cm/s, SA(T) in g, SV(T) in cm/s), > 0.
    edp, collapsed : array_like
        EDP and collapse flag of each sample (EDPs of collapsed samples are ignored, may be NaN).
    threshold : float
        Performance-level threshold (> 0).
    n_stripes : int
        Number of stripes (paper: 12).
    stripes : {"equal-width", "equal-count"}
    im_range : (float, float), optional
        IM interval split into equal-width stripes (default: data min..max).
    min_count : int
        Stripes with fewer samples are reported as NaN.
    n_boot, confidence, rng
        Bootstrap within each stripe.
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
    im = float_array(im, "im", ndim=None, finite=False)
    if im.shape != edp.shape:
        raise ParameterError(f"im has length {im.size}, edp has {edp.size}")
    if not np.all(np.isfinite(im)):
        raise ParameterError("IM values must be finite")
    edges = stripe_edges(im, n_stripes, stripes, im_range)
    k = edges.size - 1
    # stripe index; the last stripe is closed on the right
    idx = np.clip(np.searchsorted(edges, im, side="right") - 1, 0, k - 1)
    inside = (im >= edges[0]) & (im <= edges[-1])
    g = as_rng(rng)
    out = {name: np.full(k, np.nan) for name in ("im", "p", "pe", "lo", "hi")}
    n = np.zeros(k, dtype=int)
    nc = np.zeros(k, dtype=int)
    degenerate = np.zeros(k, dtype=bool)
    for s in range(k):
        sel = inside & (idx == s)
        n[s] = sel.sum()
        nc[s] = collapsed[sel].sum()
        out["im"][s] = 0.5 * (edges[s] + edges[s + 1]) if stripes == "equal-width" else (
            np.median(im[sel]) if n[s] else np.nan)
        if n[s] < max(int(min_count), 1):
            continue
        out["p"][s] = _exceedance(edp[sel], collapsed[sel], threshold)
        degenerate[s] = bool(_eq4_why(edp[sel], collapsed[sel]))
        out["pe"][s] = empirical_exceedance(edp[sel], collapsed[sel], threshold)
        out["lo"][s], out["hi"][s] = bootstrap_interval(edp[sel], collapsed[sel], threshold, n_boot=n_boot,
                                                        confidence=confidence, rng=g)
    return StripeCurve(edges, out["im"], n, nc, out["p"], out["pe"], out["lo"], out["hi"], threshold, stripes,
                       degenerate)


# --------------------------------------------------------------------------- MLE lognormal curve

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


def _fit_degenerate(ln_im, y, p, bounds) -> str:
    """Why a maximum-likelihood fragility fit (parameters ``p`` = (ln theta, ln beta)) is not an
    estimate, ``""`` when it is (see :class:`LognormalFragility`)."""
    why = []
    if y.size < MIN_FIT_POINTS:
        why.append(f"only {y.size} runs (fewer than {MIN_FIT_POINTS})")
    lo_y, hi_y = ln_im[y], ln_im[~y]
    if lo_y.min() > hi_y.max() or lo_y.max() < hi_y.min():
        why.append("every exceeding run lies on one side of every other in IM: the likelihood has no finite "
                   "maximum")
    for value, (lo, hi), what in ((p[0], bounds[0], "median"), (p[1], bounds[1], "beta")):
        if min(value - lo, hi - value) < 1e-6:
            why.append(f"{what} = {np.exp(value):.3g} is on the optimiser's bound [{np.exp(lo):.3g}, {np.exp(hi):.3g}]")
    return "; ".join(why)


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
        Two-sided level of the band.
    rng : None, int or numpy.random.Generator
    band_im : array_like, optional
        IM grid of the band (default: 100 points log-spaced over the data).
    """
    edp, collapsed, threshold = _as_inputs(edp, collapsed, threshold)
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
    why = [_fit_degenerate(ln_im, y, (ln_theta, ln_beta), _mle_bounds(ln_im))]
    members = None
    if n_boot:
        strata = np.zeros(y.size, dtype=int) if groups is None else np.unique(
            np.asarray(groups), return_inverse=True)[1].ravel()
        if strata.size != y.size:
            raise ParameterError(f"groups has length {strata.size}, expected {y.size}")
        members = [np.flatnonzero(strata == s) for s in np.unique(strata)]
        if all(m.size == 1 for m in members):
            # every resample is the data itself: a zero-width band would claim certainty
            why.append("one run per bootstrap stratum: the resamples cannot vary, no interval")
            members = None
    fit.degenerate = "; ".join(w for w in why if w)
    if fit.degenerate:
        warnings.warn(f"fit_lognormal_fragility ({threshold:g}): {fit.degenerate}", DegenerateFitWarning,
                      stacklevel=2)
    if members is not None:
        g = as_rng(rng)
        grid = (np.geomspace(im.min(), im.max(), 100) if band_im is None
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
    return fit


# --------------------------------------------------------------------------- record suites: stripes, cloud, MSA
#
# A record-suite table is a dict of arrays in the layout of ``/samples`` (one row per run; keys of
# :mod:`pycolfrag.names`), optionally with 2-D ``sa_g`` / ``sv_cm_s`` (rows x periods) and
# ``periods_s``. Fits use scipy only (no new dependency): ``scipy.stats.linregress`` for the cloud
# regression, ``scipy.optimize.minimize`` for the logistic collapse model and the MSA likelihood.
# statsmodels would give the same numbers (ordinary least squares and a binomial GLM) but would be a
# new dependency for two two-parameter fits whose likelihoods and standard errors are a few lines.

def ok_rows(table) -> np.ndarray:
    """Mask of a table's successful rows (``status == 0``; every row when it has no ``status``)."""
    status = table.get("status")
    n = len(np.asarray(table["collapsed"]))
    return np.ones(n, dtype=bool) if status is None else (np.asarray(status) == 0)


def table_im(table, im: str, period_s: float | None = None) -> tuple[np.ndarray, str]:
    """One IM column of a suite table and its label: a scalar IM, or a spectral IM (``sa_g``,
    ``sv_cm_s``) at ``period_s`` (the nearest stored period must match to 1e-9 s)."""
    q = _names.im(im)
    if not q.spectral:
        return np.asarray(table[im], dtype=float), q.label
    if period_s is None:
        raise ParameterError(f"{im} is spectral: give period_s")
    values = np.asarray(table[im], dtype=float)
    periods = np.asarray(table["periods_s"], dtype=float)
    j = int(np.argmin(np.abs(periods - float(period_s))))
    if abs(periods[j] - float(period_s)) > 1e-9:
        raise ParameterError(f"period {period_s} s is not stored (periods: {periods.tolist()})")
    return values[:, j], _names.label(im, float(period_s))


def stripe_analysis(table, levels=PERFORMANCE_LEVELS, ims=("pga_g", "pgv_cm_s", "sa_g", "sv_cm_s"), *,
                    period_s=1.0, n_stripes=12, stripes="equal-width", min_count=5, n_boot=200,
                    confidence=0.90, rng=None) -> dict:
    """Stripe-method fragility curves (paper Fig. 3 / Fig. 16) of a suite table, every IM x level.

    Successful rows (``status == 0``) only; spectral IMs at ``period_s``. Returns
    ``{(im, level.label): StripeCurve}`` (:func:`stripe_curve`).
    """
    ok = ok_rows(table)
    g = as_rng(rng)
    out = {}
    for im in ims:
        x, _ = table_im(table, im, period_s)
        for lev in levels:
            e = np.asarray(table[lev.edp], dtype=float)[ok]
            c = np.asarray(table["collapsed"])[ok].astype(bool)
            out[(im, lev.label)] = stripe_curve(x[ok], e, c, lev.threshold, n_stripes=n_stripes, stripes=stripes,
                                                min_count=min_count, n_boot=n_boot, confidence=confidence, rng=g)
    return out


@dataclass
class LogisticCollapse:
    """P(collapse | IM) = 1 / (1 + exp(-(c0 + c1 ln IM))), fitted by maximum likelihood.

    ``cov``: inverse of the observed information (the Hessian of -loglik) at the optimum.
    """

    c0: float
    c1: float
    cov: np.ndarray
    n: int
    n_collapsed: int
    loglik: float

    def __call__(self, im):
        im = np.asarray(im, dtype=float)
        return special.expit(self.c0 + self.c1 * np.log(im))

    @property
    def se(self) -> tuple[float, float]:
        return float(np.sqrt(self.cov[0, 0])), float(np.sqrt(self.cov[1, 1]))


def fit_logistic_collapse(im, collapsed) -> LogisticCollapse:
    """Logistic regression of the collapse flags on ln IM (``scipy.optimize.minimize``, BFGS with the
    analytic gradient; standard errors from the analytic Hessian). Both outcomes must occur; a
    separable sample (every collapse above every survivor) has no finite maximum and is refused."""
    x = np.log(_positive_im(im))
    y = _as_flags(collapsed).astype(float)
    if y.shape != x.shape:
        raise ParameterError(f"im has length {x.size}, collapsed has {y.size}")
    if y.all() or not y.any():
        raise ParameterError("logistic collapse fit needs both collapsed and standing runs")
    if x[y == 1].min() > x[y == 0].max() or x[y == 1].max() < x[y == 0].min():
        raise ParameterError("collapses and survivors are separated by the IM: the logistic fit has no finite "
                             "maximum (more runs near the threshold are needed)")
    X = np.column_stack([np.ones_like(x), x])

    def nll(b):
        eta = X @ b
        ll = np.sum(y * eta - np.logaddexp(0.0, eta))
        return -ll, -(X.T @ (y - special.expit(eta)))

    res = optimize.minimize(nll, np.zeros(2), jac=True, method="BFGS", options={"gtol": 1e-10})
    p = special.expit(X @ res.x)
    hess = (X * (p * (1 - p))[:, None]).T @ X
    return LogisticCollapse(float(res.x[0]), float(res.x[1]), np.linalg.inv(hess), int(y.size), int(y.sum()),
                            float(-res.fun))


def _positive_im(im) -> np.ndarray:
    im = float_array(im, "IM", ndim=None, allow_empty=True, finite=False)
    if im.ndim != 1 or im.size == 0:
        raise ParameterError("IM must be a non-empty 1-D array")
    if not np.all(np.isfinite(im)) or np.any(im <= 0):
        raise ParameterError("IM values must be finite and positive (they enter as ln IM)")
    return im


@dataclass
class CloudFit:
    """Cloud analysis: ln EDP = a + b ln IM + beta eps over the non-collapsed runs, plus collapse.

    Attributes
    ----------
    a, b : float
        Intercept and slope (ordinary least squares, ``scipy.stats.linregress``).
    se_a, se_b : float
        Their standard errors.
    beta : float
        Dispersion: standard deviation of the residuals with n - 2 degrees of freedom.
    n : int
        Runs in the regression (non-collapsed, EDP > 0); ``n_collapsed`` collapsed runs.
    collapse : LogisticCollapse or None
        P(C | IM), when collapses and survivors both occur and overlap in IM (else None:
        ``p_collapse`` is then the constant fraction).
    """

    a: float
    b: float
    se_a: float
    se_b: float
    beta: float
    n: int
    n_collapsed: int
    r2: float
    collapse: LogisticCollapse | None = None
    p_collapse: float = 0.0

    def median_edp(self, im):
        """exp(a + b ln IM): the median EDP of a standing column at ``im``."""
        return np.exp(self.a + self.b * np.log(np.asarray(im, dtype=float)))

    def collapse_probability(self, im):
        im = np.asarray(im, dtype=float)
        return self.collapse(im) if self.collapse is not None else np.full(im.shape, self.p_collapse)

    def exceedance(self, im, threshold):
        """P(EDP >= threshold | IM) = P(C|IM) + (1 - P(C|IM)) (1 - Phi((ln t - a - b ln IM) / beta))."""
        im = np.asarray(im, dtype=float)
        pc = self.collapse_probability(im)
        tail = stats.norm.sf((np.log(float(threshold)) - self.a - self.b * np.log(im)) / self.beta)
        return pc + (1.0 - pc) * tail


def cloud_analysis(im, edp, collapsed=None) -> CloudFit:
    """Cloud analysis of a record suite (each run one point in the ln IM - ln EDP plane).

    Parameters
    ----------
    im : array_like, > 0 (IM units)
    edp : array_like (dimensionless); collapsed and non-positive values stay out of the regression
    collapsed : array_like of bool, optional (default: nothing collapsed)
    """
    x = _positive_im(im)
    e = float_array(edp, "edp", ndim=None, finite=False)
    c = np.zeros(x.size, dtype=bool) if collapsed is None else _as_flags(collapsed)
    if e.shape != x.shape or c.shape != x.shape:
        raise ParameterError(f"im, edp and collapsed must have one value per run ({x.size}, {e.size}, {c.size})")
    with np.errstate(invalid="ignore"):
        use = (~c) & np.isfinite(e) & (e > 0)
    if use.sum() < 3:
        raise ParameterError(f"cloud regression needs at least 3 standing runs with EDP > 0, got {int(use.sum())}")
    lx, ly = np.log(x[use]), np.log(e[use])
    if np.ptp(lx) == 0:
        raise ParameterError("cloud regression needs runs at different IM values")
    r = stats.linregress(lx, ly)
    resid = ly - (r.intercept + r.slope * lx)
    n = int(use.sum())
    beta = float(np.sqrt(np.sum(resid ** 2) / (n - 2)))
    fit = CloudFit(float(r.intercept), float(r.slope), float(r.intercept_stderr), float(r.stderr), beta, n,
                   int(c.sum()), float(r.rvalue ** 2), p_collapse=float(c.mean()))
    if c.any() and not c.all():
        try:
            fit.collapse = fit_logistic_collapse(x, c)
        except ParameterError:
            fit.collapse = None
    return fit


@dataclass
class MSAFragility(LognormalFragility):
    """Multiple-stripe fragility (Baker 2015): :class:`LognormalFragility` plus the stripes it was
    fitted to and the standard errors of ln(median) and ln(beta) from the Fisher information."""

    im_levels: np.ndarray | None = None
    n_trials: np.ndarray | None = None
    n_exceed_stripe: np.ndarray | None = None
    cov_ln: np.ndarray | None = None


def msa_fragility(im_levels, n_trials, n_exceed) -> MSAFragility:
    """Lognormal fragility from multiple stripes by maximum likelihood (Baker 2015, Eq. 11).

    At stripe j (IM level x_j) z_j of n_j runs exceed; with p_j = Phi(ln(x_j / theta) / beta) the
    log-likelihood sum_j [ln C(n_j, z_j) + z_j ln p_j + (n_j - z_j) ln(1 - p_j)]
    (``scipy.stats.binom.logpmf``) is maximised over (ln theta, ln beta) with
    ``scipy.optimize.minimize`` (Nelder-Mead, then polished by L-BFGS-B). ``cov_ln`` is the inverse of
    the expected Fisher information sum_j n_j phi(z_j)^2 / (p_j (1 - p_j)) g_j g_j^T,
    g_j = (-1/beta, -z_j), of (ln theta, ln beta).
    """
    x = _positive_im(im_levels)
    n = np.asarray(n_trials)
    z = np.asarray(n_exceed)
    if n.shape != x.shape or z.shape != x.shape:
        raise ParameterError("im_levels, n_trials and n_exceed need one value per stripe")
    if np.any(n < 1) or np.any(z < 0) or np.any(z > n) or np.any(n != np.round(n)) or np.any(z != np.round(z)):
        raise ParameterError("n_trials must be integers >= 1 and n_exceed integers in [0, n_trials]")
    if z.sum() == 0 or z.sum() == n.sum():
        raise ParameterError("every run exceeds or none does: the MSA likelihood has no interior maximum")
    lx = np.log(x)

    def nll(p):
        pr = np.clip(stats.norm.cdf((lx - p[0]) / np.exp(p[1])), 1e-300, 1 - 1e-16)
        return -np.sum(stats.binom.logpmf(z, n, pr))

    frac = z / n
    x0 = np.array([lx[np.argmin(np.abs(frac - 0.5))], np.log(0.4)])
    res = optimize.minimize(nll, x0, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
    bounds = _mle_bounds(lx)
    res = optimize.minimize(nll, res.x, method="L-BFGS-B", bounds=bounds)
    ln_theta, ln_beta = res.x
    beta = float(np.exp(ln_beta))
    zz = (lx - ln_theta) / beta
    pr = stats.norm.cdf(zz)
    w = n * stats.norm.pdf(zz) ** 2 / np.clip(pr * (1 - pr), 1e-300, None)
    gvec = np.stack([-np.ones_like(zz) / beta, -zz])
    info = (gvec * w) @ gvec.T
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.nan)
    runs_y = np.concatenate([np.arange(int(nj)) < int(zj) for nj, zj in zip(n, z)])
    why = _fit_degenerate(np.repeat(lx, n.astype(int)), runs_y, res.x, bounds)
    if why:
        warnings.warn(f"msa_fragility: {why}", DegenerateFitWarning, stacklevel=2)
    return MSAFragility(float(np.exp(ln_theta)), beta, int(n.sum()), int(z.sum()), float(-res.fun),
                        im_levels=x, n_trials=n.astype(int), n_exceed_stripe=z.astype(int), cov_ln=cov,
                        degenerate=why)


def msa_from_table(table, im: str, level: PerformanceLevel, *, stripe_key="scale", period_s=None) -> MSAFragility:
    """MSA fragility of a suite run at several amplitude factors (``--scale``): one stripe per value of
    ``stripe_key``; the stripe's IM level is the geometric mean of its runs' IM (the common IM level
    when the records were scaled to one; with plain amplitude factors the runs of a stripe have
    different IMs and :func:`fit_lognormal_fragility` on the individual IMs is the sharper fit)."""
    ok = ok_rows(table)
    x, _ = table_im(table, im, period_s)
    key = np.asarray(table[stripe_key])[ok]
    y = exceeded(np.asarray(table[level.edp], dtype=float)[ok], np.asarray(table["collapsed"])[ok].astype(bool),
                 level.threshold)
    x = x[ok]
    levels, n, z = [], [], []
    for k in np.unique(key):
        sel = key == k
        levels.append(float(np.exp(np.mean(np.log(_positive_im(x[sel]))))))
        n.append(int(sel.sum()))
        z.append(int(y[sel].sum()))
    return msa_fragility(np.array(levels), np.array(n), np.array(z))
