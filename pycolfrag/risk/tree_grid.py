"""A logic tree of site choices on the grid route: ``pycolfrag risk SITE RESULTS OUTDIR --logic-tree TREE``
(docs/logic_tree.md, "On the grid route").

A tree whose branch sets change only the site (rates, b-values, Mmax, the pulse-occurrence model) needs no
new runs: every end branch is the same grid files' cells, re-weighted by that branch's site
(:func:`pycolfrag.risk.site_risk.site_risk` of the branch's site). Every branch is computed with the same
seed of the intervals' draws (common random numbers: the branches' intervals differ by their weights alone),
each distinct path once (a sampled tree may draw one twice). The single model -- the site file as it is -- is
computed beside them and written as the risk command writes it (``risk.md``, ``risk.json``, figures); the tree
adds ``logic_tree.md`` and ``logic_tree.json`` (:mod:`pycolfrag.risk.tree_report`).

A tree with a set that changes the runs (``vp_scale``, the contact model, ...) is refused: its branches need
runs of their own, with common random numbers, on the rare-event route (:mod:`pycolfrag.risk.tree_rare_run`).
"""
from __future__ import annotations

import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError, PycolfragError
from pycolfrag.risk import tree_stats as ts
from pycolfrag.risk.logic_tree import EndBranchArrays, LogicTree, load_tree, tree_from_dict
from pycolfrag.risk.tree_apply import check_tree
from pycolfrag.risk.tree_quantile_error import quantile_errors

__all__ = ["TreeRisk", "site_dict_of", "tree_risk", "level_stats", "run_tree"]

#: z of the two-sided 90 % interval: a branch's estimation sd is read from its interval as (high - low) / (2 z).
_Z90 = 1.6448536269514722


def site_dict_of(path) -> dict:
    """The parsed site file (by the site file's policy: a regular UTF-8 file of at most 16 MiB)."""
    text = input_files.read_text(path, "site file")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None


def _tree_of(site_path, site_dict: dict, tree_path) -> LogicTree:
    """The tree of ``--logic-tree``: a file of its own, or the site file itself (its ``[logic_tree]``)."""
    if Path(tree_path).resolve() == Path(site_path).resolve():   # ./site.toml is site.toml
        if "logic_tree" not in site_dict:
            raise ParameterError(f"--logic-tree {tree_path}: the site file has no [logic_tree] table")
        return tree_from_dict(site_dict["logic_tree"], str(tree_path))
    return load_tree(tree_path)


def _refuse_run_sets(tree: LogicTree, pulse_model, pulse_only) -> None:
    runs = [f"{s.name!r} ({s.choice.name})" for s in tree.run_sets]
    if runs:
        raise ParameterError(
            f"logic tree {tree.origin}: branch sets {', '.join(runs)} change the runs, which the grid route cannot "
            "give (it re-weights one grid's runs). Model-choice branches need their own runs with common random "
            "numbers: run the tree on the rare-event route, `risk SITE --simulate OUTDIR --logic-tree TREE` "
            "(docs/logic_tree.md). Site choices (rate, "
            "rate_factor, b, m_max, pulse_model) work here")
    pulse_sets = [s.name for s in tree.branch_sets if s.choice.name == "pulse_model"]
    if pulse_sets and (pulse_model is not None or pulse_only):
        raise ParameterError(f"--pulse-model / --pulse-only would override the tree's pulse_model set(s) {pulse_sets} "
                             "in every branch: drop one of the two")


@dataclass
class TreeRisk(EndBranchArrays):
    """The risk of every end branch of a site-only tree, the single model's, and their statistics."""

    tree: LogicTree
    ends: tuple
    base: Any                          # SiteRisk of the site file as it is (the analysis imported on use)
    branch_risk: tuple                 # SiteRisk per end branch (a path drawn twice: the same object)
    labels: tuple
    years: tuple
    stats: dict = field(default_factory=dict)        # label -> level_stats(...)
    prob_stats: dict = field(default_factory=dict)   # years -> label -> {mean, quantiles}

    @property
    def incomplete(self) -> bool:
        return bool(self.base.incomplete)


def _sd(rate: tuple) -> float:
    """A branch's estimation sd of lambda, read from its 90 % interval: (high - low) / (2 z_0.95) (the interval
    is not symmetric: an approximation, said where it is shown)."""
    _, lo, hi = rate
    return (hi - lo) / (2.0 * _Z90)


def level_stats(values, sds, weights, index, sets, names) -> dict:
    """The tree's statistics of one level: weighted mean, quantiles, the estimation sd of the mean (the branches
    share their runs: the bound at full correlation), the variance split and the tornado."""
    v, s = np.asarray(values, dtype=float), np.asarray(sds, dtype=float)
    split = ts.variance_split(v, weights, index, sets, estimation_var=s ** 2)
    return {"mean": float(ts.weighted_mean(v, weights)),
            "quantiles": {q: float(x) for q, x in ts.quantiles(v, weights).items()},
            "mean_sd_bound": float(ts.mean_estimation_sd(s, weights, correlated=True)),
            "split": {"epistemic": float(split.epistemic), "estimation": float(0.0 if split.estimation is None else split.estimation),
                      "per_set": {k: float(x) for k, x in split.per_set.items()},
                      "interaction": float(split.interaction)},
            "tornado": ts.tornado(v, weights, index, sets, names),
            "quantile_error": quantile_errors(v, s, weights)}


def tree_risk(site, tree, pulse_results, no_pulse_results=None, **options) -> TreeRisk:
    """The risk of a site-only tree on the grid route: every end branch's :func:`site_risk` of the same grid
    files (``options``: site_risk's keywords, the seed an integer so that every branch has the same draws),
    the single model's, and their statistics. Every branch is checked before any is computed."""
    from pycolfrag.analysis.data import as_data
    from pycolfrag.risk.grid_route import QUANTITIES, site_risk
    seed = options.get("rng", 0)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ParameterError(f"the tree's branches need an integer seed (rng), so that each has the same draws, got {seed!r}")
    site_dict = site_dict_of(site)
    lt = tree if isinstance(tree, LogicTree) else _tree_of(site, site_dict, tree)
    _refuse_run_sets(lt, options.get("pulse_model"), options.get("pulse_only", False))
    checked = check_tree(lt, site_dict, str(site))
    pulse = as_data(pulse_results)
    no_pulse = None if no_pulse_results is None else as_data(no_pulse_results)
    base = site_risk(str(site), pulse, no_pulse, **{**options, "curves": True})   # the single model, as the command writes it
    options = {**options, "curves": False}     # the branches: their rates alone
    done: dict = {}
    for end, s in zip(checked.ends, checked.sites):
        if end.index not in done:
            try:
                done[end.index] = site_risk(s, pulse, no_pulse, **options)
            except ParameterError as exc:        # e.g. a branch's Mmax beyond the grid under outside = "refuse"
                raise ParameterError(f"logic tree branch {end.path!r}: {exc}") from None
    out = TreeRisk(lt, checked.ends, base, tuple(done[e.index] for e in checked.ends),
                   tuple(q.label for q in QUANTITIES), tuple(base.prob))
    names = [[b.name for b in s.branches] for s in lt.branch_sets]
    for label in out.labels:
        rates = [r.rate[label] for r in out.branch_risk]
        out.stats[label] = level_stats([x[0] for x in rates], [_sd(x) for x in rates], out.weights, out.index,
                                       out.sets, names)
    for t in out.years:
        out.prob_stats[t] = {}
        for label in out.labels:
            p = np.array([r.prob[t][label][0] for r in out.branch_risk])
            out.prob_stats[t][label] = {"mean": float(ts.weighted_mean(p, out.weights)),
                                        "quantiles": {q: float(x) for q, x in ts.quantiles(p, out.weights).items()}}
    return out


def run_tree(a, prog: str) -> int:
    """The command's tree form (parsed arguments of the risk command): exit 0, or 2 with the message of a bad
    site, tree, results file or folder."""
    from pycolfrag.risk import tree_report
    from pycolfrag.risk.report import check_outdir, write_outputs
    try:
        check_outdir(a.outdir)
        tr = tree_risk(a.site, a.logic_tree, a.results, a.no_pulse, pulse_only=a.pulse_only, estimator=a.estimator,
                       uncertainty=a.uncertainty, eq4_misfit=a.eq4_misfit, pulse_model=a.pulse_model,
                       outside=a.outside, years=a.years, n_draws=a.draws, rng=a.seed,
                       allow_incomplete=a.allow_incomplete)
        write_outputs(tr.base, a.outdir, figures=not a.no_figures)
        paths = tree_report.write_tree_outputs(tr, a.outdir, figures=not a.no_figures)
    except PycolfragError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    tree_report.print_tree_summary(tr, 50.0 if 50.0 in tr.years else tr.years[0])
    print(paths["markdown"])
    return 0
