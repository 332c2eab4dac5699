#!/usr/bin/env python3
"""Scaling of the grid over ranks: measured here, and predicted by the replay model (never a test).

    .venv/bin/python bench/scale_out.py measure DIR [--ranks 1 2 4 8] [--repeat 2] [--grid "..."]
    .venv/bin/python bench/scale_out.py validate DIR          # the replay against those runs, error stated
    .venv/bin/python bench/scale_out.py predict [--results /work/baseline/grid_full.h5]

``measure`` runs the grid (default: 2 Mw x 2 R x 20 samples = 80 rows) on each rank count, one run after
the other, ranks beyond the machine's cores oversubscribed (``mpirun --oversubscribe``), and keeps each
run's results file (its rows and timeline), its job time (the launcher's start to its exit) and the
cores the job got (the machine's cores less the background load of other jobs, from ``/proc/stat``
less this job's CPU time). ``validate`` replays every run with what it measured (the rows of the
one-rank run, its chunks' CPU time as the one calibration, the fixed costs of the timelines, the job's
cores and, oversubscribed, the measured polling weight of a waiting rank) and prints measured against
predicted times on both clocks, and the start-up CPU per rank. ``predict`` prints the tables of
docs/performance.md: efficiency on both clocks (``E_job``: launch to exit; ``E_session``: run_grid's
own clock) for N = 1 ... 1024, one core per rank, b2afe10's scheduler and this one, the default grid and
a 35 000-row grid, on AVX-512 (8 lanes) and AVX2 (4 lanes), and the issue's targets.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pycolfrag.analysis.timeline import summarise  # noqa: E402
from pycolfrag.grid import replay as RP  # noqa: E402
from pycolfrag.results.timeline import read_timeline  # noqa: E402

GRID = "--mw 6.5 7.5 --dist 5 20 --samples 20"

SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)
_START_UP = ("launch", "imports", "mpi_init", "checks", "identity")


def _busy_s() -> float:
    """CPU seconds the whole machine has been busy since boot (/proc/stat, every CPU)."""
    with open("/proc/stat") as fh:
        f = [int(x) for x in fh.readline().split()[1:]]
    return (sum(f) - f[3] - f[4]) / os.sysconf("SC_CLK_TCK")   # less idle and iowait


def _env() -> dict:
    env = {k: v for k, v in os.environ.items()
           if not (k.startswith(("PMIX_", "OMPI_")) and not k.startswith("OMPI_ALLOW_RUN_AS_ROOT"))}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    return env


def measure(args) -> None:
    out = Path(args.dir)
    out.mkdir(parents=True, exist_ok=True)
    for k in range(args.repeat):
        for n in args.ranks:
            h5 = out / f"n{n}_r{k}.h5"
            for p in (h5, Path(f"{h5}.journal"), Path(f"{h5}.lock")):
                p.unlink(missing_ok=True)
            cmd = [sys.executable, "scripts/run_grid.py"] if n == 1 else \
                ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(n), sys.executable, "-m", "mpi4py",
                 "scripts/run_grid.py"]
            cmd += [*shlex.split(args.grid), "--no-figures", "--no-progress", "--out", str(h5)]
            r0, b0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), _busy_s(), time.time()
            p = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=ROOT)
            t1, b1, r1 = time.time(), _busy_s(), resource.getrusage(resource.RUSAGE_CHILDREN)
            if p.returncode != 0:
                raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
            job_cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
            background = max(0.0, (b1 - b0 - job_cpu) / (t1 - t0))
            run = {"n": n, "repeat": k, "h5": str(h5), "t_launch": t0, "t_exit": t1, "wall": t1 - t0,
                   "job_cpu": job_cpu, "background_cores": background, "cores": os.cpu_count()}
            (out / f"n{n}_r{k}.json").write_text(json.dumps(run, indent=1))
            print(f"n={n} r{k}: {t1 - t0:.2f} s, job CPU {job_cpu:.2f} s, background {background:.2f} cores", flush=True)


def _session(h5: str) -> dict:
    return list(read_timeline(h5).values())[-1]


def _spin(sess: dict) -> float | None:
    """A waiting worker's CPU per wall second over a computing one's (Open MPI polls or yields)."""
    rows, names = sess["rows"], sess["kinds"]
    kinds = np.array([names[k] for k in rows["kind"]])
    workers = rows["rank"] > 0
    w = workers & (kinds == "wait")
    c = workers & (kinds == "chunk")
    ww, cw = (rows["t1"] - rows["t0"])[w].sum(), (rows["t1"] - rows["t0"])[c].sum()
    if ww <= 0.05 or cw <= 0:
        return None
    return float((np.nansum(rows["cpu_s"][w]) / ww) / (np.nansum(rows["cpu_s"][c]) / cw))


def validate(args) -> None:
    runs = sorted((json.loads(p.read_text()) for p in Path(args.dir).glob("n*_r*.json")),
                  key=lambda r: (r["repeat"], r["n"]))
    ref = next(r for r in runs if r["n"] == 1)
    rows, _ = RP.Rows.from_results(ref["h5"])
    sessions = {r["h5"]: _session(r["h5"]) for r in runs}
    # fixed costs: the medians over every rank of every run
    pooled = {"rows": np.concatenate([s["rows"] for s in sessions.values()]), "kinds": sessions[ref["h5"]]["kinds"]}
    costs = RP.costs_from_timeline(pooled)
    chunks = [s["rows"] for s in [sessions[ref["h5"]]]][0]
    chunk_cpu = float(np.nansum(chunks["cpu_s"][chunks["kind"] == pooled["kinds"].index("chunk")]))
    spins = [x for r in runs if r["n"] > r["cores"] for x in [_spin(sessions[r["h5"]])] if x is not None]
    spin_over = float(np.median(spins)) if spins else 0.1
    print(f"{len(runs)} runs of {rows.n} rows; fixed costs (CPU s, medians): imports {costs.imports:.3f}, interpreter "
          f"{costs.interp:.3f}, MPI {costs.mpi_init:.3f}, checks {costs.checks:.3f}, identity {costs.identity:.3f}, "
          f"open {costs.open_cpu:.3f}, flush {costs.flush_cpu:.3f}; polling weight oversubscribed {spin_over:.2f}")
    print(f"{'run':8s} {'cores':>5s} | {'job meas':>8s} {'pred':>7s} {'err':>7s} | {'session':>7s} {'pred':>7s} "
          f"{'err':>7s} | {'chunk CPU':>9s} {'pred':>7s} | chunks")
    errs = {"job": [], "session": []}
    for r in runs:
        sess = sessions[r["h5"]]
        s = summarise(sess)
        n, cores = r["n"], r["cores"] - r["background_cores"]
        c = RP.calibrate(rows, costs, RP.CURRENT, 1, chunk_cpu) if r is ref else \
            RP.calibrate(rows, costs, RP.CURRENT, 1, chunk_cpu)
        m = RP.Machine(cores=cores, spin=1.0 if n <= r["cores"] else spin_over, sleep_extra=0.5e-3)
        p = RP.simulate(rows, n, RP.CURRENT, c, m)
        meas_chunk = s["ranks"] and sum(pr["cpu_s"] for pr in s["ranks"])
        ej, es = p["t_final"] / s["job_s"] - 1, p["t_session"] / s["session_s"] - 1
        errs["job"].append(ej)
        errs["session"].append(es)
        print(f"n{n}_r{r['repeat']:<4d} {cores:5.2f} | {s['job_s']:8.2f} {p['t_final']:7.2f} {100 * ej:+6.1f}% | "
              f"{s['session_s']:7.2f} {p['t_session']:7.2f} {100 * es:+6.1f}% | {meas_chunk:9.2f} {p['chunk_cpu']:7.2f} | "
              f"{s['chunks']}/{p['n_chunks']}")
    for k, v in errs.items():
        v = np.array(v)
        print(f"{k} error: rms {100 * np.sqrt(np.mean(v ** 2)):.1f} %, worst {100 * np.max(np.abs(v)):.1f} %, "
              f"mean {100 * np.mean(v):+.1f} %")
    _measured_efficiency(runs, sessions)
    _start_up_table(runs, sessions)


def _measured_efficiency(runs, sessions) -> None:
    """E(N) = T(1) / (N T(N)) of the measured runs, each against the one-rank run of its own round, on
    the job's clock (the launcher's start to its exit), the timeline's (first launch to the final write)
    and the session's (run_grid's), with the cores the job got."""
    print("measured efficiency, each round against its own 1-rank run (E = T1 / (N T_N)):")
    print(f"{'run':8s} {'cores':>5s} {'T job s':>8s} {'E job':>6s} {'T launch-write':>14s} {'E':>6s} "
          f"{'T session':>9s} {'E':>6s}")
    for r in runs:
        one = next(x for x in runs if x["n"] == 1 and x["repeat"] == r["repeat"])
        s, s1 = summarise(sessions[r["h5"]]), summarise(sessions[one["h5"]])
        n = r["n"]
        print(f"n{n}_r{r['repeat']:<4d} {r['cores'] - r['background_cores']:5.2f} {r['wall']:8.2f} "
              f"{100 * one['wall'] / (n * r['wall']):5.1f}% {s['job_s']:14.2f} "
              f"{100 * s1['job_s'] / (n * s['job_s']):5.1f}% {s['session_s']:9.2f} "
              f"{100 * s1['session_s'] / (n * s['session_s']):5.1f}%")


def _start_up_table(runs, sessions) -> None:
    """The start-up CPU per rank, by phase: medians over the ranks of each rank count."""
    print("start-up CPU per rank (s, median over ranks and runs):")
    by_n: dict = {}
    for r in runs:
        sess = sessions[r["h5"]]
        rows, names = sess["rows"], sess["kinds"]
        for rank in np.unique(rows["rank"]):
            m = rows["rank"] == rank
            cpu = {k: float(np.nansum(rows["cpu_s"][m & (rows["kind"] == names.index(k))])) for k in _START_UP}
            by_n.setdefault(r["n"], []).append(cpu)
    print(f"{'phase':10s} " + " ".join(f"{'N=' + str(n):>7s}" for n in sorted(by_n)))
    for k in (*_START_UP, "total"):
        vals = [np.median([sum(c.values()) if k == "total" else c[k] for c in by_n[n]]) for n in sorted(by_n)]
        print(f"{k:10s} " + " ".join(f"{v:7.3f}" for v in vals))


def predict(args) -> None:
    rows, costs, info = RP.measured(args.results)
    print(f"costs: {args.results} ({rows.n} rows, written by the {info['policy']} scheduler on {info['n_ranks']} "
          f"rank(s)), scale {costs.sigma_scale:.3f}; one core per rank")
    before_costs = replace(costs, imports=RP.IMPORTS_WITH_SCIPY_S)
    if info["policy"] == RP.BEFORE.name:   # the file's own run, replayed: the check of the calibration
        own = RP.simulate(rows, info["n_ranks"], RP.BEFORE, before_costs)
        print(f"the file's own session ({info['n_ranks']} ranks, b2afe10): measured {info['session_s']:.1f} s, "
              f"replayed {own['t_session']:.1f} s")
    targets = {}
    for label, rws in (("default grid, 3500 rows", rows), ("35 000 rows (1000 samples)", rows.resample(1000))):
        for lanes in (8, 4):
            print(f"\n== {label}, {lanes} lanes ({'AVX-512' if lanes == 8 else 'AVX2'}) ==")
            print(f"{'policy':10s} {'':9s} " + " ".join(f"{n:>11d}" for n in args.ranks))
            for pol, c in ((RP.BEFORE, before_costs), (RP.CURRENT, costs)):
                c = RP.on_avx2(c) if lanes == 4 else c   # an AVX2 CPU: its own costs per run-step
                res = RP.efficiency(rws, args.ranks, pol, c)
                print(f"{pol.name:10s} {'E job/ses':9s} " + " ".join(
                    f"{100 * r['E_job']:5.1f}/{100 * r['E_session']:5.1f}" for r in res))
                print(f"{'':10s} {'T_job s':9s} " + " ".join(f"{r['t_job']:11.2f}" for r in res))
                if pol is RP.CURRENT and lanes == 8:
                    targets[label] = {r["size"]: r for r in res}
    print("\ntargets (predicted, one core per rank, 8 lanes):")
    d, big = targets["default grid, 3500 rows"], targets["35 000 rows (1000 samples)"]
    for text, r, goal in (("default grid, 16 ranks >= 90 %", d.get(16), 0.9),
                          ("default grid, 128 ranks >= 80 %", d.get(128), 0.8),
                          ("35 000 rows, 128 ranks >= 90 %", big.get(128), 0.9)):
        if r is not None:
            print(f"  {text}: E_job {100 * r['E_job']:.1f} %, E_session {100 * r['E_session']:.1f} % -> "
                  f"job clock {'met' if r['E_job'] >= goal else 'NOT met'}, session clock "
                  f"{'met' if r['E_session'] >= goal else 'NOT met'}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="what", required=True)
    m = sub.add_parser("measure")
    m.add_argument("dir")
    m.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4, 8])
    m.add_argument("--repeat", type=int, default=2)
    m.add_argument("--grid", default=GRID)
    v = sub.add_parser("validate")
    v.add_argument("dir")
    q = sub.add_parser("predict")
    q.add_argument("--results", default="/work/baseline/grid_full.h5")
    q.add_argument("--ranks", type=int, nargs="+", default=list(SIZES))
    args = p.parse_args(argv)
    {"measure": measure, "validate": validate, "predict": predict}[args.what](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
