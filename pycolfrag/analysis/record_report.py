"""Analysis of a record-suite results file (``scripts/run_grid.py --records``): stripe curves, cloud
analysis, multiple-stripe fragility, Fig. 10, and a short markdown report.

    python -m pycolfrag.analysis.record_report results/records.h5 results/records_analysis [--synthetic results/grid.h5]
    python scripts/record_checks.py analyse results/records.h5 --out results/records_analysis

What it writes into the output folder (docs/records.md, "Analysing a record-suite file"):

* ``stripes.png`` and ``stripes.csv`` -- the stripe method of paper Fig. 3 / Fig. 16 on PGA, PGV,
  SA(T) and SV(T) (:func:`pycolfrag.analysis.fragility.stripe_analysis`, stripes of equal counts), every
  performance level;
* ``cloud.png`` -- ln u_top and ln u_d against ln IM with the cloud regression
  (:func:`pycolfrag.analysis.fragility.cloud_analysis`: OLS with its dispersion, collapse by logistic
  regression on the IM);
* ``msa.png`` -- with several ``--scale`` values, the multiple-stripe fragility by maximum likelihood
  (Baker 2015, :func:`pycolfrag.analysis.fragility.msa_from_table`), one stripe per scale factor;
* ``fig10_records.png`` -- Fig. 10 (:func:`pycolfrag.analysis.record_figures.fig_10`) of the rows at scale 1,
  with the synthetic mean line when a synthetic grid file is given;
* ``report.md`` -- the run, the per-record table, the cloud and MSA fits, links to the figures.

Numbers come from the file through :func:`pycolfrag.analysis.data.load` (the one reader). Figures need
matplotlib (imported when drawing); without it the report is written with its tables only.
An analysis a small suite cannot support (too few standing runs for a cloud, every run or none
exceeding a level for MSA, too few runs per stripe) is reported as ``n/a`` with the reason.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import warnings
from pathlib import Path

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis import record_figures as rf
from pycolfrag.analysis.completeness import ALLOW_INCOMPLETE_HELP, check_complete
from pycolfrag.analysis.data import Results, as_results, read_table
from pycolfrag.analysis.figures import Figure, mark_figure
from pycolfrag.analysis.summary import format_table, summary_table
from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError, PycolfragError

__all__ = ["STRIPE_IMS", "suite_table", "analyse", "write_record_report", "main"]

#: IMs of the stripe, cloud and MSA analyses (spectral ones at ``period_s``).
STRIPE_IMS = ("pga_g", "pgv_cm_s", "sa_g", "sv_cm_s")
#: Runs per stripe below which a stripe is left empty (as in :func:`pycolfrag.analysis.fragility.stripe_curve`).
MIN_PER_STRIPE = 5


def suite_table(path) -> dict:
    """A record-suite results file as a suite table (the ``/samples`` fields, ``sa_g``/``sv_cm_s``
    rows x periods, ``periods_s``, and ``attrs``): finished rows only, failed rows included with
    their ``status`` (the analyses keep ``status == 0``)."""
    return read_table(path, layout="records")


def _period(table, period_s):
    p = np.asarray(table["periods_s"], dtype=float)
    return float(p[int(np.argmin(np.abs(p - float(period_s))))])


def analyse(table, *, period_s=1.0, levels=fr.PERFORMANCE_LEVELS, n_boot=200, rng=0) -> dict:
    """Stripes, clouds and (several scales) MSA fits of a suite table. Returns a dict with
    ``period_s`` (the stored period nearest to the one asked), ``n_ok``, ``stripes``
    ({(im, level label): StripeCurve} or an error string), ``cloud`` ({(im, edp): CloudFit or error
    string}), ``msa`` ({(im, level label): MSAFragility or error string}; empty with one scale) and
    ``scales``. The stripes hold equal counts of runs (a suite's IMs are irregular, and equal-width
    stripes leave most of them nearly empty): the paper's 12 stripes when the suite has at least 60
    successful runs, else ``n_ok // 5`` (at least 1), so every stripe holds :data:`MIN_PER_STRIPE` runs."""
    period = _period(table, period_s)
    ok = np.asarray(table["status"]) == 0
    n_ok = int(ok.sum())
    out = {"period_s": period, "n_ok": n_ok, "stripes": {}, "cloud": {}, "msa": {}, "scales": []}
    n_stripes = max(1, min(12, n_ok // MIN_PER_STRIPE))
    try:
        out["stripes"] = fr.stripe_analysis(table, levels, STRIPE_IMS, period_s=period, n_stripes=n_stripes,
                                            stripes="equal-count", min_count=min(MIN_PER_STRIPE, max(n_ok, 1)), n_boot=n_boot, rng=rng)
    except (ParameterError, ValueError) as exc:
        out["stripes"] = f"n/a ({exc})"
    for im in STRIPE_IMS:
        x, _ = fr.table_im(table, im, period)
        for edp in names.edps_of(table):
            try:
                out["cloud"][(im, edp)] = fr.cloud_analysis(x[ok], np.asarray(table[edp], dtype=float)[ok],
                                                            np.asarray(table["collapsed"])[ok])
            except (ParameterError, ValueError) as exc:
                out["cloud"][(im, edp)] = f"n/a ({exc})"
    scales = np.unique(np.asarray(table["scale"], dtype=float)[ok])
    out["scales"] = [float(f) for f in scales]
    if len(scales) > 1:
        for im in STRIPE_IMS:
            for lev in levels:
                try:
                    out["msa"][(im, lev.label)] = fr.msa_from_table(table, im, lev, stripe_key="scale",
                                                                    period_s=period)
                except (ParameterError, ValueError) as exc:
                    out["msa"][(im, lev.label)] = f"n/a ({exc})"
    return out


def _im_label(im, period):
    return names.label(im, period if names.IMS[im].spectral else None)


# --------------------------------------------------------------------------------- figures

def _fig_stripes(a, levels):
    fig = Figure(figsize=(12, 8))
    for k, im in enumerate(STRIPE_IMS):
        ax = fig.add_subplot(2, 2, k + 1)
        for j, lev in enumerate(levels):
            c = a["stripes"][(im, lev.label)]
            ax.plot(c.im, c.p, "o-", color=f"C{j}", ms=3, label=lev.label)
        ax.set_xlabel(_im_label(im, a["period_s"]))
        ax.set_ylabel("P(EDP > threshold | IM) (-)")
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(f"stripes on {names.IMS[im].short}")
        ax.grid(alpha=0.3)
    fig.axes[0].legend(fontsize=7)
    fig.suptitle("Stripe-method fragility of the record suite (paper Fig. 3 / Fig. 16)")
    fig.tight_layout()
    return fig


def _fig_cloud(table, a):
    ok = np.asarray(table["status"]) == 0
    coll = np.asarray(table["collapsed"]).astype(bool)[ok]
    edps = names.edps_of(table)   # the EDPs these runs have: a row of panels each
    fig = Figure(figsize=(14, 3.25 * len(edps)))
    for row, edp in enumerate(edps):
        e = np.asarray(table[edp], dtype=float)[ok]
        for k, im in enumerate(STRIPE_IMS):
            ax = fig.add_subplot(len(edps), 4, row * 4 + k + 1)
            x = fr.table_im(table, im, a["period_s"])[0][ok]
            with np.errstate(invalid="ignore"):
                st = ~coll & np.isfinite(e) & (e > 0) & (x > 0)
            ax.loglog(x[st], e[st], "o", mfc="none", ms=4, label="standing runs")
            fit = a["cloud"][(im, edp)]
            if not isinstance(fit, str):
                xx = np.geomspace(np.min(x[st]), np.max(x[st]), 50)
                ax.loglog(xx, fit.median_edp(xx), "k-", label=f"b = {fit.b:.2f}, beta = {fit.beta:.2f}")
                ax.legend(fontsize=7)
            ax.set_xlabel(_im_label(im, a["period_s"]))
            ax.set_ylabel(names.EDPS[edp].label if k == 0 else f"{edp} ({names.EDPS[edp].unit})")
            ax.set_title(f"cloud: {edp} on {names.IMS[im].short}", fontsize=9)
            ax.grid(alpha=0.3, which="both")
    fig.suptitle("Cloud analysis (ln EDP = a + b ln IM; collapsed runs left out of the regression)")
    fig.tight_layout()
    return fig


def _fig_msa(a, levels):
    fig = Figure(figsize=(12, 8))
    for k, im in enumerate(STRIPE_IMS):
        ax = fig.add_subplot(2, 2, k + 1)
        for j, lev in enumerate(levels):
            f = a["msa"].get((im, lev.label))
            if f is None or isinstance(f, str):
                continue
            ax.plot(f.im_levels, f.n_exceed_stripe / f.n_trials, "o", color=f"C{j}")
            xx = np.geomspace(f.im_levels.min() / 2, f.im_levels.max() * 2, 100)
            ax.plot(xx, f(xx), "-", color=f"C{j}", label=f"{lev.label}: median {f.median:.3g}, beta {f.beta:.2f}")
        ax.set_xscale("log")
        ax.set_xlabel(_im_label(im, a["period_s"]))
        ax.set_ylabel("P(EDP > threshold | IM) (-)")
        ax.set_title(f"multiple stripes on {names.IMS[im].short} (one stripe per scale)")
        ax.grid(alpha=0.3)
        if ax.get_lines():
            ax.legend(fontsize=7)
    fig.suptitle("Multiple-stripe fragility by maximum likelihood (Baker 2015)")
    fig.tight_layout()
    return fig


def _write_stripes_csv(path, a, levels):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["im", "period_s", "level", "stripe_im", "n", "n_collapsed", "p_eq4", "p_empirical", "low", "high",
                    "degenerate"])
        for im in STRIPE_IMS:
            for lev in levels:
                c = a["stripes"][(im, lev.label)]
                for i in range(len(c.im)):
                    w.writerow([im, a["period_s"] if names.IMS[im].spectral else "", lev.label, f"{c.im[i]:.6g}",
                                int(c.n[i]), int(c.n_collapsed[i]), f"{c.p[i]:.4g}", f"{c.p_empirical[i]:.4g}",
                                f"{c.low[i]:.4g}", f"{c.high[i]:.4g}", int(bool(c.degenerate[i]))])


# --------------------------------------------------------------------------------- report

def _fmt(v, d=3):
    return "n/a" if v is None or not np.isfinite(v) else f"{v:.{d}g}"


def _run_lines(path, t, a, note) -> list:
    """The report's title and its run section (suite, counts, completeness, failed runs)."""
    attrs = t["attrs"]
    status = np.asarray(t["status"])
    L = [f"# Record-suite report: `{path}`" if not isinstance(path, Results) else "# Record-suite report", ""]
    if note:
        L += [f"**{note}.**", ""]
    L.append(f"- suite: `{attrs.get('records', '?')}` ({attrs.get('n_records', '?')} records), components "
             f"{attrs.get('components', '?')}, scales {', '.join(f'{f:g}' for f in a['scales']) or 'n/a'}")
    L.append(f"- finished runs: {len(status)} of {int(np.size(t['record']))}; successful: {a['n_ok']}; failed "
             f"(excluded): {int((status != 0).sum())}; collapsed: {int(np.asarray(t['collapsed'])[status == 0].sum())}")
    L.append(f"- complete: {bool(attrs.get('complete', False))}; version `{attrs.get('version', '?')}`, git "
             f"`{attrs.get('git_revision', '?')}`")
    L.append(f"- spectral IMs at T = {a['period_s']:g} s; stripe, cloud and MSA fits: pycolfrag.analysis.fragility (scipy)")
    failed = np.flatnonzero(status != 0)
    if failed.size:
        L += ["", "Failed runs:", ""]
        for i in failed[:20]:
            L.append(f"- {t['record_id'][i]} {t['component'][i]} x{t['scale'][i]:g}: status {status[i]}, "
                     f"{t['message'][i]}")
    return L


def _fit_lines(a) -> list:
    """The cloud and multiple-stripe tables, degenerate MSA fits marked with their reasons."""
    L = ["", "## Cloud analysis", "",
         "ln EDP = a + b ln IM + beta eps over the standing runs (EDP > 0); collapse: logistic regression "
         "on ln IM when both collapses and survivors occur.", "",
         "| IM | EDP | n | a | b (± se) | beta | R² | collapsed | P(C) logistic c0, c1 |", "|---|---|---|---|---|---|---|---|---|"]
    for (im, edp), f in a["cloud"].items():
        lab = _im_label(im, a["period_s"])
        if isinstance(f, str):
            L.append(f"| {lab} | {edp} | | {f} | | | | | |")
            continue
        lc = f"{f.collapse.c0:.3g}, {f.collapse.c1:.3g}" if f.collapse is not None else f"constant {f.p_collapse:.3g}"
        L.append(f"| {lab} | {edp} | {f.n} | {_fmt(f.a)} | {_fmt(f.b)} (± {_fmt(f.se_b, 2)}) | {_fmt(f.beta)} | "
                 f"{_fmt(f.r2, 2)} | {f.n_collapsed} | {lc} |")
    if a["msa"]:
        L += ["", "## Multiple-stripe fragility (Baker 2015)", "",
              "One stripe per scale factor (its IM level: the geometric mean IM of its runs); lognormal median "
              "and dispersion by maximum likelihood.", "",
              "| IM | level | median | beta | runs | exceeding |", "|---|---|---|---|---|---|"]
        for (im, lab), f in a["msa"].items():
            if isinstance(f, str):
                L.append(f"| {_im_label(im, a['period_s'])} | {lab} | {f} | | | |")
            else:
                mark = f" (degenerate: {f.degenerate})" if f.degenerate else ""
                L.append(f"| {_im_label(im, a['period_s'])} | {lab} | {_fmt(f.median)}{mark} | {_fmt(f.beta)} | "
                         f"{int(f.n_trials.sum())} | {int(f.n_exceed_stripe.sum())} |")
    elif len(a["scales"]) <= 1:
        L += ["", "Multiple-stripe fragility: needs runs at several `--scale` factors."]
    return L


def _draw(t, a, levels, out, synthetic, band_km, dist_km, note) -> tuple[list, str]:
    """Draw the figures into ``out``; (file names, what Fig. 10 was drawn against, or None when it was not
    drawn: no runs at scale 1)."""
    figs = []
    if not isinstance(a["stripes"], str):
        figs.append(("stripes.png", _fig_stripes(a, levels)))
    figs.append(("cloud.png", _fig_cloud(t, a)))
    if a["msa"] and any(not isinstance(f, str) for f in a["msa"].values()):
        figs.append(("msa.png", _fig_msa(a, levels)))
    syn = synthetic if synthetic is not None and Path(synthetic).exists() else None
    kw = {}
    if band_km is not None:
        kw["band_km"] = tuple(band_km)
    if dist_km is not None:
        kw["dist_km"] = float(dist_km)
    # Fig. 10 is about the records as recorded: the rows at scale 1 only
    unscaled = np.asarray(t["scale"], dtype=float) == 1.0
    fig10_note = None
    if unscaled.any():
        t1 = {k: (np.asarray(v)[unscaled] if k not in ("periods_s", "attrs") and np.ndim(v) >= 1
                  and len(v) == len(unscaled) else v) for k, v in t.items()}
        try:
            fig10 = rf.fig_10(t1, syn, **kw)
            fig10_note = f"against `{syn}`" if syn else "without a synthetic grid file (no mean line)"
        except ParameterError as exc:
            fig10 = rf.fig_10(t1, None, **{k: v for k, v in kw.items() if k == "band_km"})
            fig10_note = f"without the synthetic line ({exc})"
        figs.append(("fig10_records.png", fig10))
    for name, fig in figs:
        if note:
            mark_figure(fig, note)
        fig.savefig(out / name, dpi=110)
    return [name for name, _ in figs], fig10_note


def write_record_report(path, out_dir, *, report_path=None, synthetic=None, period_s=1.0,
                        band_km=None, dist_km=None, n_boot=200, rng=0, figures=True, allow_incomplete=False) -> str:
    """Analyse a record-suite file into ``out_dir`` (figures, ``stripes.csv``) and write the markdown
    report (default ``out_dir/report.md``); returns the report's path.

    ``synthetic``: a synthetic grid results file for the Fig. 10 line (skipped when None or missing).
    ``band_km``/``dist_km``: Fig. 10's Rrup band and synthetic distance (defaults of
    :mod:`pycolfrag.analysis.record_figures`). ``figures=False``: tables only (no matplotlib needed).
    ``allow_incomplete``: analyse a file whose run has not finished (refused otherwise,
    :mod:`pycolfrag.analysis.completeness`); the report and every figure are then marked."""
    levels = fr.PERFORMANCE_LEVELS
    res = as_results(path)   # read once for the suite table and the run counts
    t = suite_table(res)
    note = check_complete(t, allow_incomplete, "a record-suite report", path=None if isinstance(path, Results) else path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    report = Path(report_path) if report_path else out / "report.md"
    report.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():   # the tables below mark degenerate fits with their reasons
        warnings.simplefilter("ignore", fr.DegenerateFitWarning)
        a = analyse(t, period_s=period_s, levels=levels, n_boot=n_boot, rng=rng)
    L = _run_lines(path, t, a, note)
    L += ["", "## Runs per record", "", "```", format_table(summary_table(res, by="record")), "```"]
    if len(a["scales"]) > 1:
        L += ["", "```", format_table(summary_table(res, by="scale")), "```"]
    L += _fit_lines(a)
    if isinstance(a["stripes"], str):
        L += ["", f"Stripes: {a['stripes']}"]
    else:
        _write_stripes_csv(out / "stripes.csv", a, levels)
        L += ["", "## Stripes", "", f"Stripe curves on PGA, PGV, SA and SV: `stripes.csv` "
              f"({max(1, min(12, a['n_ok'] // MIN_PER_STRIPE))} stripes of equal counts of runs, each "
              f"point at the stripe's median IM; Eq. (4) inside each stripe)."]
    if figures:
        try:
            import matplotlib  # noqa: F401 -- a probe: the plotting stack is optional, the tables are not
        except ImportError:
            L += ["", "Figures: matplotlib is not installed; tables only."]
            figures = False
    if figures:
        drawn, fig10_note = _draw(t, a, levels, out, synthetic, band_km, dist_km, note)
        if fig10_note is None:
            L += ["", "Fig. 10: no runs at scale 1 (it shows the records as recorded)."]
        L += ["", "## Figures", ""]
        for name in drawn:
            rel = Path(_relpath(out / name, report.parent))
            extra = f" ({fig10_note})" if name.startswith("fig10") else ""
            L.append(f"![{name}]({rel.as_posix()}){extra}")
            L.append("")
    report.write_text("\n".join(L) + "\n", encoding="utf-8")
    return str(report)


def _relpath(p: Path, start: Path) -> str:
    return os.path.relpath(p, start)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="pycolfrag record-report",
                                description="Analyse a record-suite results file (pycolfrag grid --records): stripes, "
                                            "cloud, MSA (several scales), Fig. 10, report.md")
    p.add_argument("results", help="record-suite HDF5 file")
    p.add_argument("out", help="output folder (figures, stripes.csv, report.md)")
    p.add_argument("--synthetic", default=None, help="synthetic grid file for the Fig. 10 line")
    p.add_argument("--period", type=float, default=1.0, help="period of SA and SV, s (nearest stored)")
    p.add_argument("--band", nargs=2, type=float, default=None, metavar=("LO", "HI"), help="Fig. 10 Rrup band, km")
    p.add_argument("--dist", type=float, default=None, help="Fig. 10 synthetic distance, km")
    p.add_argument("--no-figures", action="store_true", help="tables only")
    p.add_argument("--allow-incomplete", action="store_true", help=ALLOW_INCOMPLETE_HELP)
    args = p.parse_args(argv)
    try:
        rep = write_record_report(args.results, args.out, synthetic=args.synthetic, period_s=args.period,
                                  band_km=args.band, dist_km=args.dist, figures=not args.no_figures,
                                  allow_incomplete=args.allow_incomplete)
    except (PycolfragError, OSError) as exc:
        print(f"record_report: {exc}", file=sys.stderr)
        return 2
    print(f"record report -> {rep}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
