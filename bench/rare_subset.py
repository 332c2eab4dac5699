"""Subset simulation against brute force: the estimate, its stated CoV and interval, against crude Monte
Carlo of the same runs (docs/rare_events.md, "Subset simulation").

The verification problem: collapse of the Parthenon column as one rigid body (``monolithic``: about 2 ms
a run with its record) under the pulse records of Mw 6.25 at 10 km, p about 1e-3. Three steps:

    python bench/rare_subset.py crude --n 100000        # the crude reference (counts + provenance, JSON)
    python bench/rare_subset.py repeat --reps 20        # independent subset simulations (JSON, resumable)
    python bench/rare_subset.py table                   # the table of docs/rare_events.md

``crude`` writes ``tests/data/rare_subset_reference.json`` (the reference the table and the tests read)
and keeps its scores so far beside the file (``.npy``), so a killed run resumes where it stopped;
``repeat`` writes one line per repetition to ``bench/results/rare_subset_reps.jsonl`` and resumes the
same way. ``--quick`` runs the small version: the analytic check (a linear limit state in N(0, I),
whose probability is known exactly) and three subset simulations of the real problem at N = 200.
Run niced: ``nice -n 10 .venv/bin/python bench/rare_subset.py ...``.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
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
REPS = ROOT / "bench" / "results" / "rare_subset_reps.jsonl"
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
    part = out.with_suffix(".scores.npy")
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("crude", help="the crude reference")
    c.add_argument("--n", type=int, default=100_000)
    c.add_argument("--seed", type=int, default=CRUDE_SEED)
    c.add_argument("--batch", type=int, default=1000)
    c.add_argument("--out", default=str(REFERENCE))
    a = ap.parse_args(argv)
    return {"crude": crude}[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
