"""Sample functions for the grid tests (loaded by ``--sample-function grid_fakes:NAME``; the
tests put this folder on PYTHONPATH).

* ``fake``: no physics; deterministic numbers from the row's own seeds, so the driver's
  scheduling, resume and rank independence are tested without the solver. ``PCF_FAKE_SLEEP_S``
  makes each row take that long (to kill a run part-way); ``PCF_FAKE_BUSY_S`` burns CPU for
  about that long times (1 + 4 (Mw - 5.5)) (scheduler benchmarks without the solver).
* ``failing``: :func:`real_solver`, except that the rows listed in
  ``PCF_FAIL_ROWS`` (comma-separated) raise.
* ``failing_fake``: ``fake`` with the same forced failures.
* ``real_solver``: :func:`pycolfrag.grid.run_sample`; stand-in records and IMs are installed only
  if ``pycolfrag.ground_motion.synthesize`` / ``pycolfrag.intensity.measures`` do not exist.
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


def failing(ctx, row):
    if row in _fail_rows():
        raise RuntimeError(f"forced failure of row {row}")
    return real_solver(ctx, row)


def failing_fake(ctx, row):
    if row in _fail_rows():
        raise RuntimeError(f"forced failure of row {row}")
    return fake(ctx, row)


def _standin_ground_motion():
    """Pulse-plus-noise records and simple IMs, used only while the real generator is missing."""
    import types

    import pycolfrag.ground_motion as gm
    import pycolfrag.intensity as im

    def sample_pulse_parameters(Mw, dist_km, n, seed, vp_scale=1.0):
        rng = np.random.default_rng(seed)
        u = (np.arange(n) + rng.random(n)) / n
        return {"Vp_cm_s": vp_scale * 10 ** (0.3 * Mw - 0.0 - 0.4 * np.log10(dist_km)) * (0.7 + 0.6 * u),
                "fp_hz": 10 ** (2.0 - 0.35 * Mw) * (0.8 + 0.4 * rng.permutation(u)),
                "nu_rad": 2 * np.pi * rng.permutation(u), "gamma": 1.5 + 2 * rng.permutation(u),
                "t0_s": 4 + 2 * rng.permutation(u)}

    def synthesize(Mw, dist_km, seed, dt=0.005, vp_scale=1.0, pulse=None):
        rng = np.random.default_rng(seed)
        dur = 5 + 2.5 * (Mw - 5) + 0.1 * dist_km
        t = np.arange(int(dur / dt)) * dt
        fp, vp, g, nu, t0 = (pulse[k] for k in ("fp_hz", "Vp_cm_s", "gamma", "nu_rad", "t0_s"))
        env = np.where(np.abs(t - t0) <= g / (2 * fp), 0.5 * (1 + np.cos(2 * np.pi * fp * (t - t0) / g)), 0.0)
        acc = 0.01 * vp * 2 * np.pi * fp * env * np.cos(2 * np.pi * fp * (t - t0) + nu)
        acc += 0.3 * rng.normal(size=t.size) * np.exp(-((t - t0) / (0.3 * dur)) ** 2)
        return types.SimpleNamespace(acc=acc, dt=dt, meta=dict(pulse, A_cm_s=vp, Ap_g=float(np.abs(acc).max() / 9.81)))

    def measures(acc, dt, periods=(0.2, 0.5, 1.0, 2.0, 3.0), damping=0.05):
        v = np.cumsum(acc) * dt
        d = np.cumsum(v) * dt
        ia = np.cumsum(acc ** 2) * dt * np.pi / (2 * 9.81)
        p = np.asarray(periods, dtype=float)
        return {"pga_g": np.abs(acc).max() / 9.81, "pgv_cm_s": 100 * np.abs(v).max(), "pgd_cm": 100 * np.abs(d).max(),
                "arias_m_s": ia[-1], "d5_95_s": dt * (np.searchsorted(ia, 0.95 * ia[-1]) - np.searchsorted(ia, 0.05 * ia[-1])),
                "sa_g": np.abs(acc).max() / 9.81 / (1 + p), "sv_cm_s": 100 * np.abs(v).max() * p / (1 + p), "periods_s": p}

    if not hasattr(gm, "synthesize"):
        gm.synthesize, gm.sample_pulse_parameters = synthesize, sample_pulse_parameters
    if not hasattr(im, "measures"):
        im.measures = measures


def real_solver(ctx, row):
    """The real solver on stand-in records while the ground-motion work has not landed."""
    _standin_ground_motion()
    return run_sample(ctx, row)
