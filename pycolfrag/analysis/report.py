"""Markdown report of a results file: run metadata, per-scenario tables, IM fragility fits, figures.

``write_report(results_path, out_path)`` is called by the grid driver at the end of a run
(``results/report.md`` next to ``results/grid.h5`` by default) and by
``python -m pycolfrag.analysis.report RESULTS.h5 [OUT.md]``.

Confidence intervals: Eq. (4) exceedances and mean EDPs carry percentile-bootstrap intervals
(resampling within the scenario, :mod:`pycolfrag.analysis.fragility`); the collapse probability, a binomial
proportion, carries the exact Clopper-Pearson interval (``scipy.stats.binomtest``), which stays
informative when no run collapsed (the bootstrap interval of 0 of n is [0, 0]).

EDPs of collapsed runs (``u_d`` is NaN for them) are not used: means and log-moments are over the
non-collapsed runs, and Eq. (4) counts a collapse as exceeding every level.

Fits that are not estimates (:func:`pycolfrag.analysis.fragility.eq4_degenerate`, ``LognormalFragility.degenerate``:
too few runs, a parameter on the optimiser's bound, a bootstrap that cannot vary) are marked in the
tables and their reasons listed under them; their numbers are still printed, as the formula gives them.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from pathlib import Path

import numpy as np

from .. import names, progress
from ..errors import PycolfragError
from . import fragility as fr
from .completeness import ALLOW_INCOMPLETE_HELP, check_complete
from .data import read_results
from .figures import FIGURES, im_curves
from .fragility import binomial_ci
from .risk import report_section

__all__ = ["write_report", "binomial_ci", "fmt_ci"]

CONFIDENCE = 0.90


def fmt_ci(v, ci=None, digits=2) -> str:
    """``0.40 [0.31, 0.49]``; ``n/a`` for NaN."""
    if v is None or not np.isfinite(v):
        return "n/a"
    s = f"{v:.{digits}f}"
    if ci is not None and np.all(np.isfinite(ci)):
        s += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    return s


def _g(x, digits=3):
    return "n/a" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


#: Marks a value whose fit is not an estimate; the reasons are listed under the table.
DEGENERATE_MARK = " (degenerate)"


def _degenerate_notes(items) -> list:
    """Lines listing why the marked fits of a table are not estimates (none when all are)."""
    bad = [(where, why) for where, why in items if why]
    if not bad:
        return []
    return ["", "Degenerate fits (the numbers are what the formulas give, not estimates):", ""] + [
        f"- {where}: {why}" for where, why in bad]


def _meta_lines(d):
    a = d.attrs
    out = [f"- results file: `{d.path}`",
           f"- finished runs: {d.n_total}; successful: {d.n}; failed (excluded from all statistics): {d.n_failed}"
           + (f" (by status code: {', '.join(f'{k}: {v}' for k, v in sorted(d.failures.items()))})"
              if d.failures else "")]
    for key in ("version", "git_revision", "seed", "n_ranks", "created", "vp_scale", "pulse", "tp_model", "contact"):
        if key in a and str(a[key]) != "":
            out.append(f"- {key}: `{a[key]}`")
    for key in ("column", "solver"):
        if key in a:
            try:
                txt = json.dumps(json.loads(a[key]), sort_keys=True)
            except (TypeError, ValueError):
                txt = str(a[key])
            out.append(f"- {key}: `{txt[:400]}{'...' if len(txt) > 400 else ''}`")
    return out


def write_report(results_path, out_path=None, *, figures_dir=None, n_boot=1000, rng=0, risk=None,
                 allow_incomplete=False) -> str:
    """Write a Markdown report of a results file; return its path.

    Parameters
    ----------
    results_path : str or path-like
        HDF5 results of ``scripts/run_grid.py``.
    out_path : str or path-like, optional
        Markdown file (default: ``report.md`` next to the results file).
    figures_dir : str or path-like, optional
        Where :func:`pycolfrag.analysis.figures.make_all` wrote the PNGs (default: ``figures/`` next to the
        report); PNGs found there are embedded with relative links.
    n_boot : int
        Bootstrap resamples per interval.
    rng : int
        Seed of the bootstrap (reports are reproducible).
    risk : pycolfrag.analysis.risk.SiteRisk, optional
        A site risk computed from this results file (:func:`pycolfrag.analysis.risk.site_risk`): its section
        is added before the figures.
    allow_incomplete : bool
        Report on a file whose run has not finished (refused otherwise, :mod:`pycolfrag.analysis.completeness`);
        the report then says so in its first lines.
    """
    d = read_results(results_path)
    note = check_complete(d, allow_incomplete, "a report")
    out_path = Path(out_path) if out_path else Path(os.fspath(results_path)).with_name("report.md")
    figures_dir = Path(figures_dir) if figures_dir else out_path.parent / "figures"
    g = np.random.default_rng(rng)
    # the report marks degenerate fits itself (below), so their warnings would only repeat it
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fr.DegenerateFitWarning)
        with progress.task("report", _n_fits(d), unit="fit"):
            return _write(d, out_path, figures_dir, n_boot, g, risk, note)


def _n_fits(d) -> int:
    """Steps of the report's bar: each scenario's fits, then each IM's fits of every level (:func:`_write`)."""
    n_ims = 4 if d.sa_g is not None and d.periods_s is not None and d.periods_s.size else 2
    return len(set(zip(np.asarray(d["mw"]).tolist(), np.asarray(d["dist_km"]).tolist()))) + n_ims * len(
        fr.PERFORMANCE_LEVELS)


def _write(d, out_path, figures_dir, n_boot, g, risk, note="") -> str:
    edps = names.edps_of(d.samples)   # every declared EDP the file's runs have (older files lack newer ones)
    rows = fr.scenario_table(d["mw"], d["dist_km"], {e: d[e] for e in edps}, d["collapsed"],
                             n_boot=n_boot, confidence=CONFIDENCE, rng=g)
    L = ["# pycolfrag results report", ""] + ([f"**{note}.**", ""] if note else []) + [
         "Fragility of the column by the method of Psycharis, Fragiadakis & Stefanou: Eq. (3) collapse "
         "probability, Eq. (4) exceedance (lognormal fit of the non-collapsed runs combined with collapse) "
         "and the empirical ratio. Intervals are two-sided 90 %: Clopper-Pearson for P(collapse), "
         "percentile bootstrap within the scenario for everything else.", "", "## Run", ""]
    L += _meta_lines(d)
    L += ["", "## Collapse and EDP statistics per scenario", "",
          "Means and log-moments use the non-collapsed runs (a collapsed run has no u_d: NaN in the results "
          "file); mu and beta are the mean and dispersion of ln EDP "
          "(maximum likelihood, `scipy.stats.lognorm.fit` with loc = 0).", "",
          "| Mw | R (km) | n | collapsed | P(collapse) [90 % CI] | "
          + " | ".join(f"mean {e} | mu ln {e} | beta ln {e}" for e in edps) + " |",
          "|---:|---:|---:|---:|---|" + "---:|" * (3 * len(edps))]
    for r in rows:
        mark = {e: DEGENERATE_MARK if r.degenerate.get(e) else "" for e in edps}
        L.append(f"| {r.mw:g} | {r.dist_km:g} | {r.n} | {r.n_collapsed} | "
                 f"{fmt_ci(r.p_collapse, binomial_ci(r.n_collapsed, r.n))} | "
                 + " | ".join(f"{_g(r.mean[e])} | {_g(r.mu_ln[e])}{mark[e]} | {_g(r.beta_ln[e])}{mark[e]}"
                              for e in edps) + " |")
    L += _degenerate_notes([(f"Mw {r.mw:g}, R {r.dist_km:g} km, {e}", r.degenerate.get(e, ""))
                            for r in rows for e in edps])
    for title, levels in (("Table III levels (u_top)", fr.U_TOP_LEVELS), ("Table IV levels (u_d)", fr.U_D_LEVELS)):
        L += ["", f"## Exceedance probabilities per scenario: {title}", "",
              "Each cell: Eq. (4) [90 % bootstrap CI] (empirical ratio).", "",
              "| Mw | R (km) | n | " + " | ".join(f"{lv.label} ({lv.name})" for lv in levels) + " |",
              "|---:|---:|---:|" + "---|" * len(levels)]
        for r in rows:
            cells = [f"{fmt_ci(r.exceedance[lv.label], r.ci[lv.label])}"
                     f"{DEGENERATE_MARK if r.degenerate.get(lv.edp) else ''} ({r.empirical[lv.label]:.2f})"
                     for lv in levels]
            L.append(f"| {r.mw:g} | {r.dist_km:g} | {r.n} | " + " | ".join(cells) + " |")
    L += ["", "## Fragility against intensity measures", "",
          "Lognormal fragility P = Phi(ln(IM / median) / beta) fitted by maximum likelihood to the exceedance "
          "indicators (collapsed or EDP >= level) of all runs; 90 % intervals from a bootstrap stratified by "
          "scenario. The stripe-method curves (12 equal-width stripes, Eq. (4) inside each) are in Fig. 16.", "",
          "| IM | level | n exceeding | median [90 % CI] | beta [90 % CI] |", "|---|---|---:|---|---|"]
    notes = []
    ims = [(names.label("pga_g"), d["pga_g"]), (names.label("pgv_cm_s"), d["pgv_cm_s"])]
    if d.sa_g is not None and d.periods_s is not None and d.periods_s.size:
        k = int(np.argmin(np.abs(d.periods_s - 1.0)))
        ims.append((names.label("sa_g", d.periods_s[k]), d.sa_g[:, k]))
        ims.append((names.label("sv_cm_s", d.periods_s[k]), d.sv_cm_s[:, k]))
    for name, values in ims:
        if not np.all(np.isfinite(values)) or np.any(values <= 0):
            L.append(f"| {name} | all | - | IM not positive/finite in every run: not fitted | |")
            continue
        for lev, _sc, mle in im_curves(d, values, n_boot=max(n_boot // 5, 20), n_boot_mle=max(n_boot // 5, 20),
                                       rng=g):
            if mle is None:
                L.append(f"| {name} | {lev.label} | - | no interior maximum (all or none exceed) | |")
            else:
                flag = " (beyond the largest IM: extrapolated)" if mle.median > np.max(values) else ""
                mark = DEGENERATE_MARK if mle.degenerate else ""
                L.append(f"| {name} | {lev.label} | {mle.n_exceed}/{mle.n} | {fmt_ci(mle.median, mle.median_ci, 3)}"
                         f"{flag}{mark} | {fmt_ci(mle.beta, mle.beta_ci)}{mark} |")
                notes.append((f"{name}, {lev.label}", mle.degenerate))
    L += _degenerate_notes(notes)
    if risk is not None:
        L += ["", report_section(risk)]
    L += ["", "## Figures", ""]
    found = False
    for stem in FIGURES:
        png = figures_dir / f"{stem}.png"
        if png.exists():
            found = True
            rel = os.path.relpath(png, out_path.parent)
            L += [f"![{stem}]({rel})", ""]
    if not found:
        L.append(f"No figures found in `{figures_dir}`; run `python scripts/make_figures.py {d.path} "
                 f"--out {figures_dir}`.")
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text("\n".join(L) + "\n", encoding="utf-8")
    return str(out_path)


def main(argv=None) -> int:
    """Command-line entry point; exit code 0, or 2 with one line naming the bad input."""
    p = argparse.ArgumentParser(prog="pycolfrag report",
                                description="Markdown report of a synthetic grid's results file (docs/fragility.md)")
    p.add_argument("results", help="results file (pycolfrag grid)")
    p.add_argument("out", nargs="?", default=None, help="report to write (default: report.md beside the results)")
    p.add_argument("--allow-incomplete", action="store_true", help=ALLOW_INCOMPLETE_HELP)
    args = p.parse_args(argv)
    try:
        print(write_report(args.results, args.out, allow_incomplete=args.allow_incomplete))
    except (PycolfragError, OSError) as exc:
        print(f"report: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
