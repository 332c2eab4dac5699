"""What an event-based site simulation (``pycolfrag risk SITE.toml --simulate OUTDIR``) hands to people:
its rates with their CoV and intervals, the diagnostics of its weights, the efficiency against crude
Monte Carlo, and -- when the grid's results are given -- the grid-convolution route beside it.

Like with like: the grid's runs must be runs of the simulated model -- the same column or scene, solver options,
records, pulse model and meaning of the seeds (:mod:`.rare_like`; a two-drum simulation beside a Parthenon
grid is refused, naming the column) --, and the grid route integrates the fragility surface over the grid's
range only (with the site file's ``outside = "zero"``), so the event-based estimate is restricted to the strata
inside the grid's range (whole strata: the grid's Mw and R limits are bin edges) for the comparison, and the two
*agree* when their log-rates differ by at most sqrt(h1^2 + h2^2), h the half-widths of the two intervals
on the log scale. The whole-site estimate is set beside the grid route's bracket: ``zero`` (nothing
outside the grid) to ``clamp`` (the grid's edge for what lies beyond).

The command line (:func:`build_parser`) and the run are :func:`pycolfrag.risk.site_risk.main`'s
(``--simulate``); the simulation itself is :mod:`pycolfrag.rare`.
"""
from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pycolfrag.analysis.completeness import MARK, IncompleteResultsError
from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError, ParameterError
from pycolfrag.rare.driver import failures
from pycolfrag.rare.estimate import FEW_RUNS, UNRESOLVED, efficiency, estimate
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk import simulate as _rare_command
from pycolfrag.risk.rare_like import check_like_with_like
from pycolfrag.risk.report import _write_text, check_outdir
from pycolfrag.site.sources import OUTSIDE_CHOICES

__all__ = ["build_parser", "GridComparison", "grid_route", "check_grid_range", "compare_with_grid", "report", "to_json",
           "write_outputs", "larger_estimate", "print_summary", "PRINTED_YEARS"]

#: Horizon of the probabilities printed and tabled, years.
PRINTED_YEARS = 50.0


def build_parser(prog: str = "pycolfrag risk") -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog=prog, description="Annual rates and T-year probabilities of the column's damage levels at a site by "
                               "event-based simulation (--simulate OUTDIR; docs/rare_events.md), beside the grid "
                               "route when its results are given.")
    ap.add_argument("site", help="site file (TOML)")
    ap.add_argument("results", nargs="?", default=None,
                    help="results of the grid with pulses, for the grid route beside the simulation (optional)")
    ap.add_argument("--no-pulse", metavar="H5", help="results of the same grid made with --pulse none")
    ap.add_argument("--pulse-only", action="store_true",
                    help="every motion carries a pulse (p_pulse = 1); overstates the risk, said in every output")
    ap.add_argument("--pulse-model", metavar="TABLE", help="pulse-occurrence model of every source (TOML inline table)")
    ap.add_argument("--outside", choices=OUTSIDE_CHOICES, help="override the site file's choice")
    ap.add_argument("--years", type=float, nargs="*", default=[], help="more horizons (50, 100, 475 always)")
    ap.add_argument("--draws", type=int, default=2000, help="draws per grid cell for the grid route's intervals")
    ap.add_argument("--no-figures", action="store_true")
    _rare_command.add_arguments(ap)
    return ap


@dataclass
class GridComparison:
    """The grid route beside the simulation: its rates with ``zero`` and ``clamp``, the simulation's part
    inside the grid's range, and whether they agree."""

    files: dict
    mws: list
    ds: list
    zero: dict                  # label -> (lambda, low, high)
    clamp: dict
    in_grid: object             # Estimate of the strata inside the grid's range
    agree: dict = field(default_factory=dict)   # label -> True / False / None (no verdict)

    def as_dict(self) -> dict:
        return {"files": self.files, "grid": {"mw": self.mws, "dist_km": self.ds},
                "grid_route_zero": {k: list(v) for k, v in self.zero.items()},
                "grid_route_clamp": {k: list(v) for k, v in self.clamp.items()},
                "event_based_in_grid": {k: v.as_dict() for k, v in self.in_grid.levels.items()},
                "agree": self.agree}


def _half_width(low: float, high: float) -> float:
    return 0.5 * (math.log(high) - math.log(low)) if low > 0 and math.isfinite(high) else math.inf


def _agree(e, g) -> bool | None:
    """|ln a - ln b| <= sqrt(h_a^2 + h_b^2); None when either has no interval (a refused level, a zero rate) or
    failed runs leave the simulation's unresolved."""
    lam, lo, hi = g
    if e.status in ("refused", UNRESOLVED) or not (e.rate > 0 and lam > 0 and lo > 0):
        return None
    return abs(math.log(e.rate) - math.log(lam)) <= math.hypot(_half_width(e.low, e.high), _half_width(lo, hi))


def check_grid_range(strata, mws, ds) -> tuple:
    """The grid's (Mw, R) box; ParameterError when its limits cut a stratum (they must be bin edges, so
    that the simulation's part inside the grid is a sum over whole strata), saying which edges to add."""
    mws, ds = np.asarray(mws, float), np.asarray(ds, float)
    box = ((mws[0], mws[-1]), (ds[0], ds[-1]))
    cut = [st for st in strata.strata if st.straddles(*box)]
    if cut:
        raise ParameterError(
            f"the grid's range Mw {mws[0]:g}-{mws[-1]:g}, R {ds[0]:g}-{ds[-1]:g} km cuts {len(cut)} strata (e.g. Mw "
            f"{cut[0].mw}, R {cut[0].r_km} km): the part of the simulation inside it is not a sum over whole strata. "
            "Run the simulation (another folder) with --r-edges and --mw-step that put the grid's limits on edges")
    return box


def grid_route(args, site, settings, site_risk, record=None) -> dict:
    """The grid route beside the simulation (``{"zero": SiteRisk, "clamp": SiteRisk}``), computed from the
    parsed arguments before any run, so that grid files that cannot serve -- missing, incomplete, of other
    branches, runs of another model than the simulation's ``record`` settings (column, solver options,
    records, pulse model, seeds' meaning: :func:`~.rare_like.check_like_with_like`), or a range that
    cuts the strata of ``site`` and ``settings`` -- are refused before the simulation, not after it
    (ParameterError or the reader's error). ``site_risk``: :func:`pycolfrag.risk.site_risk.site_risk`."""
    if args.results is None:
        if args.no_pulse is not None:
            raise ParameterError("--no-pulse was given without the pulse grid's results: give both "
                                 "(risk SITE PULSE.h5 --no-pulse NOPULSE.h5 --simulate OUTDIR) or neither")
        return {}
    kw = dict(pulse_only=args.pulse_only, pulse_model=args.pulse_model, n_draws=args.draws, curves=False)
    try:
        zero = site_risk(args.site, args.results, args.no_pulse, outside="zero", **kw)
        clamp = site_risk(args.site, args.results, args.no_pulse, outside="clamp", **kw)
    except IncompleteResultsError as exc:
        note = getattr(exc, "note", "")
        raise ParameterError(
            f"the grid route beside the simulation refused: {note[len(MARK) + 2:] or exc}. The comparison needs "
            "complete grids: finish that grid (rerun its command to resume), or run --simulate without the grid's "
            "files (the grid route alone takes --allow-incomplete: risk SITE PULSE.h5 OUTDIR --allow-incomplete)"
        ) from None
    if record is not None:
        check_like_with_like(record, zero.files)
    check_grid_range(build_strata(site, settings.mw_step, settings.r_edges_km), zero.mws, zero.ds)
    return {"zero": zero, "clamp": clamp}


def compare_with_grid(run, risk_zero, risk_clamp) -> GridComparison:
    """The comparison of a :class:`~pycolfrag.rare.driver.SiteRun` with the grid route's two site risks
    (:func:`pycolfrag.risk.site_risk.site_risk` with ``outside`` zero and clamp). The grid's Mw and R
    limits must be bin edges of the strata (else ParameterError saying which edges to add), and the grid's runs
    runs of the simulated model (:func:`~.rare_like.check_like_with_like`: column, solver options, records,
    pulse model, seeds' meaning; else ParameterError naming each difference)."""
    if getattr(run, "record", None) is not None:
        check_like_with_like(run.record, risk_zero.files)
    mws, ds = np.asarray(risk_zero.mws, float), np.asarray(risk_zero.ds, float)
    box = check_grid_range(run.strata, mws, ds)
    keep = [st.inside(*box) for st in run.strata.strata]
    s = run.stop
    in_grid = estimate(run.cols, run.strata, run.design, run.quantities, confidence=s.confidence, min_neff=s.min_neff,
                       max_share=s.max_share, target_cov=None, keep=keep, floor=getattr(run, "floor", None),
                       pieces=True)
    zero = {q.label: tuple(risk_zero.rate[q.label]) for q in run.quantities}
    clamp = {q.label: tuple(risk_clamp.rate[q.label]) for q in run.quantities}
    agree = {q.label: _agree(in_grid.levels[q.label], zero[q.label]) for q in run.quantities}
    return GridComparison(dict(risk_zero.files), mws.tolist(), ds.tolist(), zero, clamp, in_grid, agree)


# --------------------------------------------------------------------------- the report

def _e(x):
    return "0" if x == 0 else ("inf" if not math.isfinite(x) else f"{x:.3g}")


def _p(lam: float, years: float = PRINTED_YEARS) -> float:
    return -math.expm1(-lam * years) if math.isfinite(lam) else 1.0


def _rate_cell(e) -> str:
    if e.status == "refused":
        return f"<= {_e(e.bound)} (refused)"
    return f"{_e(e.rate)} [{_e(e.low)}, {_e(e.high)}]"


def _failed_cell(e) -> str:
    """The rate with every failed run counted as no exceedance and as an exceedance (``-`` without failures)."""
    return "-" if not e.failed else f"{e.failed} runs: {_e(e.failed_low)} - {_e(e.failed_high)}"


def _levels_table(run) -> list:
    est, pct = run.estimate, f"{100 * run.stop.confidence:g} %"
    L = [f"| level | lambda (1/yr) [{pct}] | CoV | P in {PRINTED_YEARS:g} yr [{pct}] | n_eff | largest run | failed "
         f"runs: lambda as none - as exceeding | status | crude runs for this CoV | efficiency | rate on strata of < "
         f"{FEW_RUNS} runs | variance from strata without exceedance |",
         "|---|---|---:|---|---:|---:|---|---|---:|---:|---:|---:|"]
    for q in run.quantities:
        e = est.levels[q.label]
        eff = efficiency(e, run.strata.total_rate, run.runs)
        refused = e.status == "refused"
        p = "-" if refused else f"{_p(e.rate):.3g} [{_p(e.low):.3g}, {_p(e.high):.3g}]"
        cov, crude, gain = ("-", "-", "-") if refused else (f"{e.cov:.3f}", f"{eff['crude_runs']:.3g}",
                                                             f"{eff['efficiency']:.3g}")
        mark = "" if q in run.requested else " (not requested)"
        status = e.status.upper() if e.status == UNRESOLVED else e.status
        L.append(f"| {q.label} | {_rate_cell(e)} | {cov} | {p} | {e.n_eff:.1f} | {100 * min(e.max_share, 1):.1f} % | "
                 f"{_failed_cell(e)} | {status}{mark} | {crude} | {gain} | {100 * e.few_runs_rate_share:.1f} % | "
                 f"{100 * e.floor_variance_share:.1f} % ({e.floored_strata} strata) |")
    return L


def _failures(run) -> list:
    """The failed runs by stratum and their most common message (nothing when every run succeeded)."""
    failed, done, text = failures(run.cols)
    if not failed:
        return []
    by = run.estimate.failed_by_stratum
    L = ["", f"**{failed} of {done} runs failed** (most common message: {text}). A failed run is not a non-exceedance: "
             "its outcome is unknown. Each level's rate rests on the successful runs of each stratum, and is bounded "
             "by counting every failed run as no exceedance and as an exceedance, weighted as the estimator weights "
             "a run; a level whose two bounds differ by more than its CoV x rate is UNRESOLVED (not converged: the "
             "failed runs, not the number of runs, limit it; docs/rare_events.md).", "",
         "| stratum | source | Mw | R (km) | pulse | runs | failed |", "|---:|---|---|---|---|---:|---:|"]
    for st in run.strata.strata:
        k = int(by[st.index]) if st.index < by.size else 0
        if k:
            n = k + int(run.estimate.n_by_stratum[st.index])
            L.append(f"| {st.index} | {st.source_name} | {st.mw[0]:g}-{st.mw[1]:g} | {st.r_km[0]:g}-{st.r_km[1]:g} | "
                     f"{'yes' if st.pulse else 'no'} | {n} | {k} |")
    return L


def _at_target(run) -> str:
    """One sentence: crude Monte Carlo's events for every requested level at the target CoV, against the runs used."""
    t = run.stop.target_cov
    need = []
    for q in run.requested:
        e = run.estimate.levels[q.label]
        p = e.rate / run.strata.total_rate
        need.append(((1 - p) / (p * t * t) if p > 0 else math.inf, q.label))
    n, label = max(need)
    if not math.isfinite(n):
        return ""
    return (f" Every requested level at CoV {t:g}: crude Monte Carlo needs {n:.3g} events ({label}), this simulation "
            f"used {run.runs} runs ({n / run.runs:.3g} times fewer).")


def _header(run) -> list:
    s, st, d = run.site, run.settings, run.design
    runs_by = ", ".join(f"{b['name']} {b['runs']}" + (f" of {b['planned']}" if b["runs"] < b["planned"] else "")
                        for b in run.batches)
    why = {"target": "every requested level reached the target",
           "failures": "every requested level converged or, its CoV at the target, is left unresolved by failed "
                       "runs (more runs would not resolve it)"}.get(run.stopped,
                                                                     f"the run budget ({run.stop.max_runs}) was spent")
    L = [f"- site file: `{s.path}`; {len(run.strata)} strata (source x Mw bin x R bin x pulse) over "
         f"{len(s.sources)} source(s), total event rate {run.strata.total_rate:.4g} /yr",
         f"- runs: {run.runs} ({runs_by}); failed runs: {run.estimate.n_failed}; stopped because {why}",
         f"- stopping rule: CoV <= {run.stop.target_cov:g}, n_eff >= {run.stop.min_neff:g}, no run above "
         f"{100 * run.stop.max_share:.0f} % of a level's rate; levels served: "
         + ", ".join(q.label for q in run.requested),
         f"- seed {st.seed}; pilot {st.pilot_for(len(run.strata))} runs per stratum; batches of {st.batch}; defensive share "
         f"alpha_0 = {st.defensive:g} (weights of the pulse quantiles <= {1 / st.defensive:.3g})",
         f"- pilot proposal: {d.pilot.as_dict()}; production proposal: "
         f"{None if d.production is None else d.production.as_dict()}"]
    L += [f"- cross-entropy step: {n}" for n in d.notes]
    L += [f"- pulse model of {src.name}: {src.pulse.describe()}" for src in s.sources]
    for o in run.strata.outside:
        if o.outside > 0:
            L.append(f"- where the models do not apply, left out (outside = 'zero'): {o.text()}")
    ess = run.estimate.ess_relative
    L.append(f"- strata of fewer than {FEW_RUNS} runs: {run.estimate.few_runs_strata} of {len(run.strata)}, "
             f"{100 * run.estimate.few_runs_event_share:.1f} % of the event rate (each level's share of its rate on them, "
             "and the share of its variance from the floor of strata none of whose runs exceed it, are in the table)")
    L.append(f"- weights: Kong's relative effective sample size of a stratum's weights >= "
             f"{float(np.nanmin(ess)):.3f}; largest pulse factor / its bound: "
             + (f"{max(run.estimate.max_ratio.values()):.3f}" if run.estimate.max_ratio else "-"))
    return L


def _comparison_table(cmp: GridComparison, run) -> list:
    pct = f"{100 * run.stop.confidence:g} %"
    L = ["", f"Beside the grid route (grid Mw {cmp.mws[0]:g}-{cmp.mws[-1]:g}, R {cmp.ds[0]:g}-{cmp.ds[-1]:g} km; "
             f"`{'`, `'.join(cmp.files.values())}`). Like with like: the simulation's strata inside the grid's "
             "range against the grid route with nothing outside the grid (`zero`); they agree when their "
             "log-rates differ by at most the root sum of squares of the intervals' log half-widths. The whole "
             "site's estimate against the grid route's bracket `zero`-`clamp`:", "",
             f"| level | event-based, grid's range [{pct}] | grid route, zero [{pct}] | agree | event-based, whole "
             f"site [{pct}] | grid route, zero - clamp |", "|---|---|---|---|---|---|"]
    for q in run.quantities:
        e, z, c = cmp.in_grid.levels[q.label], cmp.zero[q.label], cmp.clamp[q.label]
        a = cmp.agree[q.label]
        L.append(f"| {q.label} | {_rate_cell(e)} | {_e(z[0])} [{_e(z[1])}, {_e(z[2])}] | "
                 f"{'-' if a is None else 'yes' if a else 'NO'} | {_rate_cell(run.estimate.levels[q.label])} | "
                 f"{_e(z[0])} - {_e(c[0])} |")
    return L


def _deaggregation(run) -> list:
    rates = run.estimate.contributions
    groups = {}
    for st in run.strata.strata:
        for key in (f"source: {st.source_name}", f"pulse: {'yes' if st.pulse else 'no'}",
                    f"R {st.r_km[0]:g}-{st.r_km[1]:g} km", f"Mw {st.mw[0]:g}-{st.mw[1]:g}"):
            groups.setdefault(key, []).append(st.index)
    L = ["", "Deaggregation (share of each level's rate, %):", "",
         "| part of the site | " + " | ".join(q.label for q in run.quantities) + " |",
         "|---|" + "---:|" * len(run.quantities)]
    for key, hs in groups.items():
        cells = []
        for q in run.quantities:
            tot = float(np.sum(rates[q.label]))
            cells.append("-" if tot <= 0 else f"{100 * float(np.sum(rates[q.label][hs])) / tot:.1f}")
        L.append(f"| {key} | " + " | ".join(cells) + " |")
    return L


def _history(run) -> list:
    L = ["", "After each batch (rate /yr, CoV):", "", "| batch | runs | " + " | ".join(q.label for q in run.requested)
         + " |", "|---:|---:|" + "---|" * len(run.requested)]
    for h in run.history:
        L.append(f"| {h['stage']} | {h['runs']} | " + " | ".join(
            f"{_e(h['levels'][q.label][0])}, {h['levels'][q.label][1]:.3f}" for q in run.requested) + " |")
    return L


def report(run, cmp: GridComparison | None = None, figures: dict | None = None) -> str:
    """The simulation as a Markdown document."""
    L = [f"# pycolfrag site risk by event-based simulation: {run.site.name}", ""]
    if run.site.description:
        L += [run.site.description, ""]
    L += _header(run) + [""] + _levels_table(run)
    L += ["", "Refused: a level whose estimate rests on fewer effective exceedances than the floor, or on one run "
              "carrying more than the largest share allowed; only an upper bound is stated (failed runs counted as "
              "exceeding). Unresolved: failed runs could move the level by more than its CoV. Crude runs for this "
              "CoV: N = (1 - p) / (p CoV^2), p = lambda / (the site's event rate); efficiency = that over the runs "
              "used. A stratum none of whose runs exceeds a level adds to its variance a floor, not 0: the variance the "
              "steering and demand models predict there, at most the Jeffreys pseudo-count's (half an exceedance in "
              "n + 1 runs; docs/rare_events.md)." + _at_target(run)]
    if cmp is not None:
        L += _comparison_table(cmp, run)
    L += _failures(run) + _deaggregation(run) + _history(run)
    for caption, rel in (figures or {}).items():
        L += ["", f"![{caption}]({rel})"]
    return "\n".join(L) + "\n"


def to_json(run, cmp: GridComparison | None = None) -> dict:
    levels = {}
    for q in run.quantities:
        e = run.estimate.levels[q.label]
        levels[q.label] = {**e.as_dict(), **efficiency(e, run.strata.total_rate, run.runs),
                           f"probability_{PRINTED_YEARS:g}_years": [_p(e.rate), _p(e.low), _p(e.high)],
                           "requested": q in run.requested}
    return {"site": run.site.name, "site_file": run.site.path, "method": "event-based simulation",
            "runs": run.runs, "failed_runs": run.estimate.n_failed,
            "failed_runs_by_stratum": run.estimate.failed_by_stratum.tolist(),
            "failure_most_common": failures(run.cols)[2] or None, "stopped": run.stopped,
            "settings": run.settings.as_dict(), "stop_rule": dict(run.stop.__dict__), "design": run.design.as_dict(),
            "batches": run.batches, "history": run.history, "levels": levels, "strata": run.strata.as_dict(),
            "runs_by_stratum": run.estimate.n_by_stratum.tolist(), "pilot_per_stratum": run.settings.pilot_for(len(run.strata)),
            "few_runs": {"below": FEW_RUNS, "strata": run.estimate.few_runs_strata,
                         "event_rate_share": run.estimate.few_runs_event_share},
            "kong_ess_relative": [None if not np.isfinite(x) else float(x) for x in run.estimate.ess_relative],
            "contributions": {k: v.tolist() for k, v in run.estimate.contributions.items()},
            "grid_route": None if cmp is None else cmp.as_dict()}


def write_outputs(run, outdir, cmp: GridComparison | None = None, *, figures: bool = True) -> dict:
    """``risk.md``, ``risk.json`` and (with matplotlib) the figures in ``outdir``; returns the paths."""
    from pycolfrag.risk import rare_figures as risk_rare_figures  # here: the figures load matplotlib
    outdir = check_outdir(outdir)
    try:
        paths, figs = {}, {}
        if figures:
            for stem, path in risk_rare_figures.make_all(run, cmp, outdir).items():
                figs[risk_rare_figures.CAPTIONS[stem]] = Path(path).name
                paths[stem] = str(path)
        md, js = outdir / "risk.md", outdir / "risk.json"
        _write_text(md, report(run, cmp, figs))
        _write_text(js, report_json.dumps(to_json(run, cmp), indent=1, default=float))
    except OSError as exc:
        raise OutputError(f"cannot write the risk outputs into {outdir}: {exc.strerror or exc}") from None
    paths.update(markdown=str(md), json=str(js))
    return paths


def larger_estimate(run, outdir) -> int | None:
    """The runs of the estimate in ``outdir``'s risk.json when it rests on more runs than ``run`` (a smaller
    ``--max-runs`` on a finished folder: ``run`` is then a prefix of the folder's runs), else None (no
    risk.json, an unreadable one, or as many runs or fewer)."""
    try:
        runs = json.loads((Path(outdir) / "risk.json").read_text(encoding="utf-8"))["runs"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return int(runs) if isinstance(runs, int) and runs > run.runs else None


def print_summary(run, cmp: GridComparison | None = None) -> None:
    """One line per level: rate, interval, CoV, the failed runs' bounds and status; the grid route's verdict
    beside it."""
    failed, done, _ = failures(run.cols)
    if failed:
        print(f"{failed} of {done} runs FAILED (by stratum in risk.md); each level's rate with them counted as none - "
              "as exceeding:")
    for q in run.quantities:
        e = run.estimate.levels[q.label]
        status = e.status.upper() if e.status == UNRESOLVED else e.status
        text = (f"{q.label:>14}: {_rate_cell(e)} /yr" + ("" if e.status == "refused" else
                f", CoV {e.cov:.3f}, P{PRINTED_YEARS:g} {_p(e.rate):.3g}") + f", n_eff {e.n_eff:.1f}, largest run "
                f"{100 * min(e.max_share, 1):.1f} %" + (f", failed runs {_e(e.failed_low)} - {_e(e.failed_high)}"
                                                          if e.failed else "") + f" ({status})")
        if cmp is not None and cmp.agree[q.label] is not None:
            text += f"; grid route (its range) {'agrees' if cmp.agree[q.label] else 'DISAGREES'}"
        print(text)
