"""The outputs of a logic tree's site risk on the grid route (docs/logic_tree.md): ``logic_tree.md`` (the
weighted mean and quantiles of every level beside the single model, P in T years, the per-branch table, the
variance split and the tornado of collapse, what matters most), ``logic_tree.json`` (every number) and the
command's summary. Written through a temporary file renamed into place, as risk.md is."""
from __future__ import annotations

from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import OutputError
from pycolfrag.risk.tree_figures import write_figures
from pycolfrag.risk.tree_stats import QUANTILES
from pycolfrag.risk.tree_summary import summary, summary_lines

__all__ = ["markdown", "to_json", "write_tree_outputs", "print_tree_summary"]


def _e(x: float) -> str:
    return f"{x:.3g}"


def _q(q: float) -> str:
    return f"{100 * q:g} %"


def _qe(s: dict, q: float) -> str:
    """A quantile with its estimation sd (tree_quantile_error), when stated."""
    sd = s.get("quantile_error", {}).get("sd", {}).get(q)
    return _e(s["quantiles"][q]) + (f" +- {sd:.2g}" if sd is not None and sd == sd else "")


def _head(tr) -> list:
    t = tr.tree
    how = (f"{len(tr.ends)} end branches drawn (samples = {t.samples}, seed {t.seed}; each of weight 1/{t.samples})"
           if t.samples else f"all {len(tr.ends)} end branches (full enumeration; weight: the product of the alternatives')")
    lines = ["# pycolfrag site risk over a logic tree", ""]
    if tr.incomplete:
        lines += ["**INCOMPLETE** results: every rate below rests on the computed part (risk.md says how much).", ""]
    lines += [f"Site: {tr.base.site.name} ({tr.base.site.path}); tree: {t.origin or 'given'}"
              + (f" -- {t.description}" if t.description else ""), "",
              f"Branch sets: {'; '.join(f'{s.name} ({s.choice.name}: ' + ', '.join(f'{b.name} {b.weight:g}' for b in s.branches) + ')' for s in t.branch_sets)}.",
              f"{how}. Every set changes only the site: the same runs re-weighted (no new runs), every branch with "
              "the same draws of its interval (common random numbers). The single model is the site file as it is "
              "(risk.md).", ""]
    return lines


def _level_table(tr) -> list:
    qs = " | ".join(_q(q) for q in QUANTILES)
    lines = ["## Annual rates over the tree", "",
             f"| level | single model | mean | {qs} | estimation sd of the mean (<=) |",
             "|---|---|---|" + "---|" * len(QUANTILES) + "---|"]
    for label in tr.labels:
        s = tr.stats[label]
        lines.append(f"| {label} | {_e(tr.base.rate[label][0])} | {_e(s['mean'])} | "
                     + " | ".join(_qe(s, q) for q in QUANTILES) + f" | {_e(s['mean_sd_bound'])} |")
    lines += ["", "Quantiles by OpenQuake's weighted rule (sorted values, accumulated weights, linear "
              "interpolation); +- each quantile's estimation sd, by resampling every branch's estimate from its sd "
              "(lognormal, the larger of independent and fully correlated draws: docs/logic_tree.md). The estimation sd of the mean is the bound at full correlation (Sum w sd), the "
              "branches sharing their runs; each branch's sd is read from its 90 % interval as (high - low) / "
              "3.29, an approximation of an asymmetric interval.", ""]
    return lines


def _prob_table(tr) -> list:
    lines = ["## Probability in T years", "", "| level | " + " | ".join(f"{t:g} yr: mean [16-84 %]" for t in tr.years) + " |",
             "|---|" + "---|" * len(tr.years)]
    for label in tr.labels:
        cells = []
        for t in tr.years:
            s = tr.prob_stats[t][label]
            cells.append(f"{_e(s['mean'])} [{_e(s['quantiles'][0.16])}-{_e(s['quantiles'][0.84])}]")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "The mean of the branches' probabilities (as OpenQuake's mean curve of PoEs), not 1 - exp(-mean "
              "lambda T).", ""]
    return lines


def _branch_table(tr) -> list:
    lines = ["## End branches", "", "| branch | weight | " + " | ".join(f"{lb} (CoV)" for lb in tr.labels) + " |",
             "|---|---|" + "---|" * len(tr.labels)]
    for end, r in zip(tr.ends, tr.branch_risk):
        cells = []
        for label in tr.labels:
            lam, lo, hi = r.rate[label]
            cov = (hi - lo) / 3.2897072539029444 / lam if lam > 0 else float("nan")
            cells.append(f"{_e(lam)} ({cov:.2f})")
        lines.append(f"| {end.path} | {end.weight:.4g} | " + " | ".join(cells) + " |")
    return lines + [""]


def _split_lines(tr, label: str) -> list:
    s = tr.stats[label]
    sp = s["split"]
    total = sp["epistemic"] + sp["estimation"]
    share = (lambda x: f"{100 * x / total:.1f} %") if total > 0 else (lambda x: "-")
    lines = [f"## What moves the rate of {label}", "",
             "| part | variance | share |", "|---|---|---|",
             f"| estimation (the branches' own runs) | {_e(sp['estimation'])} | {share(sp['estimation'])} |"]
    lines += [f"| branch set {k} | {_e(v)} | {share(v)} |" for k, v in sp["per_set"].items()]
    lines += [f"| interactions | {_e(sp['interaction'])} | {share(sp['interaction'])} |", "",
              "Tornado (each set's alternatives with the other sets at their weights):", ""]
    for b in s["tornado"]:
        lines.append(f"* {b['set']}: {_e(b['low'])} ({b['set']}={b['low_branch']}) to {_e(b['high'])} "
                     f"({b['set']}={b['high_branch']}), "
                     f"swing {_e(b['swing'])}" + (f"; not drawn: {b['missing']}" if b["missing"] else ""))
    top = s["tornado"][0]
    lines += ["", f"The branch set that matters most for {label}: **{top['set']}** (swing {_e(top['swing'])} /yr "
              f"against a mean of {_e(s['mean'])} /yr).", ""]
    return lines


def markdown(tr) -> str:
    head = _head(tr)
    body = head[:2] + summary_lines(tr) + head[2:] + _level_table(tr) + _prob_table(tr) + _split_lines(tr, "collapse")
    body += _branch_table(tr)
    body += ["Not done yet (docs/logic_tree.md): branches of the model choices (pulse amplitude and period, contact "
             "model, joints, connectors) need the rare-event route with common random numbers."]
    return "\n".join(body) + "\n"


def to_json(tr) -> dict:
    return {"site": tr.base.site.path, "tree": tr.tree.origin, "samples": tr.tree.samples, "seed": tr.tree.seed,
            "incomplete": tr.incomplete, "site_only": True, "summary": summary(tr),
            "branch_sets": [{"name": s.name, "choice": s.choice.name, "scope": s.scope, "sources": list(s.sources),
                             "branches": [{"name": b.name, "value": b.value, "weight": b.weight} for b in s.branches]}
                            for s in tr.tree.branch_sets],
            "end_branches": [{"path": e.path, "index": list(e.index), "weight": e.weight,
                              "rate": {lb: list(r.rate[lb]) for lb in tr.labels}}
                             for e, r in zip(tr.ends, tr.branch_risk)],
            "single_model": {lb: list(tr.base.rate[lb]) for lb in tr.labels},
            "levels": {lb: {**s, "quantiles": {str(q): x for q, x in s["quantiles"].items()}}
                       for lb, s in tr.stats.items()},
            "probability": {str(t): {lb: {"mean": s["mean"], "quantiles": {str(q): x for q, x in s["quantiles"].items()}}
                                     for lb, s in v.items()} for t, v in tr.prob_stats.items()}}


def write_tree_outputs(tr, outdir, figures: bool = False) -> dict:
    """Write ``logic_tree.md`` and ``logic_tree.json`` into ``outdir`` (made by the risk outputs before), and with
    ``figures`` the tree's figures (:mod:`pycolfrag.risk.tree_figures`)."""
    from pycolfrag.risk.report import _write_text  # the risk outputs' atomic write
    out = Path(outdir)
    md, js = out / "logic_tree.md", out / "logic_tree.json"
    try:
        out.mkdir(parents=True, exist_ok=True)
        _write_text(md, markdown(tr))
        _write_text(js, report_json.dumps(to_json(tr), indent=1))
    except OSError as exc:
        raise OutputError(f"cannot write the logic tree's outputs into {out}: {exc.strerror or exc}") from None
    figs = write_figures(tr, out) if figures else {}
    return {"markdown": str(md), "json": str(js), **figs}


def print_tree_summary(tr, years: float) -> None:
    """The command's printout: per level the single model, the tree's mean and 16-84 % band of lambda and of P
    in ``years`` years, and the branch set that matters most for collapse."""
    print(f"logic tree: {len(tr.ends)} end branches{' (sampled)' if tr.tree.samples else ''}, site choices only "
          "(the same runs re-weighted)" + ("; INCOMPLETE results" if tr.incomplete else ""))
    for label in tr.labels:
        s, p = tr.stats[label], tr.prob_stats[years][label]
        print(f"  {label:>24}: single {_e(tr.base.rate[label][0])} /yr; mean {_e(s['mean'])} /yr "
              f"[16-84 % {_e(s['quantiles'][0.16])}-{_e(s['quantiles'][0.84])}]; P({years:g} yr) mean {_e(p['mean'])} "
              f"[{_e(p['quantiles'][0.16])}-{_e(p['quantiles'][0.84])}]")
    top = tr.stats["collapse"]["tornado"][0]
    print(f"  matters most for collapse: {top['set']} (swing {_e(top['swing'])} /yr)")
