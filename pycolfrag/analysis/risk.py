"""Site risk: annual rates and T-year probabilities of the column's damage levels at a site.

The fragility surfaces of a results file, P(EDP > x | Mw, R) on the grid's scenarios, are combined
with a site's earthquake sources (``docs/risk.md``)::

    lambda(EDP > x) = sum_sources nu * int int P(EDP > x | m, r) f(m) f(r) dm dr
    P(in T years)   = 1 - exp(-lambda T)                        (Poisson occurrence)

for every level of Tables III and IV and for collapse. The site and its sources come from a site
file (:mod:`pycolfrag.site`). Every synthetic motion of a grid carries a
velocity pulse, so a results file is one branch; a no-pulse grid (the stochastic part alone) is
the other, and the two are mixed with a pulse-occurrence probability p(r) given in the site file
(a number, or the model of :mod:`pycolfrag.ground_motion.shahi_baker_2014`)::

    P(EDP > x | m, r) = p(r) P_pulse(EDP > x | m, r) + (1 - p(r)) P_nopulse(EDP > x | m, r)

A pulse-only answer is given only when it is asked for explicitly (``model = "pulse-only"`` or
``--pulse-only``) and every output says so.

Interpolation: between grid scenarios the probability is bilinear in (Mw, ln R); a bilinear
combination of values in [0, 1] stays in [0, 1]. Because of that, lambda is a weighted sum of the
grid cells' probabilities, ``lambda = sum_ij W_ij P_ij`` with ``W_ij`` the annual rate of events
whose interpolation draws on scenario ij (:func:`node_weights`). The same weights give the
deaggregation by scenario (W_ij P_ij / lambda) and carry the Monte Carlo error of every cell to
lambda: draws of every cell's probability (by default the bootstrap over the cell's runs;
optionally, for a proportion k of n -- collapse, the empirical ratio -- the Jeffreys beta posterior
Beta(k + 1/2, n - k + 1/2)), summed with the weights, give lambda's distribution and its 90 %
interval. Cells are independent of each other (every scenario has its own seeds), but the pulse and
no-pulse branches of one scenario share theirs (the no-pulse grid is the pulse grid's stochastic
part), so a cell's two branches are drawn jointly, pairing the rows by sample number.

Magnitudes and distances are integrated by Gauss-Legendre quadrature on the segments between the
grid's nodes (the integrand is smooth inside each segment). The part of a source outside the
simulated (Mw, R) range is always reported (rate fractions below/above in Mw and in R); the site
file chooses what it contributes: ``refuse`` (default: an error giving the fractions), ``clamp``
(the nearest edge of the grid) or ``zero`` (nothing).

Command: ``python -m pycolfrag.analysis.risk SITE.toml RESULTS.h5 OUTDIR [--no-pulse NOPULSE.h5]``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import fragility as fr
from . import risk_figures
from ..errors import ParameterError, PycolfragError, ResultsFileError
from ..site import OUTSIDE_CHOICES, PulseModel, Site, load_site
from .data import as_data

__all__ = ["RiskQuantity", "QUANTITIES", "node_weights", "interpolate", "OutsideReport", "SiteRisk",
           "declared_pulse", "site_risk", "report_section", "write_outputs", "main"]

#: Tolerance of "on the grid's edge" in Mw and in ln R.
_EDGE_TOL = 1e-9


# --------------------------------------------------------------------------- quantities

@dataclass(frozen=True)
class RiskQuantity:
    """One exceedance event whose rate is computed: a performance level, or collapse."""

    label: str
    name: str
    level: fr.PerformanceLevel | None = None   # None: collapse

    @property
    def edp(self):
        return None if self.level is None else self.level.edp


#: The six levels of Tables III and IV, then collapse (Eq. (3)).
QUANTITIES = tuple(RiskQuantity(lv.label, lv.name, lv) for lv in fr.PERFORMANCE_LEVELS) + (
    RiskQuantity("collapse", "Collapse"),)


# --------------------------------------------------------------------------- interpolation weights

def _axis(nodes, x, log):
    """(lower index, upper index, fraction) of x between the nodes; linear in x or in ln x."""
    nodes = np.asarray(nodes, dtype=float)
    u, x = (np.log(nodes), np.log(x)) if log else (nodes, np.asarray(x, dtype=float))
    if nodes.size == 1:
        z = np.zeros(x.shape, dtype=int)
        return z, z, np.zeros(x.shape)
    i = np.clip(np.searchsorted(u, x, side="right") - 1, 0, nodes.size - 2)
    t = np.clip((x - u[i]) / (u[i + 1] - u[i]), 0.0, 1.0)
    return i, i + 1, t


def _beyond(nodes, x, log):
    """Masks of the points below the first node and above the last (in x, or in ln x)."""
    u, x = (np.log(nodes), np.log(x)) if log else (np.asarray(nodes, float), np.asarray(x, float))
    return x < u[0] - _EDGE_TOL, x > u[-1] + _EDGE_TOL


def _bilinear(mws, ds, m, r):
    """Node indices and weights of bilinear interpolation in (Mw, ln R) at points (m, r) on the grid."""
    i0, i1, tm = _axis(mws, m, False)
    j0, j1, tr = _axis(ds, r, True)
    return ((i0, j0, (1 - tm) * (1 - tr)), (i1, j0, tm * (1 - tr)), (i0, j1, (1 - tm) * tr), (i1, j1, tm * tr))


def interpolate(values, mws, ds, m, r):
    """The surface ``values`` (n_mw, n_dist) at points (m, r) inside the grid: bilinear in (Mw, ln R).

    Points outside the grid raise :class:`ParameterError` (see :func:`node_weights` for the treatments).
    """
    values = np.asarray(values, dtype=float)
    m, r = np.broadcast_arrays(np.asarray(m, float), np.asarray(r, float))
    lo_m, hi_m = _beyond(mws, m, False)
    lo_r, hi_r = _beyond(ds, r, True)
    out = lo_m | hi_m | lo_r | hi_r
    if np.any(out):
        k = np.flatnonzero(out.ravel())
        raise ParameterError(f"{k.size} of {out.size} points outside the grid Mw {mws[0]:g}-{mws[-1]:g}, R "
                             f"{ds[0]:g}-{ds[-1]:g} km, the first at Mw {m.ravel()[k[0]]:g}, R {r.ravel()[k[0]]:g} km")
    out = np.zeros(m.shape)
    for i, j, w in _bilinear(mws, ds, m, r):
        out = out + w * values[i, j]
    return out


@dataclass
class OutsideReport:
    """The part of one source outside the simulated (Mw, R) range, as fractions of its rate.

    A point of the source counts in every category it falls in; ``outside`` is the fraction outside
    in Mw or R (or both). ``treatment`` is what that part contributed: clamp, zero or refuse.
    """

    source: str
    rate: float
    mw_below: float
    mw_above: float
    r_below: float
    r_above: float
    outside: float
    treatment: str

    def as_dict(self):
        return dict(self.__dict__)


def node_weights(sources, mws, ds, *, outside="refuse", branch="all"):
    """Annual rate attached to every grid scenario: lambda = sum(W * P) for a surface P on the grid.

    Parameters
    ----------
    sources : sequence of Source
    mws, ds : array_like
        The grid's magnitudes and distances (km), ascending.
    outside : {"refuse", "clamp", "zero"}
        What the part of a source outside the grid contributes (always reported).
    branch : {"all", "pulse", "no-pulse"}
        Weight every event by 1, by p_pulse(r), or by 1 - p_pulse(r).

    Returns
    -------
    W : ndarray (n_mw, n_dist), per_source : list of ndarray, reports : list of OutsideReport
    """
    if outside not in OUTSIDE_CHOICES:
        raise ParameterError(f"outside must be one of {', '.join(OUTSIDE_CHOICES)}, got {outside!r}")
    if branch not in ("all", "pulse", "no-pulse"):
        raise ParameterError(f"branch must be 'all', 'pulse' or 'no-pulse', got {branch!r}")
    mws, ds = np.asarray(mws, dtype=float), np.asarray(ds, dtype=float)
    total = np.zeros((mws.size, ds.size))
    per_source, reports = [], []
    for s in sources:
        mm, wm = s.magnitude.points(mws)
        rr, wr = s.distance.points(ds)
        M, R = (a.ravel() for a in np.meshgrid(mm, rr, indexing="ij"))
        w = (s.rate * np.outer(wm, wr)).ravel()
        lo_m, hi_m = _beyond(mws, M, False)
        lo_r, hi_r = _beyond(ds, R, True)
        out = lo_m | hi_m | lo_r | hi_r
        shares = [float(np.sum(w[mask]) / s.rate) if s.rate > 0 else 0.0 for mask in (lo_m, hi_m, lo_r, hi_r, out)]
        rep = OutsideReport(s.name, s.rate, *shares, outside)
        reports.append(rep)
        if outside == "refuse" and np.any(out & (w > 0)):
            raise ParameterError(
                f"source {s.name!r} lies partly outside the simulated range Mw {mws[0]:g}-{mws[-1]:g}, "
                f"R {ds[0]:g}-{ds[-1]:g} km: fractions of its rate Mw below {rep.mw_below:.3g}, above "
                f"{rep.mw_above:.3g}, R below {rep.r_below:.3g}, above {rep.r_above:.3g}. Set outside = "
                "'clamp' (the grid's nearest edge) or 'zero' (no contribution) in the site file, or run a "
                "grid that covers the source")
        if branch != "all":
            p = s.pulse.probability(R)
            w = w * (p if branch == "pulse" else 1.0 - p)
        if outside == "zero":
            w = np.where(out, 0.0, w)
        M = np.clip(M, mws[0], mws[-1])
        R = np.clip(R, ds[0], ds[-1])
        W = np.zeros_like(total)
        for i, j, b in _bilinear(mws, ds, M, R):
            np.add.at(W, (i, j), w * b)
        per_source.append(W)
        total += W
    return total, per_source, reports


# --------------------------------------------------------------------------- cell probabilities

def _cells(data):
    """Grid nodes and the row indices of each (Mw, R) cell of a results file; every cell must have runs."""
    mw = np.asarray(data["mw"], dtype=float)
    dist = np.asarray(data["dist_km"], dtype=float)
    mws, ds = np.unique(mw), np.unique(dist)
    rows = {}
    for i, m in enumerate(mws):
        for j, r in enumerate(ds):
            idx = np.flatnonzero((mw == m) & (dist == r))
            if idx.size == 0:
                raise ResultsFileError(f"{data.path}: no successful run at Mw {m:g}, R {r:g} km; the surface "
                                       "cannot be interpolated over a hole (run the missing scenarios)")
            rows[i, j] = idx
    return mws, ds, rows


def _pairs(ids, n):
    """Rows of one cell in every branch, split into the rows paired across the branches and the rest.

    ``ids`` maps a branch to the sample numbers of its rows in the cell (None: the file has no sample
    numbers), ``n`` to its number of rows. The branches of a site are the same grid run with and
    without pulses from the same seeds, so row ``k`` of a cell in one branch and row ``k`` in the
    other share their random stream: they are paired. Returns {branch: (positions of the paired
    rows, in a common order; positions of the others)}; one branch: all its rows count as paired.
    """
    branches = list(ids)
    if len(branches) == 1:
        return {branches[0]: (np.arange(n[branches[0]]), np.zeros(0, dtype=int))}
    if any(ids[b] is None for b in branches):         # nothing to pair them by (reported as unpaired)
        return {b: (np.zeros(0, dtype=int), np.arange(n[b])) for b in branches}
    common = ids[branches[0]]
    for b in branches[1:]:
        common = np.intersect1d(common, ids[b])
    out = {}
    for b in branches:
        _, pos, _ = np.intersect1d(ids[b], common, return_indices=True)   # sorted by sample number
        out[b] = (pos, np.setdiff1d(np.arange(n[b]), pos))
    return out


def _cell_draws(cell, threshold, estimator, uncertainty, n_draws, rng):
    """Point estimate and n_draws joint draws of one cell's exceedance probability in every branch.

    ``cell`` maps a branch to (edp or None, collapsed, sample numbers or None); threshold None is
    collapse. Bootstrap: the runs of the cell resampled with replacement, the paired rows of the
    branches (:func:`_pairs`) resampled together, so the branches' draws keep the correlation their
    shared seeds give them; rows without a partner are resampled within their branch. Beta (for a
    proportion k of n: collapse, or every level with the empirical ratio): the Jeffreys posterior
    Beta(k + 1/2, n - k + 1/2) of each branch; for two fully paired branches the four joint outcomes
    are drawn from Dirichlet(counts + 1/4) (the Perks prior), whose margins are exactly those Jeffreys
    posteriors. Returns {branch: (point, draws)} and whether the draws are paired.
    """
    pairs = _pairs({b: v[2] for b, v in cell.items()}, {b: np.size(v[1]) for b, v in cell.items()})
    prop = threshold is None or estimator == "empirical"
    x, point = {}, {}
    for b, (edp, c, _) in cell.items():
        c = np.asarray(c, dtype=bool)
        if prop:
            x[b] = c if threshold is None else fr.exceeded(edp, c, threshold)
            point[b] = float(np.mean(x[b]))
        else:
            point[b] = fr.exceedance(edp, c, threshold)
    paired = all(pos.size > 0 for pos, _ in pairs.values())
    if prop and uncertainty == "beta":
        full = paired and all(rest.size == 0 for _, rest in pairs.values())
        if len(cell) == 2 and full:
            (bp, (pp, _)), (bn, (pn, _)) = pairs.items()
            a, b_ = x[bp][pp], x[bn][pn]
            counts = [np.sum(a & b_), np.sum(a & ~b_), np.sum(~a & b_), np.sum(~a & ~b_)]
            d = rng.dirichlet(np.asarray(counts, dtype=float) + 0.25, size=n_draws)
            return {bp: (point[bp], d[:, 0] + d[:, 1]), bn: (point[bn], d[:, 0] + d[:, 2])}, True
        out = {}
        for b, v in x.items():
            k, n = int(np.sum(v)), v.size
            out[b] = (point[b], rng.beta(k + 0.5, n - k + 0.5, size=n_draws))
        return out, len(cell) == 1
    n_common = next(iter(pairs.values()))[0].size
    shared = rng.integers(0, n_common, size=(n_draws, n_common)) if n_common else None
    out = {}
    for b, (edp, c, _) in cell.items():
        pos, rest = pairs[b]
        parts = [pos[shared]] if n_common else []
        if rest.size:
            parts.append(rest[rng.integers(0, rest.size, size=(n_draws, rest.size))])
        idx = np.concatenate(parts, axis=1)
        if prop:
            draws = np.mean(x[b][idx], axis=1)
        else:
            e = np.nan_to_num(np.asarray(edp, dtype=float), nan=0.0)
            c = np.asarray(c, dtype=bool)
            draws = fr.eq4_statistic(threshold)(e[idx], c[idx], axis=-1)
        out[b] = (point[b], draws)
    return out, len(cell) == 1 or paired


def _surface_draws(branches, grids, shape, threshold, edp_name, estimator, uncertainty, n_draws, rng):
    """{branch: (point surface, draws (n_draws, n_mw, n_dist))} and the number of cells drawn unpaired."""
    point = {b: np.zeros(shape) for b in branches}
    draws = {b: np.zeros((n_draws,) + shape) for b in branches}
    unpaired = 0
    for ij in grids[next(iter(branches))][2]:
        cell = {}
        for b, data in branches.items():
            idx = grids[b][2][ij]
            cell[b] = (None if edp_name is None else np.asarray(data[edp_name])[idx],
                       np.asarray(data["collapsed"])[idx],
                       np.asarray(data["sample"])[idx] if "sample" in data.samples else None)
        res, paired = _cell_draws(cell, threshold, estimator, uncertainty, n_draws, rng)
        unpaired += not paired
        for b, (p, d) in res.items():
            point[b][ij] = p
            draws[b][(slice(None),) + ij] = d
    return point, draws, unpaired


# --------------------------------------------------------------------------- branches

def declared_pulse(attrs) -> str | None:
    """What a results file says about its pulses: the root attribute or grid-signature entry ``pulse``
    (``"none"`` for the stochastic part alone), None when it says nothing (files made before the
    no-pulse grid existed; every one of their motions carries a pulse)."""
    v = attrs.get("pulse")
    if v is None:
        try:
            v = json.loads(attrs.get("grid_signature", "{}") or "{}").get("pulse")
        except (TypeError, ValueError, AttributeError):
            v = None
    if isinstance(v, bytes):
        v = v.decode()
    return None if v is None else str(v)


def _check_branches(pulse, no_pulse):
    dp = declared_pulse(pulse.attrs)
    if dp is not None and dp.lower() == "none":
        raise ParameterError(f"{pulse.path} declares pulse = 'none' (no velocity pulses) but was given as the "
                             "pulse branch; give it as the no-pulse branch (--no-pulse)")
    if no_pulse is None:
        return
    dn = declared_pulse(no_pulse.attrs)
    if dn is None or dn.lower() != "none":
        raise ParameterError(f"{no_pulse.path} was given as the no-pulse branch but does not declare pulse = "
                             f"'none' (it declares {dn!r}); make it with scripts/run_grid.py --pulse none")
    cp, cn = pulse.attrs.get("column"), no_pulse.attrs.get("column")
    if cp is not None and cn is not None and json.loads(cp) != json.loads(cn):
        raise ParameterError(f"{pulse.path} and {no_pulse.path} are grids of different columns; the two "
                             "branches must describe the same column")
    sp, sn = (_signature(d.attrs) for d in (pulse, no_pulse))
    differ = [k for k in _SHARED_SETTINGS if k in sp and k in sn and sp[k] != sn[k]]
    if differ:
        raise ParameterError(f"{pulse.path} and {no_pulse.path} differ in {', '.join(differ)} ("
                             + "; ".join(f"{k}: {sp[k]!r} against {sn[k]!r}" for k in differ)[:400]
                             + "); the two branches must be the same column, solver and records but for the pulse")


#: Grid settings the two branches must share (everything but the pulse and the scenarios' sample counts).
_SHARED_SETTINGS = ("column", "solver", "damping", "record_dt_s", "max_record_s", "sample_function", "streams")


def _signature(attrs) -> dict:
    try:
        v = json.loads(attrs.get("grid_signature", "{}") or "{}")
    except (TypeError, ValueError):
        return {}
    return v if isinstance(v, dict) else {}


# --------------------------------------------------------------------------- the risk

@dataclass
class SiteRisk:
    """Everything :func:`site_risk` computes (see its docstring); ``to_json`` gives the numbers."""

    site: Site
    files: dict
    branches: tuple
    estimator: str
    uncertainty: str
    confidence: float
    n_draws: int
    mws: np.ndarray
    ds: np.ndarray
    quantities: tuple
    rate: dict                 # label -> (lambda, low, high), 1/yr
    prob: dict                 # years -> label -> (P, low, high)
    source_rate: dict          # source name -> label -> lambda
    deagg: dict                # label -> (n_mw, n_dist) fractions of lambda
    outside: list              # OutsideReport per source
    weights: dict              # branch -> W (n_mw, n_dist)
    pulse_share: dict          # source name -> rate-weighted mean p_pulse
    unpaired_cells: int = 0    # cells whose two branches could not be drawn jointly (see _cell_draws)
    curves: dict = field(default_factory=dict)   # edp -> dict(x, rate, low, high)

    @property
    def pulse_only(self) -> bool:
        """True when the pulse branch was used alone (p_pulse = 1 for every source)."""
        return self.branches == ("pulse",)

    def to_json(self) -> dict:
        return {"site": self.site.name, "site_file": self.site.path, "files": self.files,
                "branches": list(self.branches), "pulse_only": self.pulse_only,
                "estimator": self.estimator, "uncertainty": self.uncertainty, "confidence": self.confidence,
                "n_draws": self.n_draws,
                "interpolation": "bilinear in (Mw, ln R) on the probability",
                "grid": {"mw": self.mws.tolist(), "dist_km": self.ds.tolist()},
                "rate_per_year": {k: list(v) for k, v in self.rate.items()},
                "probability": {f"{t:g}": {k: list(v) for k, v in d.items()} for t, d in self.prob.items()},
                "source_rate_per_year": self.source_rate,
                "pulse_share": self.pulse_share, "unpaired_cells": self.unpaired_cells,
                "outside": [o.as_dict() for o in self.outside],
                "deaggregation": {k: v.tolist() for k, v in self.deagg.items()},
                "curves": {k: {kk: np.asarray(vv).tolist() for kk, vv in v.items()} for k, v in self.curves.items()}}


def _interval(draws, confidence):
    a = 100 * (1 - confidence) / 2
    lo, hi = np.percentile(draws, [a, 100 - a])
    return float(lo), float(hi)


def _p_years(lam, years):
    return 1.0 - math.exp(-lam * years)


CURVE_X = {"u_top": np.geomspace(0.05, 1.5, 25), "u_d": np.geomspace(0.001, 0.05, 25)}


def site_risk(site, pulse_results, no_pulse_results=None, *, pulse_only=False, estimator="eq4",
              uncertainty="bootstrap", outside=None, years=(), n_draws=2000, confidence=0.90, rng=0, curves=True,
              curve_draws=200) -> SiteRisk:
    """Annual rates and T-year probabilities of every Table III/IV level and of collapse at a site.

    Parameters
    ----------
    site : Site or path
        The site file (:func:`load_site`).
    pulse_results : path or figures.ResultsData
        Results of the grid with pulses (``scripts/run_grid.py``).
    no_pulse_results : path or figures.ResultsData, optional
        Results of the same grid without pulses (``run_grid.py --pulse none``). Required unless every
        source's pulse model is pulse-only or has p_pulse = 1.
    pulse_only : bool
        Ask for the pulse branch alone (p_pulse = 1 for every source), whatever the site file says;
        the outputs say so.
    estimator : {"eq4", "empirical"}
        Cell probability: Eq. (4) (lognormal fit + collapse, the paper's) or the empirical ratio.
    uncertainty : {"bootstrap", "beta"}
        Draws of every cell: the bootstrap over its runs, or for proportions (collapse, and every
        level with the empirical ratio) the Jeffreys posterior Beta(k + 1/2, n - k + 1/2), which
        keeps an upper bound above 0 in cells where nothing exceeded (Eq. (4) levels stay bootstrapped).
    outside : {"refuse", "clamp", "zero"}, optional
        Overrides the site file's choice.
    years : sequence of float
        Horizons besides 50, 100, 475 years and the site file's.
    n_draws : int
        Draws of every cell's probability for the intervals.
    confidence : float
        Two-sided level of the intervals (0.90).
    rng : int or numpy Generator
    curves : bool
        Also compute lambda(EDP > x) over a range of x for each EDP (risk curves, fewer draws).
    """
    if not isinstance(site, Site):
        site = load_site(site)
    if estimator not in ("eq4", "empirical"):
        raise ParameterError(f"estimator must be 'eq4' or 'empirical', got {estimator!r}")
    if uncertainty not in ("bootstrap", "beta"):
        raise ParameterError(f"uncertainty must be 'bootstrap' or 'beta', got {uncertainty!r}")
    if not 0 < confidence < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    if int(n_draws) < 10:
        raise ParameterError(f"n_draws must be >= 10, got {n_draws!r}")
    if pulse_only:
        site = replace(site, sources=tuple(replace(s, pulse=PulseModel("pulse-only")) for s in site.sources))
    if outside is not None:
        site = replace(site, outside=outside)
    extra = [float(y) for y in years]
    if any(not (math.isfinite(y) and y > 0) for y in extra):
        raise ParameterError(f"years must be positive, got {list(years)!r}")
    all_years = tuple(sorted(set(site.years) | set(extra)))
    g = fr.as_rng(rng)
    pulse = as_data(pulse_results)
    no_pulse = None if no_pulse_results is None else as_data(no_pulse_results)
    need = [s.name for s in site.sources if s.pulse.needs_no_pulse_branch]
    if no_pulse is None and need:
        raise ParameterError(
            f"sources {', '.join(map(repr, need))} have p_pulse < 1 but only the pulse branch was given: "
            "give the no-pulse results (--no-pulse, from scripts/run_grid.py --pulse none), or ask for the "
            "pulse branch alone explicitly (model = 'pulse-only' or --pulse-only; it overstates the risk)")
    if no_pulse is not None and not need:
        raise ParameterError("a no-pulse branch was given but every source is pulse-only (p_pulse = 1): "
                             "drop one of the two")
    _check_branches(pulse, no_pulse)
    branches = {"pulse": pulse} if no_pulse is None else {"pulse": pulse, "no-pulse": no_pulse}
    grids = {b: _cells(data) for b, data in branches.items()}
    mws, ds, _ = grids["pulse"]
    for b, (m2, d2, _) in grids.items():
        if not (np.array_equal(m2, mws) and np.array_equal(d2, ds)):
            raise ParameterError(f"the {b} branch's grid (Mw {m2.tolist()}, R {d2.tolist()}) differs from the pulse "
                                 f"branch's (Mw {mws.tolist()}, R {ds.tolist()}); run both on the same scenarios")
    weights, per_source, reports = {}, {}, None
    for b in branches:
        key = "all" if len(branches) == 1 else b
        weights[b], per_source[b], rep = node_weights(site.sources, mws, ds, outside=site.outside, branch=key)
        reports = reports or rep
    shape = (mws.size, ds.size)
    rate, prob, deagg = {}, {t: {} for t in all_years}, {}
    source_rate = {s.name: {} for s in site.sources}
    unpaired = 0
    for q in QUANTITIES:
        thr = None if q.level is None else q.level.threshold
        point, draws, u = _surface_draws(branches, grids, shape, thr, q.edp, estimator, uncertainty, int(n_draws), g)
        unpaired = max(unpaired, u)
        lam = sum(float(np.sum(weights[b] * point[b])) for b in branches)
        contrib = sum(weights[b] * point[b] for b in branches)
        lam_draws = sum(np.tensordot(draws[b], weights[b], axes=([1, 2], [0, 1])) for b in branches)
        src = [sum(float(np.sum(per_source[b][k] * point[b])) for b in branches) for k in range(len(site.sources))]
        lo, hi = _interval(lam_draws, confidence)
        rate[q.label] = (lam, lo, hi)
        for t in all_years:
            prob[t][q.label] = (_p_years(lam, t), _p_years(lo, t), _p_years(hi, t))
        deagg[q.label] = contrib / lam if lam > 0 else np.zeros(shape)
        for s, v in zip(site.sources, src):
            source_rate[s.name][q.label] = v
    pulse_share = {}
    for s in site.sources:
        rr, wr = s.distance.points(ds)
        pulse_share[s.name] = float(np.sum(wr * s.pulse.probability(rr)) / np.sum(wr)) if np.sum(wr) > 0 else 1.0
    out = SiteRisk(site, {b: str(d.path) for b, d in branches.items()}, tuple(branches), estimator, uncertainty,
                   confidence, int(n_draws), mws, ds, QUANTITIES, rate, prob, source_rate, deagg, reports, weights,
                   pulse_share, unpaired)
    if curves:
        out.curves = _curves(branches, grids, weights, estimator, uncertainty, int(curve_draws), confidence, g)
    return out


def _curves(branches, grids, weights, estimator, uncertainty, n_draws, confidence, g):
    res = {}
    for edp, xs in CURVE_X.items():
        lam = np.zeros(xs.size)
        lo = np.zeros(xs.size)
        hi = np.zeros(xs.size)
        shape = weights["pulse"].shape
        for k, x in enumerate(xs):
            point, draws, _ = _surface_draws(branches, grids, shape, float(x), edp, estimator, uncertainty, n_draws, g)
            lam[k] = sum(float(np.sum(weights[b] * point[b])) for b in branches)
            lo[k], hi[k] = _interval(sum(np.tensordot(draws[b], weights[b], axes=([1, 2], [0, 1]))
                                         for b in branches), confidence)
        res[edp] = {"x": xs, "rate": lam, "low": lo, "high": hi}
    return res


# --------------------------------------------------------------------------- outputs

def _e(x):
    return "0" if x == 0 else f"{x:.2e}"


def _p(x):
    return f"{x:.3f}" if x >= 0.001 or x == 0 else f"{x:.1e}"


def report_section(risk: SiteRisk, figures: dict | None = None, heading: str = "##") -> str:
    """The risk as a Markdown section: rates and probabilities with intervals, sources, range, figures.

    ``figures`` maps a caption to a relative PNG path (links written at the end).
    """
    s = risk.site
    pct = f"{100 * risk.confidence:g} %"
    L = [f"{heading} Site risk: {s.name}", ""]
    if s.description:
        L += [s.description, ""]
    if risk.pulse_only:
        L += ["**PULSE-ONLY: every motion is taken to carry a velocity pulse (asked for explicitly). "
              "Near-fault practice mixes pulse and no-pulse motions; this answer overstates the risk.**", ""]
    if risk.uncertainty == "bootstrap":
        unc = "percentile bootstrap over each cell's runs"
    else:
        unc = ("Jeffreys beta posterior of k of n for " + ("collapse, bootstrap over the runs for Eq. (4)"
               if risk.estimator == "eq4" else "every level") + ("" if len(risk.branches) == 1 else
               " (paired branches: Dirichlet(counts + 1/4) of the joint outcomes, Jeffreys margins)")
               + "; a Bayesian interval, which may lie above the plug-in estimate where most cells have 0 of n")
    L += [f"- site file: `{s.path}`",
          *[f"- {b} branch: `{p}`" for b, p in risk.files.items()],
          f"- cell probability: {'Eq. (4)' if risk.estimator == 'eq4' else 'empirical ratio'}; "
          f"collapse: Eq. (3); interpolation: bilinear in (Mw, ln R) on the probability; "
          f"grid Mw {risk.mws[0]:g}-{risk.mws[-1]:g}, R {risk.ds[0]:g}-{risk.ds[-1]:g} km",
          f"- intervals: two-sided {pct} from {risk.n_draws} draws of every grid cell ({unc}) summed with "
          "the rate weights; cells drawn independently" + ("" if len(risk.branches) == 1 else
          ", a cell's pulse and no-pulse rows paired by sample (same seeds) and drawn together"
          + (f" ({risk.unpaired_cells} cells without pairs drawn branch by branch)" if risk.unpaired_cells
             else "")) + "; P in T years = 1 - exp(-lambda T) (Poisson)",
          f"- part of the sources outside the grid: treated as `{s.outside}` (table below)", "",
          f"| level | lambda (1/yr) [{pct}] | return period (yr) | "
          + " | ".join(f"P in {t:g} yr [{pct}]" for t in sorted(risk.prob)) + " | largest contribution |",
          "|---|---|---:|" + "---|" * len(risk.prob) + "---|"]
    for q in risk.quantities:
        lam, lo, hi = risk.rate[q.label]
        d = risk.deagg[q.label]
        if lam > 0:
            i, j = np.unravel_index(np.argmax(d), d.shape)
            top = f"Mw {risk.mws[i]:g}, R {risk.ds[j]:g} km ({100 * d[i, j]:.0f} %)"
        else:
            top = "-"
        cells = [f"{_p(v[0])} [{_p(v[1])}, {_p(v[2])}]" for v in (risk.prob[t][q.label] for t in sorted(risk.prob))]
        name = q.label if q.level is None else f"{q.label} ({q.name})"
        L.append(f"| {name} | {_e(lam)} [{_e(lo)}, {_e(hi)}] | {'inf' if lam == 0 else f'{1 / lam:.3g}'} | "
                 + " | ".join(cells) + f" | {top} |")
    L += ["", "Sources (rate of each level per year; p_pulse is the mean over the source's distances):", "",
          "| source | model | pulse | mean p_pulse | " + " | ".join(q.label for q in risk.quantities) + " |",
          "|---|---|---|---:|" + "---:|" * len(risk.quantities)]
    for src in s.sources:
        L.append(f"| {src.name} | {src.describe()} | {src.pulse.describe()} | {risk.pulse_share[src.name]:.3f} | "
                 + " | ".join(_e(risk.source_rate[src.name][q.label]) for q in risk.quantities) + " |")
    L += ["", "Part of each source outside the simulated range (fractions of its rate; a point outside in "
              "both Mw and R counts in both columns):", "",
          "| source | Mw below | Mw above | R below | R above | outside (any) | treated as |",
          "|---|---:|---:|---:|---:|---:|---|"]
    for o in risk.outside:
        L.append(f"| {o.source} | {o.mw_below:.3f} | {o.mw_above:.3f} | {o.r_below:.3f} | {o.r_above:.3f} | "
                 f"{o.outside:.3f} | {o.treatment} |")
    if figures:
        L += [""]
        for caption, rel in figures.items():
            L += [f"![{caption}]({rel})", ""]
    return "\n".join(L) + "\n"


def write_outputs(risk: SiteRisk, outdir, *, figures=True) -> dict:
    """Write ``risk.md``, ``risk.json`` and (with matplotlib) the figures into ``outdir``; return the paths."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = {}
    figs = {}
    if figures:
        for stem, path in risk_figures.make_all(risk, outdir).items():
            figs[risk_figures.CAPTIONS[stem]] = Path(path).name
            paths[stem] = str(path)
    md = outdir / "risk.md"
    md.write_text("# pycolfrag site risk\n\n" + report_section(risk, figs), encoding="utf-8")
    js = outdir / "risk.json"
    js.write_text(json.dumps(risk.to_json(), indent=1), encoding="utf-8")
    paths.update(markdown=str(md), json=str(js))
    return paths


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m pycolfrag.analysis.risk",
                                 description="Annual rates and T-year probabilities of the column's damage "
                                             "levels at a site (docs/risk.md).")
    ap.add_argument("site", help="site file (TOML)")
    ap.add_argument("results", help="results of the grid with pulses (HDF5)")
    ap.add_argument("outdir", help="folder for risk.md, risk.json and the figures")
    ap.add_argument("--no-pulse", metavar="H5", help="results of the same grid made with run_grid.py --pulse none")
    ap.add_argument("--pulse-only", action="store_true",
                    help="use the pulse branch alone (p_pulse = 1); overstates the risk, said in every output")
    ap.add_argument("--estimator", choices=("eq4", "empirical"), default="eq4")
    ap.add_argument("--uncertainty", choices=("bootstrap", "beta"), default="bootstrap")
    ap.add_argument("--outside", choices=OUTSIDE_CHOICES, help="override the site file's choice")
    ap.add_argument("--years", type=float, nargs="*", default=[], help="more horizons (50, 100, 475 always)")
    ap.add_argument("--draws", type=int, default=2000, help="draws per grid cell for the intervals")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-figures", action="store_true")
    a = ap.parse_args(argv)
    try:
        risk = site_risk(a.site, a.results, a.no_pulse, pulse_only=a.pulse_only, estimator=a.estimator,
                         uncertainty=a.uncertainty, outside=a.outside, years=a.years, n_draws=a.draws, rng=a.seed)
    except PycolfragError as exc:       # a bad site file or results file: its message, not a traceback
        print(f"{ap.prog}: error: {exc}", file=sys.stderr)
        return 2
    paths = write_outputs(risk, a.outdir, figures=not a.no_figures)
    if risk.pulse_only:
        print("PULSE-ONLY risk (asked for explicitly): it overstates the risk of a site")
    for o in risk.outside:
        if o.outside > 0:
            print(f"{o.source}: {100 * o.outside:.1f} % of its rate lies outside the simulated range (Mw below "
                  f"{100 * o.mw_below:.1f} %, above {100 * o.mw_above:.1f} %; R below {100 * o.r_below:.1f} %, above "
                  f"{100 * o.r_above:.1f} %), treated as {o.treatment!r}")
    for q in risk.quantities:
        lam, lo, hi = risk.rate[q.label]
        p50 = risk.prob[50.0][q.label]
        print(f"{q.label:>14}: lambda {_e(lam)} [{_e(lo)}, {_e(hi)}] /yr, "
              f"P50 {_p(p50[0])} [{_p(p50[1])}, {_p(p50[2])}]")
    print(paths["markdown"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
