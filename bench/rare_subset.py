"""Subset simulation against brute force: the estimate, its stated CoV and interval, against crude Monte
Carlo of the same runs (docs/rare_events.md, "Subset simulation").

The verification problem: collapse of the Parthenon column as one rigid body (``monolithic``: about 2 ms
a run with its record) under the pulse records of Mw 6.25 at 10 km, p about 1e-3. Three steps:

    python bench/rare_subset.py crude --n 100000        # the crude reference (counts + provenance, JSON)
    python bench/rare_subset.py repeat --reps 20        # independent subset simulations (JSON, resumable)
    python bench/rare_subset.py table                   # the table of docs/rare_events.md

``crude`` writes ``tests/data/rare_subset_reference.json`` (the reference the table and the tests read)
and keeps its scores so far in ``results/rare_subset_crude_scores.npy``, so a killed run resumes where
it stopped; ``repeat`` writes one line per repetition to ``results/rare_subset_reps.jsonl`` and resumes
the same way (``results/`` is not versioned). ``analytic`` repeats the estimate on the linear limit state
``sum(x)/sqrt(d) >= beta`` in N(0, I), whose probability Phi(-beta) is exact: the bias, the stated
against the observed CoV and the interval's coverage at p = 1e-3 and 1e-5 (``--reps 400``: about 10
CPU-minutes). The small version runs in CI: tests/test_rare_subset.py. Run niced:
``nice -n 10 .venv/bin/python bench/rare_subset.py ...``.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

import pycolfrag as pcf
from pycolfrag.rare import subset as sus

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "rare_subset_reference.json"
REPS = ROOT / "results" / "rare_subset_reps.jsonl"
#: Where ``crude`` keeps its scores so far (a killed run resumes from them).
SCORES = ROOT / "results" / "rare_subset_crude_scores.npy"
#: The verification problem (what the reference file records and the table checks).
PROBLEM = {"column": "Column.parthenon()", "mw": 6.25, "dist_km": 10.0, "edp": "u_top", "threshold": math.inf,
           "shape": "mp03", "dt_s": 0.005, "vp_scale": 1.0, "solver_options": {"monolithic": True}}
#: Scores at which the crude reference counts exceedances (u_top; inf: collapse).
COUNT_AT = (0.15, 0.35, 0.6, 0.8, 1.0, math.inf)
CRUDE_SEED = 7


def problem() -> sus.SubsetProblem:
    kw = {k: v for k, v in PROBLEM.items() if k != "column"}
    return sus.SubsetProblem(pcf.Column.parthenon(), **kw)


def jeffreys(k: int, n: int, confidence: float = 0.90) -> tuple[float, float]:
    """Jeffreys interval of a binomial proportion (Beta(k + 1/2, n - k + 1/2) quantiles)."""
    a = (1.0 - confidence) / 2.0
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a, k + 0.5, n - k + 0.5))
    hi = 1.0 if k == n else float(stats.beta.ppf(1.0 - a, k + 0.5, n - k + 0.5))
    return lo, hi


def _revision() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout
        return rev.strip() + ("+dirty" if dirty.strip() else "")
    except OSError:
        return "unknown"


def _jsonable(x):
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def crude(args) -> int:
    """The crude reference: ``--n`` runs at level 0's normals of seed ``--seed``, counts at COUNT_AT."""
    prob, out = problem(), Path(args.out)
    part = Path(args.scores)
    part.parent.mkdir(parents=True, exist_ok=True)
    done = np.load(part) if part.exists() else np.empty(0)
    if done.size > args.n:
        done = done[:args.n]
    print(f"crude Monte Carlo: {args.n} runs ({done.size} done in {part})", flush=True)
    t0, n0 = time.time(), done.size

    def save(k, scores):
        np.save(part, np.concatenate([done, scores]))
        el = time.time() - t0
        print(f"  {done.size + k} runs, collapses {int(np.sum(np.concatenate([done, scores]) == math.inf))}, "
              f"{el:.0f} s ({1e3 * el / k:.1f} ms/run)", flush=True)

    if done.size < args.n:
        rest = sus.crude_monte_carlo(prob, seed=args.seed, n=args.n - done.size, start=done.size, batch=args.batch,
                                     progress=save)
        done = np.concatenate([done, rest])
    counts = {("collapse" if math.isinf(t) else f"u_top>={t:g}"): int(np.sum(done >= t)) for t in COUNT_AT}
    k = counts["collapse"]
    ref = {"problem": {k_: _jsonable(v) for k_, v in PROBLEM.items()}, "n": int(done.size), "seed": args.seed,
           "normals": "level 0 of subset simulation with this seed (run i: SeedSequence(seed, spawn_key="
                      "(STREAM, 0, i, 0))), pycolfrag.rare.subset.crude_monte_carlo",
           "failed": int(np.sum(done == -math.inf)), "counts": counts,
           "collapse_probability": k / done.size, "collapse_jeffreys_90": jeffreys(k, int(done.size)),
           "command": "python bench/rare_subset.py crude " + " ".join(sys.argv[2:]), "revision": _revision(),
           "date": datetime.date.today().isoformat(), "machine": platform.machine(),
           "numpy": np.__version__, "wall_s_this_session": round(time.time() - t0, 1),
           "runs_this_session": int(done.size - n0)}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(ref, indent=1) + "\n")
    print(json.dumps(ref, indent=1))
    return 0


def _rep_line(seed, res, wall_s) -> dict:
    return {"seed": seed, "n_per_level": res.settings["n"], "probability": res.probability, "cov": res.cov,
            "cov_uncorrelated": res.cov_uncorrelated, "interval": list(res.interval),
            "runs": res.runs, "failed": res.failed, "converged": res.converged,
            "thresholds": [_jsonable(lv.next_threshold) for lv in res.levels],
            "acceptance": [lv.acceptance for lv in res.levels[1:]], "gamma": [lv.gamma for lv in res.levels],
            "at_u_top_0.35": list(res.at(0.35)), "at_u_top_0.6": list(res.at(0.6)), "wall_s": round(wall_s, 2)}


def repeat(args) -> int:
    """``--reps`` independent subset simulations (seeds ``--first`` ...), one JSON line each, resumable."""
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    have = {json.loads(x)["seed"] for x in out.read_text().splitlines()} if out.exists() else set()
    prob = problem()
    evaluate = sus.PoolEvaluator(args.processes) if args.processes > 1 else sus.run_batch
    try:
        for seed in range(args.first, args.first + args.reps):
            if seed in have:
                continue
            t0 = time.time()
            res = sus.subset_simulation(prob, evaluate, seed=seed, n=args.n_per_level)
            line = _rep_line(seed, res, time.time() - t0)
            with out.open("a") as f:
                f.write(json.dumps(line) + "\n")
            print(f"seed {seed}: {res.summary()} ({line['wall_s']:.0f} s)", flush=True)
    finally:
        if args.processes > 1:
            evaluate.close()
    return 0


def _ratio_band(reps: int, confidence: float = 0.90) -> tuple[float, float]:
    """Where the observed CoV of ``reps`` repetitions falls, as a fraction of the true CoV, at the
    given confidence (chi-square with reps - 1 dof: the sample sd of near-normal estimates)."""
    a = (1.0 - confidence) / 2.0
    return (math.sqrt(stats.chi2.ppf(a, reps - 1) / (reps - 1)), math.sqrt(stats.chi2.ppf(1 - a, reps - 1) / (reps - 1)))


def table_rows(ref: dict, lines: list) -> list[str]:
    """The markdown table of the subset simulations in ``lines`` against the crude reference ``ref``."""
    k, n = ref["counts"]["collapse"], ref["n"]
    p_ref, (lo, hi) = k / n, ref["collapse_jeffreys_90"]
    ps = np.array([x["probability"] for x in lines])
    covs = np.array([x["cov"] for x in lines])
    runs = float(np.mean([x["runs"] for x in lines]))
    mean, obs = float(ps.mean()), float(ps.std(ddof=1) / ps.mean())
    stated = float(np.sqrt(np.mean(covs ** 2)))
    inside = int(sum(a <= p_ref <= b for a, b in (x["interval"] for x in lines)))
    crude_runs = (1 - p_ref) / (p_ref * obs ** 2)
    band = _ratio_band(len(lines))
    return [
        f"crude reference: {k} collapses in {n} runs, p = {p_ref:.3e}, Jeffreys 90 % [{lo:.3e}, {hi:.3e}] "
        f"(revision {ref['revision'][:12]}, {ref['date']})",
        "",
        "| quantity | value |", "|---|---|",
        f"| repetitions (N = {lines[0]['n_per_level']} per level, p0 = 0.1, aCS) | {len(lines)} |",
        f"| mean estimate | {mean:.3e} ({'inside' if lo <= mean <= hi else 'OUTSIDE'} the crude 90 % interval; "
        f"SE of the mean {mean * obs / math.sqrt(len(lines)):.1e}) |",
        f"| mean estimate / crude p | {mean / p_ref:.3f} |",
        f"| stated CoV (rms over repetitions) | {stated:.3f} |",
        f"| observed CoV (sd / mean of the estimates) | {obs:.3f} |",
        f"| stated / observed | {stated / obs:.3f} (90 % band of observed/true for {len(lines)} repetitions: "
        f"[{band[0]:.2f}, {band[1]:.2f}]) |",
        f"| stated 90 % intervals holding the crude p | {inside} of {len(lines)} |",
        *_uncorrelated_rows(lines, p_ref, obs),
        f"| runs per estimate (mean) | {runs:.0f} |",
        f"| crude runs for the observed CoV, (1 - p)/(p CoV^2) | {crude_runs:.0f} |",
        f"| efficiency (crude runs / runs) | {crude_runs / runs:.1f} |",
    ]


def _uncorrelated_rows(lines: list, p_ref: float, obs: float) -> list[str]:
    """Au & Beck's sum over uncorrelated levels beside the stated CoV (repetitions that recorded it)."""
    old = [x["cov_uncorrelated"] for x in lines if "cov_uncorrelated" in x]
    if len(old) != len(lines):
        return []
    rms = math.sqrt(float(np.mean(np.square(old))))
    inside = sum(lo <= p_ref <= hi for lo, hi in (sus.lognormal_interval(x["probability"], c) for x, c in zip(lines, old)))
    return [f"| Au & Beck's sum over uncorrelated levels (rms; / observed; its 90 % intervals holding the crude p) "
            f"| {rms:.3f}; {rms / obs:.3f}; {inside} of {len(lines)} |"]


def table(args) -> int:
    ref = json.loads(Path(args.reference).read_text())
    lines = [json.loads(x) for x in Path(args.reps_file).read_text().splitlines()]
    print("\n".join(table_rows(ref, lines)))
    return 0


class Linear:
    """``sum(x) / sqrt(d) >= beta`` in N(0, I_d): P = Phi(-beta) exactly (the problem interface)."""

    def __init__(self, d: int, beta: float):
        self.dimension, self.threshold = d, beta

    def run_input(self, x, level, chain, step):
        return {"normals": x}

    def score(self, row):
        return sus.score(row, "u_top")

    def evaluate(self, batch):
        return [{"status": 0, "collapsed": 0, "u_top": float(np.sum(b["normals"])) / math.sqrt(self.dimension)}
                for b in batch]


def _coverage(results, p: float, attr: str) -> float:
    """Fraction of the results whose log-normal 90 % interval with CoV ``attr`` holds p."""
    return float(np.mean([lo <= p <= hi for lo, hi in
                          (sus.lognormal_interval(r.probability, getattr(r, attr)) for r in results)]))


def analytic(args) -> int:
    """The estimator's bias, stated against observed CoV and interval coverage where P is exact: the stated
    CoV (the levels' correlation included) and, beside it, Au & Beck's sum over uncorrelated levels."""
    print("| d | P (exact) | N | repetitions | mean / P - 1 (SE) | observed CoV | stated CoV (rms) | stated / observed "
          "| 90 % intervals holding P | Au & Beck's sum: CoV (rms), / observed, intervals holding P "
          "| runs | crude runs for the observed CoV | efficiency |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for beta in args.beta:
        for n in args.n_per_level:
            prob, p = Linear(args.d, beta), float(stats.norm.sf(beta))
            res = [sus.subset_simulation(prob, prob.evaluate, seed=r, n=n) for r in range(args.reps)]
            ps = np.array([r.probability for r in res])
            obs = ps.std(ddof=1) / ps.mean()
            stated = math.sqrt(np.mean([r.cov ** 2 for r in res]))
            cover = np.mean([r.interval[0] <= p <= r.interval[1] for r in res])
            old = math.sqrt(np.mean([r.cov_uncorrelated ** 2 for r in res]))
            runs = np.mean([r.runs for r in res])
            crude_runs = (1 - p) / (p * obs ** 2)
            print(f"| {args.d} | {p:.3e} | {n} | {args.reps} | {ps.mean() / p - 1:+.3f} ({obs / math.sqrt(args.reps):.3f}) "
                  f"| {obs:.3f} | {stated:.3f} | {stated / obs:.3f} | {cover:.2f} "
                  f"| {old:.3f}, {old / obs:.3f}, {_coverage(res, p, 'cov_uncorrelated'):.2f} | {runs:.0f} "
                  f"| {crude_runs:.3g} | {crude_runs / runs:.0f} |", flush=True)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("crude", help="the crude reference")
    c.add_argument("--n", type=int, default=100_000)
    c.add_argument("--seed", type=int, default=CRUDE_SEED)
    c.add_argument("--batch", type=int, default=1000)
    c.add_argument("--out", default=str(REFERENCE))
    c.add_argument("--scores", default=str(SCORES), help="the scores so far (resume)")
    r = sub.add_parser("repeat", help="independent subset simulations")
    r.add_argument("--reps", type=int, default=20)
    r.add_argument("--first", type=int, default=1, help="seed of the first repetition")
    r.add_argument("--n-per-level", type=int, default=sus.N_PER_LEVEL)
    r.add_argument("--processes", type=int, default=1)
    r.add_argument("--out", default=str(REPS))
    t = sub.add_parser("table", help="the table against the crude reference")
    t.add_argument("--reference", default=str(REFERENCE))
    t.add_argument("--reps-file", default=str(REPS))
    z = sub.add_parser("analytic", help="the linear limit state, exact P")
    z.add_argument("--d", type=int, default=300)
    z.add_argument("--beta", type=float, nargs="+", default=[3.090232306167813, 4.264890793922602],
                   help="P = Phi(-beta): 1e-3 and 1e-5 by default")
    z.add_argument("--n-per-level", type=int, nargs="+", default=[500, 1000])
    z.add_argument("--reps", type=int, default=400)
    a = ap.parse_args(argv)
    return {"crude": crude, "repeat": repeat, "table": table, "analytic": analytic}[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
