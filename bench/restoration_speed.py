"""Solver speed of the restoration choices (README "Speed", docs/restoration.md): microseconds per step
of the default column free, with titanium and with wooden dowels in every joint, and of the 2- and
4-column portals with epistyles, on the case of the README's speed table (17 s of a 0.25 g 2 Hz sine and
3 s of tail, vertex contacts, dt 0.8 of the stability limit). The cases are timed in turn, best of
``--repeat``, so that other jobs on a shared machine slow them alike. Prints a table.

    python bench/restoration_speed.py [--repeat 5]
"""
from __future__ import annotations

import argparse
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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5, help="timings of each case (the best is kept)")
    args = p.parse_args(argv)
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
