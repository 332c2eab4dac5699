"""A logic tree on the rare-event route: its run groups, the folder's record of the tree, the site choices
re-weighted, and the tree's statistics (docs/logic_tree.md, "On the rare-event route").

* :func:`run_groups` -- the distinct run settings of the tree's end branches (the tree's first alternatives
  first), each a :class:`RunGroup` with its folder ``runs_NN`` under OUTDIR and its
  :class:`~pycolfrag.rare.evaluator.RecordSettings`; they are simulated on the same events by
  :func:`pycolfrag.rare.paired.simulate_paired`.
* :func:`check_folder` -- ``OUTDIR/logic_tree_runs.json`` records the tree's form (its sets, alternatives and
  values, samples, seed) and every group's run settings before any run; a resume whose tree or run settings
  differ is refused listing the differences; a change of the weights alone changes no run (the runs never
  depend on the weights) and is re-weighted, and said.
* :func:`row_factors` / :func:`branch_estimate` -- an end branch whose site choices differ from the site file's
  is its run group's rows re-weighted, with no new runs: each row's weight times the ratio of the branch's
  event density to the simulated one at that row's (source, Mw, R, pulse or not),

      rho = (nu' / nu) (f'_M(m) / f_M(m)) (g'(r) / g(r) with a pulse, (1 - g'(r)) / (1 - g(r)) without),

  the strata and their rates W_h those of the simulated site. Each row was drawn from the simulated
  stratum's density, so Sum_h W_h (1/n_h) Sum_i w_i rho_i y_i is unbiased for the branch's rate (importance
  sampling with the simulated site as the proposal), exact in the same sense as the simulated site's own
  estimate; with rho = 1 it is that estimate bit for bit. It needs the simulated site to reach every event
  of the branch: a branch Mmax above the site file's, or a no-pulse branch of a pulse-only site, is refused
  before any run (set the site file's value to the tree's widest).
* :class:`TreeShare` -- where the runs go: the simulation stops when the tree's weighted mean meets the target
  CoV, and each production batch is run by the run settings whose share of the mean's error asks for it.
* :func:`tree_of_runs` -- every end branch's estimate and the tree's statistics (weighted mean, OpenQuake's
  quantiles, variance split, tornado: :mod:`pycolfrag.risk.tree_stats`).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError, ResultsFileError
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, vp_model_key
from pycolfrag.rare.driver import site_fingerprint
from pycolfrag.rare.estimate import estimate, row_weights
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk import tree_stats as ts
from pycolfrag.risk.logic_tree import RUNS, EndBranchArrays, _canonical
from pycolfrag.risk.tree_apply import ModelSettings
from pycolfrag.risk.tree_quantile_error import quantile_errors

__all__ = ["RunGroup", "run_groups", "FOLDER_FILE", "tree_form", "check_folder", "steering_weights", "check_reweighting",
           "row_factors", "branch_floor", "branch_estimate", "TreeShare", "TreeRare", "groups_of_ends", "tree_of_runs"]

#: The tree's record in OUTDIR.
FOLDER_FILE = "logic_tree_runs.json"
_KIND = "pycolfrag-logic-tree-runs"


@dataclass(frozen=True)
class RunGroup:
    """One distinct run setting of the tree: its folder, a name (the run-changing alternatives), its end
    branches (positions) and its record settings."""

    folder: str
    name: str
    ends: tuple
    model: ModelSettings
    record: object


def run_groups(checked, record) -> list:
    """The tree's distinct run settings (a :class:`~pycolfrag.risk.tree_apply.CheckedTree`'s), in the order of
    their first end branch (the first alternatives of every set first: the lead group, whose pilot places the
    design); ``record``: the command line's RecordSettings, which each group's run choices change."""
    order: dict = {}
    for k, end in enumerate(checked.ends):
        order.setdefault(end.runs_key, []).append(k)
    groups = []
    for g, (key, ends) in enumerate(order.items()):
        m = checked.models[ends[0]]
        rec = replace(record, column=m.column_dict(), solver_options=dict(m.solver_options), vp_scale=m.vp_scale,
                      tp_model=m.tp_model or DEFAULT_TP_MODEL, vp_model=vp_model_key(m.vp_model))
        name = ", ".join(f"{s}={_short(v)}" for s, v in key) or "the site file's model"
        groups.append(RunGroup(f"runs_{g:02d}", name, tuple(ends), m, rec))
    return groups


def _short(canonical: str) -> str:
    return canonical if len(canonical) <= 40 else canonical[:37] + "..."


def tree_form(tree) -> dict:
    """What of the tree fixes its runs and its end branches, the weights left out."""
    return {"samples": tree.samples, "seed": tree.seed,
            "branch_sets": [{"name": s.name, "choice": s.choice.name, "scope": s.scope, "sources": list(s.sources),
                             "branches": [[b.name, _canonical(b.value)] for b in s.branches]}
                            for s in tree.branch_sets]}


def _weights(tree) -> dict:
    return {s.name: [b.weight for b in s.branches] for s in tree.branch_sets}


def _group_record(g: RunGroup) -> dict:
    m = g.model
    vp = vp_model_key(m.vp_model)      # Eq. (6): no key, as in every folder begun before vp_model was a setting
    return {"folder": g.folder, "name": g.name, "vp_scale": m.vp_scale, "tp_model": m.tp_model or DEFAULT_TP_MODEL,
            **({"vp_model": vp} if vp else {}),
            "solver_options": json.loads(json.dumps(m.solver_options, sort_keys=True, default=str)),
            "column": json.loads(json.dumps(m.column_dict(), sort_keys=True, default=str))}


def _diffs(a, b, where: str) -> list:
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) for d in _diffs(a.get(k), b.get(k), f"{where}.{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _diffs(x, y, f"{where}[{i}]")]
    return [] if a == b else [f"{where}: {a!r} in the folder, {b!r} now"]


def check_folder(outdir, tree, groups) -> str:
    """Refuse a folder begun with another tree or other run settings (ResultsFileError listing the
    differences); record the tree when the folder has none. Returns a note when only the weights changed."""
    path = Path(outdir) / FOLDER_FILE
    now = {"kind": _KIND, "version": 1, "form": tree_form(tree), "groups": [_group_record(g) for g in groups],
           "weights": _weights(tree), "steering_weights": _weights(tree)}
    now = json.loads(json.dumps(now))
    if path.exists():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ResultsFileError(f"{path}: the folder's record of its logic tree cannot be read ({exc})") from None
        diffs = _diffs(old.get("form"), now["form"], "tree") + _diffs(old.get("groups"), now["groups"], "runs")
        if old.get("kind") != _KIND or diffs:
            raise ResultsFileError(
                f"{outdir} was begun with another logic tree or other run settings:\n  - " + "\n  - ".join(diffs[:20])
                + "\nResuming would mix the runs of two trees: rerun with the tree and settings it began with, or use "
                "another folder (a change of the weights alone is allowed: the runs do not depend on them)")
        now["steering_weights"] = old.get("steering_weights", old.get("weights"))
        if old.get("weights") == now["weights"]:
            return ""
        note = (f"the tree's weights changed since {outdir} began ({'; '.join(_diffs(old.get('weights'), now['weights'], 'weights'))}): "
                "the same runs are re-weighted, with no new runs (where the runs go stays steered by the weights the "
                "folder began with)")
    else:
        note = ""
        Path(outdir).mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(now, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(path)
    return note


def steering_weights(outdir, tree, ends) -> np.ndarray:
    """The end branches' weights that steer the runs (:class:`TreeShare`): those of the tree the folder began with
    (its record's ``steering_weights``; a folder's first weights, kept when the weights change), so that a resume
    with other weights takes the uninterrupted run's decisions and re-weights its runs, with no new runs. A sampled
    tree's end branches weigh 1/N whatever the weights."""
    rec = json.loads((Path(outdir) / FOLDER_FILE).read_text(encoding="utf-8"))
    first = rec.get("steering_weights", rec.get("weights"))
    if tree.samples:
        return np.array([e.weight for e in ends], dtype=float)
    names = [s.name for s in tree.branch_sets]
    return np.array([math.prod(first[n][i] for n, i in zip(names, e.index)) for e in ends], dtype=float)


def _support(model):
    try:
        return tuple(float(x) for x in model.support)
    except (AttributeError, TypeError):
        return None


def check_reweighting(site, branch_site, path: str, mw_step: float, r_edges_km) -> None:
    """Refuse (ParameterError naming the branch) a branch site whose events the simulated site does not reach."""
    where = f"logic tree branch {path!r}"
    if len(site.sources) != len(branch_site.sources):
        raise ParameterError(f"{where}: its site has other sources than the simulated one")
    for s0, s1 in zip(site.sources, branch_site.sources):
        if s1.rate > 0 and not s0.rate > 0:
            raise ParameterError(f"{where}: source {s0.name!r} has rate {s0.rate!r} in the site file: its events were "
                                 "never simulated, so no re-weighting reaches them")
        if getattr(s0, "magnitude", None) != getattr(s1, "magnitude", None):
            a, b = _support(s0.magnitude), _support(s1.magnitude)
            if a is None or b is None or b[0] < a[0] - 1e-12 or b[1] > a[1] + 1e-12:
                raise ParameterError(
                    f"{where}: source {s0.name!r}'s magnitudes {b} reach beyond the simulated site's {a}: its events "
                    "there were never simulated. Give the site file the tree's widest range (the largest Mmax): the "
                    "other branches are then re-weighted from its runs")
        if s0.pulse != s1.pulse:
            r = np.linspace(0.5, 300.0, 64)
            if np.all(np.asarray(s0.pulse.mean_probability(r)) >= 1.0) and np.any(s1.pulse.mean_probability(r) < 1.0):
                raise ParameterError(f"{where}: the simulated site is pulse-only, so its motions without a pulse were "
                                     "never simulated; the branch's pulse model needs them")
    try:
        build_strata(branch_site, mw_step, r_edges_km)    # the branch's own site within the models' ranges
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None


def row_factors(cols: dict, site, branch_site):
    """rho of every row (module docstring), or None when the branch's site is the simulated one."""
    if site_fingerprint(site)["sha256"] == site_fingerprint(branch_site)["sha256"]:
        return None
    src = np.asarray(cols["source"], dtype=int)
    m, r = np.asarray(cols["mw"], dtype=float), np.asarray(cols["dist_km"], dtype=float)
    pulse = np.asarray(cols["pulse"], dtype=bool)
    rho = np.ones(src.size)
    for k, (s0, s1) in enumerate(zip(site.sources, branch_site.sources)):
        sel = src == k
        if not sel.any():
            continue
        f = np.full(int(sel.sum()), s1.rate / s0.rate)
        if getattr(s0, "magnitude", None) != getattr(s1, "magnitude", None):
            f *= np.asarray(s1.magnitude.pdf(m[sel]), dtype=float) / np.asarray(s0.magnitude.pdf(m[sel]), dtype=float)
        if s0.pulse != s1.pulse:
            g0 = np.asarray(s0.pulse.mean_probability(r[sel]), dtype=float)
            g1 = np.asarray(s1.pulse.mean_probability(r[sel]), dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                f *= np.where(pulse[sel], g1 / g0, (1.0 - g1) / (1.0 - g0))
        rho[sel] = f
    return rho


def branch_floor(run, rho):
    """The variance floor (:mod:`pycolfrag.rare.estimate`) of a branch whose rows are re-weighted by ``rho``: the
    run's floor of each stratum times the mean square of w rho over that of w among its successful rows -- the
    per-run variance m2 p0 - p0^2 of a stratum none of whose runs exceeds, its weights scaled (exactly where rho is
    one value in the stratum and the p0^2 term small, as a rate factor's); None when the run has no floor."""
    if run.floor is None:
        return None
    ok = np.asarray(run.cols["status"]) == _results.STATUS_OK
    sub = {k: np.asarray(v)[ok] for k, v in run.cols.items()}
    w, _ = row_weights(sub, run.strata, run.design)
    h = np.asarray(sub["stratum"], dtype=int)
    H = len(run.strata)
    m2 = np.bincount(h, weights=w * w, minlength=H)
    m2_rho = np.bincount(h, weights=(w * rho[ok]) ** 2, minlength=H)
    ratio = np.divide(m2_rho, m2, out=np.ones(H), where=m2 > 0)
    return np.asarray(run.floor, dtype=float) * ratio[:, None]


def branch_estimate(run, branch_site):
    """The estimate of an end branch from its run group's rows (:class:`~pycolfrag.rare.driver.SiteRun`):
    the run's own when the site is the simulated one, else its rows re-weighted by :func:`row_factors` through
    the rare route's one estimator (:func:`pycolfrag.rare.estimate.estimate`: its control variates and, by
    :func:`branch_floor`, its variance floor)."""
    rho = row_factors(run.cols, run.site, branch_site)
    if rho is None:
        return run.estimate
    s = run.stop
    return estimate(run.cols, run.strata, run.design, run.quantities, confidence=s.confidence, min_neff=s.min_neff,
                    max_share=s.max_share, target_cov=s.target_cov, floor=branch_floor(run, rho), reweight=rho,
                    pieces=True)


@dataclass(frozen=True)
class TreeShare:
    """Where a logic tree's runs go (``share`` of :func:`pycolfrag.rare.paired.simulate_paired`; docs/logic_tree.md,
    "Where the runs go"). The target is the tree's: the weighted mean of every requested level with the estimation
    CoV ``target_cov``, stated as the bound at full correlation, S = Sum_e w_e sd_e (the branches share their events),
    against m = Sum_e w_e lambda_e; a branch whose estimate is refused (too few effective exceedances) enters S with
    its upper bound on the rate in place of an sd. Run setting g's part of S is c_g = Sum_{e in g} w_e sd_e; with its
    n_g runs its sd falls as 1 / sqrt(n), so u_g = c_g sqrt(n_g) is its part per unit of runs and the fewest runs
    that give S = target m are n_g = N* t_g, t_g = u_g^(2/3) / Sum u^(2/3), N* = (Sum u^(2/3))^3 / (target m)^2
    (Lagrange).

    Asked before each production batch after the first (which every run setting takes): the tree stops ("target";
    "failures" when a branch is unresolved by failed runs) when every requested level has S <= target m; otherwise
    a batch is taken, for each level not met, by the run settings with fewer runs than their n_g (the one whose
    batch would cut S most when none is short). The weights are the folder's first (:func:`steering_weights`), the
    branches' estimates :func:`branch_estimate`'s."""

    weights: tuple                  # end branches' steering weights
    group_of: tuple                 # the run group of every end branch
    sites: tuple                    # every end branch's site
    target_cov: float
    batch: int

    def branch_estimates(self, views: dict) -> list:
        """(weight, group, Estimate) of every end branch whose group is live in ``views``."""
        return [(w, g, branch_estimate(views[g], s))
                for w, g, s in zip(self.weights, self.group_of, self.sites) if g in views]

    def __call__(self, stage: int, views: dict) -> tuple:
        takers: set = set()
        unresolved = False
        requested = next(iter(views.values())).requested
        branches = self.branch_estimates(views)         # once: every level reads them
        for q in requested:
            lv = [(w, g, est.levels[q.label]) for w, g, est in branches]
            m = math.fsum(w * e.rate for w, _, e in lv)
            sd = {g: 0.0 for g in views}
            for w, g, e in lv:
                unresolved |= e.status == "unresolved"
                known = e.status != "refused" and math.isfinite(e.cov)
                sd[g] += w * (e.cov * e.rate if known else e.bound)
            if math.fsum(sd.values()) <= self.target_cov * m:
                continue
            n = {g: max(int(views[g].estimate.n_runs), 1) for g in views}
            level = {g for g in views if not math.isfinite(sd[g])}
            u = {g: sd[g] * math.sqrt(n[g]) for g in views if g not in level}
            z = math.fsum(x ** (2.0 / 3.0) for x in u.values())
            if m > 0 and z > 0 and not level:
                total = z ** 3 / (self.target_cov * m) ** 2
                level = {g for g, x in u.items() if n[g] < total * x ** (2.0 / 3.0) / z}
            if not level:
                gain = {g: sd[g] * (1.0 - math.sqrt(n[g] / (n[g] + self.batch))) for g in views}
                level.add(max(sorted(gain), key=lambda g: gain[g]))
            takers |= level
        if not takers:
            return ("failures" if unresolved else "target"), []
        return "budget", sorted(takers)


@dataclass
class TreeRare(EndBranchArrays):
    """Every end branch's estimate on the rare-event route and the tree's statistics."""

    tree: Any
    ends: tuple
    groups: list
    runs: list                       # SiteRun per group
    estimates: list                  # Estimate per end branch
    group_of: list                   # the group of every end branch
    labels: tuple
    years: tuple
    note: str = ""                   # the weights' change, when there was one
    stats: dict = field(default_factory=dict)
    prob_stats: dict = field(default_factory=dict)

    def failed(self, k: int) -> int:
        """Failed runs under end branch k (its group's)."""
        return int(self.estimates[k].n_failed)


def level_stats(values, sds, weights, index, sets, names) -> dict:
    """The tree's statistics of one level; a branch without a finite sd (a refused level) leaves the estimation
    part and the mean's sd bound unstated (NaN)."""
    v, s = np.asarray(values, dtype=float), np.asarray(sds, dtype=float)
    finite = bool(np.all(np.isfinite(s)))
    split = ts.variance_split(v, weights, index, sets, estimation_var=s ** 2 if finite else None)
    return {"mean": float(ts.weighted_mean(v, weights)),
            "quantiles": {q: float(x) for q, x in ts.quantiles(v, weights).items()},
            "mean_sd_bound": float(ts.mean_estimation_sd(s, weights, correlated=True)) if finite else math.nan,
            "split": {"epistemic": float(split.epistemic),
                      "estimation": math.nan if split.estimation is None else float(split.estimation),
                      "per_set": {k: float(x) for k, x in split.per_set.items()},
                      "interaction": float(split.interaction)},
            "tornado": ts.tornado(v, weights, index, sets, names),
            "quantile_error": quantile_errors(v, s, weights)}


def groups_of_ends(groups, n_ends: int) -> list:
    """The run group of every end branch (its position in ``groups``, whose ``ends`` list it)."""
    return [next(g for g, grp in enumerate(groups) if k in grp.ends) for k in range(n_ends)]


def tree_of_runs(tree, ends, sites, groups, runs, years, note: str = "") -> TreeRare:
    """Every end branch's estimate (its group's rows, re-weighted to its site) and the tree's statistics of every
    level: the rate's, with the failed runs' bounds (every failed run as none, as an exceedance) where runs failed,
    and P in each horizon's."""
    group_of = groups_of_ends(groups, len(ends))
    ests = [branch_estimate(runs[g], s) for g, s in zip(group_of, sites)]
    labels = tuple(q.label for q in runs[0].quantities)
    out = TreeRare(tree, tuple(ends), groups, runs, ests, group_of, labels, tuple(years), note)
    names = [[b.name for b in s.branches] for s in tree.branch_sets]
    w = out.weights
    for label in labels:
        lv = [e.levels[label] for e in ests]
        rates = [x.rate for x in lv]
        sds = [x.cov * x.rate if math.isfinite(x.cov) else math.nan for x in lv]
        st = level_stats(rates, sds, w, out.index, out.sets, names)
        if any(x.failed for x in lv):
            lo = [x.failed_low if math.isfinite(x.failed_low) else x.rate for x in lv]
            hi = [x.failed_high if math.isfinite(x.failed_high) else x.rate for x in lv]
            st["failed_bounds"] = [float(ts.weighted_mean(lo, w)), float(ts.weighted_mean(hi, w))]
        st["status"] = [x.status for x in lv]
        out.stats[label] = st
    for t in out.years:
        out.prob_stats[t] = {}
        for label in labels:
            p = np.array([-math.expm1(-e.levels[label].rate * t) for e in ests])
            out.prob_stats[t][label] = {"mean": float(ts.weighted_mean(p, w)),
                                        "quantiles": {q: float(x) for q, x in ts.quantiles(p, w).items()}}
    return out


def runs_scope(tree) -> str:
    """How the tree's sets split into run settings and re-weighted site choices, in words."""
    run_sets = [s.name for s in tree.branch_sets if s.scope == RUNS]
    site_sets = [s.name for s in tree.branch_sets if s.scope != RUNS]
    return (f"run settings: {', '.join(run_sets) or 'none'} (each distinct one simulated, all on the same events); "
            f"site choices: {', '.join(site_sets) or 'none'} (re-weighted from the same runs, no new runs)")
