"""The paper's figures from a results file (Figs. 7, 8, 9, 11, 12, 13, 14, 15, 16), PNG and PDF.

Every figure is built with the object-oriented matplotlib API (``matplotlib.figure.Figure``, no
pyplot state, no display needed) by a ``fig_XX(data)`` function that returns the Figure, so tests
can inspect axes, labels and titles; :func:`make_all` writes all of them.

Only successful runs (``status == 0``) enter the statistics; the number of failed runs is printed
in each figure's title when non-zero.  Units: PGA, SA and Ap in g, PGV and Vp in cm/s, distances
in km, periods in s; the EDPs u_top and u_d are dimensionless.

Collapsed runs enter the collapse statistics only: every EDP plot, mean and fit uses the
non-collapsed runs (or counts a collapse as exceeding every level), so the EDPs stored for collapsed
rows are never read -- ``u_d`` of a collapsed run is NaN (no residual state), and so may be ``u_top``.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis.completeness import check_complete
from pycolfrag.analysis.contour_figures import fig_08_map, fig_12_map, fig_13_map
from pycolfrag.analysis.data import ResultsData, as_data, read_results
from pycolfrag.analysis.fit_check import stripe_departures
from pycolfrag.core import names as _names
from pycolfrag.core import progress
from pycolfrag.core.errors import ParameterError

__all__ = ["FIGURES", "make_all", "mark_figure", "ROCKING_INITIATION_G"]

#: Minimum base acceleration initiating rocking of the column as a rigid block (paper Fig. 11c), g.
ROCKING_INITIATION_G = 0.17

#: Axis labels, from the one registry (:mod:`pycolfrag.core.names`).
EDP_LABELS = {k: q.label for k, q in _names.EDPS.items()}
IM_LABELS = {k: q.label for k, q in _names.IMS.items()}



def Figure(*args, **kwargs):
    """A ``matplotlib.figure.Figure``; matplotlib is imported here, on the first figure, so that
    reading results (:mod:`pycolfrag.analysis.data`) and the modules built on it (:mod:`~pycolfrag.analysis.report`,
    :mod:`~pycolfrag.analysis.validation`) work without matplotlib installed."""
    from matplotlib.figure import Figure as _Figure  # here: the optional plotting stack, only to draw
    return _Figure(*args, **kwargs)


# --------------------------------------------------------------------------- helpers

def _surface_axes(fig, pos, surf: fr.Surface, zlabel, title, zlim=None):
    """One 3-D surface over (Mw, R) with its bootstrap interval as grey wireframes."""
    ax = fig.add_subplot(*pos, projection="3d")
    R, M = np.meshgrid(surf.dist_km, surf.mw)
    # a probability (zlim given) is coloured on 0..1 in every panel, as the maps' one colour bar
    # (pycolfrag.analysis.contour_figures); a mean EDP on its own range
    colour = {"vmin": zlim[0], "vmax": zlim[1]} if zlim is not None else {}
    if surf.mw.size > 1 and surf.dist_km.size > 1:
        ax.plot_surface(M, R, surf.value, cmap="viridis", alpha=0.85, linewidth=0.3, edgecolor="k", **colour)
        for lim in (surf.low, surf.high):
            ax.plot_wireframe(M, R, lim, color="0.5", linewidth=0.4, alpha=0.6)
    else:   # a degenerate grid (one Mw or one R): points with interval bars
        ax.scatter(M.ravel(), R.ravel(), surf.value.ravel(), color="C0")
        for m, r, lo, hi in zip(M.ravel(), R.ravel(), surf.low.ravel(), surf.high.ravel()):
            ax.plot([m, m], [r, r], [lo, hi], color="0.5")
    ax.set_xlabel("Mw (-)")
    ax.set_ylabel("R (km)")
    ax.set_zlabel(zlabel)
    if zlim is not None:
        ax.set_zlim(*zlim)
    ax.set_title(title, fontsize=9)
    ax.view_init(elev=25, azim=-130)
    return ax


def _level_surface(d: ResultsData, lev: fr.PerformanceLevel, n_boot, rng):
    return fr.exceedance_surface(d["mw"], d["dist_km"], d[lev.edp], d["collapsed"], lev.threshold,
                                 n_boot=n_boot, rng=rng, label=lev.label)


# --------------------------------------------------------------------------- the figures

def fig_07(data, **_) -> Figure:
    """Fig. 7: u_d versus u_top for the runs that did not collapse."""
    d = as_data(data)
    ok = ~d["collapsed"]
    fig = Figure(figsize=(6, 5))
    ax = fig.add_subplot(1, 1, 1)
    x, y = d["u_top"][ok], d["u_d"][ok]
    pos = (x > 0) & (y > 0)
    ax.scatter(x[pos], y[pos], s=8, alpha=0.5)
    for lev in fr.U_TOP_LEVELS:
        ax.axvline(lev.threshold, color="0.6", ls=":", lw=0.8)
    for lev in fr.U_D_LEVELS:
        ax.axhline(lev.threshold, color="0.6", ls=":", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(EDP_LABELS["u_top"])
    ax.set_ylabel(EDP_LABELS["u_d"])
    ax.set_title(f"Fig. 7: u_d vs u_top, non-collapsed runs (n = {int(ok.sum())}{d.failed_note()})")
    ax.text(0.02, 0.98, "dotted: performance levels (Tables III, IV)", transform=ax.transAxes,
            va="top", fontsize=8)
    return fig


def fig_08(data, n_boot=500, rng=0, **_) -> Figure:
    """Fig. 8: mean u_top, mean u_d (non-collapsed) and collapse probability over (Mw, R)."""
    d = as_data(data)
    g = np.random.default_rng(rng)
    fig = Figure(figsize=(15, 5))
    s1 = fr.mean_edp_surface(d["mw"], d["dist_km"], d["u_top"], d["collapsed"], n_boot=n_boot, rng=g)
    s2 = fr.mean_edp_surface(d["mw"], d["dist_km"], d["u_d"], d["collapsed"], n_boot=n_boot, rng=g)
    s3 = fr.collapse_surface(d["mw"], d["dist_km"], d["collapsed"], n_boot=n_boot, rng=g)
    _surface_axes(fig, (1, 3, 1), s1, "mean u_top (-)", "(a) mean u_top, non-collapsed")
    _surface_axes(fig, (1, 3, 2), s2, "mean u_d (-)", "(b) mean u_d, non-collapsed")
    _surface_axes(fig, (1, 3, 3), s3, "P(collapse) (-)", "(c) collapse probability, Eq. (3)", (0, 1))
    fig.suptitle(f"Fig. 8: mean EDPs and collapse probability (grey: 90 % bootstrap interval; "
                 f"n = {d.n}{d.failed_note()})")
    return fig


def _pulse_ap_g(d: ResultsData):
    """Peak pulse acceleration Ap in g: the file's ``ap_g``; else pi fp A / g as an approximation."""
    if "ap_g" in d.samples and np.any(np.isfinite(d["ap_g"])):
        return d["ap_g"], "Ap = peak pulse acceleration (g)"
    amp = d["a_cm_s"] if "a_cm_s" in d.samples else d["vp_cm_s"]
    return np.pi * d["fp_hz"] * amp / (_names.CM_PER_M * _names.G), "Ap ~ pi fp A (g, approximation)"


def _has_pulses(d) -> bool:
    """False for a grid without pulses (``run_grid.py --pulse none``: the pulse fields are all NaN)."""
    return bool(np.any(np.isfinite(d["fp_hz"])))


def fig_09(data, **_) -> Figure | None:
    """Fig. 9: mean sampled Vp and mean pulse acceleration amplitude Ap per (Mw, R); None without pulses."""
    d = as_data(data)
    if not _has_pulses(d):
        return None
    ap, ap_label = _pulse_ap_g(d)
    fig = Figure(figsize=(11, 4.5))
    axes = [fig.add_subplot(1, 2, k) for k in (1, 2)]
    mws = np.unique(d["mw"])
    for r in np.unique(d["dist_km"]):
        sel_r = d["dist_km"] == r
        vp = [np.mean(d["vp_cm_s"][sel_r & (d["mw"] == m)]) for m in mws]
        a = [np.nanmean(ap[sel_r & (d["mw"] == m)]) for m in mws]
        axes[0].plot(mws, vp, "o-", label=f"R = {r:g} km")
        axes[1].plot(mws, a, "o-", label=f"R = {r:g} km")
    axes[0].set_ylabel("mean Vp (cm/s)")
    axes[1].set_ylabel("mean " + ap_label)
    for ax, t in zip(axes, ("(a) pulse velocity amplitude Vp", "(b) pulse acceleration amplitude Ap")):
        ax.set_xlabel("Mw (-)")
        ax.set_title(t)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Fig. 9: mean sampled pulse parameters per scenario (Eqs. (6), (7))")
    return fig


def fig_11(data, **_) -> Figure | None:
    """Fig. 11: u_top vs Tp; safe/unsafe on the PGA-fp and Ap-fp planes (Mw >= 6.5); None without pulses."""
    d = as_data(data)
    if not _has_pulses(d):
        return None
    ap, ap_label = _pulse_ap_g(d)
    c = d["collapsed"]
    fig = Figure(figsize=(15, 4.8))
    ax = fig.add_subplot(1, 3, 1)
    tp = 1.0 / d["fp_hz"]
    ax.scatter(tp[~c], d["u_top"][~c], s=8, alpha=0.5, label="non-collapsed")
    if np.any(~c):
        edges = np.linspace(np.nanmin(tp[~c]), np.nanmax(tp[~c]), 16)
        idx = np.clip(np.searchsorted(edges, tp[~c]) - 1, 0, edges.size - 2)
        env = [np.max(d["u_top"][~c][idx == k]) if np.any(idx == k) else np.nan for k in range(edges.size - 1)]
        ax.plot(0.5 * (edges[1:] + edges[:-1]), env, "k--", label="envelope (max per Tp bin)")
    ax.set_xlabel("Tp = 1/fp (s)")
    ax.set_ylabel(EDP_LABELS["u_top"])
    ax.set_title("(a) u_top vs pulse period")
    ax.legend(fontsize=7)
    big = d["mw"] >= 6.5
    for k, (y, ylab, title) in enumerate(((d["pga_g"], IM_LABELS["pga_g"], "(b) PGA vs fp, Mw >= 6.5"),
                                          (ap, ap_label, "(c) Ap vs fp, Mw >= 6.5")), start=2):
        ax = fig.add_subplot(1, 3, k)
        ax.scatter(d["fp_hz"][big & ~c], y[big & ~c], s=12, facecolors="none", edgecolors="C0",
                   label="non-collapsed")
        ax.scatter(d["fp_hz"][big & c], y[big & c], s=14, marker="x", color="C3", label="collapsed")
        if k == 3:
            ax.axhline(ROCKING_INITIATION_G, color="k", ls="--",
                       label=f"rocking initiation {ROCKING_INITIATION_G} g")
        ax.set_xlabel("fp (Hz)")
        ax.set_ylabel(ylab)
        ax.set_title(title)
        ax.legend(fontsize=7)
    fig.suptitle(f"Fig. 11: pulse period and collapse (n = {d.n}{d.failed_note()})")
    return fig


def _degenerate_scenarios(d: ResultsData, edp: str) -> str:
    """" (Eq. (4) degenerate in k of n scenarios: <first reason>)", or "" when no scenario's is
    (:func:`pycolfrag.analysis.fragility.degenerate_scenarios`)."""
    bad = fr.degenerate_scenarios(d["mw"], d["dist_km"], d[edp], d["collapsed"])
    n = len({(m, r) for m, r in zip(d["mw"], d["dist_km"])})
    return f"\n(Eq. (4) degenerate in {len(bad)} of {n} scenarios: {bad[0][2]})" if bad else ""


def _fig_levels(data, levels, number, edp, n_boot, rng):
    d = as_data(data)
    g = np.random.default_rng(rng)
    fig = Figure(figsize=(15, 5))
    mark = _degenerate_scenarios(d, edp)
    for k, lev in enumerate(levels, start=1):
        s = _level_surface(d, lev, n_boot, g)
        _surface_axes(fig, (1, 3, k), s, f"P({lev.label}) (-)",
                      f"({'abc'[k - 1]}) {lev.label}: {lev.name}{mark}", (0, 1))
    fig.suptitle(f"Fig. {number}: fragility surfaces of {edp}, Eq. (4) per scenario "
                 f"(grey: 90 % bootstrap interval; n = {d.n}{d.failed_note()})")
    return fig


def fig_12(data, n_boot=500, rng=0, **_) -> Figure:
    """Fig. 12: fragility surfaces for u_top > 0.15, 0.35, 1.0 (Table III)."""
    return _fig_levels(data, fr.U_TOP_LEVELS, 12, "u_top", n_boot, rng)


def fig_13(data, n_boot=500, rng=0, **_) -> Figure:
    """Fig. 13: fragility surfaces for u_d > 0.005, 0.01, 0.02 (Table IV)."""
    return _fig_levels(data, fr.U_D_LEVELS, 13, "u_d", n_boot, rng)


def _fig_im_vs_edp(data, im, number):
    d = as_data(data)
    c = d["collapsed"]
    fig = Figure(figsize=(11, 4.8))
    for k, (edp, levels) in enumerate((("u_top", fr.U_TOP_LEVELS), ("u_d", fr.U_D_LEVELS)), start=1):
        ax = fig.add_subplot(1, 2, k)
        x = d[edp][~c]
        pos = x > 0
        ax.scatter(x[pos], d[im][~c][pos], s=8, alpha=0.5, label="non-collapsed")
        for lev in levels:
            ax.axvline(lev.threshold, color="0.6", ls=":", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel(EDP_LABELS[edp])
        ax.set_ylabel(IM_LABELS[im])
        ax.set_title(f"({'ab'[k - 1]}) {IM_LABELS[im].split()[0]} vs {edp} ({int(c.sum())} collapsed runs not shown)")
    fig.suptitle(f"Fig. {number}: {IM_LABELS[im]} versus the EDPs (n = {d.n}{d.failed_note()})")
    return fig


def fig_14(data, **_) -> Figure:
    """Fig. 14: PGA versus u_top and u_d."""
    return _fig_im_vs_edp(data, "pga_g", 14)


def fig_15(data, **_) -> Figure:
    """Fig. 15: PGV versus u_top and u_d."""
    return _fig_im_vs_edp(data, "pgv_cm_s", 15)


def im_curves(d: ResultsData, im_values, levels=fr.PERFORMANCE_LEVELS, *, n_stripes=12, n_boot=200,
              n_boot_mle=100, rng=0):
    """Stripe curves (Eq. (4) per stripe) and MLE lognormal curves of every level against one IM.

    Returns a list of ``(level, StripeCurve, LognormalFragility or None)``; the MLE is None when every
    sample (or none) exceeds the level.  Bootstrap: within each stripe for the stripe curve, within
    each (Mw, R) scenario for the MLE band.
    """
    g = np.random.default_rng(rng)
    groups = d.scenario_index()
    out = []
    for lev in levels:
        sc = fr.stripe_curve(im_values, d[lev.edp], d["collapsed"], lev.threshold, n_stripes=n_stripes,
                             n_boot=n_boot, rng=g)
        try:
            mle = fr.fit_lognormal_fragility(im_values, d[lev.edp], d["collapsed"], lev.threshold,
                                             groups=groups, n_boot=n_boot_mle, rng=g)
        except ParameterError:
            mle = None
        out.append((lev, sc, mle))
        progress.advance(unit="fit")   # one step of a command's bar (pycolfrag.core.progress)
    return out


def _fig_curves(d, ims, number, title, n_boot, rng):
    fig = Figure(figsize=(11, 9))
    for i, (im_name, im_values, im_label) in enumerate(ims):
        curves = im_curves(d, im_values, n_boot=n_boot, n_boot_mle=max(n_boot // 2, 20), rng=rng)
        for j, edp in enumerate(("u_top", "u_d")):
            ax = fig.add_subplot(len(ims), 2, 2 * i + j + 1)
            for k, (lev, sc, mle) in enumerate(c for c in curves if c[0].edp == edp):
                col = f"C{k}"
                good = np.isfinite(sc.p)
                n_bad = int(np.sum(sc.degenerate[good]))
                # a percentile interval need not contain the point estimate: no bar below zero length
                ax.errorbar(sc.im[good], sc.p[good],
                            yerr=np.maximum([sc.p[good] - sc.low[good], sc.high[good] - sc.p[good]], 0.0),
                            fmt="o", color=col, ms=4, capsize=2,
                            label=f"P({edp} \u2265 {lev.threshold:g} | {im_name}): stripes, Eq. (4)"
                            + (f" ({n_bad} degenerate)" if n_bad else ""))
                if mle is not None:
                    x = np.linspace(0, np.nanmax(im_values), 200)[1:]
                    ax.plot(x, mle(x), "-", color=col, lw=1,
                            label=f"MLE: median {mle.median:.3g}, beta {mle.beta:.2f}"
                                  + (" (degenerate fit)" if mle.degenerate else ""))
                    if mle.band_im is not None:
                        ax.fill_between(mle.band_im, mle.band_low, mle.band_high, color=col, alpha=0.15)
                    _mark_departures(ax, sc, mle, col, lev.label)
            ax.set_ylim(-0.02, 1.02)
            ax.set_xlabel(im_label)
            ax.set_ylabel(f"P({edp} \u2265 level | {im_name}) (-)")
            ax.set_title(f"({'abcd'[2 * i + j]}) {im_name}, {edp}", fontsize=9)
            ax.legend(fontsize=6)
            ax.grid(alpha=0.3)
    fig.suptitle(title + f" (12 equal-width stripes, 90 % bootstrap bars and bands; n = {d.n}{d.failed_note()})",
                 fontsize=10)
    return fig


def _mark_departures(ax, sc, mle, col, label) -> None:
    """Ring, in the level's colour, the empirical share of the stripes whose 90 % binomial interval
    excludes the fitted curve (:func:`pycolfrag.analysis.fit_check.stripe_departures`); the legend says
    how many."""
    bad = stripe_departures(sc, mle)
    if bad.size:
        used = int(np.sum((np.asarray(sc.n) > 0) & np.isfinite(sc.p_empirical)))
        ax.plot(sc.im[bad], sc.p_empirical[bad], "o", ms=10, mfc="none", mec=col, mew=1.5,
                label=f"{label}: MLE misses {bad.size} of {used} stripes (rings: their share)")


def fig_16(data, n_boot=200, rng=0, **_) -> Figure:
    """Fig. 16: fragility curves against PGA and PGV (stripe method and MLE lognormal curves)."""
    d = as_data(data)
    return _fig_curves(d, [("PGA", d["pga_g"], IM_LABELS["pga_g"]), ("PGV", d["pgv_cm_s"], IM_LABELS["pgv_cm_s"])],
                       16, "Fig. 16: fragility curves against PGA and PGV", n_boot, rng)


def fig_16_spectral(data, period_s=1.0, n_boot=200, rng=0, **_) -> Figure | None:
    """Fig. 16 with SA(T) and SV(T) at the stored period nearest ``period_s`` (None without spectra)."""
    d = as_data(data)
    if d.sa_g is None or d.periods_s is None or d.sv_cm_s is None or d.periods_s.size == 0:
        return None
    k = int(np.argmin(np.abs(d.periods_s - period_s)))
    t = d.periods_s[k]
    return _fig_curves(d, [(f"SA({t:g} s)", d.sa_g[:, k], _names.label("sa_g", t)),
                           (f"SV({t:g} s)", d.sv_cm_s[:, k], _names.label("sv_cm_s", t))],
                       16, f"Fig. 16 (spectral): fragility curves against SA and SV at T = {t:g} s", n_boot, rng)


#: file stem -> builder
FIGURES = {
    "fig07_ud_vs_utop": fig_07,
    "fig08_mean_edp_collapse": fig_08,
    "fig08m_mean_edp_collapse_map": fig_08_map,
    "fig09_pulse_amplitudes": fig_09,
    "fig11_pulse_period_collapse": fig_11,
    "fig12_fragility_utop": fig_12,
    "fig12m_fragility_utop_map": fig_12_map,
    "fig13_fragility_ud": fig_13,
    "fig13m_fragility_ud_map": fig_13_map,
    "fig14_pga_vs_edp": fig_14,
    "fig15_pgv_vs_edp": fig_15,
    "fig16_im_fragility": fig_16,
    "fig16s_spectral_fragility": fig_16_spectral,
}


def mark_figure(fig, note: str) -> None:
    """Print ``note`` (e.g. :func:`pycolfrag.analysis.completeness.incomplete_note`) across the foot of ``fig``."""
    fig.text(0.5, 0.003, note, ha="center", va="bottom", fontsize=7, color="C3", wrap=True)


def make_all(results_path, out_dir, *, n_boot=500, rng=0, formats=("png", "pdf"), dpi=120,
             allow_incomplete=False) -> list[str]:
    """Write every figure as PNG and PDF into ``out_dir``; return the written paths.

    Parameters
    ----------
    results_path : str or path-like
        HDF5 results file of ``scripts/run_grid.py``.
    out_dir : str or path-like
        Output directory (created).
    n_boot : int
        Bootstrap resamples for the surfaces (the curve figures use ``n_boot // 2``).
    rng : int
        Seed of the bootstrap (figures are reproducible).
    allow_incomplete : bool
        Draw from a file whose run has not finished (refused otherwise,
        :mod:`pycolfrag.analysis.completeness`); every figure then says so at its foot.
    """
    d = read_results(results_path)
    note = check_complete(d, allow_incomplete, "the figures")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, builder in progress.steps(FIGURES.items(), "figures", unit="figure"):
        kw = {"n_boot": n_boot // 2 if stem.startswith("fig16") else n_boot, "rng": rng}
        with warnings.catch_warnings():   # the curve legends say "degenerate fit" themselves
            warnings.simplefilter("ignore", fr.DegenerateFitWarning)
            fig = builder(d, **kw)
        if fig is None:
            continue
        if fig.get_layout_engine() is None and not any(a.name == "3d" for a in fig.axes):
            fig.tight_layout()
        if note:
            mark_figure(fig, note)
        for ext in formats:
            p = out / f"{stem}.{ext}"
            fig.savefig(p, dpi=dpi)
            written.append(str(p))
    return written
