"""One definition of "a sample": a record (synthetic or natural) -> intensity measures -> column
response -> one row dict in the layout of ``/samples`` (docs/results_format.md).

The MPI driver (:mod:`pycolfrag.grid`) only schedules rows, derives seeds and writes results; what a
row holds is decided here, for both kinds of sample:

* :func:`run_synthetic_sample` -- a near-fault record synthesised for a scenario (Mw, R) from a
  row of pulse parameters and a high-frequency seed (the paper's grid);
* :func:`run_record_sample` -- a natural record of a :class:`~pycolfrag.ground_motion.record_suites.RecordSet`, one
  horizontal component or both, scaled by an amplitude factor (record suites, multiple stripes).

Both fill the IMs and EDPs by iterating over the registry :mod:`pycolfrag.core.names`, through the
shared :func:`response_row`, and never raise for a failing sample: ``status`` (the codes of
:mod:`pycolfrag.results`) and ``message`` say which phase failed.

The motion of every run is a :class:`~pycolfrag.ground_motion.Record` (:meth:`Record.motion
<pycolfrag.ground_motion.Record.motion>` of a suite member, or a synthetic record), checked once when it was
made; the periods and damping (:class:`~pycolfrag.ground_motion.intensity.SpectralOptions`) and the solver
options (:class:`~pycolfrag.solver.options.SolverOptions`) once per call, or once per grid (:class:`PreparedRows`,
with the column's C set-up and each scenario's synthesis), so the IMs and the runs take them as they are.
"""
from __future__ import annotations

import math
import time
import warnings
from collections import OrderedDict
from typing import Any

import numpy as np

from pycolfrag import results as _r
from pycolfrag.core import names
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import positive_float
from pycolfrag.ground_motion import _checked_row, intensity
from pycolfrag.ground_motion import record_suites as _records
from pycolfrag.ground_motion import synthesis as _synthesis
from pycolfrag.ground_motion.intensity import SpectralOptions
from pycolfrag.ground_motion.record import COMPONENTS, Record
from pycolfrag.ground_motion.registry import DEFAULT_PULSE_SHAPE, PULSE_FIELDS
from pycolfrag.solver import prepared_batch as _prepared  # through the module, as run (below)
from pycolfrag.solver import run as _solver  # called through the module, so a test's fake of simulate takes effect
from pycolfrag.solver.options import SolverOptions
from pycolfrag.solver.run import EnergyWarning, StepWarning
from pycolfrag.structure.column import Column

__all__ = ["DEFAULT_PERIODS_S", "DEFAULT_DAMPING", "COMPONENTS", "STATUS", "record_identity", "ims_row", "response_row",
           "run_synthetic_sample", "run_synthetic_samples", "PreparedRows", "run_record_sample", "run_record_samples", "response_rows", "record_jobs", "run_suite", "rows_to_table"]

#: Spectral periods of a row (``/spectra``), s -- the grid's default.
DEFAULT_PERIODS_S = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0)
#: Spectral damping ratio.
DEFAULT_DAMPING = 0.05
#: Runs of :func:`run_suite` integrated together (side by side in SIMD lanes, lanes refilled).
_SUITE_BATCH = 64


#: Status codes of a row by phase (0 ok; see :mod:`pycolfrag.results`).
STATUS = {"ok": _r.STATUS_OK, "record": _r.STATUS_RECORD_FAILED, "im": _r.STATUS_IM_FAILED,
          "solver": _r.STATUS_SOLVER_FAILED, "other": _r.STATUS_OTHER_FAILED}


def _meta(meta: dict, *keys, default=math.nan) -> float:
    for k in keys:
        if k in meta and meta[k] is not None:
            try:
                return float(meta[k])
            except (TypeError, ValueError):
                return default
    return default


def record_identity(record, component, scale) -> dict:
    """The fields that name a record row: record_id, event, station, component, mw, rrup_km (also as
    dist_km, the synthetic grid's distance) and scale. Kept in a row whose run failed. ``record``: a
    suite member (a Record or an unreadable member's marker)."""
    rrup = _meta(record.meta, "rrup_km")
    return {"record_id": record.record_id, "event": str(record.event), "station": str(record.station),
            "component": str(component), "mw": _meta(record.meta, "mw"), "rrup_km": rrup, "dist_km": rrup,
            "scale": scale}


def ims_row(acc, dt, periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING) -> dict:
    """Every IM of :data:`pycolfrag.core.names.IMS` of one record: scalars as floats, spectral ones as
    arrays over ``periods_s`` (:func:`pycolfrag.ground_motion.intensity.measures`)."""
    return _ims_of(intensity.measures(acc, dt, periods=periods_s, damping=damping))


def _ims(motion: Record, spectral: SpectralOptions) -> dict:
    """:func:`ims_row` of a run's motion (its ``acc``) for checked periods and damping."""
    return _ims_of(intensity.record_measures(motion, spectral))


def _ims_of(ims: dict) -> dict:
    out = {}
    for name, q in names.IMS.items():
        out[name] = np.asarray(ims[name], dtype=float) if q.spectral else float(ims[name])
    return out


def _combine_ims(a: dict, b: dict) -> dict:
    """IMs of a two-component excitation: the geometric mean of the two components' values."""
    out = {}
    for name in a:
        with np.errstate(invalid="ignore", divide="ignore"):
            v = np.sqrt(np.asarray(a[name], dtype=float) * np.asarray(b[name], dtype=float))
        out[name] = v if np.ndim(v) else float(v)
    return out


def _edp_row(res) -> dict:
    """EDPs (:data:`pycolfrag.core.names.EDPS`) and run diagnostics of a :class:`~pycolfrag.solver.run.Response`."""
    collapsed = bool(res.collapsed)
    cb = getattr(res, "collapse_block", None)
    ct = getattr(res, "collapse_time", None)
    out: dict[str, Any] = {name: float(getattr(res, q.response or name)) for name, q in names.EDPS.items()}
    out.update(collapsed=int(collapsed),
               collapse_block=int(cb) if (collapsed and cb is not None and cb >= 0) else -1,
               collapse_time_s=float(ct) if (collapsed and ct is not None) else math.nan,
               n_steps=int(res.n_steps), t_end_s=float(res.t_end),
               energy_error=float(getattr(res, "energy_error", math.nan)),
               energy_warning=int(bool(getattr(res, "energy_warning", False))),
               solver_dt_s=float(getattr(res, "dt", math.nan)))
    if collapsed:
        out["collapse_reason"] = str(getattr(res, "collapse_reason", "") or "")
    return out


def _spectral(periods_s, damping):
    """The checked periods and damping of a call's rows, or the exception that refuses them (each
    row then fails in its IM phase with it: a failing sample is a row, not an exception)."""
    try:
        return SpectralOptions(periods_s, damping)
    except Exception as exc:
        return exc


def _ims_phase(out, motion, ims, spectral) -> bool:
    """The IMs of a row (``ims`` when given, else those of the motion's ``acc``); False (and
    ``status``) when they failed."""
    out.setdefault("status", STATUS["ok"])
    out.setdefault("message", "")
    try:
        if isinstance(spectral, Exception):
            raise spectral
        out.update(_ims(motion, spectral) if ims is None else ims)
    except Exception as exc:  # a failed sample is a result (status, message), not the end of the run
        out["status"] = STATUS["im"]
        out["message"] = f"{type(exc).__name__}: {exc}"
        return False
    return True


def _response_phase(out, res, steps=()) -> None:
    """The EDPs of a row from its run: a Response, or the exception the run raised; ``steps``, the
    texts of the run's step warnings, go into the row's message."""
    if isinstance(res, BaseException):
        out["status"] = STATUS["solver"]
        out["message"] = f"{type(res).__name__}: {res}"
        return
    try:
        out.update(_edp_row(res))
    except Exception as exc:
        out["status"] = STATUS["other"]
        out["message"] = f"{type(exc).__name__}: {exc}"
        return
    if steps:
        out["message"] = "StepWarning: " + "; ".join(steps)


def _options(solver_options):
    """A call's solver options, resolved once: a SolverOptions (what the grid passes) as it is, a
    dict of overrides on the defaults, or the exception that refuses them (each run then fails with it)."""
    if isinstance(solver_options, SolverOptions):
        return solver_options
    try:
        return SolverOptions().replace(**dict(solver_options or {}))
    except Exception as exc:
        return exc


def _caught(run):
    """``run()`` as a row needs it: (its result or the exception it raised, the texts of its step
    warnings). An energy warning is stored in the row (energy_warning), not printed per run; a step
    warning (dt_solver above the stability limit or the record's dt) is kept in the row's message."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("ignore", UserWarning)
        warnings.simplefilter("ignore", EnergyWarning)
        warnings.simplefilter("always", StepWarning)
        try:
            res = run()
        except Exception as exc:
            res = exc
    return res, [str(w.message) for w in caught if issubclass(w.category, StepWarning)]


def _simulate(column, motion: Record, options):
    """One run as a row needs it: (the Response or the exception, its step-warning texts)."""
    if isinstance(options, Exception):
        return options, []
    return _caught(lambda: _solver.simulate(column, motion, options=options))


def _motion_of(motion) -> Record:
    if not isinstance(motion, Record):
        raise ParameterError(f"a run's motion must be a Record (acc along x, h2 along y, v vertical), "
                             f"got {type(motion).__name__}")
    return motion


def response_row(column, motion, *, ims=None, periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING,
                 solver_options=None, out=None) -> dict:
    """IMs then the column's response: the shared body of every sample.

    ``motion``: the run's ground motion, a :class:`~pycolfrag.ground_motion.Record` (``acc`` along x,
    ``h2`` along y, ``v`` vertical). ``ims``: precomputed IMs (else those of ``motion.acc``).
    ``out``: a row dict to fill (its ``status``/``message`` are set by the phase that fails; nothing
    is raised).
    """
    return _response_row(column, _motion_of(motion), ims, _spectral(periods_s, damping), _options(solver_options),
                         {} if out is None else out)


def _response_row(column, motion: Record, ims, spectral, options, out: dict) -> dict:
    """:func:`response_row` of resolved periods, damping and options (:func:`_spectral`, :func:`_options`)."""
    if _ims_phase(out, motion, ims, spectral):
        _response_phase(out, *_simulate(column, motion, options))
    return out


def _simulate_many(column, motions: list, options, batch=None) -> list:
    """The runs (Records) on one column: (Response or exception, step-warning texts) each, the
    Response bitwise what :func:`_simulate` gives, through :func:`pycolfrag.solver.run.simulate_batch`
    (runs in SIMD lanes). Where the batch cannot start (options the set-up refuses) or warns about
    the step (an explicit dt_solver above the stability limit or a record's dt: rare, the grid
    refuses both), every run alone, so that each row gets the message and the warnings of its own run.
    ``batch``: a callable giving the column's PreparedBatch (or None), run instead of simulate_batch."""
    if len(motions) < 2 or isinstance(options, Exception):
        return [_simulate(column, m, options) for m in motions]
    ready = None if batch is None else batch()
    res, steps = _caught(lambda: _solver.simulate_batch(column, motions, errors="return", options=options)
                         if ready is None else ready.run(motions))
    if isinstance(res, Exception) or steps:
        return [_simulate(column, m, options) for m in motions]
    return [(x, []) for x in res]


def response_rows(column, rows, *, periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING, solver_options=None,
                  times=None) -> None:
    """:func:`response_row` for many rows at once, their runs in one batch: each row gets bitwise what
    :func:`response_row` gives it.

    ``rows``: (row dict to fill, motion (a Record), precomputed IMs or None) of each. ``times`` (list,
    one per row, or None): each row's own seconds are added to it -- its IMs, and of the batch's
    solver time the share of its steps.
    """
    rows = [(out, _motion_of(motion), ims) for out, motion, ims in rows]
    _response_rows(column, rows, _spectral(periods_s, damping), _options(solver_options), times)


def _response_rows(column, rows: list, spectral, options, times, batch=None) -> None:
    """:func:`response_rows` of resolved periods, damping and options (:func:`_spectral`, :func:`_options`)."""
    t_ims, todo = [], []
    for out, motion, ims in rows:
        t0 = time.perf_counter()
        if _ims_phase(out, motion, ims, spectral):
            todo.append((out, motion))
        t_ims.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    res = _simulate_many(column, [m for _, m in todo], options, batch)
    t_run = time.perf_counter() - t0
    for (out, _), (x, warned) in zip(todo, res):
        _response_phase(out, x, warned)
    if times is not None:
        steps = {id(out): float(getattr(x, "n_steps", 0)) for (out, _), (x, _) in zip(todo, res)}
        total = sum(steps.values())
        for i, (out, _, _) in enumerate(rows):
            share = steps.get(id(out), 0.0) / total if total > 0 else (1.0 / len(todo) if id(out) in steps else 0.0)
            times[i] += t_ims[i] + share * t_run


def run_synthetic_sample(column, mw, dist_km, hf_seed, pulse, *, record_dt_s=0.005, vp_scale=1.0,
                         periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING, solver_options=None,
                         max_record_s=None, with_pulse=True, pulse_shape=DEFAULT_PULSE_SHAPE) -> dict:
    """One synthetic sample of the paper's grid (what :func:`pycolfrag.grid.run_sample` computes).

    Parameters
    ----------
    column : Column
    mw, dist_km : float -- the scenario
    hf_seed : int -- seed of the high-frequency noise
    pulse : dict -- a row of :func:`pycolfrag.ground_motion.sample_pulse_parameters`
    record_dt_s, vp_scale : see :func:`pycolfrag.ground_motion.synthesize`
    periods_s, damping : spectral periods (s) and damping ratio of the IMs
    solver_options : SolverOptions, or a dict of :func:`pycolfrag.simulate` keywords
    max_record_s : float or None -- cut the record (tests and quick looks only)
    with_pulse : bool -- False: the high-frequency record alone (:func:`pycolfrag.ground_motion.stochastic`
        with the same ``hf_seed``: the no-pulse branch of a site's motions); ``pulse`` and ``vp_scale``
        are then unused and the pulse fields stay NaN
    pulse_shape : str -- the pulse's shape (:data:`pycolfrag.ground_motion.registry.PULSE_SHAPES`), of
        which ``pulse`` is a row

    Returns
    -------
    dict: ``mw``, ``dist_km``, ``status``, ``message``, the pulse parameters
    (:data:`pycolfrag.ground_motion.registry.PULSE_FIELDS`, NaN without a pulse), ``record_s``, every
    IM and EDP of :mod:`pycolfrag.core.names`, the run diagnostics and ``wall_s``. The grid adds ``row``,
    ``scenario`` and ``sample``.
    """
    t0 = time.perf_counter()
    out, motion = _synthetic_motion(mw, dist_km, hf_seed, pulse, record_dt_s, vp_scale, max_record_s, with_pulse,
                                    pulse_shape)
    if motion is not None:
        _response_row(column, motion, None, _spectral(periods_s, damping), _options(solver_options), out)
    out["wall_s"] = time.perf_counter() - t0
    return out


def _synthetic_motion(mw, dist_km, hf_seed, pulse, record_dt_s, vp_scale, max_record_s, with_pulse=True,
                      pulse_shape=DEFAULT_PULSE_SHAPE):
    """The record of a synthetic sample and its row so far: (row, the run's motion, a Record); the
    motion is None (and the row says why) when the record failed."""
    return _synthetic_row(_scenario(mw, dist_km, record_dt_s, vp_scale, with_pulse, pulse_shape), mw, dist_km,
                          hf_seed, pulse, max_record_s)


def _scenario(mw, dist_km, record_dt_s, vp_scale, with_pulse, pulse_shape):
    """The scenario's :func:`pycolfrag.ground_motion.synthesis.prepare`, or the exception refusing it."""
    try:
        return _synthesis.prepare(mw, dist_km, record_dt_s, vp_scale, pulse_shape if with_pulse else None)
    except Exception as exc:
        return exc


def _synthetic_row(synth, mw, dist_km, hf_seed, pulse, max_record_s, checked=False):
    """:func:`_synthetic_motion` of a prepared scenario ``synth`` (or its exception); ``checked``: the seed
    and ``pulse`` (the inputs) as ``ground_motion._checked_row`` gives them (the grid's: once per scenario)."""
    out = {"mw": float(mw), "dist_km": float(dist_km), "status": STATUS["ok"], "message": ""}
    try:
        if isinstance(synth, Exception):
            raise synth
        seed, inputs, source = (hf_seed, pulse, "argument") if checked else _checked_row(synth, hf_seed, pulse)
        rec = synth.record(seed, inputs, components=False, source=source)
        cut = None if max_record_s is None else int(round(max_record_s / rec.dt)) + 1
        motion = Record._checked(rec.acc[:cut], rec.dt, rec.meta)   # rec.motion("h1", max_samples=cut)
        out["record_s"] = motion.n * motion.dt
        if synth.model is not None:
            out.update({p.row_field: _meta(rec.meta, p.meta_key) for p in PULSE_FIELDS})
    except Exception as exc:
        out.update(status=STATUS["record"], message=f"{type(exc).__name__}: {exc}")
        return out, None
    return out, motion


def _synthetic_record(mw, dist_km, hf_seed, pulse, record_dt_s, vp_scale, max_record_s, with_pulse=True,
                      pulse_shape=DEFAULT_PULSE_SHAPE):
    """:func:`_synthetic_motion` as arrays (row, acc, dt), None when the record failed (the grid's probe's)."""
    out, motion = _synthetic_motion(mw, dist_km, hf_seed, pulse, record_dt_s, vp_scale, max_record_s, with_pulse,
                                    pulse_shape)
    return (out, None, None) if motion is None else (out, motion.acc, motion.dt)


def run_synthetic_samples(column, samples, *, record_dt_s=0.005, vp_scale=1.0, periods_s=DEFAULT_PERIODS_S,
                          damping=DEFAULT_DAMPING, solver_options=None, max_record_s=None,
                          with_pulse=True, pulse_shape=DEFAULT_PULSE_SHAPE) -> list[dict]:
    """Many synthetic samples of one column, their runs side by side in SIMD lanes (:class:`PreparedRows`): each
    row bitwise the :func:`run_synthetic_sample` of its sample, but faster. ``samples``: (mw, dist_km, hf_seed,
    pulse) of each; the rest as there. ``wall_s``: its record and IMs, and its steps' share of the solver time."""
    return PreparedRows(column, record_dt_s=record_dt_s, vp_scale=vp_scale, periods_s=periods_s, damping=damping,
                        solver_options=solver_options, max_record_s=max_record_s, with_pulse=with_pulse,
                        pulse_shape=pulse_shape).synthetic(samples)


class PreparedRows:
    """What the rows of one column share, prepared once and kept: the checked periods and damping, the
    solver options, the column's C set-up (:class:`~pycolfrag.solver.prepared_batch.PreparedBatch`, on the
    first batch) and each scenario's synthesis (:mod:`pycolfrag.ground_motion.synthesis`, the last few).
    The grid keeps one per rank, so that a row in steady state does only its own work; :meth:`synthetic`
    and :meth:`records` give bitwise the rows of ``run_synthetic_samples`` and ``run_record_samples``."""

    SCENARIOS = 8   # prepared scenarios kept (a rank's chunks come from few scenarios at a time)

    def __init__(self, column, *, record_dt_s=0.005, vp_scale=1.0, periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING,
                 solver_options=None, max_record_s=None, with_pulse=True, pulse_shape=DEFAULT_PULSE_SHAPE) -> None:
        self.column, self.max_record_s = column, max_record_s
        self.spectral, self.options = _spectral(periods_s, damping), _options(solver_options)
        self._record = (record_dt_s, vp_scale, with_pulse, pulse_shape)
        self._scenarios: OrderedDict = OrderedDict()
        self._batch: Any = None

    def scenario(self, mw, dist_km):
        """The scenario's prepared synthesis, or the exception refusing it (made once, then kept)."""
        synth = self._scenarios.get((mw, dist_km))
        if synth is None:
            synth = self._scenarios[(mw, dist_km)] = _scenario(mw, dist_km, *self._record)
            while len(self._scenarios) > self.SCENARIOS:
                self._scenarios.popitem(last=False)
        return synth

    def batch(self):
        """The column's PreparedBatch; None: each batch through simulate_batch (its set-up refused or warned)."""
        if self._batch is None:
            ready, steps = _caught(lambda: _prepared.PreparedBatch(self.column, self.options))
            self._batch = False if isinstance(ready, Exception) or steps else ready
        return self._batch or None

    def synthetic(self, samples, checked=False) -> list[dict]:
        """Rows of synthetic ``samples``, (mw, dist_km, hf_seed, pulse) each; ``checked``: the seed and pulse
        of each as ``pycolfrag.ground_motion._checked_row`` gives them."""
        def prepare(mw, dist_km, hf_seed, pulse):
            synth = self.scenario(mw, dist_km)
            return (*_synthetic_row(synth, mw, dist_km, hf_seed, pulse, self.max_record_s, checked), None)
        return _batch_rows(self.column, samples, prepare, self.spectral, self.options, self.batch)

    def records(self, samples, vertical=False, rotation_deg=None) -> list[dict]:
        """Rows of natural-record ``samples``, (record, component, scale) each (:func:`run_record_samples`)."""
        def prepare(record, component, scale):
            return _record_run(record, component, scale, vertical, rotation_deg, self.spectral, self.max_record_s)
        return _batch_rows(self.column, samples, prepare, self.spectral, self.options, self.batch)


def _batch_rows(column, samples, prepare, spectral, options, batch=None) -> list[dict]:
    """Rows of many samples: ``prepare(*sample)`` gives each its row so far, its run's motion (None when it
    failed before the run) and precomputed IMs (or None), then :func:`response_rows` runs them together;
    ``wall_s`` of a row: its own preparation and IMs, and the share of its steps of the batch's solver time."""
    rows, runs, owner, times = [], [], [], []
    for i, smp in enumerate(samples):
        t0 = time.perf_counter()
        out, motion, ims = prepare(*smp)
        rows.append(out)
        times.append(time.perf_counter() - t0)
        if motion is not None:
            runs.append((out, motion, ims))
            owner.append(i)
    run_times = [0.0] * len(runs)
    _response_rows(column, runs, spectral, options, run_times, batch)
    for i, t in zip(owner, run_times):
        times[i] += t
    for out, t in zip(rows, times):
        out["wall_s"] = t
    return rows


def run_record_sample(record, *, column, component="h1", scale=1.0, vertical=False, rotation_deg=None,
                      periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING, solver_options=None,
                      max_record_s=None) -> dict:
    """One natural-record sample: a record (or its pair) scaled by ``scale`` on the column.

    Parameters
    ----------
    record : :class:`~pycolfrag.ground_motion.Record` (a suite member) or
        :class:`~pycolfrag.ground_motion.record_suites.UnreadableRecord` (the row fails with its reason)
    column : Column
    component : "h1", "h2" or "both"
        One horizontal component along the solver's x axis (the paper's Fig. 10 runs each on its own),
        or the pair (H1 along x, H2 along y: two-component excitation).
    scale : float (> 0)
        Amplitude factor on every component (multiple-stripe analysis). IMs are those of the scaled motion.
    vertical : bool
        Add the vertical component (acc_z) when the record has one.
    rotation_deg : float or None
        Rotate the pair first (:meth:`~pycolfrag.ground_motion.Record.rotated`); ``component`` then
        refers to the rotated axes.
    periods_s, damping, solver_options, max_record_s : as in :func:`run_synthetic_sample`.

    Returns
    -------
    dict: the record's metadata (``record_id``, ``event``, ``station``, ``component``, ``mw``,
    ``rrup_km``, ``scale``, ``rjb_km``, ``vs30_m_s``, ``tp_s``, ``year``, ``mechanism``), ``dist_km``
    (= ``rrup_km``, the same distance definition as the synthetic grid's), ``record_s``, ``dt_s``,
    ``status``, ``message``, every IM and EDP of :mod:`pycolfrag.core.names`, the run diagnostics and
    ``wall_s``. With ``component="both"`` every IM is the geometric mean of the two components'
    values (the convention of the NGA GMPEs before RotD50).
    """
    t0 = time.perf_counter()
    spectral = _spectral(periods_s, damping)
    out, motion, ims = _record_run(record, component, scale, vertical, rotation_deg, spectral, max_record_s)
    if motion is not None:
        _response_row(column, motion, ims, spectral, _options(solver_options), out)
    out["wall_s"] = time.perf_counter() - t0
    return out


def _record_row(record, component, rotation_deg) -> dict:
    """A record row's fields before its run: the record's identity and metadata."""
    meta = record.meta
    return {**record_identity(record, component, math.nan), "rjb_km": _meta(meta, "rjb_km"),
            "vs30_m_s": _meta(meta, "vs30_m_s"), "tp_s": _meta(meta, "tp_s"), "year": _meta(meta, "year"),
            "mechanism": str(record.mechanism), "rotation_deg": math.nan if rotation_deg is None
            else float(rotation_deg), "status": STATUS["ok"], "message": ""}


def _record_run(record, component, scale, vertical, rotation_deg, spectral, max_record_s):
    """A natural-record sample up to its run: (row, motion, ims) with the motion a Record (the chosen
    components, scaled, cut: :meth:`~pycolfrag.ground_motion.Record.motion`) and ims the combined IMs
    of a pair (else None); the motion is None (and the row says why) when the record or the IMs of a
    pair failed. An unreadable suite member's row fails with its reason."""
    out = _record_row(record, component, rotation_deg)
    try:
        if component not in COMPONENTS:
            raise ParameterError(f"component must be one of {COMPONENTS}, got {component!r}")
        out["scale"] = f = positive_float(scale, "scale")   # the row's field, also when its run fails
        if not record.readable:
            out["status"], out["message"] = STATUS["record"], record.error
            return out, None, None
        rec = record.rotated(rotation_deg) if rotation_deg is not None else record
        cut = None if max_record_s is None else int(round(max_record_s / rec.dt)) + 1
        motion = rec.motion(component, f, vertical=vertical, max_samples=cut)
        out.update(record_s=motion.n * motion.dt, dt_s=motion.dt)
    except Exception as exc:
        out["status"] = STATUS["record"]
        out["message"] = f"{type(exc).__name__}: {exc}"
        return out, None, None
    ims = None
    if motion.h2 is not None:
        try:
            if isinstance(spectral, Exception):
                raise spectral
            x, y = motion.horizontals()
            ims = _combine_ims(_ims(x, spectral), _ims(y, spectral))
        except Exception as exc:
            out["status"] = STATUS["im"]
            out["message"] = f"{type(exc).__name__}: {exc}"
            return out, None, None
    return out, motion, ims


def run_record_samples(samples, *, column, vertical=False, rotation_deg=None, periods_s=DEFAULT_PERIODS_S,
                       damping=DEFAULT_DAMPING, solver_options=None, max_record_s=None) -> list[dict]:
    """Many natural-record samples of one column, their runs side by side in SIMD lanes
    (:func:`pycolfrag.solver.run.simulate_batch`, two-component runs too): each row bitwise the
    :func:`run_record_sample` of its sample, but faster. ``samples``: (record, component, scale) of
    each; the other arguments as :func:`run_record_sample`. ``wall_s`` as in
    :func:`run_synthetic_samples`."""
    return PreparedRows(column, periods_s=periods_s, damping=damping, solver_options=solver_options,
                        max_record_s=max_record_s).records(samples, vertical, rotation_deg)


def rows_to_table(rows) -> dict:
    """Row dicts -> a suite table (dict of arrays, the ``/samples`` layout): numbers as float arrays
    (ints for ``status``/``collapsed``), strings as lists, spectral IMs stacked (rows x periods, NaN
    for a row without them)."""
    rows = list(rows)
    keys: list[str] = []
    for r in rows:
        keys.extend(k for k in r if k not in keys)
    table: dict = {}
    for k in keys:
        vals = [r.get(k) for r in rows]
        if k in names.IMS and names.IMS[k].spectral:
            width = max((np.size(v) for v in vals if v is not None), default=0)
            table[k] = np.array([np.full(width, np.nan) if v is None else np.asarray(v, dtype=float) for v in vals])
        elif all(isinstance(v, str) or v is None for v in vals):
            table[k] = ["" if v is None else v for v in vals]
        elif k in ("status", "collapsed", "collapse_block", "n_steps", "energy_warning"):
            table[k] = np.array([(-1 if k == "collapse_block" else 0) if v is None else int(v) for v in vals])
        else:
            table[k] = np.array([math.nan if v is None else float(v) for v in vals])
    return table


def record_jobs(suite, components=("h1", "h2"), scales=(1.0,)) -> list[tuple[int, str, float]]:
    """The rows of a record-suite run, in order: (record index, component, scale) for every record x
    component x scale, record-major; a component the record lacks (``h2``/``both`` of a
    one-component record) is skipped. Depends on the suite and the choices only, so every rank of a
    parallel run derives the same list and row ``i`` is the same run everywhere."""
    for c in components:
        if c not in COMPONENTS:
            raise ParameterError(f"component must be one of {COMPONENTS}, got {c!r}")
    if len(set(components)) != len(components):
        raise ParameterError(f"repeated components in {components!r}")
    scales = [float(f) for f in scales]
    if not scales or any(not (math.isfinite(f) and f > 0) for f in scales) or len(set(scales)) != len(scales):
        raise ParameterError(f"scales must be distinct finite numbers > 0, got {scales!r}")
    return [(k, c, f) for k, r in enumerate(suite) for c in components for f in scales
            if not (c in ("h2", "both") and not r.has_h2)]


def run_suite(records, *, column=None, components=("h1", "h2"), scales=(1.0,), periods_s=DEFAULT_PERIODS_S,
              damping=DEFAULT_DAMPING, solver_options=None, max_record_s=None, progress=None) -> dict:
    """Every record x component x scale, in one process (the MPI grid will do the same rows in
    parallel): a suite table (:func:`rows_to_table`) with ``periods_s``. A component a record lacks
    (``h2`` of a one-component record) is skipped. ``progress``: callable(done, total) or None."""
    suite = _records.load_records(records)
    col = Column.parthenon() if column is None else column
    jobs = record_jobs(suite, components, scales)
    rows = []
    for i in range(0, len(jobs), _SUITE_BATCH):   # runs side by side, progress between batches
        part = jobs[i:i + _SUITE_BATCH]
        rows.extend(run_record_samples([(suite[k], c, s) for k, c, s in part], column=col, periods_s=periods_s,
                                       damping=damping, solver_options=solver_options, max_record_s=max_record_s))
        if progress is not None:
            progress(len(rows), len(jobs))
    table = rows_to_table(rows)
    table["periods_s"] = np.asarray(periods_s, dtype=float)
    return table
