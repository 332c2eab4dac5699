"""Subset simulation (Au & Beck 2001) of a rare response within one scenario: the record-to-record tail,
in the space of the standard normals a record is made from (docs/rare_events.md, "Subset simulation").

The space. Every run of a scenario (Mw, R, pulse shape, column) is a pure function of a vector x of
d independent standard normals: ``ground_motion.synthesize(normals=x)`` takes the pulse's quantiles
then the record's white noise (d = 4 + about 2 400 at Mw 6.25, 10 km; :func:`normals_layout`). A
level of Table III or IV, or collapse, is ``g(x) >= threshold`` with the score g of a run's row: its
EDP (``u_top`` or ``u_d``), +inf when the column collapsed, -inf when the run failed (a failed run is
counted and never in a failure domain); ``threshold = inf`` is collapse alone.

The estimate. ``P = P(F_1) P(F_2 | F_1) ... P(F | F_m)`` with ``F_j = {g >= b_j}``: level 0 is N
independent runs; the intermediate threshold b_{j+1} is the (N p0)-th largest score of level j
(p0 = 0.1), its conditional probability the fraction of level j's scores >= b_{j+1} (p0 but for
ties); the N p0 runs of level j above it seed as many Markov chains of 1/p0 states (the seed the
first), which sample N states conditional on F_{j+1} by adaptive conditional sampling (aCS,
Papaioannou, Betz, Zwirglmaier & Straub 2015): candidate ``rho * x + sigma * xi`` per component,
``xi`` ~ N(0, I), ``sigma = min(1, lambda * sd of the seeds)``, ``rho = sqrt(1 - sigma^2)`` (a move
that leaves N(0, I) invariant, so no per-component rejection: the candidate is kept iff its score
stays >= b_{j+1}); the scale lambda starts at 0.6 and adapts after every step of all chains towards
an acceptance of 0.44 (``ln lambda += (a - 0.44) / sqrt(k)``, k the step), carried to the next level.
All chains take a step together: one step is one batch of N p0 independent runs (what the ranks of
an MPI run share). The last level, where the (N p0)-th score reaches the threshold, gives
``P(F | F_m)`` as its fraction of scores >= threshold.

Its precision: each level's CoV as Au & Beck (2001, Eqs. 27-29) give it, ``delta_j^2 = (1 - p_j) / (N p_j)
(1 + gamma_j)``, gamma_j from the correlation of the indicators along the chains (0 at level 0,
independent runs); the stated CoV of the estimate adds the correlation between the levels (a level's
chains start from the level below's states): the genealogical estimate of :mod:`pycolfrag.rare.subset_cov`,
``sum over level-0 runs e of Z_e^2``, each run's descendants' residuals on every level summed (Chan &
Lai 2013; Lee & Whiteley 2018). Au & Beck's sum ``sum_j delta_j^2`` (levels uncorrelated: 0.85-0.98
of the observed spread) is kept as ``cov_uncorrelated``, their upper bound ``(sum_j delta_j)^2`` as
``cov_bound``. Interval: log-normal with that CoV, ``P exp(-/+ z sqrt(ln(1 + delta^2)))`` (z = 1.645
for 90 %): never below 0, and skewed like the product of fractions it describes.

Determinism. Every run is a pure function of (seed, level, chain, step): level 0's run i draws its
normals from the stream ``SeedSequence(seed, spawn_key=(STREAM, 0, i, 0))``, level j's chain c at step
k its proposal's xi from ``(STREAM, j, c, k)``, through the C generator (``cf_rng_normals``); the
arithmetic of the chains is IEEE elementwise (numpy ``*``, ``+``, ``sqrt``), sums are ``math.fsum``
and exp/log the library's own, so the whole estimate replays bitwise from its seed on any machine and
any evaluator (serial, :class:`PoolEvaluator`, or the grid's ranks): ``evaluate(batch) -> rows`` is all
the algorithm asks of the runs, and a row depends only on its input.
"""
from __future__ import annotations

import math
import multiprocessing
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError, RareEventError
from pycolfrag.core.ffi import ffi, lib, ptr
from pycolfrag.core.validate import integer
from pycolfrag.damage import exceedance_score
from pycolfrag.ground_motion import normals_layout, registry, stochastic, synthesize
from pycolfrag.rare.subset_cov import correlated_bound_cov2, genealogy_cov2, uncorrelated_cov2
from pycolfrag.solver import sample
from pycolfrag.solver.options import SolverOptions
from pycolfrag.structure.column import Column

__all__ = ["STREAM", "P0", "N_PER_LEVEL", "MAX_LEVELS", "ACS_TARGET_ACCEPTANCE", "ACS_INITIAL_SCALE", "Z90",
           "SubsetProblem", "Level", "SubsetResult", "run_normals", "run_batch", "PoolEvaluator", "score",
           "subset_simulation", "crude_monte_carlo", "lognormal_interval"]

#: First word of the spawn key of every stream of a subset simulation ("SuSi"): its streams never equal
#: another algorithm's of the same seed.
STREAM = 0x53755369
#: Conditional probability of the intermediate levels (Au & Beck 2001 recommend 0.1).
P0 = 0.1
#: Runs per level (N): 500 gives a CoV of about 0.3 at p = 1e-3 (three levels).
N_PER_LEVEL = 500
#: Most levels (p down to about P0**MAX_LEVELS).
MAX_LEVELS = 10
#: aCS: the acceptance rate the scale adapts to, and the initial scale (Papaioannou et al. 2015).
ACS_TARGET_ACCEPTANCE = 0.44
ACS_INITIAL_SCALE = 0.6
#: The standard normal's 95 % quantile: two-sided 90 % intervals.
Z90 = 1.6448536269514722


def score(row: dict, edp: str) -> float:
    """The score of a run's row: -inf when the run failed (``status`` not 0, or no collapse and no finite
    EDP), else its :func:`pycolfrag.damage.exceedance_score` on ``edp`` (a key of
    :data:`pycolfrag.core.names.EDPS`): +inf for a collapse, the EDP otherwise -- a level ``edp >= t`` is
    exceeded as in :func:`pycolfrag.damage.exceeded`."""
    collapsed = bool(row.get("collapsed"))
    v = row.get(edp, math.nan)
    if row.get("status", 0) != 0 or not (collapsed or math.isfinite(float(v))):
        return -math.inf
    return float(exceedance_score(v, collapsed))


@dataclass(frozen=True)
class SubsetProblem:
    """One scenario on one column and the level asked for: what every run of the estimate shares.

    column : Column; mw, dist_km : the scenario (the pulse model's and AS00's ranges)
    edp : "u_top" or "u_d"; threshold : the level, > 0 (``math.inf``: collapse alone)
    shape : the pulse shape ("mp03"), or "none" for the high-frequency record alone
    dt_s : record time step, s; vp_scale : factor on the Eq. (6) mean Vp
    solver_options : a :class:`SolverOptions` or a dict of overrides (e.g. ``{"monolithic": True}``)
    """

    column: Column
    mw: float
    dist_km: float
    edp: str = "u_top"
    threshold: float = math.inf
    shape: str = registry.DEFAULT_PULSE_SHAPE
    dt_s: float = 0.005
    vp_scale: float = 1.0
    solver_options: object = field(default_factory=SolverOptions)

    def __post_init__(self):
        if not isinstance(self.column, Column):
            raise ParameterError(f"column must be a Column, got {type(self.column).__name__}")
        if self.edp not in names.EDPS:
            raise ParameterError(f"edp must be one of {list(names.EDPS)}, got {self.edp!r}")
        t = self.threshold
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not t > 0:
            raise ParameterError(f"threshold must be > 0 (math.inf: collapse alone), got {t!r}")
        opts = self.solver_options
        if not isinstance(opts, SolverOptions):
            if not isinstance(opts, dict):
                raise ParameterError(f"solver_options must be a SolverOptions or a dict, got {type(opts).__name__}")
            object.__setattr__(self, "solver_options", SolverOptions().replace(**opts))
        object.__setattr__(self, "threshold", float(t))
        # the layout checks the scenario, dt and shape (ModelRangeError / ParameterError naming the value)
        object.__setattr__(self, "_layout", normals_layout(self.mw, self.dist_km, self.dt_s, self.shape))

    @property
    def dimension(self) -> int:
        """d: the standard normals of one run (pulse quantiles, then the white noise)."""
        return self._layout.size

    def run_input(self, x: np.ndarray, level: int, chain: int, step: int) -> dict:
        """The explicit input of one run (what an evaluator gets): the run's settings, its normals and
        its identity in the estimate."""
        return {"column": self.column, "solver_options": self.solver_options, "mw": float(self.mw),
                "dist_km": float(self.dist_km), "dt_s": float(self.dt_s), "vp_scale": float(self.vp_scale),
                "shape": self.shape, "normals": x, "level": level, "chain": chain, "step": step}

    def score(self, row: dict) -> float:
        """:func:`score` of a row for this problem's EDP."""
        return score(row, self.edp)

    def describe(self) -> dict:
        """The problem as plain data (for a result's provenance)."""
        return {"column": self.column.to_dict(), "mw": float(self.mw), "dist_km": float(self.dist_km),
                "edp": self.edp, "threshold": self.threshold, "shape": self.shape, "dt_s": float(self.dt_s),
                "vp_scale": float(self.vp_scale), "solver_options": self.solver_options.to_dict(),
                "dimension": self.dimension}


# ------------------------------------------------------------------------------------------ the runs
def _record_row(inp: dict):
    """(the row so far, the run's motion or None when the record failed) of one run input."""
    out = {"level": int(inp["level"]), "chain": int(inp["chain"]), "step": int(inp["step"]),
           "mw": float(inp["mw"]), "dist_km": float(inp["dist_km"]), "status": sample.STATUS["ok"], "message": ""}
    try:
        if inp["shape"] == registry.NO_PULSE:
            rec = stochastic(inp["mw"], inp["dist_km"], dt=inp["dt_s"], normals=inp["normals"])
        else:
            rec = synthesize(inp["mw"], inp["dist_km"], dt=inp["dt_s"], vp_scale=inp["vp_scale"],
                             shape=inp["shape"], normals=inp["normals"])
            out.update({p.row_field: float(rec.meta.get(p.meta_key, math.nan)) for p in registry.PULSE_FIELDS})
        motion = rec.motion("h1")
    except Exception as exc:  # a failed record is a row (status, message), not the end of the estimate
        out["status"] = sample.STATUS["record"]
        out["message"] = f"{type(exc).__name__}: {exc}"
        return out, None
    out["record_s"] = motion.n * motion.dt
    return out, motion


def run_batch(batch: Sequence[dict]) -> list[dict]:
    """The rows of a batch of run inputs (:meth:`SubsetProblem.run_input`), in order: the grid's row of
    each record made from its normals (IMs, EDPs, collapse, status; :mod:`pycolfrag.solver.sample`), plus its
    ``level``, ``chain`` and ``step``. The runs on one column and one set of solver options are
    integrated side by side (:func:`pycolfrag.solver.sample.response_rows`: bitwise each run alone). Serial."""
    rows, groups = [], {}
    for i, inp in enumerate(batch):
        out, motion = _record_row(inp)
        rows.append(out)
        if motion is not None:
            groups.setdefault((id(inp["column"]), id(inp["solver_options"])), []).append((i, motion))
    for members in groups.values():
        first = batch[members[0][0]]
        sample.response_rows(first["column"], [(rows[i], m, None) for i, m in members],
                             solver_options=first["solver_options"])
    return rows


class PoolEvaluator:
    """``evaluate(batch) -> rows`` over a :mod:`multiprocessing` pool: the batch cut into one contiguous
    part per process, each part :func:`run_batch`; the rows are bitwise those of :func:`run_batch`
    (each depends only on its input). Use as a context manager, or call :meth:`close`."""

    def __init__(self, processes: int):
        self.processes = integer(processes, "processes", 1)
        self._pool = multiprocessing.get_context("fork").Pool(self.processes)

    def __call__(self, batch: Sequence[dict]) -> list[dict]:
        parts = [list(p) for p in np.array_split(np.arange(len(batch)), self.processes) if len(p)]
        done = self._pool.map(run_batch, [[batch[i] for i in p] for p in parts])
        return [row for part in done for row in part]

    def close(self) -> None:
        self._pool.close()
        self._pool.join()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def run_normals(seed: int, key: tuple, d: int) -> np.ndarray:
    """d standard normals of the stream ``SeedSequence(seed, spawn_key=(STREAM, *key))``: its first 64-bit
    word seeds the C generator (xoshiro256**, polar method: ``cf_rng_normals``), the same bits on any
    machine."""
    state = np.random.SeedSequence(seed, spawn_key=(STREAM, *key)).generate_state(1, np.uint64)[0]
    rng = ffi.new("cf_rng *")
    lib.cf_rng_seed(rng, int(state))
    out = np.empty(d, dtype=np.float64)
    lib.cf_rng_normals(rng, ptr(out), d)
    return out


def _evaluate(problem, evaluate, xs, idents) -> tuple[np.ndarray, list]:
    """Scores and rows of the runs at normals ``xs`` with identities (level, chain, step)."""
    batch = [problem.run_input(x, *ident) for x, ident in zip(xs, idents)]
    rows = evaluate(batch)
    if not isinstance(rows, list) or len(rows) != len(batch):
        raise RareEventError(f"the evaluator returned {len(rows) if hasattr(rows, '__len__') else rows!r} rows "
                             f"for a batch of {len(batch)} runs")
    return np.array([problem.score(r) for r in rows], dtype=np.float64), rows


# ------------------------------------------------------------------------------------------ results
@dataclass(frozen=True)
class Level:
    """One level's runs: N states conditional on ``F_j = {g >= threshold}`` (level 0: no condition,
    threshold -inf), and what they estimate: the fraction ``p_next`` of scores >= ``next_threshold``
    (the next intermediate threshold, or the problem's at the last level), its chain-correlation factor
    ``gamma`` and CoV (Au & Beck 2001, Eqs. 27-29). ``acceptance``: the chains' mean acceptance (NaN at
    level 0); ``scale``: the aCS scale lambda after the level; ``scores`` (steps x chains at j >= 1);
    ``eves``: the level-0 run each of its chains descends from (level 0: ``arange(N)``, each run its own)."""

    index: int
    threshold: float
    next_threshold: float
    p_next: float
    gamma: float
    cov: float
    acceptance: float
    scale: float
    runs: int
    scores: np.ndarray = field(repr=False)
    eves: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class SubsetResult:
    """A subset-simulation estimate of ``P(g >= threshold)`` in one scenario.

    probability, cov : the estimate and its stated CoV (the levels' correlation included:
    :func:`pycolfrag.rare.subset_cov.genealogy_cov2`); interval : its log-normal interval at ``confidence``;
    cov_uncorrelated, cov_bound : Au & Beck's (2001) sum over the levels (taken as uncorrelated) and their
    upper bound (taken as fully correlated), for comparison; levels : the :class:`Level` s; runs : runs made (N + (m - 1) N (1 - p0)); failed :
    runs whose row failed (scored -inf); converged : False when MAX_LEVELS ran out before a level's
    (N p0)-th score reached the threshold (the estimate is then that of the last level's fraction,
    possibly 0); rows : every run's row (level, chain, step, score, EDPs, ...) in the order run;
    settings : seed, n, p0, the problem.
    """

    probability: float
    cov: float
    interval: tuple
    confidence: float
    levels: tuple
    runs: int
    failed: int
    converged: bool
    rows: list = field(repr=False)
    settings: dict = field(repr=False)
    cov_uncorrelated: float = math.nan
    cov_bound: float = math.nan

    def at(self, threshold: float) -> tuple[float, float]:
        """(P(g >= threshold), its CoV) for a lower level of the same EDP, from the same runs: the last
        level whose condition threshold <= ``threshold`` times the fraction of its scores above it (the
        CoV: the genealogical estimate over those levels, the last one's fraction taken at ``threshold``).
        ParameterError above the problem's level."""
        top = self.levels[-1].next_threshold
        if not threshold <= top:
            raise ParameterError(f"threshold {threshold!r} is above the level the runs reached ({top!r})")
        j = max(i for i, lv in enumerate(self.levels) if lv.threshold <= threshold)
        p_before = math.prod(lv.p_next for lv in self.levels[:j])
        frac = _fraction(self.levels[j].scores, threshold, False)[0]
        below = [lv.next_threshold for lv in self.levels[:j]]
        return p_before * frac, _stated_cov(genealogy_cov2(self.levels[:j + 1], below + [threshold]))

    def crude_runs(self) -> float:
        """Runs crude Monte Carlo needs for the same CoV: (1 - p) / (p CoV^2)."""
        p = self.probability
        return (1.0 - p) / (p * self.cov ** 2) if p > 0 else math.inf

    def efficiency(self) -> float:
        """:meth:`crude_runs` / runs made."""
        return self.crude_runs() / self.runs

    def summary(self) -> str:
        lo, hi = self.interval
        text = (f"P = {self.probability:.4g} (CoV {self.cov:.3f}, {100 * self.confidence:.0f} % interval "
                f"[{lo:.3g}, {hi:.3g}]) from {self.runs} runs in {len(self.levels)} levels "
                f"(thresholds {', '.join(f'{lv.next_threshold:.4g}' for lv in self.levels)}); "
                f"crude Monte Carlo needs {self.crude_runs():.3g} runs for this CoV ({self.efficiency():.1f}x)")
        if self.failed:
            text += f"; {self.failed} failed runs scored -inf"
        if not self.converged:
            text += f"; NOT CONVERGED: the last of {len(self.levels)} levels did not reach the threshold"
        return text


def lognormal_interval(p: float, cov: float, confidence: float = 0.90) -> tuple[float, float]:
    """``p exp(-/+ z s)``, ``s = sqrt(ln(1 + cov^2))``, z the two-sided normal quantile of ``confidence``
    (cf_math's ndtri): the interval of a log-normal estimate of mean p and that CoV."""
    if not 0 < confidence < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    if not (p > 0 and math.isfinite(cov)):
        return 0.0, math.inf
    z = -lib.cf_math_ndtri(0.5 * (1.0 - confidence))
    s = math.sqrt(lib.cf_math_log(1.0 + cov * cov))
    return p * lib.cf_math_exp(-z * s), p * lib.cf_math_exp(z * s)


def _gamma(ind: np.ndarray) -> float:
    """Au & Beck (2001) Eq. (29): ``gamma = 2 sum_{k=1}^{Ns-1} (1 - k Nc / N) rho_k``, rho_k = R_k / R_0,
    ``R_k = mean over chains and states of I_l I_{l+k} - p^2`` (``ind``: steps x chains, 0/1)."""
    ns, nc = ind.shape
    n = ns * nc
    p = math.fsum(ind.ravel()) / n
    r0 = p - p * p
    if r0 <= 0.0:
        return 0.0
    g = 0.0
    for k in range(1, ns):
        rk = math.fsum((ind[:-k] * ind[k:]).ravel()) / (n - k * nc) - p * p
        g += 2.0 * (1.0 - k * nc / n) * rk / r0
    return g


def _fraction(scores: np.ndarray, threshold: float, chained: bool) -> tuple[float, float]:
    """(fraction of scores >= threshold, its gamma: 0 for independent runs)."""
    ind = (scores >= threshold).astype(np.float64)
    frac = math.fsum(ind.ravel()) / ind.size
    return frac, (_gamma(ind) if chained else 0.0)


def _stated_cov(var_log: float) -> float:
    """The CoV of P from the variance of ln P (:func:`~pycolfrag.rare.subset_cov.genealogy_cov2`) of a
    log-normal estimate, ``sqrt(exp(var) - 1)`` (the library's exp): :func:`lognormal_interval` then spreads
    ``exp(-/+ z sqrt(var))`` about P."""
    return math.sqrt(lib.cf_math_exp(var_log) - 1.0) if math.isfinite(var_log) else math.inf


def _cov2(p: float, n: int, gamma: float) -> float:
    """Au & Beck (2001) Eq. (28): the squared CoV of a fraction p of n states, ``(1 - p)/(n p) (1 + gamma)``."""
    return (1.0 - p) / (n * p) * (1.0 + gamma) if p > 0 else math.inf


# ------------------------------------------------------------------------------------------ the algorithm
def _settings(n, p0, max_levels, seed, confidence) -> tuple[int, int, int]:
    """(n, chains N p0, states per chain 1/p0) after the checks, or ParameterError naming the value."""
    n = integer(n, "n", 20)
    if isinstance(p0, bool) or not isinstance(p0, (int, float)) or not 0 < p0 <= 0.5:
        raise ParameterError(f"p0 must be in (0, 0.5], got {p0!r}")
    nc = round(n * p0)
    if abs(nc - n * p0) > 1e-9 * n or nc < 2 or n % nc:
        raise ParameterError(f"n * p0 must be a whole number of chains (>= 2) that divides n: n = {n}, p0 = {p0!r}")
    integer(max_levels, "max_levels", 1)
    integer(seed, "seed", 0, 2**63 - 1)
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0 < confidence < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    return n, nc, n // nc


def _column_sd(x: np.ndarray) -> np.ndarray:
    """Sample standard deviation of each component over the rows of x (fsum: the same bits anywhere)."""
    m = x.shape[0]
    out = np.empty(x.shape[1])
    for i in range(x.shape[1]):
        col = x[:, i]
        mean = math.fsum(col) / m
        out[i] = math.sqrt(math.fsum((col - mean) * (col - mean)) / (m - 1))
    return out


def _chains(problem, evaluate, seed, level, seeds_x, seeds_g, threshold, scale, ns, rows):
    """aCS chains from the seeds (one per row of seeds_x), all stepping together: (states x, scores g:
    steps x chains, mean acceptance, the scale after the level). Rows of the runs are appended to rows."""
    nc, d = seeds_x.shape
    sd = _column_sd(seeds_x)
    xs = np.empty((ns, nc, d))
    gs = np.empty((ns, nc))
    xs[0], gs[0] = seeds_x, seeds_g
    accepted = 0
    for k in range(1, ns):
        sigma = np.minimum(scale * sd, 1.0)
        rho = np.sqrt(1.0 - sigma * sigma)
        x = xs[k - 1]
        cand = np.array([rho * x[c] + sigma * run_normals(seed, (level, c, k), d) for c in range(nc)])
        g, new_rows = _evaluate(problem, evaluate, cand, [(level, c, k) for c in range(nc)])
        ok = g >= threshold
        xs[k] = np.where(ok[:, None], cand, x)
        gs[k] = np.where(ok, g, gs[k - 1])
        rows.extend(new_rows)
        a = int(ok.sum())
        accepted += a
        # Robbins-Monro step of ln(lambda) towards the target acceptance (Papaioannou et al. 2015)
        scale = lib.cf_math_exp(lib.cf_math_log(scale) + (a / nc - ACS_TARGET_ACCEPTANCE) / math.sqrt(k))
    return xs.reshape(ns * nc, d), gs, accepted / (nc * (ns - 1)), scale


def _level(index, threshold, scores, next_threshold, acceptance, scale, runs, chained, eves) -> Level:
    p, gamma = _fraction(scores, next_threshold, chained)
    return Level(index=index, threshold=threshold, next_threshold=next_threshold, p_next=p, gamma=gamma,
                 cov=math.sqrt(_cov2(p, scores.size, gamma)), acceptance=acceptance, scale=scale, runs=runs,
                 scores=scores, eves=eves)


def subset_simulation(problem, evaluate: Callable[[list], list] = run_batch, *, seed: int, n: int = N_PER_LEVEL,
                      p0: float = P0, max_levels: int = MAX_LEVELS, confidence: float = 0.90,
                      progress: Callable[[Level], None] | None = None) -> SubsetResult:
    """``P(g >= problem.threshold)`` by subset simulation with aCS (the module docstring).

    Parameters
    ----------
    problem : :class:`SubsetProblem` (or any object with ``dimension``, ``threshold``,
        ``run_input(x, level, chain, step)``, ``score(row)``)
    evaluate : ``evaluate(batch) -> rows``, a list of run inputs to their rows in order
        (:func:`run_batch`, a :class:`PoolEvaluator`, or the ranks of an MPI run)
    seed : int, 0 <= seed < 2**63: the estimate is a pure function of it (and of the problem)
    n : runs per level (N); p0 : conditional probability of the intermediate levels; N p0 chains
        of 1/p0 states must be whole numbers
    max_levels : the most levels; confidence : of the stated interval
    progress : called with each finished :class:`Level`

    Returns
    -------
    :class:`SubsetResult`
    """
    n, nc, ns = _settings(n, p0, max_levels, seed, confidence)
    d, target = int(problem.dimension), float(problem.threshold)
    rows: list = []
    xs = np.array([run_normals(seed, (0, i, 0), d) for i in range(n)])
    g, rows0 = _evaluate(problem, evaluate, xs, [(0, i, 0) for i in range(n)])
    rows.extend(rows0)
    levels, threshold, scale, acceptance, chained = [], -math.inf, ACS_INITIAL_SCALE, math.nan, False
    eves = np.arange(n)                      # the level-0 run each chain (level 0: each run) descends from
    for j in range(max_levels):
        flat = g.ravel()
        order = np.argsort(-flat, kind="stable")            # largest first, ties by run order
        b = float(flat[order[nc - 1]])
        reached = b >= target
        last = reached or j == max_levels - 1
        nxt = target if last else b
        if not last and (b == -math.inf or b <= threshold):
            raise RareEventError(
                f"subset simulation stopped rising at level {j}: its {nc}-th largest score is {b!r} "
                f"(condition {threshold!r}; {int(np.sum(flat == -math.inf))} of {flat.size} runs failed, "
                f"chain acceptance {acceptance:.3f})")
        levels.append(_level(j, threshold, g, nxt, acceptance, scale, flat.size if j == 0 else nc * (ns - 1), chained,
                             eves))
        if progress is not None:
            progress(levels[-1])
        if last:
            break
        seeds = order[:nc]
        eves = eves[seeds] if j == 0 else eves[seeds % nc]   # state k * nc + c of a level is chain c's
        xs, g, acceptance, scale = _chains(problem, evaluate, seed, j + 1, xs[seeds], flat[seeds], b, scale, ns, rows)
        threshold, chained = b, True
    p = math.prod(lv.p_next for lv in levels)
    cov = _stated_cov(genealogy_cov2(levels))
    covs = [lv.cov for lv in levels]
    for r in rows:
        r["score"] = problem.score(r)
    return SubsetResult(probability=p, cov=cov, interval=lognormal_interval(p, cov, confidence),
                        confidence=float(confidence), levels=tuple(levels), runs=len(rows),
                        failed=sum(r["score"] == -math.inf for r in rows), converged=reached, rows=rows,
                        settings={"seed": int(seed), "n": n, "p0": float(p0), "chains": nc, "states": ns,
                                  "sampler": "aCS", "max_levels": int(max_levels),
                                  "problem": problem.describe() if hasattr(problem, "describe") else None},
                        cov_uncorrelated=math.sqrt(uncorrelated_cov2(covs)), cov_bound=math.sqrt(correlated_bound_cov2(covs)))


def crude_monte_carlo(problem, evaluate: Callable[[list], list] = run_batch, *, seed: int, n: int,
                      batch: int = 500, start: int = 0, progress: Callable[[int, np.ndarray], None] | None = None):
    """Scores of ``n`` independent runs (crude Monte Carlo), run ``i`` at the normals of level 0's run
    ``start + i`` of a subset simulation of the same seed, in batches of ``batch``; ``progress(done,
    scores so far)`` after each. Returns the scores (``problem.score`` of each row), in run order."""
    n = integer(n, "n", 1)
    batch = integer(batch, "batch", 1)
    start = integer(start, "start", 0)
    integer(seed, "seed", 0, 2**63 - 1)
    d = int(problem.dimension)
    out = np.empty(n)
    for lo in range(0, n, batch):
        idx = range(start + lo, start + min(n, lo + batch))
        g, _ = _evaluate(problem, evaluate, [run_normals(seed, (0, i, 0), d) for i in idx], [(0, i, 0) for i in idx])
        out[lo:lo + len(g)] = g
        if progress is not None:
            progress(lo + len(g), out[:lo + len(g)])
    return out
