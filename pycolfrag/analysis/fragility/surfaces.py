"""Per-scenario tables and surfaces over (Mw, R) (paper Figs. 8, 12, 13)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pycolfrag.analysis.fragility.bootstrap import _mean_ok_vectorised, as_rng, boot_settings, bootstrap_interval
from pycolfrag.analysis.fragility.eq4 import (
    _exceedance,
    empirical_exceedance,
    eq4_degenerate,
    exceedance,
    lognormal_parameters,
)
from pycolfrag.core import progress
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import float_array
from pycolfrag.damage import PERFORMANCE_LEVELS, _as_inputs


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
    boot_settings(n_boot, confidence)
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
            progress.advance(unit="fit")   # a scenario's fits: one step of a command's bar (pycolfrag.core.progress)
    return rows


def degenerate_scenarios(mw, dist_km, edp, collapsed) -> list:
    """``[(mw, dist_km, reason)]`` of the scenarios whose Eq. (4) is not an estimate
    (:func:`~pycolfrag.analysis.fragility.eq4_degenerate`), in (mw, dist_km) order; with the number of
    scenarios as ``len`` of :func:`scenario_table` it tells a figure or a document what to mark."""
    mw, dist_km, mws, ds = _groups(mw, dist_km)
    edp, collapsed = _as_inputs(edp, collapsed)
    out = []
    for m in mws:
        for d in ds:
            sel = (mw == m) & (dist_km == d)
            why = eq4_degenerate(edp[sel], collapsed[sel]) if sel.any() else ""
            if why:
                out.append((float(m), float(d), why))
    return out


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
    boot_settings(n_boot, confidence)
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
    boot_settings(n_boot, confidence)
    g = as_rng(rng)
    return _surface(mw, dist_km, edp, collapsed, lambda e, c: float(_mean_ok_vectorised(e, c)),
                    lambda e, c: bootstrap_interval(e, c, statistic="mean", n_boot=n_boot,
                                                    confidence=confidence, rng=g),
                    label or "mean EDP (non-collapsed)")


def collapse_surface(mw, dist_km, collapsed, *, n_boot=1000, confidence=0.90, rng=None) -> Surface:
    """Collapse probability, Eq. (3), over (Mw, R) (paper Fig. 8c)."""
    boot_settings(n_boot, confidence)
    g = as_rng(rng)
    c = np.asarray(collapsed)
    return _surface(mw, dist_km, np.zeros(c.shape), c, lambda e, c: float(np.mean(c)),
                    lambda e, c: bootstrap_interval(e, c, statistic="collapse", n_boot=n_boot,
                                                    confidence=confidence, rng=g),
                    "P(collapse)")


