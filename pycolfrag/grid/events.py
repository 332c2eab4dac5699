"""A batch of events with explicit inputs: the kind of grid an algorithm above the grid runs its runs as.

Each row is one synthetic run whose inputs are given, not derived from a grid position: magnitude,
distance, the seed of the record's high-frequency noise and, when the motion carries a pulse, the
pulse's parameters (the shape's ``INPUTS``), plus *tags* -- the fields that name the row in the
algorithm that asked for it (stage, stratum, index, the standard normals it was drawn from, its
sampling weight: the rare route's declaration, :data:`pycolfrag.layouts.events.KIND`). The row itself is the synthetic
grid's (:func:`pycolfrag.solver.sample.run_synthetic_samples`), so an event with the inputs of a grid row
gives that row's record and response bit for bit.

:class:`EventBatchSpec` implements :class:`~pycolfrag.grid.protocol.RunSpec`: the scheduler, the
results file (journal, lock, checksums) and the code signature are the grid's. Its signature holds
a SHA-256 of the inputs and what the asking algorithm declares about them (``purpose``), so a resume
with other inputs or another purpose is refused as a changed grid is. ``limit`` (not signed) computes
only the first ``limit`` rows: an algorithm with a run budget cuts its last batch to a prefix, and a
later call with a larger budget computes the rest of the same batch.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError
from pycolfrag.grid.chunks import synthetic_record_s
from pycolfrag.grid.protocol import RowFunction
from pycolfrag.grid.signing import build_identity, code_digest
from pycolfrag.grid.spec import MAX_ROWS, RunSettings, resolve_solver_options
from pycolfrag.ground_motion.registry import DEFAULT_PULSE_SHAPE, pulse_shape_of, tp_model_of
from pycolfrag.layouts import events as _event_rows
from pycolfrag.solver import sample as _sample
from pycolfrag.structure.column import Column
from pycolfrag.structure.kinds import model_from_dict

__all__ = ["EventBatchSpec", "EventContext", "run_event", "run_events", "EVENT_ROWS", "TAG_FIELDS",
           "inputs_digest"]

_IDENTITY = tuple(_event_rows.KIND.identity)[:tuple(_event_rows.KIND.identity).index("mw")]
#: The fields an input's ``tags`` may set: the event layout's fields before ``mw`` (its identity,
#: the normals it was drawn from, its weights) but ``pulse`` and ``hf_seed``, which come from the input.
TAG_FIELDS = tuple(f for f in _IDENTITY if f not in ("pulse", "hf_seed"))
#: The stage of a row whose tags give none (every event row names its stage: a row without one reads as
#: never written).
DEFAULT_STAGE = 0


def _plain(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def inputs_digest(inputs) -> str:
    """SHA-256 of the inputs' canonical JSON (floats as their shortest repr: exact)."""
    h = hashlib.sha256()
    for x in inputs:
        h.update(json.dumps(x, sort_keys=True, default=_plain).encode())
        h.update(b"\n")
    return h.hexdigest()


def _check_input(i: int, x, shape) -> dict:
    """One input as a plain dict (mw, dist_km, hf_seed, pulse, tags), or ParameterError naming it."""
    if not isinstance(x, dict):
        raise ParameterError(f"event {i}: an input must be a dict, got {type(x).__name__}")
    unknown = set(x) - {"mw", "dist_km", "hf_seed", "pulse", "tags"}
    if unknown:
        raise ParameterError(f"event {i}: unknown input key(s) {sorted(unknown)}")
    for k in ("mw", "dist_km"):
        v = x.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"event {i}: {k} must be a finite number, got {v!r}")
    seed = x.get("hf_seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**64:
        raise ParameterError(f"event {i}: hf_seed must be an integer in [0, 2**64), got {seed!r}")
    pulse = x.get("pulse")
    if pulse is not None:
        need = [p.meta_key for p in shape.INPUTS]
        if not isinstance(pulse, dict) or sorted(pulse) != sorted(need):
            raise ParameterError(f"event {i}: pulse must be None or a dict of {need}, got {pulse!r}")
    tags = x.get("tags", {})
    if not isinstance(tags, dict) or set(tags) - set(TAG_FIELDS):
        raise ParameterError(f"event {i}: tags must be a dict of fields among {list(TAG_FIELDS)}, got {tags!r}")
    return {"mw": float(x["mw"]), "dist_km": float(x["dist_km"]), "hf_seed": int(seed),
            "pulse": None if pulse is None else {k: float(v) for k, v in pulse.items()},
            "tags": {k: _plain(v) for k, v in tags.items()}}


@dataclass(frozen=True)
class EventBatchSpec(RunSettings):
    """Everything that fixes the results of a batch of events (stored as the file's ``grid_signature``).

    Parameters
    ----------
    inputs : sequence of dict
        One per row: ``mw``, ``dist_km`` (km), ``hf_seed`` (the record's noise seed, 0 <= seed < 2**64),
        ``pulse`` (None: the stochastic record alone; else the values of the pulse shape's ``INPUTS``)
        and ``tags`` (fields of :data:`TAG_FIELDS`, stored with the row).
    purpose : dict
        What the asking algorithm declares about the batch (JSON; signed, stored as the root attribute
        ``purpose``): a resume with another purpose is refused.
    limit : int or None
        Compute only rows ``0 .. limit - 1`` (a prefix of the batch); None: every row. Not signed.
    column, solver_options, vp_scale, periods_s, damping, record_dt_s, max_record_s, sample_function :
        as :class:`~pycolfrag.grid.GridSpec` (``vp_scale`` is recorded: the pulse rows carry scaled
        amplitudes already).
    pulse_shape, tp_model, vp_model : str
        The pulse shape of the rows with a pulse, and the pulse-period and pulse-amplitude relations their
        parameters were drawn with (recorded; ``vp_model`` empty: Eq. (6), and then absent from the
        signature and the file's attributes, as in every file written before it existed).
    """

    inputs: tuple = ()
    purpose: dict = field(default_factory=dict)
    limit: int | None = field(default=None, compare=False)
    pulse_shape: str = DEFAULT_PULSE_SHAPE

    layout = "events"
    #: what the grid command would run after the run (the algorithm that asked reads the rows itself)
    after_run = "pycolfrag.cli.grid:synthetic_outputs"

    @property
    def fields(self) -> dict:
        """The ``/samples`` fields of its rows (:data:`pycolfrag.layouts.events.KIND` with the shared ones)."""
        return _results.fields_of(self.layout)

    def probe(self) -> tuple:
        """Nothing to probe, ``(None, None, None, [], None)``: the inputs are checked when the spec is made,
        and the algorithm that made them checked its record options (:mod:`pycolfrag.rare.driver`)."""
        return None, None, None, [], None

    def check_inputs(self) -> None:
        """Nothing: the inputs are checked when the spec is made."""

    def expected_work(self, durations, timing, log) -> float:
        """0: the asking algorithm sizes its batches by its own run budget."""
        return 0.0

    def __post_init__(self):
        shape = pulse_shape_of(self.pulse_shape)
        tp_model_of(self.tp_model)
        object.__setattr__(self, "solver_options", resolve_solver_options(self.solver_options))
        if not self.inputs:
            raise ParameterError("a batch of events needs at least one event")
        if len(self.inputs) > MAX_ROWS:
            raise ParameterError(f"a batch of {len(self.inputs)} events; at most {MAX_ROWS} fit one file")
        object.__setattr__(self, "inputs", tuple(_check_input(i, x, shape) for i, x in enumerate(self.inputs)))
        object.__setattr__(self, "_digest", inputs_digest(self.inputs))
        if self.limit is not None and (isinstance(self.limit, bool) or not isinstance(self.limit, int)
                                       or self.limit < 0):
            raise ParameterError(f"limit must be None or an integer >= 0, got {self.limit!r}")
        self._check_run_settings()

    @property
    def n_rows(self) -> int:
        return len(self.inputs)

    @property
    def digest(self) -> str:
        """SHA-256 of the inputs (:func:`inputs_digest`)."""
        return self._digest

    def signature(self) -> dict:
        return {
            "kind": "events", "purpose": self.purpose, "inputs_sha256": self._digest, "n_rows": self.n_rows,
            "column": self.column, "solver": self.solver_options.to_dict(), "build": build_identity(),
            "code_digest": code_digest(self.solver_options), "vp_scale": float(self.vp_scale),
            "periods_s": [float(p) for p in self.periods_s], "damping": float(self.damping),
            "record_dt_s": float(self.record_dt_s), "max_record_s": self.max_record_s,
            "sample_function": self.sample_function, "pulse_shape": self.pulse_shape, "tp_model": self.tp_model,
            **({"vp_model": self.vp_model} if self.vp_model else {}),
            "rows": "the inputs as given, row i = input i (hf_seed, pulse parameters); v1",
        }

    def order(self, rows) -> list[int]:
        """The rows below ``limit``, longest expected first: Mw descending, then R descending, then row."""
        stop = self.n_rows if self.limit is None else self.limit
        x = self.inputs
        return sorted((r for r in rows if r < stop), key=lambda r: (-x[r]["mw"], -x[r]["dist_km"], r))

    def expected_cost(self, rows) -> np.ndarray:
        """Each row's expected cost before it runs, in simulated seconds, as the synthetic grid's
        (:meth:`pycolfrag.grid.GridSpec.expected_cost`): the nominal record of its (Mw, R)
        (:func:`~pycolfrag.grid.chunks.synthetic_record_s`, cut to ``max_record_s``) plus the solver's tail."""
        x = self.inputs
        cut = self.max_record_s or math.inf
        return np.array([min(synthetic_record_s(x[r]["mw"], x[r]["dist_km"]), cut) + self.solver_options.tail_s
                         for r in rows], dtype=float)

    def context(self) -> "EventContext":
        return EventContext(self)

    def default_function(self) -> RowFunction:
        return EVENT_ROWS

    def file_attrs(self) -> dict:
        return {"layout": self.layout, "purpose": json.dumps(self.purpose, sort_keys=True),
                "inputs_sha256": self._digest, "vp_scale": float(self.vp_scale),
                "record_dt_s": float(self.record_dt_s), "pulse": self.pulse_shape, "tp_model": self.tp_model,
                "max_record_s": -1.0 if self.max_record_s is None else float(self.max_record_s),
                **({"vp_model": self.vp_model} if self.vp_model else {})}

    def shortest_record_dt(self) -> float:
        return float(self.record_dt_s)

    def describe(self) -> str:
        n_pulse = sum(1 for x in self.inputs if x["pulse"] is not None)
        part = "" if self.limit is None or self.limit >= self.n_rows else f", the first {self.limit} now"
        return f"{self.n_rows} events ({n_pulse} with a pulse){part}"

    def input_notes(self) -> list:
        """Nothing: the inputs are checked when the spec is made."""
        return []


class EventContext:
    """What a rank needs to compute any row of a batch of events: the spec and the structure (a column, or a
    scene such as a portal: the grid's rows read it the same way)."""

    spec: object     # the EventBatchSpec
    column: Column

    def __init__(self, spec):
        self.spec = spec
        self.column = model_from_dict(spec.column)   # a column, or a colonnade (the restoration's portal)

    def locate(self, row: int) -> tuple:
        """(row, Mw, R km, with a pulse) of a row."""
        x = self.spec.inputs[int(row)]
        return int(row), x["mw"], x["dist_km"], x["pulse"] is not None

    def identity(self, row: int) -> dict:
        return _identity(self.spec.inputs[int(row)])


def _identity(x: dict) -> dict:
    """The fields an event row carries from its input: its tags, pulse flag, seed, Mw and R."""
    return {"stage": DEFAULT_STAGE, **x["tags"], "pulse": int(x["pulse"] is not None), "hf_seed": x["hf_seed"],
            "mw": x["mw"], "dist_km": x["dist_km"]}


def run_event(ctx: EventContext, row: int) -> dict:
    """Compute one row of a batch of events (:func:`run_events` of one row). Never raises for a failing run."""
    return run_events(ctx, [row])[0]


def run_events(ctx: EventContext, rows) -> list[dict]:
    """The rows of a chunk: those with a pulse side by side in SIMD lanes, then those without
    (:func:`pycolfrag.solver.sample.run_synthetic_samples`; each row bitwise its run on its own), each with
    its tags; in the order asked."""
    spec = ctx.spec
    out: dict = {}
    for with_pulse in (True, False):
        mine = [r for r in rows if (spec.inputs[int(r)]["pulse"] is not None) == with_pulse]
        if not mine:
            continue
        xs = [spec.inputs[int(r)] for r in mine]
        done = _sample.run_synthetic_samples(
            ctx.column, [(x["mw"], x["dist_km"], x["hf_seed"], x["pulse"]) for x in xs],
            record_dt_s=spec.record_dt_s, vp_scale=spec.vp_scale, periods_s=spec.periods_s, damping=spec.damping,
            solver_options=spec.solver_options, max_record_s=spec.max_record_s, with_pulse=with_pulse,
            pulse_shape=spec.pulse_shape)
        for r, x, d in zip(mine, xs, done):
            out[int(r)] = {"row": int(r), **_identity(x), **d}
    return [out[int(r)] for r in rows]


#: A batch of events' rows: one at a time, or a chunk side by side in SIMD lanes.
EVENT_ROWS = RowFunction(run_event, run_events)
