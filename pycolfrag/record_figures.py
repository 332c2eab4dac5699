"""Figures of record-suite runs: the paper's Fig. 10 (natural records against the synthetic grid).

Built with the object-oriented matplotlib API (no pyplot state), like :mod:`pycolfrag.figures`.
Labels come from :mod:`pycolfrag.names`.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from . import names
from .errors import ParameterError

__all__ = ["FIG10_BAND_KM", "FIG10_DIST_KM", "synthetic_mean_u_top", "fig_10"]

#: Distance band of the natural records of Fig. 10 (Rrup, km); the paper used 17-23 km.
FIG10_BAND_KM = (15.0, 25.0)
#: Distance of the synthetic mean line, km (the paper's R = 20 km).
FIG10_DIST_KM = 20.0


def synthetic_mean_u_top(synthetic, dist_km: float = FIG10_DIST_KM) -> tuple[np.ndarray, np.ndarray]:
    """(Mw, mean u_top of the successful non-collapsed runs) at distance ``dist_km`` of a synthetic
    grid: a results path, a :class:`pycolfrag.figures.ResultsData` or a dict of arrays."""
    if isinstance(synthetic, dict):
        s = synthetic
        ok = np.asarray(s.get("status", np.zeros(len(s["mw"]))), dtype=int) == 0
    else:
        from .figures import ResultsData, read_results
        d = synthetic if isinstance(synthetic, ResultsData) else read_results(synthetic)
        s, ok = d.samples, np.ones(d.n, dtype=bool)
    dist = np.asarray(s["dist_km"], dtype=float)
    at = ok & np.isclose(dist, float(dist_km))
    if not at.any():
        raise ParameterError(f"the synthetic grid has no runs at R = {dist_km:g} km "
                             f"(distances: {sorted(set(np.round(dist[ok], 6).tolist()))})")
    mw = np.asarray(s["mw"], dtype=float)
    standing = at & ~np.asarray(s["collapsed"]).astype(bool)
    mws = np.unique(mw[at])
    mean = np.array([np.mean(np.asarray(s["u_top"], dtype=float)[standing & (mw == m)])
                     if np.any(standing & (mw == m)) else np.nan for m in mws])
    return mws, mean


def fig_10(records, synthetic=None, *, band_km=FIG10_BAND_KM, dist_km=FIG10_DIST_KM) -> Figure:
    """Fig. 10: u_top of natural records recorded at Rrup in ``band_km`` against Mw, each horizontal
    component a separate point, with the mean u_top line of a synthetic grid at R = ``dist_km``.

    Parameters
    ----------
    records : dict of arrays (a suite table: :func:`pycolfrag.sample.run_suite`) or list of row dicts
        Needs ``mw``, ``rrup_km``, ``component``, ``u_top``, ``collapsed`` (``status`` if present:
        only 0 rows are drawn). Collapsed runs are drawn as crosses at the top of the axes.
    synthetic : results path, ResultsData, dict or None (no line)
    band_km : (low, high), km, closed; dist_km : float, km
    """
    from .sample import rows_to_table
    t = rows_to_table(records) if isinstance(records, (list, tuple)) else records
    n = len(t["mw"])
    ok = np.asarray(t.get("status", np.zeros(n)), dtype=int) == 0
    rrup = np.asarray(t["rrup_km"], dtype=float)
    lo, hi = map(float, band_km)
    with np.errstate(invalid="ignore"):
        sel = ok & (rrup >= lo) & (rrup <= hi)
    comp = np.asarray(t["component"], dtype=object)
    mw = np.asarray(t["mw"], dtype=float)
    u = np.asarray(t["u_top"], dtype=float)
    coll = np.asarray(t["collapsed"]).astype(bool)
    fig = Figure(figsize=(7.5, 5))
    ax = fig.add_subplot(1, 1, 1)
    top = np.nanmax(np.where(sel & ~coll, u, np.nan)) if np.any(sel & ~coll) else 1.0
    markers = {"h1": ("o", "C0"), "h2": ("s", "C1"), "both": ("^", "C2")}
    for c, (mk, color) in markers.items():
        m = sel & (comp == c)
        if m.any():
            ax.plot(mw[m & ~coll], u[m & ~coll], mk, color=color, mfc="none", label=f"natural records, {c}")
    if np.any(sel & coll):
        ax.plot(mw[sel & coll], np.full(int(np.sum(sel & coll)), 1.05 * top), "x", color="k",
                label=f"collapsed ({int(np.sum(sel & coll))})")
    if synthetic is not None:
        smw, smean = synthetic_mean_u_top(synthetic, dist_km)
        ax.plot(smw, smean, "-", color="k", lw=2, label=f"synthetic, mean u_top at R = {dist_km:g} km")
    ax.set_xlabel(names.label("mw"))
    ax.set_ylabel(names.label("u_top"))
    ax.set_title(f"Fig. 10: natural records with Rrup {lo:g}-{hi:g} km ({int(np.sum(sel))} components "
                 f"from {len(set(np.asarray(t.get('record_id', ['?'] * n), dtype=object)[sel]))} records)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig
