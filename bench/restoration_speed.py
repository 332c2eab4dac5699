"""Solver speed of the restoration choices (README "Speed", docs/restoration.md): microseconds per step
of the default column free, with titanium and with wooden dowels in every joint, and of the 2- and
4-column portals with epistyles, on the case of the README's speed table (17 s of a 0.25 g 2 Hz sine and
3 s of tail, vertex contacts, dt 0.8 of the stability limit). The cases are timed in turn, best of
``--repeat``, so that other jobs on a shared machine slow them alike. Prints a table.

With ``--batch N``: the grid's case instead -- N rows of the default grid (its records, spread over its
scenarios, default options) through ``simulate_batch`` as a grid chunk runs them, at the default width (runs
in SIMD lanes) and one after the other (width 1), the cases in turn, best of ``--repeat``; CPU time of the
calling thread (where the C runs go) per run-step, so that other jobs on the machine do not count.

    python bench/restoration_speed.py [--repeat 5] [--batch 16]
"""
from __future__ import annotations

import argparse
import platform
import time

import numpy as np

import pycolfrag as pcf
from pycolfrag.structure.connectors import Connectors
from pycolfrag.structure.scene import Colonnade


def cases() -> dict:
    col = pcf.Column.parthenon()
    return {"free column": col,
            "titanium dowels": col.with_connectors(Connectors.of("titanium", "all")),
            "wooden dowels": col.with_connectors(Connectors.of("wood", "all")),
            "2-column portal": Colonnade.portal(2),
            "4-column portal": Colonnade.portal(4)}


def _cpu() -> str:
    for line in open("/proc/cpuinfo", encoding="utf-8"):
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown CPU"


def grid_records(n: int) -> list:
    """n rows of the default grid (spread over its scenarios), as a grid chunk synthesises them."""
    from pycolfrag.grid import GridSpec
    spec = GridSpec()
    ctx = spec.context()
    recs = []
    for row in sorted({int(r) for r in np.linspace(0, spec.n_rows - 1, n).round()}):
        sc, k, mw, dist = ctx.locate(row)
        rec = pcf.ground_motion.synthesize(mw, dist, ctx.hf_seed(sc, k), dt=spec.record_dt_s, vp_scale=spec.vp_scale,
                                           pulse=ctx.pulse(sc, k))
        recs.append((np.ascontiguousarray(rec.acc), rec.dt))
    return recs


def batches(n: int, repeat: int) -> None:
    """The grid's case: CPU us per run-step of each structure's batch, in lanes and one run at a time."""
    recs = grid_records(n)
    models = cases()
    widths = {name: (None, 1) for name in models}
    best = {(name, w): np.inf for name in models for w in widths[name]}
    steps: dict = {}
    used: dict = {}
    for _ in range(repeat):
        for name, m in models.items():
            for w in widths[name]:
                t0 = time.thread_time()
                out = pcf.simulate_batch(m, recs, width=w)
                best[name, w] = min(best[name, w], time.thread_time() - t0)
                steps[name, w] = sum(r.n_steps for r in out)
                used[name, w] = w or pcf.solver.run.batch_width(m, n_runs=len(recs))
    print(f"{_cpu()}; {len(recs)} rows of the default grid, best CPU time of {repeat}")
    print(f"{'case':<18} {'width':>5} {'run-steps':>10} {'us/run-step':>12} {'x free per column':>20}")
    for (name, w), t in best.items():
        us = 1e6 * t / steps[name, w]
        free = 1e6 * best["free column", w] / steps["free column", w]   # a portal: per column, to the free lanes
        ncol = models[name].n_columns if isinstance(models[name], Colonnade) else 1
        print(f"{name:<18} {used[name, w]:>5} {steps[name, w]:>10} {us:>12.3f} {us / ncol / free:>20.2f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5, help="timings of each case (the best is kept)")
    p.add_argument("--batch", type=int, default=0, help="N: the grid's case, N rows in a batch (0: the single run's)")
    args = p.parse_args(argv)
    if args.batch:
        batches(args.batch, args.repeat)
        return 0
    t = np.arange(0.0, 17.0, 0.005)
    acc = 0.25 * 9.81 * np.sin(2 * np.pi * 2.0 * t)
    models = cases()
    best = {k: np.inf for k in models}
    steps = {}
    for _ in range(args.repeat):
        for name, m in models.items():
            t0 = time.perf_counter()
            r = pcf.simulate(m, acc, 0.005, early_exit=False)
            best[name] = min(best[name], time.perf_counter() - t0)
            steps[name] = (r.n_steps, r.dt)
    free = best["free column"] / steps["free column"][0]
    print(f"{'case':<18} {'steps':>7} {'dt (ms)':>8} {'us/step':>8} {'x free':>7} {'us/step/column':>15}")
    for name, m in models.items():
        n, dt = steps[name]
        us = 1e6 * best[name] / n
        ncol = m.n_columns if isinstance(m, Colonnade) else 1
        print(f"{name:<18} {n:>7} {1e3 * dt:>8.4f} {us:>8.2f} {us / (1e6 * free):>7.2f} {us / ncol:>15.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
