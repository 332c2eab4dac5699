"""Sample functions for the grid tests (loaded by ``--sample-function grid_fakes:NAME``; the
tests put this folder on PYTHONPATH).

* ``fake``: no physics; deterministic numbers from the row's own seeds, so the driver's
  scheduling, resume and rank independence are tested without the solver. ``PCF_FAKE_SLEEP_S``
  makes each row take that long (to kill a run part-way); ``PCF_FAKE_BUSY_S`` burns CPU for
  about that long times (1 + 4 (Mw - 5.5)) (scheduler benchmarks without the solver).
* ``ranked``: ``fake`` whose row's message names the MPI rank that computed it (scheduling tests).
* ``failing``: :func:`real_solver`, except that the rows listed in
  ``PCF_FAIL_ROWS`` (comma-separated) raise.
* ``failing_fake``: ``fake`` with the same forced failures.
* ``real_solver``: :func:`pycolfrag.grid.run_sample` (the real records, IMs and solver).
"""
import os
import time

import numpy as np

from pycolfrag.grid import run_sample


def _fail_rows():
    return {int(x) for x in os.environ.get("PCF_FAIL_ROWS", "").split(",") if x.strip()}


def fake(ctx, row):
    sc, k, mw, dist = ctx.locate(row)
    rng = np.random.default_rng(ctx.hf_seed(sc, k))
    lhs = np.random.default_rng(ctx.lhs_seed(sc)).random(ctx.spec.samples)[k]
    time.sleep(float(os.environ.get("PCF_FAKE_SLEEP_S", "0")))
    busy = float(os.environ.get("PCF_FAKE_BUSY_S", "0")) * (1.0 + 4.0 * (mw - 5.5)) * (0.5 + lhs)
    t_end = time.perf_counter() + busy  # CPU-bound, cost growing with Mw like the real runs
    while time.perf_counter() < t_end:
        pass
    x = rng.random(8)
    n_p = len(ctx.spec.periods_s)
    return {"scenario": sc, "sample": k, "mw": mw, "dist_km": dist, "status": 0, "message": "",
            "vp_cm_s": 50 * lhs * mw, "fp_hz": x[0], "nu_rad": x[1], "gamma": 2 + x[2], "t0_s": 5.0,
            "pga_g": x[3], "pgv_cm_s": 100 * x[4], "pgd_cm": x[5], "arias_m_s": x[6], "d5_95_s": 10 * x[7],
            "u_top": x[3] * x[4], "u_d": x[5] * 0.01, "collapsed": int(x[3] > 0.9),
            "sa_g": rng.random(n_p), "sv_cm_s": rng.random(n_p)}


def ranked(ctx, row):
    out = fake(ctx, row)
    from mpi4py import MPI  # already loaded by the grid that calls this (any launcher)
    out["message"] = f"rank {MPI.COMM_WORLD.Get_rank()}"
    return out


def failing(ctx, row):
    if row in _fail_rows():
        raise RuntimeError(f"forced failure of row {row}")
    return real_solver(ctx, row)


def failing_fake(ctx, row):
    if row in _fail_rows():
        raise RuntimeError(f"forced failure of row {row}")
    return fake(ctx, row)


def real_solver(ctx, row):
    """The default per-sample function (real records, IMs and solver)."""
    return run_sample(ctx, row)
