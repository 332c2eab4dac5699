"""One definition of "a sample": a record (synthetic or natural) -> intensity measures -> column
response -> one row dict in the layout of ``/samples`` (docs/results_format.md).

The MPI driver (:mod:`pycolfrag.grid`) only schedules rows, derives seeds and writes results; what a
row holds is decided here, for both kinds of sample:

* :func:`run_synthetic_sample` -- a near-fault record synthesised for a scenario (Mw, R) from a
  row of pulse parameters and a high-frequency seed (the paper's grid);
* :func:`run_record_sample` -- a natural record of a :class:`~pycolfrag.records.RecordSet`, one
  horizontal component or both, scaled by an amplitude factor (record suites, multiple stripes).

Both fill the IMs and EDPs by iterating over the registry :mod:`pycolfrag.names`, through the
shared :func:`response_row`, and never raise for a failing sample: ``status`` (the codes of
:mod:`pycolfrag.results`) and ``message`` say which phase failed.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from . import names
from .errors import ParameterError

__all__ = ["DEFAULT_PERIODS_S", "DEFAULT_DAMPING", "COMPONENTS", "STATUS", "record_identity", "ims_row", "response_row",
           "run_synthetic_sample", "run_record_sample", "record_jobs", "run_suite", "rows_to_table"]

#: Spectral periods of a row (``/spectra``), s -- the grid's default.
DEFAULT_PERIODS_S = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0)
#: Spectral damping ratio.
DEFAULT_DAMPING = 0.05
#: Component choices of a record sample.
COMPONENTS = ("h1", "h2", "both")


def _status():
    from . import results as _r
    return {"ok": _r.STATUS_OK, "record": _r.STATUS_RECORD_FAILED, "im": _r.STATUS_IM_FAILED,
            "solver": _r.STATUS_SOLVER_FAILED, "other": _r.STATUS_OTHER_FAILED}


#: Status codes of a row by phase (0 ok; see :mod:`pycolfrag.results`).
STATUS = _status()


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
    dist_km, the synthetic grid's distance) and scale. Kept in a row whose run failed."""
    meta = dict(getattr(record, "meta", {}) or {})
    rrup = _meta(meta, "rrup_km")
    return {"record_id": str(getattr(record, "record_id", "")), "event": str(meta.get("event", "")),
            "station": str(meta.get("station", "")), "component": str(component), "mw": _meta(meta, "mw"),
            "rrup_km": rrup, "dist_km": rrup, "scale": scale}


def ims_row(acc, dt, periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING) -> dict:
    """Every IM of :data:`pycolfrag.names.IMS` of one record: scalars as floats, spectral ones as
    arrays over ``periods_s`` (:func:`pycolfrag.intensity.measures`)."""
    from .intensity import measures
    ims = measures(acc, dt, periods=periods_s, damping=damping)
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
    """EDPs (:data:`pycolfrag.names.EDPS`) and run diagnostics of a :class:`~pycolfrag.solver.Response`."""
    collapsed = bool(res.collapsed)
    cb = getattr(res, "collapse_block", None)
    ct = getattr(res, "collapse_time", None)
    out = {name: float(getattr(res, name)) for name in names.EDPS}
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


def response_row(column, acc_x, dt, *, acc_y=None, acc_z=None, ims=None, periods_s=DEFAULT_PERIODS_S,
                 damping=DEFAULT_DAMPING, solver_options=None, out=None) -> dict:
    """IMs then the column's response: the shared body of every sample.

    ``ims``: precomputed IMs (else those of ``acc_x``). ``out``: a row dict to fill (its
    ``status``/``message`` are set by the phase that fails; nothing is raised).
    """
    from .solver import simulate
    out = {} if out is None else out
    out.setdefault("status", STATUS["ok"])
    out.setdefault("message", "")
    phase = "im"
    try:
        out.update(ims_row(acc_x, dt, periods_s, damping) if ims is None else ims)
        phase = "solver"
        from .options import SolverOptions
        from .solver import EnergyWarning, StepWarning
        kw = {"options": solver_options} if isinstance(solver_options, SolverOptions) else dict(solver_options or {})
        with warnings.catch_warnings(record=True) as caught:
            # an energy warning is stored (energy_warning), not printed per run; a step warning
            # (dt_solver above the stability limit or the record's dt) is kept in the row's message
            warnings.simplefilter("ignore", EnergyWarning)
            warnings.simplefilter("always", StepWarning)
            res = simulate(column, acc_x, dt, acc_y=acc_y, acc_z=acc_z, **kw)
        phase = "other"
        out.update(_edp_row(res))
        steps = [str(w.message) for w in caught if issubclass(w.category, StepWarning)]
        if steps:
            out["message"] = "StepWarning: " + "; ".join(steps)
    except Exception as exc:  # a failed sample is a result (status, message), not the end of the run
        out["status"] = STATUS[phase]
        out["message"] = f"{type(exc).__name__}: {exc}"
    return out


def run_synthetic_sample(column, mw, dist_km, hf_seed, pulse, *, record_dt_s=0.005, vp_scale=1.0,
                         periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING, solver_options=None,
                         max_record_s=None, with_pulse=True) -> dict:
    """One synthetic sample of the paper's grid (what :func:`pycolfrag.grid.run_sample` computes).

    Parameters
    ----------
    column : Column
    mw, dist_km : float -- the scenario
    hf_seed : int -- seed of the high-frequency noise
    pulse : dict -- a row of :func:`pycolfrag.ground_motion.sample_pulse_parameters`
    record_dt_s, vp_scale : see :func:`pycolfrag.ground_motion.synthesize`
    periods_s, damping : spectral periods (s) and damping ratio of the IMs
    solver_options : dict of :func:`pycolfrag.simulate` keywords
    max_record_s : float or None -- cut the record (tests and quick looks only)
    with_pulse : bool -- False: the high-frequency record alone (:func:`pycolfrag.ground_motion.stochastic`
        with the same ``hf_seed``: the no-pulse branch of a site's motions); ``pulse`` and ``vp_scale``
        are then unused and the pulse fields stay NaN

    Returns
    -------
    dict: ``mw``, ``dist_km``, ``status``, ``message``, the pulse parameters (``vp_cm_s``, ``fp_hz``,
    ``nu_rad``, ``gamma``, ``t0_s``, ``a_cm_s``, ``ap_g``, ``tp_s``), ``record_s``, every IM and EDP
    of :mod:`pycolfrag.names`, the run diagnostics and ``wall_s``. The grid adds ``row``,
    ``scenario`` and ``sample``.
    """
    from . import ground_motion
    t0 = time.perf_counter()
    out = {"mw": float(mw), "dist_km": float(dist_km), "status": STATUS["ok"], "message": ""}
    try:
        if with_pulse:
            rec = ground_motion.synthesize(mw, dist_km, hf_seed, dt=record_dt_s, vp_scale=vp_scale, pulse=pulse)
        else:
            rec = ground_motion.stochastic(mw, dist_km, hf_seed, dt=record_dt_s)
        acc, dt, meta = np.asarray(rec.acc, dtype=float), float(rec.dt), dict(rec.meta)
        if max_record_s is not None:
            acc = acc[: int(round(max_record_s / dt)) + 1]
        out["record_s"] = len(acc) * dt
        if with_pulse:
            out.update(vp_cm_s=_meta(meta, "Vp_cm_s"), fp_hz=_meta(meta, "fp_hz"), nu_rad=_meta(meta, "nu_rad"),
                       gamma=_meta(meta, "gamma"), t0_s=_meta(meta, "t0_s"), a_cm_s=_meta(meta, "A_cm_s"),
                       ap_g=_meta(meta, "Ap_g"))
            fp = out["fp_hz"]
            out["tp_s"] = _meta(meta, "Tp_s", default=(1.0 / fp if fp and math.isfinite(fp) else math.nan))
    except Exception as exc:
        out["status"] = STATUS["record"]
        out["message"] = f"{type(exc).__name__}: {exc}"
        out["wall_s"] = time.perf_counter() - t0
        return out
    response_row(column, acc, dt, periods_s=periods_s, damping=damping, solver_options=solver_options, out=out)
    out["wall_s"] = time.perf_counter() - t0
    return out


def run_record_sample(record, *, column, component="h1", scale=1.0, vertical=False, rotation_deg=None,
                      periods_s=DEFAULT_PERIODS_S, damping=DEFAULT_DAMPING, solver_options=None,
                      max_record_s=None) -> dict:
    """One natural-record sample: a record (or its pair) scaled by ``scale`` on the column.

    Parameters
    ----------
    record : :class:`~pycolfrag.records.SuiteRecord`
    column : Column
    component : "h1", "h2" or "both"
        One horizontal component along the solver's x axis (the paper's Fig. 10 runs each on its own),
        or the pair (H1 along x, H2 along y: two-component excitation).
    scale : float (> 0)
        Amplitude factor on every component (multiple-stripe analysis). IMs are those of the scaled motion.
    vertical : bool
        Add the vertical component (acc_z) when the record has one.
    rotation_deg : float or None
        Rotate the pair first (:meth:`~pycolfrag.records.SuiteRecord.rotated`); ``component`` then
        refers to the rotated axes.
    periods_s, damping, solver_options, max_record_s : as in :func:`run_synthetic_sample`.

    Returns
    -------
    dict: the record's metadata (``record_id``, ``event``, ``station``, ``component``, ``mw``,
    ``rrup_km``, ``scale``, ``rjb_km``, ``vs30_m_s``, ``tp_s``, ``year``, ``mechanism``), ``dist_km``
    (= ``rrup_km``, the same distance definition as the synthetic grid's), ``record_s``, ``dt_s``,
    ``status``, ``message``, every IM and EDP of :mod:`pycolfrag.names`, the run diagnostics and
    ``wall_s``. With ``component="both"`` every IM is the geometric mean of the two components'
    values (the convention of the NGA GMPEs before RotD50).
    """
    t0 = time.perf_counter()
    meta = dict(getattr(record, "meta", {}) or {})
    out = {**record_identity(record, component, math.nan), "rjb_km": _meta(meta, "rjb_km"),
           "vs30_m_s": _meta(meta, "vs30_m_s"), "tp_s": _meta(meta, "tp_s"), "year": _meta(meta, "year"),
           "mechanism": str(meta.get("mechanism", "")), "rotation_deg": math.nan if rotation_deg is None
           else float(rotation_deg), "status": STATUS["ok"], "message": ""}
    try:
        if component not in COMPONENTS:
            raise ParameterError(f"component must be one of {COMPONENTS}, got {component!r}")
        f = float(scale)
        if not (math.isfinite(f) and f > 0):
            raise ParameterError(f"scale must be finite and > 0, got {scale!r}")
        out["scale"] = f
        rec = record.rotated(rotation_deg) if rotation_deg is not None else record
        dt = float(rec.dt)
        # one component alone runs as recorded (without the zeros that padded it to its pair's length)
        n = rec.n if component == "both" else rec.recorded(component).size
        n = n if max_record_s is None else min(n, int(round(max_record_s / dt)) + 1)
        x = f * rec.component("h2" if component == "h2" else "h1")[:n]
        y = f * rec.component("h2")[:n] if component == "both" else None
        z = f * rec.v[:n] if (vertical and rec.v is not None) else None
        out.update(record_s=n * dt, dt_s=dt)
    except Exception as exc:
        out["status"] = STATUS["record"]
        text = str(exc)  # an unreadable record's error already names its type
        out["message"] = text if text.startswith(f"{type(exc).__name__}: ") else f"{type(exc).__name__}: {text}"
        out["wall_s"] = time.perf_counter() - t0
        return out
    ims = None
    if y is not None:
        try:
            ims = _combine_ims(ims_row(x, dt, periods_s, damping), ims_row(y, dt, periods_s, damping))
        except Exception as exc:
            out["status"] = STATUS["im"]
            out["message"] = f"{type(exc).__name__}: {exc}"
            out["wall_s"] = time.perf_counter() - t0
            return out
    response_row(column, x, dt, acc_y=y, acc_z=z, ims=ims, periods_s=periods_s, damping=damping,
                 solver_options=solver_options, out=out)
    out["wall_s"] = time.perf_counter() - t0
    return out


def rows_to_table(rows) -> dict:
    """Row dicts -> a suite table (dict of arrays, the ``/samples`` layout): numbers as float arrays
    (ints for ``status``/``collapsed``), strings as lists, spectral IMs stacked (rows x periods, NaN
    for a row without them)."""
    rows = list(rows)
    keys = []
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
            if not (c in ("h2", "both") and r.h2 is None)]


def run_suite(records, *, column=None, components=("h1", "h2"), scales=(1.0,), periods_s=DEFAULT_PERIODS_S,
              damping=DEFAULT_DAMPING, solver_options=None, max_record_s=None, progress=None) -> dict:
    """Every record x component x scale, in one process (the MPI grid will do the same rows in
    parallel): a suite table (:func:`rows_to_table`) with ``periods_s``. A component a record lacks
    (``h2`` of a one-component record) is skipped. ``progress``: callable(done, total) or None."""
    from .column import Column
    from .records import load_records
    suite = load_records(records)
    col = Column.parthenon() if column is None else column
    jobs = record_jobs(suite, components, scales)
    rows = []
    for i, (k, c, s) in enumerate(jobs):
        rows.append(run_record_sample(suite[k], column=col, component=c, scale=s, periods_s=periods_s,
                                      damping=damping, solver_options=solver_options, max_record_s=max_record_s))
        if progress is not None:
            progress(i + 1, len(jobs))
    table = rows_to_table(rows)
    table["periods_s"] = np.asarray(periods_s, dtype=float)
    return table
