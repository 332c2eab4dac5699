"""The outputs of a logic tree on the rare-event route (docs/logic_tree.md): ``OUTDIR/logic_tree.md`` and
``logic_tree.json`` (per level the weighted mean and OpenQuake's quantiles of the rate and of P in T years, the
estimation sd of the mean, the failed runs' bounds; the variance split and tornado of collapse; the per-branch
table with each estimate's CoV, status and failed runs; the run groups), each run group's own ``risk.md`` and
``risk.json`` in its folder (:mod:`pycolfrag.risk.rare_route`), and the command's summary. The tables of the
grid route's tree report are reused (:mod:`pycolfrag.risk.tree_report`)."""
from __future__ import annotations

import math
from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError
from pycolfrag.rare.driver import failures
from pycolfrag.risk import tree_report as _tr
from pycolfrag.risk.tree_figures import write_figures
from pycolfrag.risk.tree_rare import runs_scope
from pycolfrag.risk.tree_stats import QUANTILES
from pycolfrag.risk.tree_summary import summary, summary_lines

__all__ = ["markdown", "to_json", "write_tree_outputs", "print_tree_summary"]

_e = _tr._e


def _head(tr) -> list:
    t = tr.tree
    how = (f"{len(tr.ends)} end branches drawn (samples = {t.samples}, seed {t.seed}; each of weight 1/{t.samples})"
           if t.samples else f"all {len(tr.ends)} end branches (full enumeration)")
    site = tr.runs[0].site
    lines = ["# pycolfrag site risk over a logic tree (rare-event route)", "",
             f"Site: {site.name} ({site.path}); tree: {t.origin or 'given'}" + (f" -- {t.description}" if t.description else ""),
             "", f"Branch sets: {'; '.join(f'{s.name} ({s.choice.name}: ' + ', '.join(f'{b.name} {b.weight:g}' for b in s.branches) + ')' for s in t.branch_sets)}.",
             f"{how}; {runs_scope(t)}.", "",
             f"Common random numbers: the {len(tr.groups)} run setting(s) were simulated on the same events (one seed, "
             "the same strata, pilot and batches: Mw, R, pulse occurrence, the pulse's normals and the record's noise "
             "seed alike; the design's shifts from the first run setting's pilot), so the branches' differences are "
             "paired. A site choice re-weights its run setting's rows by the ratio of event densities (no new runs).", ""]
    if tr.note:
        lines += [f"**Weights changed**: {tr.note}.", ""]
    dead = [g.folder for g, r in zip(tr.groups, tr.runs) if r.stopped == "failures" and failures(r.cols)[0] == r.runs]
    bad = [k for k in range(len(tr.ends)) if tr.failed(k)]
    if bad:
        lines += [f"**FAILED RUNS** under {len(bad)} of {len(tr.ends)} end branches (marked below): a failed run is "
                  "not a non-exceedance; each level states the tree's mean with every failed run counted as none and "
                  "as an exceedance." + (f" Run settings whose every pilot run failed (no estimate): {', '.join(dead)}."
                                        if dead else ""), ""]
    return lines


def _failed_lines(tr) -> list:
    rows = [(lb, tr.stats[lb]["failed_bounds"]) for lb in tr.labels if "failed_bounds" in tr.stats[lb]]
    if not rows:
        return []
    return ["## The failed runs' reach", "", "| level | mean, failed runs as none | as exceeding |", "|---|---|---|"] + [
        f"| {lb} | {_e(b[0])} | {_e(b[1])} |" for lb, b in rows] + [""]


def _branch_table(tr) -> list:
    lines = ["## End branches", "", "| branch | weight | runs | failed | " + " | ".join(f"{lb} (CoV)" for lb in tr.labels)
             + " |", "|---|---|---|---|" + "---|" * len(tr.labels)]
    for k, (end, est) in enumerate(zip(tr.ends, tr.estimates)):
        g = tr.groups[tr.group_of[k]]
        cells = []
        for lb in tr.labels:
            e = est.levels[lb]
            mark = "" if e.status == "converged" else f" {e.status.upper()}"
            cells.append(f"{_e(e.rate)} ({e.cov:.2f}){mark}" if math.isfinite(e.cov) else f"<= {_e(e.bound)}{mark}")
        failed = tr.failed(k)
        lines.append(f"| {end.path} [{g.folder}] | {end.weight:.4g} | {tr.runs[tr.group_of[k]].runs} | "
                     f"{f'**{failed}**' if failed else 0} | " + " | ".join(cells) + " |")
    return lines + ["", "CoV: the estimate's own (docs/rare_events.md); a status other than converged is written after "
                    "it (ABOVE TARGET: the branch's own CoV is above --target-cov, which is the tree's mean's: the runs "
                    "stop when the mean meets it, docs/logic_tree.md \"Where the runs go\"); a refused level gives only "
                    "its upper bound.", ""]


def _groups(tr) -> list:
    lines = ["## Run settings (each its own folder, the same events)", "",
             "| folder | run setting | runs | failed | stopped |", "|---|---|---|---|---|"]
    for g, r in zip(tr.groups, tr.runs):
        failed, _, _ = failures(r.cols)
        lines.append(f"| {g.folder} | {g.name} | {r.runs} | {failed} | {r.stopped} |")
    return lines + [""]


def markdown(tr) -> str:
    head = _head(tr)
    body = (head[:2] + summary_lines(tr) + head[2:] + _level_table(tr) + _tr._prob_table(tr) + _failed_lines(tr) + _tr._split_lines(tr, "collapse")
            + _branch_table(tr) + _groups(tr))
    body += ["Where the runs go: the target CoV is the tree's mean's; each production batch after the first was run by "
             "the run settings whose share of the mean's error asked for it (a run setting with fewer runs sat batches "
             "out; docs/logic_tree.md, \"Where the runs go\")."]
    return "\n".join(body) + "\n"


def _level_table(tr) -> list:
    qs = " | ".join(_tr._q(q) for q in QUANTILES)
    lines = ["## Annual rates over the tree", "", f"| level | mean | {qs} | estimation sd of the mean (<=) |",
             "|---|---|" + "---|" * len(QUANTILES) + "---|"]
    for lb in tr.labels:
        s = tr.stats[lb]
        lines.append(f"| {lb} | {_e(s['mean'])} | " + " | ".join(_tr._qe(s, q) for q in QUANTILES)
                     + f" | {_e(s['mean_sd_bound'])} |")
    return lines + ["", "Quantiles by OpenQuake's weighted rule, +- each one's estimation sd by resampling every branch's "
                    "estimate from its sd (lognormal, the larger of independent and fully correlated draws: "
                    "docs/logic_tree.md). The estimation sd of the mean is the bound at full "
                    "correlation (Sum w sd: the branches share their events); nan where a branch's level is refused "
                    "(no CoV).", ""]


def to_json(tr) -> dict:
    return {"route": "rare-event", "site": tr.runs[0].site.path, "tree": tr.tree.origin, "samples": tr.tree.samples,
            "seed": tr.tree.seed, "weights_note": tr.note, "summary": summary(tr),
            "branch_sets": [{"name": s.name, "choice": s.choice.name, "scope": s.scope, "sources": list(s.sources),
                             "branches": [{"name": b.name, "value": b.value, "weight": b.weight} for b in s.branches]}
                            for s in tr.tree.branch_sets],
            "run_groups": [{"folder": g.folder, "name": g.name, "runs": r.runs, "failed": failures(r.cols)[0],
                            "stopped": r.stopped, "end_branches": list(g.ends)} for g, r in zip(tr.groups, tr.runs)],
            "end_branches": [{"path": e.path, "index": list(e.index), "weight": e.weight,
                              "folder": tr.groups[tr.group_of[k]].folder, "failed_runs": tr.failed(k),
                              "levels": {lb: tr.estimates[k].levels[lb].as_dict() for lb in tr.labels}}
                             for k, e in enumerate(tr.ends)],
            "levels": {lb: {**s, "quantiles": {str(q): x for q, x in s["quantiles"].items()}} for lb, s in tr.stats.items()},
            "probability": {str(t): {lb: {"mean": s["mean"], "quantiles": {str(q): x for q, x in s["quantiles"].items()}}
                                     for lb, s in v.items()} for t, v in tr.prob_stats.items()}}


def write_tree_outputs(tr, outdir, figures: bool = False) -> dict:
    """Each run group's risk.md and risk.json in its folder, then OUTDIR's logic_tree.md and logic_tree.json, and
    with ``figures`` the tree's figures (:mod:`pycolfrag.risk.tree_figures`)."""
    from pycolfrag.risk import rare_route
    from pycolfrag.risk.report import _write_text  # the risk outputs' atomic write
    out = Path(outdir)
    for g, r in zip(tr.groups, tr.runs):
        if rare_route.larger_estimate(r, out / g.folder) is None:
            rare_route.write_outputs(r, out / g.folder, None, figures=figures)
    md, js = out / "logic_tree.md", out / "logic_tree.json"
    try:
        _write_text(md, markdown(tr))
        _write_text(js, report_json.dumps(to_json(tr), indent=1, default=_plain))
    except OSError as exc:
        raise OutputError(f"cannot write the logic tree's outputs into {out}: {exc.strerror or exc}") from None
    figs = write_figures(tr, out) if figures else {}
    return {"markdown": str(md), "json": str(js), **figs}


def _plain(x):
    try:
        return x.tolist()
    except AttributeError:
        return str(x)


def print_tree_summary(tr, years: float) -> None:
    """Per level the tree's mean and 16-84 % band of lambda and of P in ``years`` years; the failed runs; what
    matters most for collapse."""
    print(f"logic tree: {len(tr.ends)} end branches{' (sampled)' if tr.tree.samples else ''} over {len(tr.groups)} "
          "run setting(s) on the same events" + (f"; {tr.note}" if tr.note else ""))
    for lb in tr.labels:
        s, p = tr.stats[lb], tr.prob_stats[years][lb]
        fb = s.get("failed_bounds")
        print(f"  {lb:>24}: mean {_e(s['mean'])} /yr [16-84 % {_e(s['quantiles'][0.16])}-{_e(s['quantiles'][0.84])}]; "
              f"P({years:g} yr) mean {_e(p['mean'])} [{_e(p['quantiles'][0.16])}-{_e(p['quantiles'][0.84])}]"
              + (f"; FAILED runs: {_e(fb[0])} - {_e(fb[1])} /yr" if fb else ""))
    top = tr.stats["collapse"]["tornado"][0]
    print(f"  matters most for collapse: {top['set']} (swing {_e(top['swing'])} /yr)")
