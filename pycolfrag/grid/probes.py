"""Checks before a run: options, records and sizes that would make every row fail or the run
impossible are refused before any file is made (docs/grid.md, "Refused before any run").

Each probe asks the code the rows will run -- the solver on a 3-sample zero record, the record of
one representative row and its IMs -- rather than a rule of its own, and each refusal is a
:class:`~pycolfrag.core.errors.ParameterError` (exit code 2) or, for a disk too small, an ``OSError`` of
``ENOSPC`` (exit code 4) naming the value and what works.
"""
from __future__ import annotations

import errno
import os
import shutil
import time
import warnings
from pathlib import Path

import numpy as np

from pycolfrag import ground_motion as _gm
from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError, SolverError
from pycolfrag.grid.protocol import DEFAULT_RECORD_DT_S
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.ground_motion import rupakhety_2011
from pycolfrag.solver import run as _solver
from pycolfrag.solver import sample as _sample
from pycolfrag.solver import step_cause as _step_cause
from pycolfrag.solver.options import resolve_solver_options, solver_defaults

__all__ = ["MAX_CHECK_STEPS", "MAX_ROW_STEPS", "SAY_WORK_ABOVE_S", "check_solver_options", "probe_rows",
           "check_work", "check_space", "check_models", "check_record_dt", "probe_synthetic", "probe_suite",
           "RowTiming", "work_synthetic", "work_suite"]

#: Largest number of solver steps of the pre-run check (3 samples of zero record plus the solver's
#: tail, ~4000 steps with the defaults): a dt_solver needing more is refused before it runs (2e7 is
#: about a minute at 3 us per step, and a row then needs ~1e8 steps, hours).
MAX_CHECK_STEPS = 2e7
#: Largest number of solver steps a row of a synthetic grid may need (its longest record plus the
#: tail): 5e7 is ~2000 times a default row, about 2.5 min per row at 3 us per step.
MAX_ROW_STEPS = 5e7
#: Most solver steps the pre-run check's run takes: its tail is cut to this many steps (a model of a
#: tiny step -- a near-massless epistyle on stiff bearings -- ran the check for 86 s: 1.25e6 steps at 4e-7 s
#: until its run stopped at rest; 3e5 steps take about 1 s of a scene).
MAX_CHECK_RUN_STEPS = 3e5
#: Estimated CPU time (s) above which the grid says how long it expects to take before it starts.
SAY_WORK_ABOVE_S = 600.0


def check_solver_options(column, options, record_dt_s: float = DEFAULT_RECORD_DT_S) -> dict:
    """Refuse, before any file is touched, solver options that would fail or spoil every row:
    values the C library rejects (:class:`pycolfrag.SolverOptions`), a ``dt_solver`` above the
    column's stability limit or longer than the records' step ``record_dt_s`` (the solver would
    warn with :class:`~pycolfrag.solver.run.StepWarning` in every row: a grid refuses instead), a run
    that stops as unstable, a step so short that this check alone would need more than
    :data:`MAX_CHECK_STEPS` steps, and a column that collapses under gravity alone. The step is read
    from the set-up solver (no steps run) and the check's run is at most :data:`MAX_CHECK_RUN_STEPS`
    steps (its tail cut to fit), so it takes seconds whatever the model. Where the step is automatic
    and too short, the refusal names the part that sets it (:func:`pycolfrag.solver.step_cause.describe`), not
    a dt_solver the user did not give. Returns the solver step (``dt_s``), the measured time per step
    (``step_s``) and, for :func:`check_work`, that cause (``cause``; None with a dt_solver)."""
    options = resolve_solver_options(options)
    changed = {k: v for k, v in options.to_dict().items() if v != solver_defaults()[k]}
    caught, failure, res = [], None, None
    try:
        # the step the rows will use, from a run of a few steps: a tiny dt_solver must be refused
        # before the check below runs for minutes
        dt_step = options.dt_solver or _solver.automatic_step(column, options)
        cause = None if options.dt_solver else _step_cause.describe(column)
        check_steps = (3 * record_dt_s + options.tail_s) / dt_step
        if check_steps > MAX_CHECK_STEPS and not _collapses_at_once(column, options, dt_step):
            raise ParameterError(f"solver options {changed}: a step of {dt_step:.3g} s needs {check_steps:.3g} steps for "
                                 f"{options.tail_s:g} s of response alone (a row of a {DEFAULT_RECORD_DT_S * 4000:g} s "
                                 f"record: {(20.0 + options.tail_s) / dt_step:.3g} steps, about "
                                 f"{(20.0 + options.tail_s) / dt_step * 3e-6 / 3600:.2g} h each at 3 us per step); "
                                 + _step_advice(cause))
        # a 3-sample zero record (~20 ms) asks the solver itself: set-up, stability limit, collapse;
        # its tail cut to MAX_CHECK_RUN_STEPS steps
        tail = min(options.tail_s, max(MAX_CHECK_RUN_STEPS * dt_step - 3 * record_dt_s, 0.0))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            t0 = time.perf_counter()
            res = _solver.simulate(column, np.zeros(3), record_dt_s, options=options.replace(tail_s=tail))
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
    return {"dt_s": float(res.dt), "step_s": float(step_s), "cause": cause}


def _collapses_at_once(column, options, dt_step: float) -> bool:
    """Whether the model collapses as its run begins (joints so soft that the static settlement sinks a block:
    a collapse at t = 0, before any step): a run of three samples at the solver's own step says it at once, and
    that refusal (below, "collapses under gravity alone") is the one that names the cause, not the step's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            probe = _solver.simulate(column, np.zeros(3), dt_step, options=options.replace(tail_s=0.0))
        except (ParameterError, SolverError):
            return False
    return bool(probe.collapsed)


def _step_advice(cause) -> str:
    """What lengthens a step too short: a longer dt_solver where one was given, else the model's part
    that sets the automatic step (advising dt_solver there would advise the option the user left out)."""
    if cause is None:
        return "choose a longer dt_solver or leave it automatic (dt_factor)"
    return f"the step is automatic (dt_factor x the stability limit), and {cause}"


def probe_rows(spec) -> list[tuple[str, float]]:
    """Refuse, before any file is made, record and IM options that fail every row: the record of one
    row (a synthetic grid: the weakest scenario, lowest Mw at the largest R, sample 0 of a small LHS; a suite: the
    first readable record at its smallest scale) is made and its IMs computed with the run's options
    (``--vp-scale``, ``--damping``, ``--periods``...), and its accelerations must be within what the
    solver accepts (:data:`pycolfrag.solver.run.MAX_ABS_ACC`). Returns (label, duration s) of the longest
    record of the run (the synthetic grid: the largest Mw at the largest R, sample 0)."""
    probe = spec.probe()   # the kind's own (:func:`probe_synthetic`, :func:`probe_suite`)
    if probe[0] is None:  # a suite of unreadable records only: each row fails on its own
        return probe[3]
    acc, dt, what, durations, opt = probe
    peak = float(np.max(np.abs(acc))) if acc.size else 0.0
    if not np.isfinite(peak) or peak > _solver.MAX_ABS_ACC:
        raise ParameterError(f"{opt}: {what} reaches |a| = {peak:.3g} m/s^2, beyond the {_solver.MAX_ABS_ACC:g} "
                             "m/s^2 the solver accepts; every row would fail")
    try:  # the IMs' options are what is checked: the first 8192 samples say it (a 1e8-sample record would take minutes)
        _sample.ims_row(acc[:8192], dt, spec.periods_s, spec.damping)
    except Exception as exc:
        raise ParameterError(f"--damping {spec.damping:g}/--periods: the IMs of {what} fail ({exc}); every row "
                             "would fail") from None
    return durations


def probe_suite(spec):
    """(acceleration, dt, label, durations, the option that scales it) of a suite's probe: its first readable
    record at the smallest scale, and every readable record's duration; (None, None, None, durations, None)
    when none is readable (:meth:`pycolfrag.grid.RecordGridSpec.probe`)."""
    durations = []
    for r in spec.suite:
        try:
            durations.append((r.record_id, float(r.n * r.dt)))
        except Exception:  # an unreadable record: its rows fail on their own, with the reason
            continue
    first = next((r for r in spec.suite if not hasattr(r, "error")), None)
    if first is None:
        return None, None, None, durations, None
    f = min(spec.scales)
    return (f * first.component("h1"), float(first.dt), f"record {first.record_id} at scale {f:g}", durations,
            "--scale")


def _synthetic_probe_record(spec, ctx, scenario):
    """Sample 0's record of the scenario as its row makes it (``sample._synthetic_record``), the pulse
    from a small LHS of the scenario (a representative row, at once)."""
    m, r = spec.scenarios[scenario]
    p = None
    with_pulse = spec.pulse != _gm.registry.NO_PULSE
    if with_pulse:
        table = _gm.sample_pulse_parameters(m, r, min(spec.samples, 8), ctx.lhs_seed(scenario),
                                            vp_scale=spec.vp_scale, tp_model=spec.tp_model, shape=spec.pulse,
                                            vp_model=spec.vp_model)
        p = {k: (np.asarray(v)[0] if np.ndim(v) else v).item() for k, v in table.items()}
    out, a, d = _sample._synthetic_record(m, r, ctx.hf_seed(scenario, 0), p, spec.record_dt_s, spec.vp_scale,
                                          None, with_pulse,
                                          spec.pulse if with_pulse else _gm.registry.DEFAULT_PULSE_SHAPE)
    if a is None:
        raise RuntimeError(out["message"])
    return a, d


def probe_synthetic(spec):
    """(acceleration, dt, label, durations, the option that scales it) of a synthetic grid's probe: the
    weakest scenario's record, and the duration of the longest (the largest Mw at the largest R, cut by
    ``max_record_s``) (:meth:`pycolfrag.grid.GridSpec.probe`)."""
    ctx = spec.context()
    sc = spec.scenarios.index((min(spec.mw), max(spec.dist_km)))
    mw, dist = spec.scenarios[sc]
    what = f"the record of Mw {mw:g}, R {dist:g} km, sample 0"
    try:
        acc, dt = _synthetic_probe_record(spec, ctx, sc)
    except Exception as exc:
        raise ParameterError(f"--vp-scale {spec.vp_scale:g}/--record-dt {spec.record_dt_s:g}: {what} cannot be "
                             f"made ({exc}); every row would fail") from None
    sl = spec.scenarios.index((max(spec.mw), max(spec.dist_km)))
    mw_l, dist_l = spec.scenarios[sl]
    try:
        n_long = len(_synthetic_probe_record(spec, ctx, sl)[0])
    except Exception:
        n_long = len(acc)
    long_s = n_long * spec.record_dt_s
    if spec.max_record_s is not None:
        long_s = min(long_s, spec.max_record_s)
    return acc, dt, what, [(f"Mw {mw_l:g}, R {dist_l:g} km", long_s)], "--vp-scale"


class RowTiming:
    """What a row is expected to cost, from the pre-run check: the solver step ``dt`` (s), the measured
    time per step ``step_s`` (s), the solver's tail (s) and what sets the automatic step (``cause``)."""

    def __init__(self, tail_s: float, solver: dict):
        self.tail, self.dt, self.step_s, self.cause = tail_s, solver["dt_s"], solver["step_s"], solver.get("cause")

    def steps(self, duration: float) -> float:
        """Solver steps of a row whose record lasts ``duration`` s (its tail included)."""
        return (duration + self.tail) / self.dt

    def row_s(self, duration: float) -> float:
        """CPU seconds of such a row."""
        return self.steps(duration) * self.step_s

    @staticmethod
    def hours(x: float) -> str:
        return f"{x / 3600:.3g} h" if x >= 3600 else f"{x / 60:.3g} min"


def check_work(spec, durations, solver: dict, log) -> None:
    """Say, before the run, how long it is expected to take when that is long (more than
    :data:`SAY_WORK_ABOVE_S` of CPU time), and refuse what the kind refuses (:meth:`RunSpec.expected_work`:
    a synthetic grid whose rows need more than :data:`MAX_ROW_STEPS` solver steps each, the options being
    the cause, :func:`work_synthetic`; a record suite's rows are never refused for their length, the records
    being the user's, and a record whose row is expected to take long is named, :func:`work_suite`). The
    estimate is the solver's steps (record duration plus the solver's tail, divided by the step) times the
    time per step measured by the pre-run check."""
    timing = RowTiming(spec.solver_options.tail_s, solver)
    total = spec.expected_work(durations, timing, log)
    if total > SAY_WORK_ABOVE_S:
        log(f"run_grid: expected work about {timing.hours(total)} of CPU time ({spec.n_rows} rows; the longest "
            f"records, {timing.step_s * 1e6:.2g} us per solver step as measured now)")


def work_suite(spec, durations, timing: RowTiming, log) -> float:
    """A record suite's expected CPU seconds; a line for each record whose rows take long."""
    total = 0.0
    for rid, dur in durations:
        n = sum(1 for k, _, _ in spec.jobs if spec.suite[k].record_id == rid)
        t = timing.row_s(dur)
        total += n * t
        if t > SAY_WORK_ABOVE_S:
            log(f"run_grid: record {rid} is {dur:.6g} s long: about {timing.steps(dur):.3g} solver steps, "
                f"{timing.hours(t)} per row ({n} rows)")
    return total


def work_synthetic(spec, durations, timing: RowTiming, log) -> float:
    """A synthetic grid's expected CPU seconds (its longest row times its rows), or ParameterError when
    that row needs more than :data:`MAX_ROW_STEPS` solver steps."""
    label, dur = durations[0]
    steps = timing.steps(dur)
    if steps > MAX_ROW_STEPS:
        raise ParameterError(f"a row of {label} ({dur:.3g} s of record + {timing.tail:g} s of tail) needs {steps:.3g} "
                             f"solver steps of {timing.dt:.3g} s (at most {MAX_ROW_STEPS:.0e}; about "
                             f"{timing.hours(timing.row_s(dur))} per row): " + _step_advice(timing.cause))
    return spec.n_rows * timing.row_s(dur)


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


def check_models(spec) -> None:
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
    check_record_dt(spec.record_dt_s)


def check_record_dt(dt: float) -> None:
    """Refuse a record step outside the stochastic generator's range (``atkinson_silva_2000.DT_MIN/DT_MAX``):
    every synthetic record would fail. The one text of this refusal (the grid's and the site simulation's)."""
    if not as00.DT_MIN <= dt <= as00.DT_MAX:
        raise ParameterError(f"--record-dt {dt!r} s is outside the record generator's range "
                             f"[{as00.DT_MIN:g}, {as00.DT_MAX:g}] s")
