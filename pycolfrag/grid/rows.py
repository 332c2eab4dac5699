"""The rows of a grid: their seeds, the context a rank computes them in, and their row functions.

What a row holds -- synthetic or natural -- is defined once, in :mod:`pycolfrag.solver.sample`; this module
gives a synthetic row its seeds and pulse parameters, and a record row its record, component and
scale. Nothing here depends on the rank or the order of work.
"""
from __future__ import annotations

import importlib
import time
from collections import OrderedDict

import numpy as np

from pycolfrag import ground_motion as _gm
from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError
from pycolfrag.grid.protocol import RowFunction, as_row_function
from pycolfrag.solver import sample as _sample
from pycolfrag.structure.kinds import model_from_dict

__all__ = ["derive_seed", "SampleContext", "run_sample", "run_samples", "SYNTHETIC_ROWS",
           "RecordContext", "run_record_row", "run_record_rows", "RECORD_ROWS", "load_function"]

# stream identifiers mixed into the SeedSequence keys
_STREAM_LHS = 1
_STREAM_HF = 2
#: LHS tables kept per rank (a rank's chunks come from few scenarios at a time)
_LHS_CACHE = 8


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


# ---------------------------------------------------------------------------------------
# the synthetic grid
# ---------------------------------------------------------------------------------------

class SampleContext:
    """What a rank needs to compute any row: the spec, the column, cached LHS tables, and what every row
    shares prepared once (:class:`pycolfrag.solver.sample.PreparedRows`: the column's C set-up, each
    scenario's synthesis), so that a row in steady state does only its own work."""

    spec: object     # the GridSpec
    column: object   # a Column, or a Colonnade (--scene)

    def __init__(self, spec):
        self.spec = spec
        self.column = model_from_dict(spec.column)   # a column, or a colonnade (--scene)
        self._lhs: OrderedDict = OrderedDict()
        self._inputs: OrderedDict = OrderedDict()
        self._scenarios = list(spec.scenarios)
        with_pulse = spec.pulse != _gm.registry.NO_PULSE
        self.prepared = _sample.PreparedRows(
            self.column, record_dt_s=spec.record_dt_s, vp_scale=spec.vp_scale, periods_s=spec.periods_s,
            damping=spec.damping, solver_options=spec.solver_options, max_record_s=spec.max_record_s,
            with_pulse=with_pulse, pulse_shape=spec.pulse if with_pulse else _gm.registry.DEFAULT_PULSE_SHAPE)

    def locate(self, row: int) -> tuple[int, int, float, float]:
        """(scenario, sample, Mw, R km) of a row."""
        sc, k = divmod(int(row), self.spec.samples)
        mw, dist = self._scenarios[sc]
        return sc, k, mw, dist

    def identity(self, row: int) -> dict:
        """The fields naming a row (kept in a failed row whose sample function raised)."""
        sc, k, mw, dist = self.locate(row)
        return {"scenario": sc, "sample": k, "mw": mw, "dist_km": dist}

    def lhs_seed(self, scenario: int) -> int:
        mw, dist = self._scenarios[scenario]
        return derive_seed(self.spec.seed, _STREAM_LHS, _key(mw), _key(dist))

    def hf_seed(self, scenario: int, sample: int) -> int:
        mw, dist = self._scenarios[scenario]
        return derive_seed(self.spec.seed, _STREAM_HF, _key(mw), _key(dist), int(sample))

    def pulse(self, scenario: int, sample: int) -> dict:
        """Row ``sample`` of the scenario's LHS of pulse parameters (cached per scenario). Without the
        derived amplitude (``amplitude=False``): the record finds its own from the row's inputs, the same
        search with the same bits, and a rank then searches only for its own rows, not for every sample of
        each scenario it touches (90 % of a 1000-sample draw)."""
        if scenario not in self._lhs:
            mw, dist = self._scenarios[scenario]
            table = _gm.sample_pulse_parameters(mw, dist, self.spec.samples, self.lhs_seed(scenario),
                                                vp_scale=self.spec.vp_scale, tp_model=self.spec.tp_model,
                                                shape=self.spec.pulse, amplitude=False, vp_model=self.spec.vp_model)
            self._lhs[scenario] = {k: np.asarray(v) for k, v in table.items()}
            while len(self._lhs) > _LHS_CACHE:
                self._lhs.popitem(last=False)
        return {k: (v[sample].item() if v.ndim else v.item()) for k, v in self._lhs[scenario].items()}

    def pulse_inputs(self, scenario: int, sample: int):
        """Row ``sample``'s pulse as its record takes it (the shape's inputs), the scenario's rows checked
        once, together (``pycolfrag.ground_motion._checked_row``); raises
        what refuses the row's. None where the scenario itself is refused (its rows fail with that)."""
        if scenario not in self._inputs:
            synth = self.prepared.scenario(*self._scenarios[scenario])
            rows = [self.pulse(scenario, k) for k in range(self.spec.samples)]
            self._inputs[scenario] = [None] * len(rows) if isinstance(synth, Exception) else \
                [_checked_inputs(synth, row) for row in rows]
            while len(self._inputs) > _LHS_CACHE:
                self._inputs.popitem(last=False)
        got = self._inputs[scenario][sample]
        if isinstance(got, Exception):
            raise got
        return got


def _checked_inputs(synth, pulse):
    """The inputs of a pulse row as the scenario's record takes them, or the exception refusing them."""
    try:
        return _gm._checked_row(synth, 0, pulse)[1]   # the row's seed is the grid's own (derive_seed: 32 bits)
    except Exception as exc:
        return exc


def run_sample(ctx: SampleContext, row: int) -> dict:
    """Compute one row of the synthetic grid: the grid's seeds and pulse parameters for the row, then
    :func:`pycolfrag.solver.sample.run_synthetic_sample` (the one definition of a sample). Never raises for
    a failing sample (``status`` > 0 and ``message`` instead)."""
    return run_samples(ctx, [row])[0]


def run_samples(ctx: SampleContext, rows) -> list[dict]:
    """:func:`run_sample` of many rows, their runs side by side in SIMD lanes
    (:func:`pycolfrag.solver.sample.run_synthetic_samples`): the same rows, faster."""
    outs, samples, owner, t_seed = [], [], [], []
    with_pulse = ctx.spec.pulse != _gm.registry.NO_PULSE
    for row in rows:
        sc, k, mw, dist = ctx.locate(row)
        out = {"row": int(row), "scenario": sc, "sample": k}
        t0 = time.perf_counter()
        try:
            samples.append((mw, dist, ctx.hf_seed(sc, k), ctx.pulse_inputs(sc, k) if with_pulse else None))
            owner.append(out)
            t_seed.append(time.perf_counter() - t0)  # the scenario's LHS is drawn at its first row
        except Exception as exc:  # the pulse parameters are part of the record: a record failure
            out.update(mw=mw, dist_km=dist, status=_results.STATUS_RECORD_FAILED,
                       message=f"{type(exc).__name__}: {exc}", wall_s=time.perf_counter() - t0)
        outs.append(out)
    done = ctx.prepared.synthetic(samples, checked=True)   # run_synthetic_samples, with what rows share kept
    for out, d, t in zip(owner, done, t_seed):
        out.update(d)
        out["wall_s"] += t
    return outs


#: The synthetic grid's rows: one at a time, or a chunk side by side in SIMD lanes.
SYNTHETIC_ROWS = RowFunction(run_sample, run_samples)


# ---------------------------------------------------------------------------------------
# record suites
# ---------------------------------------------------------------------------------------

class RecordContext:
    """What a rank needs to compute any row of a record-suite grid: the spec, the column, the suite, and
    what every row shares prepared once (:class:`pycolfrag.solver.sample.PreparedRows`)."""

    spec: object     # the RecordGridSpec
    column: object   # a Column, or a Colonnade (--scene)

    def __init__(self, spec):
        self.spec = spec
        self.column = model_from_dict(spec.column)   # a column, or a colonnade (--scene)
        self.prepared = _sample.PreparedRows(self.column, periods_s=spec.periods_s, damping=spec.damping,
                                             solver_options=spec.solver_options, max_record_s=spec.max_record_s)
        self._jobs = spec.jobs

    def locate(self, row: int) -> tuple[int, str, float]:
        """(record index, component, scale) of a row."""
        return self._jobs[int(row)]

    def identity(self, row: int) -> dict:
        k, c, f = self.locate(row)
        return {"record": k, **_sample.record_identity(self.spec.suite[k], c, f)}


def run_record_row(ctx: RecordContext, row: int) -> dict:
    """Compute one row of a record-suite grid: :func:`pycolfrag.solver.sample.run_record_sample` of the
    row's record, component and scale. Never raises for a failing sample."""
    return run_record_rows(ctx, [row])[0]


def run_record_rows(ctx: RecordContext, rows) -> list[dict]:
    """:func:`run_record_row` of many rows, their runs side by side in SIMD lanes
    (:func:`pycolfrag.solver.sample.run_record_samples`): the same rows, faster."""
    spec = ctx.spec
    where = [ctx.locate(row) for row in rows]
    done = ctx.prepared.records([(spec.suite[k], c, f) for k, c, f in where])   # run_record_samples's rows
    return [{"row": int(row), "record": k, **d} for row, (k, _, _), d in zip(rows, where, done)]


#: A record suite's rows: one at a time, or a chunk side by side in SIMD lanes.
RECORD_ROWS = RowFunction(run_record_row, run_record_rows)


# ---------------------------------------------------------------------------------------
# running a row function
# ---------------------------------------------------------------------------------------

def guarded(fn: RowFunction, ctx, row: int) -> dict:
    """One row through ``fn.one``; an exception escaping it becomes a failed row."""
    t0 = time.perf_counter()
    try:
        out = dict(fn.one(ctx, row))
    except Exception as exc:
        out = dict(ctx.identity(row))
        out.update(status=_results.STATUS_OTHER_FAILED, message=f"{type(exc).__name__}: {exc}",
                   wall_s=time.perf_counter() - t0)
    out.setdefault("wall_s", time.perf_counter() - t0)
    out["row"] = int(row)
    return out


def guarded_rows(fn: RowFunction, ctx, rows) -> list[dict]:
    """The rows of a chunk: through ``fn.many`` (the same rows with the runs side by side in SIMD
    lanes) when it has one, else :func:`guarded` row by row; a chunk that raises is redone row by
    row, so that each row gets its own failure."""
    if fn.many is None or len(rows) < 2:
        return [guarded(fn, ctx, row) for row in rows]
    try:
        outs = [dict(o) for o in fn.many(ctx, rows)]
    except Exception:
        return [guarded(fn, ctx, row) for row in rows]
    for out, row in zip(outs, rows):
        out["row"] = int(row)
    return outs


def load_function(name: str | None, default: RowFunction) -> RowFunction:
    """The row function named ``module:NAME`` (a function of one row or a :class:`RowFunction`), or
    ``default`` when ``name`` is empty. A name that cannot be imported raises :class:`ParameterError`."""
    if not name:
        return default
    mod, _, attr = name.partition(":")
    if not attr:
        raise ParameterError(f"sample function must be 'module:function', got {name!r}")
    try:
        return as_row_function(getattr(importlib.import_module(mod), attr))
    except (ImportError, AttributeError) as exc:
        raise ParameterError(f"--sample-function {name}: {type(exc).__name__}: {exc}") from None
