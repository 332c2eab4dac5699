"""The rate weights of a site risk: how much annual rate of a site's events falls on each grid scenario.

Between grid scenarios the probability is interpolated bilinearly in (Mw, ln R); a bilinear
combination of values in [0, 1] stays in [0, 1]. Because the interpolation is linear in the grid
values, the rate of exceedance is a weighted sum of the grid cells' probabilities,
``lambda = sum_ij W_ij P_ij``, with ``W_ij`` the annual rate of the events whose interpolation draws
on scenario ij (:func:`node_weights`). The events come from the sources themselves
(``SiteSource.quadrature``), with their joint (Mw, R) weights: nothing here assumes that magnitude
and distance are independent.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.site.sources import OUTSIDE_CHOICES

__all__ = ["interpolate", "OutsideReport", "node_weights", "BRANCH_WEIGHTS"]

#: Tolerance of "on the grid's edge" in Mw and in ln R.
_EDGE_TOL = 1e-9

#: What an event weighs in a branch of the site's motions: all of it, the share with a pulse, the
#: share without.
BRANCH_WEIGHTS = {
    "all": lambda p: np.ones_like(p),
    "pulse": lambda p: p,
    "no-pulse": lambda p: 1.0 - p,
}


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
    in Mw or R (or both) of the grid asked for. ``treatment`` is what that part contributed: clamp, zero
    or refuse. ``not_computed``: the fraction that falls on scenarios of the grid asked for that an
    incomplete file has no rows for yet (after the treatment): it contributes 0, so every rate is a lower
    bound (docs/risk.md).
    """

    source: str
    rate: float
    mw_below: float
    mw_above: float
    r_below: float
    r_above: float
    outside: float
    treatment: str
    not_computed: float = 0.0

    def as_dict(self):
        return dict(self.__dict__)


def _outside_report(s, ev, mws, ds, outside):
    lo_m, hi_m = _beyond(mws, ev.mw, False)
    lo_r, hi_r = _beyond(ds, ev.r_km, True)
    out = lo_m | hi_m | lo_r | hi_r
    shares = [float(np.sum(ev.weight[mask]) / s.rate) if s.rate > 0 else 0.0
              for mask in (lo_m, hi_m, lo_r, hi_r, out)]
    rep = OutsideReport(s.name, s.rate, *shares, outside)
    if outside == "refuse" and np.any(out & (ev.weight > 0)):
        raise ParameterError(
            f"source {s.name!r} lies partly outside the simulated range Mw {mws[0]:g}-{mws[-1]:g}, "
            f"R {ds[0]:g}-{ds[-1]:g} km: fractions of its rate Mw below {rep.mw_below:.3g}, above "
            f"{rep.mw_above:.3g}, R below {rep.r_below:.3g}, above {rep.r_above:.3g}. Set outside = "
            "'clamp' (the grid's nearest edge) or 'zero' (no contribution) in the site file, or run a "
            "grid that covers the source")
    return rep, out


def node_weights(sources, mws, ds, *, outside="refuse", branch="all", asked=None):
    """Annual rate attached to every grid scenario: lambda = sum(W * P) for a surface P on the grid.

    Parameters
    ----------
    sources : sequence of pycolfrag.site.sources.SiteSource
    mws, ds : array_like
        The grid's magnitudes and distances (km), ascending: those with rows.
    outside : {"refuse", "clamp", "zero"}
        What the part of a source outside the grid contributes (always reported).
    branch : {"all", "pulse", "no-pulse"}
        Weight every event by 1, by its p_pulse, or by 1 - p_pulse (:data:`BRANCH_WEIGHTS`).
    asked : (mws, ds), optional
        The grid an incomplete file's run asked for (default: ``mws, ds``). ``outside`` applies beyond
        it; events inside it but beyond the computed ``mws, ds`` fall on scenarios not computed yet: they
        contribute 0 and are reported as ``not_computed`` (the rates are then lower bounds).

    Returns
    -------
    W : ndarray (n_mw, n_dist), per_source : list of ndarray, reports : list of OutsideReport
    """
    if outside not in OUTSIDE_CHOICES:
        raise ParameterError(f"outside must be one of {', '.join(OUTSIDE_CHOICES)}, got {outside!r}")
    if branch not in BRANCH_WEIGHTS:
        raise ParameterError(f"branch must be one of {', '.join(map(repr, BRANCH_WEIGHTS))}, got {branch!r}")
    mws, ds = np.asarray(mws, dtype=float), np.asarray(ds, dtype=float)
    am, ad = (mws, ds) if asked is None else (np.asarray(asked[0], dtype=float), np.asarray(asked[1], dtype=float))
    total = np.zeros((mws.size, ds.size))
    per_source, reports = [], []
    for s in sources:
        ev = s.quadrature(np.union1d(mws, am), np.union1d(ds, ad))   # segments end at every node
        rep, out = _outside_report(s, ev, am, ad, outside)
        reports.append(rep)
        w = ev.weight * BRANCH_WEIGHTS[branch](np.asarray(ev.p_pulse, dtype=float))
        if outside == "zero":
            w = np.where(out, 0.0, w)
        m, r = np.clip(ev.mw, am[0], am[-1]), np.clip(ev.r_km, ad[0], ad[-1])
        missing = np.logical_or.reduce(_beyond(mws, m, False) + _beyond(ds, r, True))
        kept = ev.weight if outside != "zero" else np.where(out, 0.0, ev.weight)
        rep.not_computed = float(np.sum(kept[missing]) / s.rate) if s.rate > 0 else 0.0
        w = np.where(missing, 0.0, w)
        W = np.zeros_like(total)
        for i, j, b in _bilinear(mws, ds, np.clip(m, mws[0], mws[-1]), np.clip(r, ds[0], ds[-1])):
            np.add.at(W, (i, j), w * b)
        per_source.append(W)
        total += W
    return total, per_source, reports


def pulse_share(source, mws, ds) -> float:
    """The rate-weighted mean pulse probability of a source's events (1 when it has no rate)."""
    ev = source.quadrature(mws, ds)
    return float(np.sum(ev.weight * ev.p_pulse) / np.sum(ev.weight)) if np.sum(ev.weight) > 0 else 1.0
