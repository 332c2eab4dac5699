"""Speed of the rigid-drum solver (a benchmark, never a timed test; results in docs/solver.md).

Default column (Column.parthenon()), 0.25 g 2 Hz sine for 3 s then free motion,
20 s simulated in all. For each fidelity option: steps, solver step, microseconds per
step, simulated seconds per wall second and wall time per 20 s (best of --repeat runs,
so that other processes on a shared machine inflate the figure as little as possible).

    .venv/bin/python bench/solver_speed.py [--repeat 5]
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

import pycolfrag as pcf
from pycolfrag.grid.schedule import cpu_model

CASES = [
    ("vertex (default)", dict(contact="vertex")),
    ("perimeter, 1 pt/edge", dict(contact="perimeter", points_per_edge=1)),
    ("perimeter, 2 pts/edge", dict(contact="perimeter", points_per_edge=2)),
    ("perimeter, 4 pts/edge", dict(contact="perimeter", points_per_edge=4)),
    ("exact", dict(contact="exact")),
    ("vertex, planar", dict(contact="vertex", planar=True)),
    ("exact, planar", dict(contact="exact", planar=True)),
    ("vertex, monolithic", dict(contact="vertex", monolithic=True)),
    ("vertex, dt_factor 0.5", dict(contact="vertex", dt_factor=0.5)),
]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per case; the fastest is reported")
    args = ap.parse_args(argv)
    col = pcf.Column.parthenon()
    dt = 0.005
    t = np.arange(0.0, 3.0 + dt / 2, dt)
    acc = 0.25 * 9.81 * np.sin(2 * np.pi * 2.0 * t)
    tail = 20.0 - t[-1]
    print(f"default column, 0.25 g 2 Hz sine for 3 s, {20.0:.0f} s simulated; best of {args.repeat} runs")
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    print(f"{'option':<24} {'steps':>7} {'dt ms':>7} {'us/step':>8} {'sim s/wall s':>13} {'wall s/20 s':>12} "
          f"{'u_top':>7} {'energy err':>10}")
    for name, opts in CASES:
        best = float("inf")
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            res = pcf.simulate(col, acc, dt, tail_s=tail, early_exit=False, **opts)
            best = min(best, time.perf_counter() - t0)
        print(f"{name:<24} {res.n_steps:>7d} {1e3 * res.dt:>7.3f} {1e6 * best / res.n_steps:>8.2f} "
              f"{res.t_end / best:>13.0f} {best * 20.0 / res.t_end:>12.3f} {res.u_top:>7.4f} {res.energy_error:>10.2e}")
    # the fixed cost of one call (set-up incl. the whole-stack stability limit, Python
    # checks and conversions): a record of two samples and no tail
    best = float("inf")
    for _ in range(20 * args.repeat):
        t0 = time.perf_counter()
        pcf.simulate(col, acc[:2], dt, tail_s=0.0)
        best = min(best, time.perf_counter() - t0)
    print(f"fixed cost per simulate() call (set-up, checks; 2-sample record): {1e3 * best:.2f} ms")


if __name__ == "__main__":
    main()
