"""Figures of a site risk (:func:`pycolfrag.risk.site_risk.site_risk`) for a committee to read.

* ``risk_curves``: annual rate of exceeding each EDP level (u_top, u_d) with its interval band, the
  Table III/IV levels marked, the probability in 50 years on the right axis;
* ``risk_deaggregation``: the share of every grid scenario (Mw, R) in the rate of collapse and of
  three levels;
* ``risk_probability``: probability of each level in T years, T from 1 to 2500 years (log axes).

Object-oriented matplotlib (no pyplot state); matplotlib is imported on the first figure.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pycolfrag.analysis.figures import Figure

__all__ = ["CAPTIONS", "fig_curves", "fig_deaggregation", "fig_probability", "make_all"]

CAPTIONS = {
    "risk_curves": "Annual rate of exceeding each EDP level (left) and probability in 50 years (right)",
    "risk_deaggregation": "Deaggregation: share of each simulated scenario (Mw, R) in the annual rate",
    "risk_probability": "Probability of each level in T years",
}


def _title(risk):
    t = risk.site.name
    if risk.pulse_only:
        t += " -- PULSE-ONLY (overstates the risk)"
    if risk.incomplete:
        t += " -- INCOMPLETE results"
    share = sum(o.rate * o.not_computed for o in risk.outside) / max(sum(o.rate for o in risk.outside), 1e-300)
    if share > 0:
        t += f" -- LOWER BOUNDS ({100 * share:.3g} % of the rate on scenarios not computed yet)"
    return t


def fig_curves(risk) -> Figure:
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    pct = f"{100 * risk.confidence:g} %"
    for k, edp in enumerate(("u_top", "u_d")):
        ax = fig.add_subplot(1, 2, k + 1)
        c = risk.curves.get(edp)
        if c is not None:
            ax.fill_between(c["x"], np.maximum(c["low"], 1e-12), np.maximum(c["high"], 1e-12), color="C0",
                            alpha=0.25, label=f"{pct} interval")
            ax.plot(c["x"], np.maximum(c["rate"], 1e-12), color="C0", label="lambda(EDP > x)")
        for q in risk.quantities:
            if q.edp == edp:
                lam, lo, hi = risk.rate[q.label]
                ax.errorbar([q.level.threshold], [max(lam, 1e-12)],
                            yerr=[[max(lam - lo, 0)], [max(hi - lam, 0)]], fmt="o", color="C3", capsize=3)
                ax.annotate(q.name, (q.level.threshold, max(lam, 1e-12)), textcoords="offset points",
                            xytext=(-6, -4), ha="right", va="top", fontsize=8)   # below-left: inside the axes
        if edp == "u_top":
            lam, lo, hi = risk.rate["collapse"]
            ax.axhline(max(lam, 1e-12), color="k", ls="--", lw=1, label=f"collapse {lam:.2e}/yr")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{edp} level x (-)")
        ax.set_ylabel("annual rate of exceedance (1/yr)")
        sec = ax.secondary_yaxis("right", functions=(lambda l: 1 - np.exp(-50 * np.clip(l, 0, None)),
                                                     lambda p: -np.log(1 - np.clip(p, 0, 1 - 1e-15)) / 50))
        sec.set_ylabel("P in 50 years")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    fig.suptitle(_title(risk), fontsize=10)
    return fig


DEAGG_LEVELS = ("collapse", "u_top > 0.15", "u_top > 0.35", "u_d > 0.01")


def fig_deaggregation(risk) -> Figure:
    labels = [lab for lab in DEAGG_LEVELS if lab in risk.deagg]
    fig = Figure(figsize=(4.2 * len(labels), 4), layout="constrained")
    for k, lab in enumerate(labels):
        ax = fig.add_subplot(1, len(labels), k + 1)
        d = 100 * risk.deagg[lab]
        im = ax.imshow(d, origin="lower", cmap="viridis", aspect="auto", vmin=0)
        for i in range(d.shape[0]):
            for j in range(d.shape[1]):
                if d[i, j] >= 0.5:
                    ax.text(j, i, f"{d[i, j]:.0f}", ha="center", va="center", fontsize=7,
                            color="w" if d[i, j] < 0.6 * d.max() else "k")
        ax.set_xticks(range(risk.ds.size), [f"{r:g}" for r in risk.ds])
        ax.set_yticks(range(risk.mws.size), [f"{m:g}" for m in risk.mws])
        ax.set_xlabel("R (km)")
        ax.set_ylabel("Mw")
        lam = risk.rate[lab][0]
        ax.set_title(f"{lab}: {lam:.2e}/yr", fontsize=9)
        fig.colorbar(im, ax=ax, label="share of the rate (%)")
    fig.suptitle(f"{_title(risk)}: share of the rate from each simulated scenario (Mw, R); part of the sources "
                 f"outside the grid treated as '{risk.site.outside}'", fontsize=10)
    return fig


def fig_probability(risk) -> Figure:
    """P(at least one exceedance in T years) on log axes, so that collapse and near collapse, orders of
    magnitude below the light levels, stay readable; u_top levels solid, u_d levels dashed."""
    fig = Figure(figsize=(7.5, 5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    t = np.geomspace(1, 2500, 200)
    low = 1.0
    for k, q in enumerate(risk.quantities):
        lam, lo, hi = risk.rate[q.label]
        color = "k" if q.level is None else f"C{k}"
        ls = "-" if q.edp in (None, "u_top") else "--"
        ax.plot(t, -np.expm1(-lam * t), color=color, ls=ls,
                label=q.label if q.level is None else f"{q.label} ({q.name})")
        ax.fill_between(t, -np.expm1(-lo * t), -np.expm1(-hi * t), color=color, alpha=0.12)
        if lam > 0:
            low = min(low, -np.expm1(-lam * t[0]))
    for y in sorted(risk.prob):
        ax.axvline(y, color="0.6", lw=0.8, ls=":")
        ax.text(y, 0.01, f"{y:g} yr", rotation=90, va="bottom", ha="right", fontsize=7, color="0.4",
                transform=ax.get_xaxis_transform())
    ax.set_xscale("log")
    if low < 1:                                       # some level has a positive rate
        ax.set_yscale("log")
        ax.set_ylim(max(low / 2, 1e-7), 1)
    else:
        ax.set_ylim(0, 1)
    ax.set_xlabel("T (years)")
    ax.set_ylabel("P(at least one exceedance in T years)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(_title(risk) + f" (bands: {100 * risk.confidence:g} %)", fontsize=10)
    return fig


def make_all(risk, outdir) -> dict:
    """Write the three figures as PNG into ``outdir``; return {stem: path}."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    out = {}
    for stem, fn in (("risk_curves", fig_curves), ("risk_deaggregation", fig_deaggregation),
                     ("risk_probability", fig_probability)):
        if stem == "risk_curves" and not risk.curves:
            continue
        path = outdir / f"{stem}.png"
        fn(risk).savefig(path, dpi=120)
        out[stem] = str(path)
    return out
