"""2-D maps of Figs. 8, 12 and 13 over (R, Mw): filled contours with colour bars, beside the 3-D surfaces.

The 3-D surfaces (:func:`pycolfrag.analysis.figures.fig_08`, ``fig_12``, ``fig_13``) show the shape but
not the values: read off a perspective, with no colour bar, they cannot be compared between panels. The
maps here draw the same estimates (Eq. (3) and (4) per scenario, the mean EDPs of the standing runs) as
filled contours over R (km, x axis) and Mw (y axis), with the simulated scenarios as dots:

* Figs. 12 and 13 (probabilities): the three levels on one colour scale, 0 to 1, and one colour bar;
* Fig. 8: the two mean EDPs and the collapse probability are different quantities, so each panel has
  its own colour bar (the probability's from 0 to 1).

A grid with a single Mw or a single R has no area to contour: its scenarios are drawn as coloured
points on the same scale. Object-oriented matplotlib, imported on the first figure.
"""
from __future__ import annotations

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.data import as_data

__all__ = ["fig_08_map", "fig_12_map", "fig_13_map", "PROBABILITY_LEVELS"]

#: Contour levels of every probability map (one scale for all panels).
PROBABILITY_LEVELS = np.linspace(0.0, 1.0, 11)


def _figure(figsize):
    from matplotlib.figure import Figure  # here: the optional plotting stack, only to draw
    return Figure(figsize=figsize, layout="constrained")


def _map_axes(ax, surf: fr.Surface, norm, levels, cmap="viridis"):
    """One map: filled contours (or coloured points on a degenerate grid) and the scenario dots; returns
    the mappable for a colour bar."""
    R, M = np.meshgrid(surf.dist_km, surf.mw)
    v = np.ma.masked_invalid(surf.value)
    if surf.mw.size > 1 and surf.dist_km.size > 1:
        m = ax.contourf(R, M, v, levels=levels, norm=norm, cmap=cmap, extend="neither")
    else:
        m = ax.scatter(R.ravel(), M.ravel(), c=surf.value.ravel(), norm=norm, cmap=cmap, s=120,
                       edgecolors="k")
    ax.plot(R.ravel(), M.ravel(), "k.", ms=4, clip_on=False)
    ax.set_xlabel("R (km)")
    ax.set_ylabel("Mw (-)")
    return m


def _norm(lo, hi):
    from matplotlib.colors import Normalize  # here: with the figure
    return Normalize(vmin=lo, vmax=hi)


def _edp_levels(surf: fr.Surface):
    v = surf.value[np.isfinite(surf.value)]
    hi = float(v.max()) if v.size and v.max() > 0 else 1.0
    return np.linspace(0.0, hi, 11), _norm(0.0, hi)


def fig_08_map(data, n_boot=500, rng=0, **_):
    """Fig. 8 as maps: mean u_top and mean u_d of the standing runs, collapse probability (one colour bar
    each: different quantities)."""
    d = as_data(data)
    g = np.random.default_rng(rng)
    s1 = fr.mean_edp_surface(d["mw"], d["dist_km"], d["u_top"], d["collapsed"], n_boot=n_boot, rng=g)
    s2 = fr.mean_edp_surface(d["mw"], d["dist_km"], d["u_d"], d["collapsed"], n_boot=n_boot, rng=g)
    s3 = fr.collapse_surface(d["mw"], d["dist_km"], d["collapsed"], n_boot=n_boot, rng=g)
    fig = _figure((15, 4.6))
    panels = ((s1, "mean u_top (-)", "(a) mean u_top, non-collapsed", _edp_levels(s1)),
              (s2, "mean u_d (-)", "(b) mean u_d, non-collapsed", _edp_levels(s2)),
              (s3, "P(collapse) (-)", "(c) collapse probability, Eq. (3)", (PROBABILITY_LEVELS, _norm(0, 1))))
    for k, (s, label, title, (levels, norm)) in enumerate(panels, start=1):
        ax = fig.add_subplot(1, 3, k)
        m = _map_axes(ax, s, norm, levels)
        ax.set_title(title, fontsize=9)
        fig.colorbar(m, ax=ax, label=label)
    fig.suptitle(f"Fig. 8 (maps): mean EDPs and collapse probability per scenario; dots: simulated scenarios "
                 f"(n = {d.n}{d.failed_note()})", fontsize=10)
    return fig


def _fig_levels_map(data, levels, number, edp, n_boot, rng):
    d = as_data(data)
    g = np.random.default_rng(rng)
    fig = _figure((15, 4.6))
    norm = _norm(0.0, 1.0)
    axes, m = [], None
    for k, lev in enumerate(levels, start=1):
        s = fr.exceedance_surface(d["mw"], d["dist_km"], d[lev.edp], d["collapsed"], lev.threshold,
                                  n_boot=n_boot, rng=g, label=lev.label)
        ax = fig.add_subplot(1, len(levels), k)
        m = _map_axes(ax, s, norm, PROBABILITY_LEVELS)
        ax.set_title(f"({'abc'[k - 1]}) P({lev.label}): {lev.name}", fontsize=9)
        axes.append(ax)
    fig.colorbar(m, ax=axes, label="P(exceedance), Eq. (4) (-)")
    fig.suptitle(f"Fig. {number} (maps): P({edp} exceeds each level) per scenario, one colour scale; dots: "
                 f"simulated scenarios (n = {d.n}{d.failed_note()})", fontsize=10)
    return fig


def fig_12_map(data, n_boot=500, rng=0, **_):
    """Fig. 12 as maps: P(u_top > 0.15, 0.35, 1.0) on one colour scale."""
    return _fig_levels_map(data, fr.U_TOP_LEVELS, 12, "u_top", n_boot, rng)


def fig_13_map(data, n_boot=500, rng=0, **_):
    """Fig. 13 as maps: P(u_d > 0.005, 0.01, 0.02) on one colour scale."""
    return _fig_levels_map(data, fr.U_D_LEVELS, 13, "u_d", n_boot, rng)
