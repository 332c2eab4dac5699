"""Figures of an event-based site simulation (:mod:`pycolfrag.risk.rare_route`).

* ``rare_rates``: every level's annual rate with its interval -- the whole site, and with the grid's
  results its part inside the grid's range beside the grid route (``zero``, and ``clamp`` as a mark);
* ``rare_convergence``: every requested level's CoV after each batch against the runs used, the target
  as a line, and crude Monte Carlo's CoV for the same runs;
* ``rare_deaggregation``: the share of each distance bin and each magnitude bin in the rate of collapse
  and three levels.

Object-oriented matplotlib (no pyplot state); matplotlib is imported on the first figure.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pycolfrag.analysis.figures import Figure

__all__ = ["CAPTIONS", "fig_rates", "fig_convergence", "fig_deaggregation", "make_all"]

CAPTIONS = {
    "rare_rates": "Annual rate of each level by event-based simulation (and beside the grid route; grey: the "
                  "range failed runs leave, from all counted as none to all as exceedances)",
    "rare_convergence": "CoV of each level after each batch against the runs used (crude Monte Carlo dotted)",
    "rare_deaggregation": "Share of each distance and magnitude bin in the annual rate",
}


def _errorbar(ax, x, e, **kw):
    if getattr(e, "failed", 0) and e.failed_high > 0:      # what the failed runs could have been: a grey band
        ax.plot([x, x], [e.failed_low if e.failed_low > 0 else e.failed_high / 10, e.failed_high], color="0.6",
                lw=6, alpha=0.5, solid_capstyle="butt", zorder=0)
    if e.status == "refused":
        ax.plot([x], [e.bound], marker="v", linestyle="none", **kw)
        return
    ax.errorbar([x], [e.rate], yerr=[[e.rate - e.low], [e.high - e.rate]], fmt="o", capsize=3, **kw)


def fig_rates(run, cmp=None) -> Figure:
    fig = Figure(figsize=(9, 4.5), layout="constrained")
    ax = fig.add_subplot()
    labels = [q.label for q in run.quantities]
    for k, q in enumerate(run.quantities):
        _errorbar(ax, k - 0.15, run.estimate.levels[q.label], color="C0", label="event-based, whole site" if k == 0 else None)
        if cmp is not None:
            _errorbar(ax, k, cmp.in_grid.levels[q.label], color="C1",
                      label="event-based, grid's range" if k == 0 else None)
            lam, lo, hi = cmp.zero[q.label]
            if lam > 0:
                ax.errorbar([k + 0.15], [lam], yerr=[[lam - lo], [hi - lam]], fmt="s", capsize=3, color="C2",
                            label="grid route (zero)" if k == 0 else None)
            if cmp.clamp[q.label][0] > 0:
                ax.plot([k + 0.15], [cmp.clamp[q.label][0]], marker="_", markersize=14, color="C2",
                        label="grid route (clamp)" if k == 0 else None)
    ax.set_xticks(range(len(labels)), labels, rotation=20, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("annual rate of exceedance, 1/yr")
    ax.grid(True, which="both", axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"{run.site.name}: {run.runs} runs ({100 * run.stop.confidence:g} % intervals; triangles: "
                 "upper bounds of refused levels)", fontsize=9)
    return fig


def fig_convergence(run) -> Figure:
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    runs = np.array([h["runs"] for h in run.history], dtype=float)
    for k, q in enumerate(run.requested):
        cov = np.array([h["levels"][q.label][1] for h in run.history], dtype=float)
        ax.plot(runs, np.where(np.isfinite(cov), cov, np.nan), marker="o", color=f"C{k}", label=q.label)
        lam = run.estimate.levels[q.label].rate
        p = lam / run.strata.total_rate
        if 0 < p < 1:
            ax.plot(runs, np.sqrt((1 - p) / (p * runs)), linestyle=":", color=f"C{k}")
    ax.axhline(run.stop.target_cov, color="k", linewidth=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("runs")
    ax.set_ylabel("coefficient of variation of the rate")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def fig_deaggregation(run) -> Figure:
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    shown = [q for q in run.quantities if q.edp is None] + [q for q in run.quantities if q.edp is not None][::2]
    for pos, (what, key) in enumerate((("R bin, km", "r_km"), ("Mw bin", "mw"))):
        ax = fig.add_subplot(1, 2, pos + 1)
        bins = sorted({getattr(st, key) for st in run.strata.strata})
        x = np.arange(len(bins))
        for k, q in enumerate(shown):
            c = run.estimate.contributions[q.label]
            tot = float(np.sum(c))
            share = [float(sum(c[st.index] for st in run.strata.strata if getattr(st, key) == b)) / tot
                     if tot > 0 else 0.0 for b in bins]
            ax.bar(x + (k - len(shown) / 2) * 0.8 / len(shown), share, width=0.8 / len(shown), label=q.label)
        ax.set_xticks(x, [f"{b[0]:g}" if b[0] == b[1] else f"{b[0]:g}-{b[1]:g}" for b in bins], rotation=45, fontsize=7)
        ax.set_xlabel(what)
        ax.set_ylabel("share of the annual rate")
        ax.legend(fontsize=7)
    return fig


def make_all(run, cmp, outdir) -> dict:
    """Write the figures as PNG into ``outdir``; return {stem: path}."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    out = {}
    for stem, make in (("rare_rates", lambda: fig_rates(run, cmp)), ("rare_convergence", lambda: fig_convergence(run)),
                       ("rare_deaggregation", lambda: fig_deaggregation(run))):
        path = outdir / f"{stem}.png"
        make().savefig(path, dpi=110)
        out[stem] = str(path)
    return out
