"""The targets of the example site's default logic tree (docs/logic_tree.md, "Default tree").

Runs -- or, when the folder holds them, resumes -- ``pycolfrag risk SITE --logic-tree TREE --simulate OUTDIR``
in this process (no MPI: what `make risk-tree` runs on NRANKS ranks gives the same files), then prints:

* the tree's mean lambda(collapse), its estimation sd (the bound at full correlation, Sum w sd: the branches share
  their events) and CoV, against the target 0.2;
* every reported quantile of lambda(collapse) (5, 16, 50, 84, 95 %) with its estimation sd (the parametric
  resampling of the branches' own sds, pycolfrag/risk/tree_quantile_error.py);
* the total runs of the tree against the runs one branch (the paper's model, runs_00) needs for the CoV the tree's
  mean has, n_00 (CoV_00 / CoV_mean)^2 (the CoV of a stratified estimate falls as 1/sqrt(n)), target <= 4x;
* paired against independent, for each pair of run settings that differ in one branch set: the variance of the
  difference of their collapse rates estimated within the run from the paired rows (the same events and weights:
  the product's paired variance, pycolfrag.risk.paired_difference) against V_a + V_b (what two independent simulations of these sizes
  would have), their ratio being the factor of runs that the common random numbers save for the same precision of
  that difference.

``--max-runs`` caps the runs per run setting (as `make risk-tree`'s TREE_MAX_RUNS; a smaller cap gives the same
table at its own CoV). Exit 1 when the mean's CoV is above ``--target-cov``. Results also in
``OUTDIR/risk_tree_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from pycolfrag.risk.paired_difference import common_batches, paired_differences

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parents[1]
LEVEL = "collapse"


def _simulate(argv):
    """(TreeRare, wall seconds of the simulation) of the tree command's arguments, in this process."""
    from pycolfrag.risk import rare_route
    from pycolfrag.risk.tree_rare import tree_of_runs
    from pycolfrag.risk.tree_rare_run import _simulate as simulate
    from pycolfrag.risk.tree_rare_run import prepare
    ap = rare_route.build_parser()
    ap.add_argument("--logic-tree", required=True)
    a = ap.parse_args(argv)
    p = prepare(a)
    t0 = time.perf_counter()
    code, runs = simulate(a, p, None, 1, lambda s: print(s, flush=True), argv)
    wall = time.perf_counter() - t0
    if runs is None:
        raise SystemExit(f"the simulation stopped (exit {code}); rerun to resume")
    years = sorted({50.0, 100.0, 475.0, *p["site"].years})
    return tree_of_runs(p["tree"], p["ends"], p["sites"], p["groups"], runs, years), wall, code


def _aligned(ra, rb) -> bool:
    keys = ("stage", "stratum", "index")
    return all(np.array_equal(np.asarray(ra.cols[k]), np.asarray(rb.cols[k])) for k in keys)


def _pairs(tr) -> list:
    """(a, b, set name) for the run groups that differ in one run-changing branch set."""
    runs_sets = [i for i, s in enumerate(tr.tree.branch_sets) if s.scope == "runs"]
    first = {g: tr.ends[grp.ends[0]].index for g, grp in enumerate(tr.groups)}
    out = []
    for a in first:
        for b in first:
            if b <= a:
                continue
            diff = [i for i in runs_sets if first[a][i] != first[b][i]]
            if len(diff) == 1:
                out.append((a, b, tr.tree.branch_sets[diff[0]].name))
    return out


def report(tr, wall: float, target: float) -> dict:
    st = tr.stats[LEVEL]
    mean, sd = st["mean"], st["mean_sd_bound"]
    cov = sd / mean if mean > 0 else math.inf
    n_groups = [int(r.estimate.n_runs) for r in tr.runs]
    total = sum(n_groups)
    lead = tr.runs[0].estimate.levels[LEVEL]
    one_branch = n_groups[0] * (lead.cov / cov) ** 2 if cov > 0 else math.inf
    print(f"\nexample site, {len(tr.ends)} end branches on {len(tr.runs)} run settings, {total} runs "
          f"({', '.join(map(str, n_groups))}) in {wall:.0f} s ({wall / max(total, 1) * 1e3:.0f} ms per run here)")
    print(f"mean lambda({LEVEL}) = {mean:.3e} /yr, estimation sd {sd:.2e} (Sum w sd), CoV {cov:.3f} "
          f"(target <= {target:g}: {'met' if cov <= target else 'NOT met'})")
    qe = st["quantile_error"]["sd"]
    print("quantile   lambda /yr   estimation sd   (sd / value)")
    for q, v in st["quantiles"].items():
        e = qe.get(float(q), math.nan)
        print(f"  {100 * float(q):4.0f} %   {v:10.3e}   {e:13.2e}   ({e / v if v > 0 else math.nan:.2f})")
    print(f"runs: total {total} against {one_branch:.0f} for the paper's branch alone at CoV {cov:.3f} "
          f"(its {n_groups[0]} runs gave CoV {lead.cov:.3f}): {total / one_branch:.2f}x (target <= 4x)")
    pairs = []
    print(f"paired against independent ({LEVEL}; within-run variances of the difference):")
    for a, b, name in _pairs(tr):
        ra, rb = common_batches(tr.runs[a], tr.runs[b])     # the batches both run settings took
        if not _aligned(ra, rb):
            print(f"  {tr.groups[a].folder} - {tr.groups[b].folder}: rows not aligned, skipped")
            continue
        la, lb = ra.estimate.levels[LEVEL], rb.estimate.levels[LEVEL]
        vp = paired_differences(ra, rb)[LEVEL].sd ** 2       # the product's paired variance (pieces, floors)
        vi = (la.cov * la.rate) ** 2 + (lb.cov * lb.rate) ** 2
        ratio = vi / vp if vp > 0 else math.inf
        pairs.append({"a": tr.groups[a].folder, "b": tr.groups[b].folder, "set": name, "difference": lb.rate - la.rate,
                      "var_paired": vp, "var_independent": vi, "ratio": ratio})
        print(f"  {name:<18} {tr.groups[b].folder} - {tr.groups[a].folder}: d = {lb.rate - la.rate:+.3e} /yr, "
              f"var paired {vp:.2e}, V_a + V_b {vi:.2e}: ratio {ratio:.2f} (runs saved for the same precision of d)")
    return {"mean": mean, "sd": sd, "cov": cov, "quantiles": st["quantiles"], "quantile_sd": qe,
            "runs": n_groups, "total_runs": total, "one_branch_runs_same_cov": one_branch,
            "runs_ratio": total / one_branch, "wall_s": wall, "pairs": pairs,
            "branches": [{"path": e.path, "weight": e.weight, "rate": x.levels[LEVEL].rate, "cov": x.levels[LEVEL].cov}
                         for e, x in zip(tr.ends, tr.estimates)]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("outdir", help="the tree's folder (resumed when it holds runs)")
    ap.add_argument("--site", default=str(ROOT / "examples" / "site_athens.toml"))
    ap.add_argument("--tree", default=str(ROOT / "examples" / "logic_tree_default.toml"))
    ap.add_argument("--target-cov", type=float, default=0.2)
    ap.add_argument("--max-runs", type=int, default=20000, help="runs per run setting")
    ap.add_argument("--allow-code-change", action="store_true", help="read a folder made by another build")
    a = ap.parse_args(argv)
    cmd = [a.site, "--logic-tree", a.tree, "--simulate", a.outdir, "--target-cov", str(a.target_cov),
           "--levels", LEVEL, "--max-runs", str(a.max_runs), "--no-progress", "--no-figures", "--mpi", "no"] + (["--allow-code-change"] if a.allow_code_change else [])
    tr, wall, code = _simulate(cmd)
    out = report(tr, wall, a.target_cov)
    out.update(exit_code=code, command=cmd)
    Path(a.outdir, "risk_tree_bench.json").write_text(json.dumps(out, indent=1, default=str))
    if not out["cov"] <= a.target_cov:
        print(f"the tree's mean collapse rate has a CoV of {out['cov']:.3f} > {a.target_cov:g}: rerun with a larger "
              f"--max-runs (the simulation resumes)")
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
