"""Figures of record-suite runs: natural records against the synthetic grid, after the paper's Fig. 10.

The paper's Fig. 10 plots u_top of 30 NGA records (60 components) recorded at 17-23 km against Mw,
with the mean u_top of its synthetic records at R = 20 km as a line, and reads from it that natural
records show the same decrease above Mw 6.5 and lie mostly below the line, the fault-parallel
components lowest. :func:`fig_10` draws the same comparison so that it can be read without
confusing whose numbers are whose:

* the natural records' points (one per horizontal component; collapsed runs as crosses at the top),
  for one or several record sets at once;
* their **binned means** (Mw bins of :data:`FIG10_MW_BIN_WIDTH` centred on the grid's magnitudes,
  mean u_top of the standing components) with percentile-bootstrap intervals
  (:func:`pycolfrag.analysis.fragility.bootstrap_interval`, resampling the components of the bin) and the
  count beside each, split into fault-normal (FN) and fault-parallel (FP) components when the rows
  carry a ``direction`` (``scripts/record_checks.py fig10`` rotates records whose strike and H1
  azimuth are known); otherwise the figure says that the split is not available;
* **pycolfrag's** synthetic mean line at R = ``dist_km`` from a grid file, labelled as ours;
* **the paper's** synthetic mean, :data:`PAPER_FIG10_MEAN_U_TOP`, marked as the paper's.

Built with the object-oriented matplotlib API (no pyplot state), like :mod:`pycolfrag.analysis.figures`.
"""
from __future__ import annotations

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.data import as_data
from pycolfrag.analysis.figures import Figure
from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError
from pycolfrag.solver.sample import rows_to_table

__all__ = ["FIG10_BAND_KM", "FIG10_DIST_KM", "FIG10_MW_BIN_WIDTH", "PAPER_FIG10_MEAN_U_TOP", "synthetic_mean_u_top",
           "binned_means", "fig_10"]

#: Distance band of the natural records of Fig. 10 (Rrup, km); the paper used 17-23 km.
FIG10_BAND_KM = (15.0, 25.0)
#: Distance of the synthetic mean line, km (the paper's R = 20 km).
FIG10_DIST_KM = 20.0
#: Width of the Mw bins of the natural records' means; bins are centred on multiples of it (the grid's
#: magnitudes 5.5, 6.0, ..., 7.5), so each bin mean sits beside one point of the synthetic line.
FIG10_MW_BIN_WIDTH = 0.5
#: The paper's synthetic mean u_top at R = 20 km (its Fig. 10 line, the same as Fig. 8a): about 0.4 at
#: Mw 6.5, the maximum, and about 0.2 at Mw 7.5, read from the paper's figures (no table gives them).
PAPER_FIG10_MEAN_U_TOP = {6.5: 0.4, 7.5: 0.2}


def synthetic_mean_u_top(synthetic, dist_km: float = FIG10_DIST_KM) -> tuple[np.ndarray, np.ndarray]:
    """(Mw, mean u_top of the successful non-collapsed runs) at distance ``dist_km`` of a synthetic
    grid: a results path, a :class:`pycolfrag.analysis.data.ResultsData` or a dict of arrays."""
    if isinstance(synthetic, dict):
        s = synthetic
        ok = np.asarray(s.get("status", np.zeros(len(s["mw"]))), dtype=int) == 0
    else:
        d = as_data(synthetic)
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


def _sets(records) -> dict:
    """``{label: suite table}`` from a table, a list of row dicts, or a mapping of labels to either."""
    def table(x):
        return rows_to_table(x) if isinstance(x, (list, tuple)) else x

    if isinstance(records, dict) and "mw" not in records:
        if not records:
            raise ParameterError("fig_10 needs at least one record set")
        return {str(k): table(v) for k, v in records.items()}
    return {"natural records": table(records)}


def _directions(t) -> np.ndarray:
    """Direction label of each row: ``FN``/``FP`` where the table says (``direction``), else the
    recorded component (``H1``, ``H2``, ``H1+H2``)."""
    n = len(t["mw"])
    comp = np.asarray(t.get("component", [""] * n), dtype=object)
    rec = np.array([{"h1": "H1", "h2": "H2", "both": "H1+H2"}.get(str(c), str(c)) for c in comp], dtype=object)
    if "direction" in t:
        d = np.asarray(t["direction"], dtype=object)
        return np.where(np.isin(d, ("FN", "FP")), d, rec)
    return rec


def _in_band(t, band_km):
    n = len(t["mw"])
    ok = np.asarray(t.get("status", np.zeros(n)), dtype=int) == 0
    rrup = np.asarray(t["rrup_km"], dtype=float)
    lo, hi = map(float, band_km)
    with np.errstate(invalid="ignore"):
        return ok & (rrup >= lo) & (rrup <= hi)


def binned_means(table, *, band_km=FIG10_BAND_KM, bin_width=FIG10_MW_BIN_WIDTH, n_boot=500, confidence=0.90,
                 rng=0) -> dict:
    """Mean u_top of the standing components of a record set per Mw bin, with its bootstrap interval.

    Rows: successful (``status == 0``) with Rrup in ``band_km``. Groups: ``"all"`` (every component),
    and ``"FN"`` and ``"FP"`` when the rows carry those directions. Returns ``{group: dict of arrays}``
    with ``mw`` (bin centres), ``n`` (components), ``n_collapsed``, ``mean`` (NaN when every component
    collapsed), ``low``, ``high`` (percentile bootstrap, NaN below 2 components).
    """
    sel = _in_band(table, band_km)
    mw = np.asarray(table["mw"], dtype=float)
    u = np.asarray(table["u_top"], dtype=float)
    coll = np.asarray(table["collapsed"]).astype(bool)
    dirs = _directions(table)
    width = float(bin_width)
    centre = np.round(mw / width) * width
    g = fr.as_rng(rng)
    groups = {"all": sel}
    for d in ("FN", "FP"):
        if np.any(sel & (dirs == d)):
            groups[d] = sel & (dirs == d)
    out = {}
    for name, m in groups.items():
        cs = np.unique(centre[m])
        rows = {k: np.full(cs.size, np.nan) for k in ("mean", "low", "high")}
        n = np.zeros(cs.size, dtype=int)
        nc = np.zeros(cs.size, dtype=int)
        for i, c in enumerate(cs):
            b = m & (centre == c)
            n[i], nc[i] = int(b.sum()), int((b & coll).sum())
            if nc[i] < n[i]:
                rows["mean"][i] = float(np.mean(u[b & ~coll]))
                rows["low"][i], rows["high"][i] = fr.bootstrap_interval(u[b], coll[b], statistic="mean", n_boot=n_boot,
                                                                        confidence=confidence, rng=g)
        out[name] = {"mw": cs, "n": n, "n_collapsed": nc, **rows}
    return out


_MARKERS = {"FN": "^", "FP": "v", "H1": "o", "H2": "s", "H1+H2": "D"}


def fig_10(records, synthetic=None, *, band_km=FIG10_BAND_KM, dist_km=FIG10_DIST_KM, bin_width=FIG10_MW_BIN_WIDTH,
           n_boot=500, rng=0, paper=True):
    """Natural records' u_top against Mw beside the synthetic mean (after the paper's Fig. 10).

    Parameters
    ----------
    records : a suite table (dict of arrays: :func:`pycolfrag.solver.sample.run_suite`), a list of row dicts,
        or ``{label: table}`` for several record sets at once. Needs ``mw``, ``rrup_km``, ``component``,
        ``u_top``, ``collapsed`` (``status``: only 0 rows are used; ``direction`` "FN"/"FP" optional).
    synthetic : results path, ResultsData, dict or None (no pycolfrag line)
    band_km : (low, high) Rrup band, km, closed; dist_km : the synthetic line's distance, km
    bin_width : Mw bin width of the binned means; n_boot, rng : their bootstrap
    paper : draw the paper's synthetic mean (:data:`PAPER_FIG10_MEAN_U_TOP`), marked as the paper's
    """
    sets = _sets(records)
    lo, hi = map(float, band_km)
    fig = Figure(figsize=(12, 5.5))
    ax = fig.add_subplot(1, 1, 1)
    tops = [np.nanmax(np.where(_in_band(t, band_km) & ~np.asarray(t["collapsed"]).astype(bool),
                               np.asarray(t["u_top"], dtype=float), np.nan))
            for t in sets.values() if np.any(_in_band(t, band_km) & ~np.asarray(t["collapsed"]).astype(bool))]
    top = max(tops) if tops else 1.0
    notes, counts = [], []
    for k, (label, t) in enumerate(sets.items()):
        color = f"C{k}"
        sel = _in_band(t, band_km)
        mw = np.asarray(t["mw"], dtype=float)
        u = np.asarray(t["u_top"], dtype=float)
        coll = np.asarray(t["collapsed"]).astype(bool)
        dirs = _directions(t)
        for d in [d for d in _MARKERS if np.any(sel & (dirs == d))]:
            m = sel & (dirs == d) & ~coll
            ax.plot(mw[m], u[m], _MARKERS[d], color=color, mfc="none", ms=5, alpha=0.6,
                    label=f"{label}: {d} components")
        if np.any(sel & coll):
            ax.plot(mw[sel & coll], np.full(int(np.sum(sel & coll)), 1.05 * top), "x", color=color,
                    label=f"{label}: collapsed ({int(np.sum(sel & coll))}, drawn at the top)")
        bm = binned_means(t, band_km=band_km, bin_width=bin_width, n_boot=n_boot, rng=rng)
        split = [g for g in ("FN", "FP") if g in bm]
        if not split:
            notes.append(f"{label}: no FN/FP split (the rows carry no fault orientation)")
        for j, g in enumerate(split or ["all"]):
            b = bm[g]
            good = np.isfinite(b["mean"])
            shift = (j - (len(split) - 1) / 2) * 0.04 * bin_width + 0.02 * k * bin_width
            x = b["mw"][good] + shift
            yerr = np.abs(np.vstack([b["mean"][good] - b["low"][good], b["high"][good] - b["mean"][good]]))
            yerr = np.nan_to_num(yerr)
            ax.errorbar(x, b["mean"][good], yerr=yerr, fmt="-" + ("^" if g == "FN" else "v" if g == "FP" else "o"),
                        color=color, ms=7, capsize=3, lw=1.2,
                        label=f"{label}: mean of {'all' if g == 'all' else g} components per Mw bin [90 % CI]")
            for xi, yi, ni, nci in zip(x, b["mean"][good], b["n"][good], b["n_collapsed"][good]):
                ax.annotate(f"n={ni}" + (f", {nci} coll." if nci else ""), (xi, yi), textcoords="offset points",
                            xytext=(4, 4), fontsize=7, color=color)
        counts.append(f"{label}: {int(np.sum(sel))} components from "
                      f"{len(set(np.asarray(t.get('record_id', ['?'] * len(mw)), dtype=object)[sel]))} records")
    if synthetic is not None:
        smw, smean = synthetic_mean_u_top(synthetic, dist_km)
        ax.plot(smw, smean, "-", color="k", lw=2, label=f"pycolfrag synthetic grid: mean u_top at R = {dist_km:g} km")
    if paper:
        pm = np.array(sorted(PAPER_FIG10_MEAN_U_TOP))
        ax.plot(pm, [PAPER_FIG10_MEAN_U_TOP[m] for m in pm], "*--", color="0.4", ms=11,
                label="the paper's synthetic mean at R = 20 km (approximate, read from its Fig. 10)")
    ax.set_xlabel(names.label("mw"))
    ax.set_ylabel(names.label("u_top"))
    ax.set_title(f"Natural records with Rrup {lo:g}-{hi:g} km against the synthetic mean (after the paper's "
                 f"Fig. 10)\n" + "; ".join(counts), fontsize=9)
    if notes:
        ax.text(0.01, 0.01, "\n".join(notes), transform=ax.transAxes, fontsize=7, va="bottom")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.subplots_adjust(left=0.07, right=0.62)
    return fig
