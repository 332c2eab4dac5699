"""A surrogate column for the site simulation's statistics: outcomes in closed form, rates exact.

The surrogate replaces the record and the solver (:class:`SurrogateEvaluator`, the evaluator interface of
:mod:`pycolfrag.rare.evaluator` without MPI or files): for an event (Mw, R, pulse normals z_vp, z_fp)
and a standard normal e drawn from its noise seed (the record-to-record scatter),

    ln u_top = A_TOP[pulse] + B_M (Mw - 6) - B_R ln R + [pulse] (B_VP z_vp + B_FP z_fp) + S_TOP e
    ln u_d   = ln u_top + D_OFF[pulse],        collapsed = u_top >= COLLAPSE_AT

so that, z_vp and z_fp being standard normal under the site's model, ln u_top given (Mw, R) is normal
with mean A + B_M (Mw - 6) - B_R ln R and standard deviation sqrt(S^2 + [pulse](B_VP^2 + B_FP^2)), and
every level -- collapsed or EDP >= t -- is u_top >= a threshold (min(t, COLLAPSE_AT) for u_top, and
min(t e^-D_OFF, COLLAPSE_AT) for u_d), whose probability is

    P(u_top >= t | Mw, R, pulse) = Phi((mean - ln t) / sd)                       (closed form)

:func:`exact_rates` integrates that over the site's sources with ``scipy.integrate.quad`` -- nothing of
the strata, weights or quadrature of :mod:`pycolfrag.rare` -- so it is an independent reference for the
estimator. The coefficients make the levels span p per event ~0.1 to ~3e-4, collapse rare and almost
only reached with a pulse, as at the example site.

``fail_at``: the runs whose u_top would reach it fail instead (status 3, no EDPs, as a solver that
refuses the strongest motions), deterministically: a run fails or not by its own inputs.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import integrate, stats

from pycolfrag.rare.evaluator import RecordSettings

A_TOP = {True: -0.4, False: -1.6}
D_OFF = {True: -3.3, False: -2.9}
B_M, B_R, B_VP, B_FP = 1.1, 0.9, 0.75, -0.25
S_TOP = 0.45
COLLAPSE_AT = 1.3


def _sd(pulse: bool, s: float) -> float:
    return math.sqrt(s * s + (B_VP ** 2 + B_FP ** 2 if pulse else 0.0))


def _mean(pulse: bool, a: dict, mw, r):
    return a[pulse] + B_M * (mw - 6.0) - B_R * np.log(r)


def columns(inputs, fail_at: float = math.inf) -> dict:
    """The rows of the events ``inputs`` (the evaluator's inputs) as the event layout's columns; those whose
    u_top would reach ``fail_at`` failed (status 3, u_top and u_d NaN, not collapsed, a message)."""
    mw = np.array([x["mw"] for x in inputs])
    r = np.array([x["dist_km"] for x in inputs])
    pulse = np.array([x["pulse"] is not None for x in inputs])
    tags = [x["tags"] for x in inputs]
    zv = np.array([t.get("z_vp", np.nan) for t in tags])
    zf = np.array([t.get("z_fp", np.nan) for t in tags])
    e = np.array([np.random.default_rng(x["hf_seed"]).standard_normal() for x in inputs])
    shift = np.where(pulse, B_VP * np.nan_to_num(zv) + B_FP * np.nan_to_num(zf), 0.0)
    a_top = np.where(pulse, A_TOP[True], A_TOP[False])
    u_top = np.exp(a_top + B_M * (mw - 6.0) - B_R * np.log(r) + shift + S_TOP * e)
    u_d = u_top * np.exp(np.where(pulse, D_OFF[True], D_OFF[False]))
    cols = {k: np.array([t.get(k, -1 if k in ("stage", "stratum", "index", "source", "component") else np.nan)
                         for t in tags]) for k in ("stage", "stratum", "index", "source", "component", "z_mw",
                                                   "z_dist", "z_nu", "z_gamma", "weight", "occurrence_weight",
                                                   "stratum_rate_per_yr")}
    fail = u_top >= fail_at
    collapsed = (u_top >= COLLAPSE_AT) & ~fail
    u_top, u_d = np.where(fail, np.nan, u_top), np.where(fail, np.nan, u_d)
    cols.update(z_vp=zv, z_fp=zf, mw=mw, dist_km=r, pulse=pulse.astype(np.uint8), u_top=u_top, u_d=u_d,
                collapsed=collapsed.astype(np.uint8), status=np.where(fail, 3, 0).astype(np.int32),
                message=np.where(fail, b"SolverError: the surrogate's solver refuses this motion", b""),
                hf_seed=np.array([x["hf_seed"] for x in inputs], dtype=np.uint64))
    return cols


def _pending(cols: dict, limit: int) -> dict:
    out = {k: v.copy() for k, v in cols.items()}
    out["status"][limit:] = -1
    return out


class SurrogateEvaluator:
    """The evaluator interface, in memory: batches planned and their rows (the surrogate's outcomes)."""

    def __init__(self, fail_at: float = math.inf):
        self.record = RecordSettings()
        self.plans, self.calls = {}, []
        self.fail_at = fail_at

    def stored(self, name):
        return self.plans.get(name)

    def evaluate(self, name, inputs, purpose, limit=None):
        self.plans.setdefault(name, (purpose, list(inputs)))
        self.calls.append((name, len(inputs), limit))
        cols = columns(self.plans[name][1], self.fail_at)
        return _pending(cols, len(inputs) if limit is None else limit)


def level_probability(q, pulse: bool, mw, r) -> float:
    """P(level exceeded | Mw, R, pulse) in closed form (module docstring)."""
    t = (COLLAPSE_AT if q.edp is None else min(q.threshold * (math.exp(-D_OFF[pulse]) if q.edp == "u_d" else 1.0),
                                                COLLAPSE_AT))
    return stats.norm.sf((math.log(t) - _mean(pulse, A_TOP, mw, r)) / _sd(pulse, S_TOP))


def exact_rates(site, quantities, probability=level_probability) -> dict:
    """lambda of every level: sum over sources of nu int int f(m) f(r) [p(r) P_pulse + (1 - p(r)) P_nopulse],
    by adaptive quadrature (scipy.integrate.quad, relative tolerance 1e-10) over the sources' own
    densities (pdf; a characteristic magnitude or fixed distance as its one value). ``probability(q, pulse,
    mw, r)``: P(level | event), :func:`level_probability` unless a surrogate of the surrogate says otherwise
    (bench/rare_allocation_bias.py's extra collapses)."""
    out = {}
    for q in quantities:
        total = 0.0
        for s in site.sources:
            def over_r(m):
                def g(r):
                    p = float(s.pulse.mean_probability(np.array([r]))[0])  # noqa: B023 (quad calls g within this iteration)
                    return p * probability(q, True, m, r) + (1 - p) * probability(q, False, m, r)  # noqa: B023 (as above)
                d = s.distance  # noqa: B023 (as above)
                if getattr(d, "atoms", None) is not None:
                    return sum(w * g(x) for x, w in d.atoms)
                return integrate.quad(lambda r: float(d.pdf(r)) * g(r), *d.support, epsabs=0, epsrel=1e-10)[0]
            mm = s.magnitude
            if getattr(mm, "atoms", None) is not None:
                total += s.rate * sum(w * over_r(x) for x, w in mm.atoms)
            else:
                total += s.rate * integrate.quad(lambda m: float(mm.pdf(m)) * over_r(m), *mm.support, epsabs=0,  # noqa: B023 (quad calls it within this iteration)
                                                 epsrel=1e-10)[0]
        out[q.label] = total
    return out
