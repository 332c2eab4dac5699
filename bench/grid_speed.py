#!/usr/bin/env python3
"""Speed of the Monte Carlo grid: 1 vs 2 ranks, per-sample cost split, full-grid estimate.

    .venv/bin/python bench/grid_speed.py              # reduced grid: 35 scenarios x 2 samples
    .venv/bin/python bench/grid_speed.py --samples 4  # more samples per scenario, better estimate
    .venv/bin/python bench/grid_speed.py --full       # also time the whole default grid on 2 ranks

1. Per-sample split, in this process: one sample of every scenario, timing record synthesis,
   intensity measures and the solver separately; "driver" = run_sample's wall time minus those
   (seeding, LHS table, dict building).
2. The reduced grid (all 35 scenarios, ``--samples`` each) through ``scripts/run_grid.py`` on 1 rank
   and on 2 ranks (``mpirun -n 2 python -m mpi4py``): wall time of the whole command and of the
   driver's session (from the file's ``wall_s_last_session``), and the speed-up. The results of both
   runs are compared (they must be identical).
3. Full default grid (3500 runs) on 2 ranks, estimated as the 2-rank session time x 100 / samples
   (the reduced grid has the same scenario mix), plus process start-up; measured with ``--full``.

The machine may be shared: the printed times are what this run saw. Never a test (times depend on the
machine and its load).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "run_grid.py"
sys.path.insert(0, str(ROOT))


def _env():
    env = {k: v for k, v in os.environ.items()
           if not (k.startswith("PMIX_") or k.startswith("OMPI_")) or k.startswith("OMPI_ALLOW_RUN_AS_ROOT")}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join([str(ROOT / "tests"), os.environ.get("PYTHONPATH", "")]))
    return env


def run(n_ranks: int, args: list[str], timeout: float) -> float:
    if n_ranks == 1:
        cmd = [sys.executable, str(SCRIPT), *args]
    else:
        cmd = ["mpirun", "--allow-run-as-root", "-n", str(n_ranks), sys.executable, "-m", "mpi4py", str(SCRIPT), *args]
    cmd = ["timeout", "-k", "10", str(int(timeout)), *cmd]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=ROOT)
    t = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    return t


def phase_split(extra_args: list[str]) -> dict:
    """Time record / IMs / solver / driver for one sample of every scenario, in this process."""
    from pycolfrag import grid
    from pycolfrag.ground_motion import intensity, synthesis
    from pycolfrag.solver import run as solver
    spec = grid.spec_from_args(grid.build_parser().parse_args(["--samples", "2", *extra_args]))
    ctx = grid.SampleContext(spec)
    acc_t = {"record": 0.0, "ims": 0.0, "solver": 0.0}
    # a row's record comes from its scenario's prepared synthesis (ground_motion/synthesis.py)
    orig = (synthesis.ScenarioSynthesis.record, intensity.record_measures, solver.simulate)

    def timed(name, f):
        def g(*a, **k):
            t0 = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                acc_t[name] += time.perf_counter() - t0
        return g

    synthesis.ScenarioSynthesis.record = timed("record", orig[0])  # type: ignore[method-assign]
    intensity.record_measures = timed("ims", orig[1])
    solver.simulate = timed("solver", orig[2])
    total, n, record_s, failed = 0.0, 0, 0.0, 0
    try:
        for sc in range(len(spec.scenarios)):
            ctx.pulse(sc, 0)  # the per-scenario LHS is built once per scenario per rank: count it apart
            out = grid.run_sample(ctx, sc * spec.samples)
            total += out["wall_s"]
            record_s += out.get("record_s", 0.0) or 0.0
            failed += out["status"] != 0
            n += 1
    finally:
        synthesis.ScenarioSynthesis.record, intensity.record_measures, solver.simulate = orig  # type: ignore[method-assign]
    per = {k: v / n for k, v in acc_t.items()}
    per["driver"] = total / n - sum(per.values())
    per["total"] = total / n
    per["record_s"] = record_s / n
    per["failed"] = failed
    return per


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=2, help="samples per scenario of the reduced grid")
    ap.add_argument("--full", action="store_true", help="also run the whole default grid on 2 ranks")
    ap.add_argument("--keep", default=None, help="folder for the result files (default: a temporary one)")
    ap.add_argument("extra", nargs="*", help="more run_grid.py options, after --")
    a = ap.parse_args()
    if shutil.which("mpirun") is None:
        raise SystemExit("mpirun not found (make system)")
    from pycolfrag import results as R
    from pycolfrag.analysis.data import load

    print("== per-sample split (one sample of each of the 35 scenarios, this process) ==")
    per = phase_split(a.extra)
    print(f"{'phase':<10} {'ms/sample':>10} {'share':>7}")
    for k in ("record", "ims", "solver", "driver", "total"):
        print(f"{k:<10} {1e3 * per[k]:10.1f} {100 * per[k] / per['total']:6.1f}%")
    print(f"mean record length {per['record_s']:.1f} s; failed samples: {per['failed']}")

    work = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="grid_speed_"))
    work.mkdir(parents=True, exist_ok=True)
    n_runs = 35 * a.samples
    common = ["--samples", str(a.samples), "--no-figures", "--no-progress", "--overwrite", *a.extra]
    rows = []
    files = {}
    for n in (1, 2):
        out = work / f"reduced_{n}.h5"
        t = run(n, [*common, "--out", str(out)], timeout=3600)
        r = load(out)
        files[n] = r
        rows.append((n, t, float(r.attrs["wall_s_last_session"])))
    print(f"\n== reduced grid: 35 scenarios x {a.samples} samples = {n_runs} runs ==")
    print("utilisation = summed sample wall times / (session time x ranks): the share of the ranks' time spent")
    print("in samples (scheduling, I/O and the tail cost the rest; a busy machine slows the samples, not this)")
    print(f"{'ranks':>5} {'command s':>10} {'session s':>10} {'ms/run':>8} {'speed-up':>9} {'utilisation':>12}")
    for n, t, s in rows:
        util = float(np.nansum(files[n].samples["wall_s"])) / (s * n)
        print(f"{n:5d} {t:10.2f} {s:10.2f} {1e3 * s / n_runs:8.1f} {rows[0][2] / s:9.2f} {util:12.2f}")
    a1, a2 = files[1], files[2]
    same = all(np.array_equal(a1.samples[k], a2.samples[k], equal_nan=a1.samples[k].dtype.kind == "f")
               for k in a1.samples if k not in R.TIMING_FIELDS)
    print(f"1-rank and 2-rank datasets identical: {same}")
    startup = rows[1][1] - rows[1][2]
    est = rows[1][2] * 100.0 / a.samples + startup
    print(f"\nfull default grid (3500 runs) on 2 ranks, estimated: {est:.0f} s = {est / 60:.1f} min "
          f"(session x {100 / a.samples:.0f} + {startup:.1f} s start-up; target <= 300 s)")
    if a.full:
        out = work / "full_2.h5"
        t = run(2, ["--no-figures", "--no-progress", "--overwrite", *a.extra, "--out", str(out)], timeout=4 * 3600)
        r = load(out)
        print(f"full default grid on 2 ranks, measured: command {t:.0f} s = {t / 60:.1f} min, "
              f"session {float(r.attrs['wall_s_last_session']):.0f} s; failed {int((r.samples['status'] != 0).sum())}")
    print(f"(result files in {work})")
    summary = {"per_sample_ms": {k: 1e3 * per[k] for k in ("record", "ims", "solver", "driver", "total")},
               "reduced": [{"ranks": n, "command_s": t, "session_s": s} for n, t, s in rows],
               "speedup": rows[0][2] / rows[1][2], "full_estimate_s": est}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
