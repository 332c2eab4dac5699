"""The replay model: the grid's scheduling policy simulated at N ranks, from measured costs.

    pycolfrag replay RESULTS.h5 [--ranks 1 2 16 128] [--samples 1000] [--policy current|b2afe10] [--lanes 4]
    python -m pycolfrag.grid.replay RESULTS.h5 ...                   # the same

A discrete-event simulation: every rank is a generator that does what :mod:`pycolfrag.grid.serve` does,
step by step -- rank 0 waits for each worker's first request, then answers requests (probing once or
twice, as Open MPI's ``Iprobe`` sees them: only what an earlier MPI call moved into its queue) between
chunks of its own and journals the rows; a worker asks for its next chunk before computing the current
one -- and yields what takes time: CPU, wall time (sleeps, disk), messages. The chunks are cut by the
scheduler's own :class:`~pycolfrag.grid.chunks.ChunkQueue`, not a copy.

What a chunk costs: every row's record and IMs (``prep``), then the batch's run-steps at the width the
C library picks for the chunk's size, idle lanes included (a longest-first refill of the rows' steps
over the lanes), times the scenario's measured cost per run-step at full lanes and the width's factor.
The rows' steps and costs come from a results file (its ``n_steps``, ``record_s``, ``wall_s``), scaled
once so that the replayed chunk CPU of the file's own session equals what it measured (the timeline's
chunk CPU, or the rows' ``wall_s``). Fixed costs (start-up phases, messages, journal, flushes, the final
write) are :class:`Costs`, measured on the machine of docs/performance.md, or the file's timeline's.

Processor sharing models a job with fewer cores than ranks (``Machine.cores``): every rank in a CPU
action runs at ``min(1, cores / n)``, n counting the computing ranks and ``Machine.spin`` of each rank
polling in a blocking MPI call (Open MPI polls at full CPU when the ranks fit the cores; oversubscribed
it yields). Predictions for real hardware take one core per rank.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from pycolfrag.grid.chunks import ChunkQueue, synthetic_record_s
from pycolfrag.grid.replay_sim import batch_width_rule, run_ranks
from pycolfrag.grid.serve import RANK0_WORKS_UP_TO

__all__ = ["Rows", "Costs", "Policy", "Machine", "CURRENT", "BEFORE", "batch_width_rule", "simulate",
           "efficiency", "main"]

# ----------------------------------------------------------------------------------------------
# what the rows cost
# ----------------------------------------------------------------------------------------------

def prep_s(record_s) -> np.ndarray:
    """A row's record, IMs and Python around it, CPU s, from its record's length: 0.53 ms for a 9.6 s
    record, 1.94 ms for 41 s (measured alone, chunks of one scenario, docs/performance.md)."""
    return 1.0e-4 + 4.5e-5 * np.asarray(record_s, dtype=float)


@dataclass
class Rows:
    """The rows of a grid as the replay sees them: their scenario, solver steps, cost per run-step at
    full lanes (s, their scenario's), record cost (s), and the scheduler's expected cost and order."""

    scenario: np.ndarray
    steps: np.ndarray
    sigma: np.ndarray
    prep: np.ndarray
    expected: np.ndarray
    order: list
    samples: int

    @property
    def n(self) -> int:
        return len(self.steps)

    @classmethod
    def from_results(cls, path) -> tuple["Rows", dict]:
        """The finished rows of a results file of the synthetic grid, and what the file measured
        (``sum_wall_s``; its last timeline's chunk CPU and session, when it has one)."""
        from pycolfrag import results as _results  # here: reading a file is only this entry's
        from pycolfrag.results.timeline import MAX_RANKS
        raw = _results.read_h5_bounded(path)
        g, attrs = raw["samples"], raw["attrs"]
        ok = (g["status"] == 0) & (g["n_steps"] > 0)
        if "scenario" not in g or not ok.any():
            raise ValueError(f"{path}: no finished rows of a synthetic grid to take costs from")
        sc, steps = g["scenario"][ok].astype(int), g["n_steps"][ok].astype(float)
        rec, wall = g["record_s"][ok], g["wall_s"][ok]
        prep = prep_s(rec)
        sigma = np.empty(len(sc))
        for s in np.unique(sc):
            m = sc == s
            sigma[m] = np.median((wall[m] - prep[m]) / steps[m])
        mw, dist = g["mw"][ok], g["dist_km"][ok]
        order = sorted(range(len(sc)), key=lambda r: (-mw[r], -dist[r], r))   # GridSpec.order
        tail = float(json.loads(attrs["solver"])["tail_s"])
        cut = float(attrs.get("max_record_s", -1.0))
        expected = np.empty(len(sc))
        for s in np.unique(sc):   # GridSpec.expected_cost: the scenario's nominal simulated seconds
            m = sc == s
            rec_s = synthetic_record_s(float(mw[m][0]), float(dist[m][0]))
            expected[m] = (min(rec_s, cut) if cut > 0 else rec_s) + tail
        n_ranks = attrs.get("n_ranks", 1)
        n_ranks = n_ranks.item() if isinstance(n_ranks, np.generic) else n_ranks
        if not isinstance(n_ranks, int) or not 1 <= n_ranks <= MAX_RANKS:
            raise ValueError(f"{path}: its n_ranks attribute {n_ranks!r} is not an integer from 1 to {MAX_RANKS}")
        measured = {"sum_wall_s": float(wall.sum()), "n_ranks": int(n_ranks),
                    "samples": int(attrs.get("samples", 1)), "session_s": float(attrs.get("wall_s_last_session", 0.0)),
                    **_rests_on(path, g, attrs, ok)}
        return cls(sc, steps, sigma, prep, expected, order, int(attrs.get("samples", 1))), measured

    def resample(self, samples: int, seed: int = 1) -> "Rows":
        """The same scenarios with ``samples`` rows each, drawn with replacement from the measured rows of
        their scenario (their steps, and with them their collapses and early ends)."""
        rng = np.random.default_rng(seed)
        idx = np.concatenate([rng.choice(np.flatnonzero(self.scenario == s), size=samples, replace=True)
                              for s in np.unique(self.scenario)])
        pos = {r: i for i, r in enumerate(self.order)}
        order = sorted(range(len(idx)), key=lambda i: (pos[idx[i]], i))
        return Rows(self.scenario[idx], self.steps[idx], self.sigma[idx], self.prep[idx], self.expected[idx],
                    order, samples)


def _rests_on(path, g, attrs, used) -> dict:
    """What a prediction from a file's rows rests on: the rows the grid asked for, those its HDF5 file holds
    finished, those used (successful, with solver steps), and those only its journal holds (an interrupted or
    running grid's, not read here); ``complete`` when every row asked for is in the HDF5 file."""
    from pycolfrag import results as _results  # here: reading a file is only this entry's
    status = np.asarray(g["status"])
    in_h5 = status != _results.STATUS_PENDING
    journal_only = 0
    jp = _results.journal_path(path)
    if jp.exists():
        try:
            _, jrows = _results.read_journal(jp)
            journal_only = sum(1 for i in jrows if 0 <= int(i) < len(status) and not in_h5[int(i)])
        except (OSError, ValueError, _results.ResultsFileError):
            journal_only = -1    # a journal that cannot be read: said as such
    n_sc = len(attrs.get("mw", [])) * len(attrs.get("dist_km", [])) if "mw" in attrs and "dist_km" in attrs else None
    return {"complete": bool(in_h5.all()), "rows_asked": int(len(status)), "rows_in_h5": int(in_h5.sum()),
            "rows_used": int(np.count_nonzero(used)), "rows_in_journal_only": int(journal_only),
            "scenarios_asked": n_sc, "scenarios_used": int(len(np.unique(np.asarray(g["scenario"])[used])))}


def incomplete_note(info: dict) -> str | None:
    """The mark of a prediction from an incomplete file (None for a complete one): what it rests on."""
    if info.get("complete", True):
        return None
    j = info["rows_in_journal_only"]
    journal = ("" if j == 0 else "; its journal could not be read" if j < 0 else
               f"; {j} more finished row(s) in its journal only, not read here (a rerun of the grid writes them "
               "into the file)")
    sc = "" if info.get("scenarios_asked") is None else f" of {info['scenarios_used']} of its {info['scenarios_asked']} scenarios"
    return (f"INCOMPLETE FILE (interrupted or still running): the grid asked for {info['rows_asked']} rows, the "
            f"HDF5 file holds {info['rows_in_h5']} finished{journal}. The prediction rests on the {info['rows_used']} "
            f"successful rows{sc} in the HDF5 file: it is the time of a run of those rows, not of the grid asked "
            "for (--samples N predicts N rows per scenario present), and their costs and timeline are a part "
            "of the run's")


@dataclass
class Costs:
    """Fixed costs, CPU s unless said, measured on the machine of docs/performance.md (a loaded 2-core
    AMD EPYC, Zen 4) with the timeline (medians over ranks and runs) or alone (calibrations)."""

    sigma_scale: float = 1.0     # one factor on every row's cost per run-step (the calibration)
    lanes: int = 8               # SIMD lanes of the CPU: 8 with AVX-512, 4 with AVX2
    width_factor: dict = field(default_factory=lambda: {8: 1.0, 4: 1.62, 1: 2.78})  # per run-step, vs full lanes
    chunk_s: float = 0.4e-3      # per chunk: Python around the batch, the solver's set-up
    lhs_per_sample: float = 1.86e-4     # a scenario's LHS with the amplitude A, per sample (once per scenario and rank)
    lhs_plain_per_sample: float = 1.0e-6   # ... without it (the grid now)
    peak_per_row: float = 0.19e-3       # a row's own peak search (when the LHS no longer did it)
    lhs_cache: int = 8           # scenarios' tables a rank keeps (grid/rows.py)
    interp: float = 0.03         # start-up: the interpreter before the package
    imports: float = 0.24        # the package's imports (1.10 with scipy, before the lazy imports)
    mpi_init: float = 0.04
    mpi_init_wall: float = 0.05
    checks: float = 0.03         # the command's checks (probe record, solver probe)
    identity: float = 0.045      # the signature's reference computation (every rank)
    open_cpu: float = 0.04       # rank 0: lock, journal header, git revision
    open_wall: float = 0.03
    create_per_row: float = 5.5e-5   # the child creating the file, per row (0.2 s for 3500 rows)
    create_fixed: float = 0.01
    msg_s: float = 0.15e-3       # rank 0: a request received, a chunk cut and sent
    journal_per_row: float = 0.06e-3
    flush_cpu: float = 0.025     # an HDF5 write: CPU, then waiting for the disk
    flush_wall: float = 0.03
    finish_cpu: float = 0.04     # the final write and its checksums
    finish_wall: float = 0.03
    summary: float = 0.10        # rank 0 after the run: the summary table
    exit_s: float = 0.05


@dataclass(frozen=True)
class Policy:
    """How the scheduler works. :data:`CURRENT` is this package's; :data:`BEFORE` is b2afe10's (rows
    counted, not costs; no lanes; one probe; scipy at start-up; the LHS with A; the file created before
    the workers start) -- the same :class:`ChunkQueue` with every row's cost 1 and one lane is b2afe10's
    guided rule, ``max(1, min(chunk_max, n // (4 N)))``."""

    name: str = "current"
    cost_guided: bool = True
    whole_lanes: bool = True
    probe_twice: bool = True
    lazy_imports: bool = True
    lhs_amplitude: bool = False
    open_overlap: bool = True
    chunk_max: int = 32
    rank0_works_up_to: int = RANK0_WORKS_UP_TO
    flush_s: float = 2.0


CURRENT = Policy()
BEFORE = Policy("b2afe10", cost_guided=False, whole_lanes=False, probe_twice=False, lazy_imports=False,
                lhs_amplitude=True, open_overlap=False)
#: An AVX2 CPU's cost per run-step relative to AVX-512's 8 lanes, at width 4 and one run after the other:
#: bench/batch_speed.py with -DCF_FORCE_AVX2 against the default build on the machine of
#: docs/performance.md (1.811 and 3.484 against 1.527 us per run-step, 64 grid records).
AVX2_WIDTH_FACTOR = {8: 1.0, 4: 1.811 / 1.527, 1: 3.484 / 1.527}


def on_avx2(costs: Costs) -> Costs:
    """``costs`` (a file's rows, measured with AVX-512's 8 lanes) for a CPU of 4 AVX2 lanes."""
    return replace(costs, lanes=4, sigma_scale=costs.sigma_scale * AVX2_WIDTH_FACTOR[4],
                   width_factor=AVX2_WIDTH_FACTOR)


#: Start-up imports (CPU s) with scipy: numpy, scipy.stats and optimize, cffi, pycolfrag, the analysis.
IMPORTS_WITH_SCIPY_S = 1.10


@dataclass
class Machine:
    """The job's machine: ``cores`` it gets (inf: one per rank), the weight of a rank polling in a
    blocking MPI call (1: Open MPI busy-polls), message latency (s), and time.sleep's oversleep."""

    cores: float = math.inf
    spin: float = 1.0
    latency: float = 20e-6
    sleep_extra: float = 0.1e-3


def _chunk_cost(rows: Rows, idx, costs: Costs, policy: Policy, cache: OrderedDict) -> float:
    """CPU s of a chunk on a rank whose LHS tables are ``cache`` (updated)."""
    idx = np.asarray(idx)
    c = costs.chunk_s + float(rows.prep[idx].sum())
    per_sample = costs.lhs_per_sample if policy.lhs_amplitude else costs.lhs_plain_per_sample
    if not policy.lhs_amplitude:
        c += costs.peak_per_row * len(idx)
    for s in rows.scenario[idx].tolist():
        if s in cache:
            cache.move_to_end(s)
        else:
            c += per_sample * rows.samples
            cache[s] = True
            while len(cache) > costs.lhs_cache:
                cache.popitem(last=False)
    steps = rows.steps[idx]
    sigma = float((rows.sigma[idx] * steps).sum() / steps.sum()) * costs.sigma_scale
    w = batch_width_rule(len(idx), costs.lanes)
    if w == 1:
        lane_steps = steps.sum()
    else:   # the lanes take the runs longest first; each lane's runs one after the other
        lanes = np.zeros(w)
        for s in np.sort(steps)[::-1]:
            lanes[int(np.argmin(lanes))] += s
        lane_steps = w * lanes.max()
    factor = costs.width_factor[w] / costs.width_factor[min(costs.lanes, 8)]
    return c + factor * sigma * lane_steps


def _queue(rows: Rows, size: int, costs: Costs, policy: Policy) -> ChunkQueue:
    cost = rows.expected[rows.order] if policy.cost_guided else np.ones(rows.n)
    return ChunkQueue(rows.order, cost, size, costs.lanes if policy.whole_lanes else 1)


def simulate(rows: Rows, size: int, policy: Policy = CURRENT, costs: Costs | None = None,
             machine: Machine | None = None, keep: bool = False) -> dict:
    """Replay a run of ``rows`` on ``size`` ranks. Returns times in s from the launch: ``t_job`` (to the
    last rank's exit), ``t_session`` (run_grid's clock: from rank 0's session start to its final write),
    ``t_startup`` (rank 0's launch to its session), ``n_chunks``, ``chunk_cpu`` (their summed CPU),
    ``small_chunks`` (fewer rows than lanes); ``keep``: also ``procs`` (every rank's marks)."""
    costs = costs or Costs()
    machine = machine or Machine()
    return run_ranks(rows, size, policy, costs, machine, _queue(rows, size, costs, policy),
                     lambda idx, cache: _chunk_cost(rows, idx, costs, policy, cache), keep)


def efficiency(rows: Rows, sizes: Sequence[int], policy: Policy = CURRENT, costs: Costs | None = None,
               machine: Machine | None = None, ref: dict | None = None) -> list[dict]:
    """``E(N) = T(1) / (N T(N))`` on both clocks (``E_job``: launch to exit; ``E_session``: run_grid's own),
    T(1) the policy's own one-rank run unless ``ref`` is given."""
    ref = ref or simulate(rows, 1, policy, costs, machine)
    out = []
    for n in sizes:
        r = simulate(rows, n, policy, costs, machine)
        r["E_job"] = ref["t_job"] / (n * r["t_job"])
        r["E_session"] = ref["t_session"] / (n * r["t_session"])
        out.append(r)
    return out


def calibrate(rows: Rows, costs: Costs, policy: Policy, n_ranks: int, measured_chunk_s: float) -> Costs:
    """``costs`` with the one scale that makes the replayed chunk CPU of an ``n_ranks`` run under ``policy``
    equal ``measured_chunk_s`` (what the rows' run measured). A chunk's cost is linear in the scale (the
    rows' records, IMs and LHS tables are not scaled), so two replays give it."""
    at0 = simulate(rows, n_ranks, policy, replace(costs, sigma_scale=0.0))["chunk_cpu"]
    at1 = simulate(rows, n_ranks, policy, replace(costs, sigma_scale=1.0))["chunk_cpu"]
    return replace(costs, sigma_scale=(measured_chunk_s - at0) / (at1 - at0))


#: Timeline kinds -> the :class:`Costs` fields measured by them (CPU s, the median per rank).
_TIMELINE_COSTS = {"imports": "imports", "mpi_init": "mpi_init", "checks": "checks", "identity": "identity",
                   "open": "open_cpu", "flush": "flush_cpu"}


def costs_from_timeline(session: dict, costs: Costs | None = None) -> Costs:
    """:class:`Costs` with the fixed costs a session's timeline measured (``session`` as
    :func:`pycolfrag.results.timeline.read_timeline` returns it): the median CPU of each start-up phase over
    the ranks, the interpreter's (the launch's CPU), rank 0's opening and flushes (CPU, and the flush's
    wall time beyond it)."""
    rows, names = session["rows"], session["kinds"]
    kinds = np.array([names[k] for k in rows["kind"]])
    out = {}
    for kind, name in _TIMELINE_COSTS.items():
        m = (kinds == kind) & np.isfinite(rows["cpu_s"])
        if m.any():
            out[name] = float(np.median(rows["cpu_s"][m]))
    m = (kinds == "launch") & np.isfinite(rows["cpu_s"])
    if m.any():
        out["interp"] = float(np.median(rows["cpu_s"][m]))
    m = (kinds == "flush") & np.isfinite(rows["cpu_s"])
    if m.any():
        out["flush_wall"] = max(0.0, float(np.median(rows["t1"][m] - rows["t0"][m] - rows["cpu_s"][m])))
    return replace(costs or Costs(), **out)


def measured(path) -> tuple[Rows, Costs, dict]:
    """The rows of a results file, the costs they measured, calibrated (:func:`calibrate`), and what was
    measured: a file with one session's timeline was written by this scheduler (:data:`CURRENT`), whose
    timeline gives the fixed costs and the chunks' CPU; a file without is b2afe10's (:data:`BEFORE`),
    whose rows' summed ``wall_s`` is the chunks' time."""
    from pycolfrag.results.timeline import (  # here: reading a file is only this entry's
        check_regular_file,
        read_timeline,
    )
    check_regular_file(path)   # a FIFO would hold the reading child until its time limit
    rows, info = Rows.from_results(path)
    sessions = list(read_timeline(path).values())
    costs, policy, chunk_s, n_ranks = Costs(), BEFORE, info["sum_wall_s"], info["n_ranks"]
    if len(sessions) == 1 and not sessions[0]["crc_ok"]:
        print(f"replay: {path}'s timeline fails its CRC-32 (changed after it was written): its costs are not used",
              file=sys.stderr)
    elif len(sessions) == 1:
        sess = sessions[0]
        chunks = sess["rows"][sess["rows"]["kind"] == sess["kinds"].index("chunk")]
        if int(chunks["n_rows"].sum()) == rows.n:
            costs, policy = costs_from_timeline(sess), CURRENT
            chunk_s, n_ranks = float(np.nansum(chunks["cpu_s"])), int(sess["attrs"].get("n_ranks", n_ranks))
    costs = calibrate(rows, costs, policy, n_ranks, chunk_s)
    return rows, costs, dict(info, policy=policy.name, chunk_s=chunk_s, n_ranks=n_ranks)


# ----------------------------------------------------------------------------------------------
# the command
# ----------------------------------------------------------------------------------------------

SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)
#: What ``--json`` says a prediction rests on (:func:`_rests_on`).
REST_KEYS = ("rows_asked", "rows_in_h5", "rows_used", "rows_in_journal_only", "scenarios_asked", "scenarios_used")


def build_parser(prog: str = "pycolfrag replay") -> argparse.ArgumentParser:
    from pycolfrag.core.help import HelpFormatter  # a leaf
    p = argparse.ArgumentParser(prog=prog, formatter_class=HelpFormatter,
                                description="Predict a grid's time and parallel efficiency on N ranks (one core "
                                            "each) by replaying the scheduler with the costs a results file measured "
                                            "(docs/performance.md).")
    p.add_argument("results", help="results file of a synthetic grid (its rows' steps and times are the costs)")
    p.add_argument("--ranks", type=int, nargs="+", default=list(SIZES), help="rank counts to predict")
    p.add_argument("--samples", type=int, default=None,
                   help="predict a grid of this many samples per scenario (rows drawn from the file's)")
    p.add_argument("--policy", choices=("current", "b2afe10"), default="current",
                   help="the scheduler replayed: this package's, or b2afe10's")
    p.add_argument("--lanes", type=int, choices=(8, 4), default=8,
                   help="SIMD lanes of the CPU (4: an AVX2 CPU, with its measured costs per run-step)")
    p.add_argument("--json", default=None, metavar="FILE", help="write the predictions as JSON")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if any(n < 1 for n in args.ranks) or (args.samples is not None and args.samples < 1):
        print("replay: --ranks and --samples must be >= 1", file=sys.stderr)
        return 2
    try:
        rows, costs, info = measured(args.results)
    except (OSError, ValueError, KeyError) as exc:
        print(f"replay: {exc}", file=sys.stderr)
        return 2
    policy = CURRENT if args.policy == "current" else BEFORE
    costs = replace(costs, imports=costs.imports if policy.lazy_imports else IMPORTS_WITH_SCIPY_S)
    if args.lanes == 4:
        costs = on_avx2(costs)
    if args.samples is not None:
        rows = rows.resample(args.samples)
    res = efficiency(rows, args.ranks, policy, costs)
    note = incomplete_note(info)
    if note:
        print(note)
    print(f"replay of {args.results}{' (INCOMPLETE, above)' if note else ''}: {rows.n} rows, policy {policy.name}, {costs.lanes} lanes, one core per rank "
          f"(costs: the file's rows, written by the {info['policy']} scheduler on {info['n_ranks']} rank(s), "
          f"scale {costs.sigma_scale:.3f}; fixed costs of " + ("its timeline)" if info["policy"] == CURRENT.name
                                                             else "docs/performance.md)"))
    print(f"{'ranks':>6} {'T_job s':>9} {'T_session s':>11} {'E_job %':>8} {'E_session %':>11} {'chunks':>7} "
          f"{'narrow':>7}")
    for r in res:
        print(f"{r['size']:6d} {r['t_job']:9.2f} {r['t_session']:11.2f} {100 * r['E_job']:8.1f} "
              f"{100 * r['E_session']:11.1f} {r['n_chunks']:7d} {r['small_chunks']:7d}")
    if args.json:
        try:
            with open(args.json, "w") as fh:
                json.dump({"policy": policy.name, "rows": rows.n, "lanes": costs.lanes, "complete": info["complete"],
                           "incomplete": note, "rests_on": {k: info[k] for k in REST_KEYS}, "results": res}, fh,
                          indent=1)
        except OSError as exc:
            print(f"replay: cannot write --json {args.json}: {exc.strerror or exc}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
