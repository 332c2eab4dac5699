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
import os
import sys
import warnings
from pathlib import Path

import numpy as np

from pycolfrag.analysis import fragility as fr
from pycolfrag.analysis import report_text as rt
from pycolfrag.analysis.codes import code_lines
from pycolfrag.analysis.completeness import ALLOW_INCOMPLETE_HELP, check_complete
from pycolfrag.analysis.data import read_results
from pycolfrag.analysis.figures import FIGURES, im_curves
from pycolfrag.analysis.fit_check import departure_note, stripe_departures
from pycolfrag.analysis.fragility import binomial_ci
from pycolfrag.core import names, progress
from pycolfrag.core.errors import PycolfragError

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
    return rt.sig(x, digits)


#: Marks a value whose fit is not an estimate; the reasons are listed under the table.
DEGENERATE_MARK = " (degenerate)"
#: Marks an IM fit that misses stripes beyond their binomial interval (:mod:`pycolfrag.analysis.fit_check`).
MISS_MARK = " \u2021"


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
    several = code_lines(a, d.n_total)        # a file resumed with other code: version etc. are the first's
    for key in ("version", "git_revision", "seed", "n_ranks", "created", "vp_scale", "pulse", "tp_model", "vp_model",
                "contact"):
        if key in a and str(a[key]) != "":
            first = " (the first code's)" if several and key in ("version", "git_revision") else ""
            out.append(f"- {key}: `{a[key]}`{first}")
    out += several
    if "solver" in a:
        out += rt.solver_lines(a["solver"])
    if "column" in a:
        out += ["", "### The column", ""] + rt.model_lines(a["column"])
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
    risk : pycolfrag.risk.site_risk.SiteRisk, optional
        A site risk computed from this results file (:func:`pycolfrag.risk.site_risk.site_risk`): its section
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
         "percentile bootstrap within the scenario for everything else.", ""] + rt.DEFINITIONS + ["", "## Run", ""]
    L += _meta_lines(d)
    L += _statistics_table(rows, edps)
    L += _exceedance_tables(rows)
    L += _im_table(d, n_boot, g)
    if risk is not None:
        L += ["", risk.section()]   # the site risk writes its own section (pycolfrag.risk sits above this layer)
    L += _figures_section(d, out_path, figures_dir)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text("\n".join(L) + "\n", encoding="utf-8")
    return str(out_path)


def _statistics_table(rows, edps) -> list:
    L = ["", "## Collapse and EDP statistics per scenario", "",
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
    return L + _degenerate_notes([(f"Mw {r.mw:g}, R {r.dist_km:g} km, {e}", r.degenerate.get(e, ""))
                                  for r in rows for e in edps])


def _outside(r, label) -> bool:
    """The cell's Eq. (4) interval and the exact 90 % binomial interval of its empirical ratio are
    disjoint: the model departs from the runs beyond the runs' sampling error (0 of 20 observed against
    Eq. (4) = 0.001 [0.0002, 0.003] is not marked; 0.01 against 0.08 [0.06, 0.10] of 100 runs is)."""
    ci, emp = r.ci[label], r.empirical[label]
    if ci is None or not np.all(np.isfinite(ci)) or not np.isfinite(emp) or r.n <= 0:
        return False
    lo, hi = binomial_ci(int(round(emp * r.n)), int(r.n), CONFIDENCE)
    return bool(hi < ci[0] or lo > ci[1])


def _exceedance_tables(rows) -> list:
    L = []
    for title, levels in (("Table III levels (u_top)", fr.U_TOP_LEVELS), ("Table IV levels (u_d)", fr.U_D_LEVELS)):
        L += ["", f"## Exceedance probabilities per scenario: {title}", "",
              "Each cell: Eq. (4) [90 % bootstrap CI] (empirical ratio).", "",
              "| Mw | R (km) | n | " + " | ".join(f"{lv.label} ({lv.name})" for lv in levels) + " |",
              "|---:|---:|---:|" + "---|" * len(levels)]
        marked = False
        for r in rows:
            cells = []
            for lv in levels:
                out = _outside(r, lv.label)
                marked |= out
                cells.append(f"{fmt_ci(r.exceedance[lv.label], r.ci[lv.label])}"
                             f"{DEGENERATE_MARK if r.degenerate.get(lv.edp) else ''} ({r.empirical[lv.label]:.2f})"
                             f"{rt.OUTSIDE_MARK if out else ''}")
            L.append(f"| {r.mw:g} | {r.dist_km:g} | {r.n} | " + " | ".join(cells) + " |")
        if marked:
            L += ["", rt.OUTSIDE_NOTE]
    return L


def _im_table(d, n_boot, g) -> list:
    L = ["", "## Fragility against intensity measures", "",
         "Lognormal fragility P = Phi(ln(IM / median) / beta) fitted by maximum likelihood to the exceedance "
         "indicators (collapsed or EDP >= level) of all runs; 90 % intervals from a bootstrap stratified by "
         "scenario; medians to 3 significant digits, in the IM's unit. The stripe-method curves (12 "
         "equal-width stripes, Eq. (4) inside each) are in Fig. 16; the fit check compares the fitted curve "
         "with each stripe's empirical share and its 90 % binomial interval.", "",
         "| IM | level | n exceeding | median [90 % CI] | beta [90 % CI] | fit check |", "|---|---|---:|---|---|---|"]
    notes, misses = [], []
    ims = [(names.label("pga_g"), d["pga_g"]), (names.label("pgv_cm_s"), d["pgv_cm_s"])]
    if d.sa_g is not None and d.periods_s is not None and d.periods_s.size:
        k = int(np.argmin(np.abs(d.periods_s - 1.0)))
        ims.append((names.label("sa_g", d.periods_s[k]), d.sa_g[:, k]))
        ims.append((names.label("sv_cm_s", d.periods_s[k]), d.sv_cm_s[:, k]))
    for name, values in ims:
        if not np.all(np.isfinite(values)) or np.any(values <= 0):
            L.append(f"| {name} | all | - | IM not positive/finite in every run: not fitted | | |")
            continue
        unit = name[name.rfind("(") + 1:-1] if name.endswith(")") else ""
        for lev, sc, mle in im_curves(d, values, n_boot=max(n_boot // 5, 20), n_boot_mle=max(n_boot // 5, 20),
                                      rng=g):
            if mle is None:
                L.append(f"| {name} | {lev.label} | - | no interior maximum (all or none exceed) | | |")
                continue
            flag = " (beyond the largest IM: extrapolated)" if mle.median > np.max(values) else ""
            mark = DEGENERATE_MARK if mle.degenerate else ""
            miss = departure_note(sc, stripe_departures(sc, mle, CONFIDENCE), unit)
            if miss:
                misses.append(f"{name}, {lev.label}: the fitted curve {miss}")
            L.append(f"| {name} | {lev.label} | {mle.n_exceed}/{mle.n} | {rt.sig_ci(mle.median, mle.median_ci)}"
                     f"{flag}{mark} | {fmt_ci(mle.beta, mle.beta_ci)}{mark} | "
                     f"{'**' + miss + '**' + MISS_MARK if miss else 'ok'} |")
            notes.append((f"{name}, {lev.label}", mle.degenerate))
    if misses:
        L += ["", MISS_MARK.strip() + " A lognormal curve in this IM does not describe these runs where it misses stripes (their "
              "empirical share's 90 % binomial interval excludes the curve; ringed in Fig. 16): read the "
              "stripes there, not the curve.", ""] + [f"- {m}" for m in misses]
    return L + _degenerate_notes(notes)


def _figures_section(d, out_path, figures_dir) -> list:
    L = ["", "## Figures", ""]
    found = False
    for stem in FIGURES:
        png = figures_dir / f"{stem}.png"
        if png.exists():
            found = True
            rel = os.path.relpath(png, out_path.parent)
            L += [f"![{stem}]({rel})", "", f"*{rt.CAPTIONS.get(stem, stem)}*", ""]
    if not found:
        L.append(f"No figures found in `{figures_dir}`; run `pycolfrag figures {d.path} "
                 f"--out {figures_dir}`.")
    return L


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
