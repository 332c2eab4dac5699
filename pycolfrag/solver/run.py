"""Response of a column to one ground-motion record: :func:`simulate`.

The physics lives in C (``csrc/solver.c``, documented in ``docs/solver.md``): rigid
blocks with soft Coulomb joints, leapfrog integration in the frame that moves with
the ground, step from the stability limit of the whole linearised stack. This module
checks the input, passes it to C and wraps the output in :class:`Response` and
:class:`History`.

A run's ground motion is given as arrays and a step (checked here, with the messages of
:func:`simulate`) or as a :class:`~pycolfrag.ground_motion.Record`, whose arrays and step were
checked when it was made and are not checked again; either way the accelerations must be within
:data:`MAX_ABS_ACC`, the solver's own range.

Example::

    import numpy as np, pycolfrag as pcf
    col = pcf.Column.parthenon()
    t = np.arange(0, 3.0, 0.005)
    res = pcf.simulate(col, 0.25 * 9.81 * np.sin(2 * np.pi * 2 * t), 0.005, history=True)
    res.u_top, res.u_d, res.collapsed, res.history.top_disp
"""
from __future__ import annotations

import contextlib
import math
import threading
import warnings
from dataclasses import dataclass

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.validate import flag, float_array, positive_float
from pycolfrag.ground_motion.record import Record
from pycolfrag.solver import scene_setup as scene_run
from pycolfrag.solver import state, step_cause
from pycolfrag.solver.options import CONTACT_OPTIONS, SolverOptions
from pycolfrag.structure import as_built
from pycolfrag.structure import kinds as structures
from pycolfrag.structure.column import Column

__all__ = ["simulate", "simulate_batch", "batch_width", "Response", "History", "EnergyWarning", "StepWarning", "CONTACT_OPTIONS", "MAX_ABS_ACC",
           "SolverOptions"]
_REASONS = {lib.CF_SOLVER_COLLAPSE_NONE: "",
            lib.CF_SOLVER_COLLAPSE_OVERTURNING: "overturning",
            lib.CF_SOLVER_COLLAPSE_OFF_FOOTPRINT: "off_footprint",
            lib.CF_SOLVER_COLLAPSE_FALLING: "falling"}
#: |acceleration| above this (m/s^2, about 10 g) is refused as a likely unit mistake
MAX_ABS_ACC = 100.0
_ENERGY_KEYS = ("kinetic", "gravity", "spring", "slip_dissipated", "damping_dissipated", "ground_work",
                "balance_error", "contact_switch")


class EnergyWarning(UserWarning):
    """The energy balance error of a run exceeded ``energy_tolerance``."""


class StepWarning(UserWarning):
    """An explicit solver step longer than the stability limit or than the record's own dt."""

#: history buffers larger than this (bytes) are refused: history_dt too small for the record
MAX_HISTORY_BYTES = 4 << 30


@dataclass
class History:
    """Time histories of one run, sampled every ``history_dt`` (SI units).

    Attributes
    ----------
    t : (n,) s
    top_disp : (n, 2) m -- x, y displacement of the top block's top-face centre relative to the ground
    block_pos : (n, nb, 3) m -- centres of mass, in the frame moving with the ground
    block_quat : (n, nb, 4) -- orientation quaternions (w, x, y, z)
    joint_opening : (n, nj) m -- max normal gap of the upper face's vertices over the joint (0 closed)
    joint_slip : (n, nj, 2) m -- dislocation vector of each joint (upper face centre minus lower)
    joint_normal_force : (n, nj) N -- normal force carried by each joint (NaN for the internal
        joints of a monolithic column)
    energy : dict of (n,) arrays, J -- kinetic, gravity (change since the start), spring (change since
        the pre-compressed start), slip_dissipated, damping_dissipated, ground_work (work of the
        inertial forces -m a_g), contact_switch (normal spring energy removed when compressed
        sub-contacts slide off a face polygon; negative when they slide onto one, only with
        ``reentry_depth`` > 0),
        balance_error = kinetic + gravity + spring + dissipated + contact_switch - ground_work (+
        connector_stored + connector_dissipated, keys present with dowels: their stored energy since
        the start and their dissipation so far)
    dowels : (n, nd, 3) or None -- per dowel: shear displacement |u| (m), shear force |F| (N), axial
        force (N, tension)

    A scene (a :class:`~pycolfrag.structure.scene.Colonnade`) has every block of its columns then its
    epistyles in ``block_pos``/``block_quat``, every joint of its columns then its bearings in the
    joint arrays, and ``top_disp`` of its first column.
    """

    t: np.ndarray
    top_disp: np.ndarray
    block_pos: np.ndarray
    block_quat: np.ndarray
    joint_opening: np.ndarray
    joint_slip: np.ndarray
    energy: dict
    joint_normal_force: np.ndarray | None = None
    dowels: np.ndarray | None = None


@dataclass
class Response:
    """EDPs and diagnostics of one run (see :func:`simulate`).

    A column with connectors or a scene (:class:`~pycolfrag.structure.scene.Colonnade`) reports also
    ``columns`` (per column: ``u_top``, ``u_d``, ``max_top_disp`` m, ``collapsed``), ``epistyles``
    (per epistyle: peak ``slip`` m at its bearings, ``residual_slip`` m, ``unseat`` = peak slip / its
    seat length, ``collapsed``), ``dowels`` (per dowel: ``joint``, ``peak_shear`` N, ``peak_slip`` m (a broken
    dowel's: the slip at its break),
    ``peak_axial`` N, ``yielded``, ``broken``, ``break_time`` s, ``dissipated`` J), and the EDPs
    ``dowel_shear_kn``, ``dowel_slip_mm``, ``dowels_yielded``, ``dowels_broken``, ``epistyle_slip_mm``,
    ``epistyle_unseat``
    (NaN where the scene has no such part). ``u_top`` and ``u_d`` of a scene are the largest over its
    columns, each normalised by its own diameters; ``collapse_part`` names where a collapse was.
    """

    u_top: float
    u_d: float          # NaN after a collapse (a residual dislocation then has no meaning)
    collapsed: bool
    collapse_block: int | None
    collapse_time: float
    collapse_reason: str
    n_steps: int
    t_end: float
    dt: float
    dt_crit: float
    energy_error: float
    energy_scale: float
    energy_warning: bool
    residual_dislocation: np.ndarray
    options: dict
    history: History | None = None
    message: str = ""
    at_rest_exit: bool = False
    max_top_disp: float = 0.0
    columns: dict | None = None
    epistyles: dict | None = None
    dowels: dict | None = None
    dowel_shear_kn: float = math.nan
    dowel_slip_mm: float = math.nan
    dowels_yielded: float = math.nan
    dowels_broken: float = math.nan
    epistyle_slip_mm: float = math.nan
    epistyle_unseat: float = math.nan
    collapse_part: str = ""
    final_state: object = None   # the State at the end of the run (simulate; docs/sequences.md)


_runs = threading.local()  # per thread: the exceptions caught during the current C run


def _stop_with(exc_type, exc, tb):
    """An exception raised in :func:`_pcf_solver_check` -- a signal handler's (KeyboardInterrupt on
    Ctrl-C), which Python runs there because Python code runs there -- is kept for
    :func:`simulate` to raise, and the C run stops (1)."""
    getattr(_runs, "caught", []).append(exc)
    return 1


@ffi.def_extern(onerror=_stop_with)
def _pcf_solver_check(user):
    """Called by the C run every CF_SOLVER_CHECK_STEPS steps; 0 lets it go on."""
    return 0


@contextlib.contextmanager
def _interruptible(solver):
    """A C run (or batch) of ``solver`` that calls back into Python every CF_SOLVER_CHECK_STEPS steps
    (about 10 ms), where a pending Ctrl-C (or any signal handler's exception) is raised: the run then
    stops at once and the exception is raised here, after it."""
    _runs.caught = caught = []
    lib.cf_solver_set_check(solver, lib._pcf_solver_check, ffi.NULL)
    try:
        yield
    finally:
        _runs.caught = []
    if caught:
        raise caught[0]


def _acc(a, name, n_expected=None):
    if a is None:
        return None
    arr = float_array(a, name)
    if n_expected is not None and arr.size != n_expected:
        raise ParameterError(f"{name} has {arr.size} samples but acc_x has {n_expected}: components must "
                             "share one time axis")
    return arr


def _within_range(arrays) -> None:
    """The solver's range of a run's accelerations (|a| <= MAX_ABS_ACC), named by the argument."""
    for name, arr in arrays:
        if arr is None:
            continue
        big = np.abs(arr) > MAX_ABS_ACC
        if big.any():
            i = int(np.argmax(big))
            raise ParameterError(
                f"{name}[{i}] = {arr[i]!r} m/s^2 exceeds {MAX_ABS_ACC:g} m/s^2 (about 10 g): accelerations must be "
                "in m/s^2 (a record in cm/s^2 or a g-factor applied twice?)")


def _motion(acc_x, dt, acc_y, acc_z, what: str = "") -> tuple:
    """A run's ground motion as (acc_x, dt, acc_y, acc_z): a Record's arrays and step as they are
    (checked when it was made), or arrays and a step checked here; then the solver's range."""
    if isinstance(acc_x, Record):
        if dt is not None or acc_y is not None or acc_z is not None:
            raise ParameterError(f"{what}a Record carries its step and components: give it alone, or arrays "
                                 "acc_x, dt (and acc_y, acc_z)")
        run = (acc_x.acc, acc_x.dt, acc_x.h2, acc_x.v)
    else:
        dt = positive_float(dt, "dt (record sampling interval, s)")
        if acc_x is None:
            raise ParameterError("acc_x must be an array of accelerations (m/s^2), got None")
        ax = _acc(acc_x, "acc_x")
        run = (ax, dt, _acc(acc_y, "acc_y", ax.size), _acc(acc_z, "acc_z", ax.size))
    _within_range(zip(("acc_x", "acc_y", "acc_z"), (run[0], run[2], run[3])))
    return run


def _model(col) -> structures.StructureKind:
    """The kind of a structure (the registry's line of its class, read as data: structure/kinds.py)."""
    kind = structures.BY_CLASS[type(col)]
    if kind is None:
        raise ParameterError(f"col must be {structures.ACCEPTED}, got {type(col).__name__}")
    return kind


def _setup(col, options, overrides, caller):
    """The set-up C solver of a structure and options (one per call of simulate / simulate_batch), the
    options, and the parts whose outputs a run reports (None for a plain column: no connectors)."""
    kind = _model(col)
    if options is None:
        options = SolverOptions()
    elif not isinstance(options, SolverOptions):
        raise ParameterError(f"options must be a SolverOptions, got {type(options).__name__}")
    if overrides:
        options = options.replace(**overrides)
    d = options.to_c()
    monolithic = options.monolithic

    solver = ffi.gc(lib.cf_solver_create(), lib.cf_solver_free)
    if solver == ffi.NULL:
        raise MemoryError("cf_solver_create failed")
    # every structure through its parts (a plain column is a one-column scene): one set-up
    parts = scene_run.parts_of(col, monolithic, caller)
    plain = not kind.reports_parts and not any(c.connectors for c, _, _ in parts.columns)   # reports no parts
    for c, _, _ in parts.columns:
        if not plain and c.foundation_tilt_deg:
            raise ParameterError(f"{caller}: a tilted foundation (foundation_tilt_deg = {c.foundation_tilt_deg:g}) "
                                 "is for a plain column, without connectors, beams or other columns")
        if not plain:   # the dowels' places and the scene's faces are those of an aligned column
            as_built.refuse(c, caller, "are for a plain column, without connectors, beams or other columns")
        if monolithic and any(j > 0 for j in c.joint_overrides):
            warnings.warn(f"{caller}: monolithic=True has the base joint only; joint_overrides of joints "
                          f"{sorted(j for j in c.joint_overrides if j > 0)} do not act", UserWarning, stacklevel=3)
    if plain:   # the solver's frame is the foundation's (docs/sequences.md)
        d.foundation_tilt_rad = math.radians(col.foundation_tilt_deg)   # checked by Column (pycolfrag/structure/foundation.py)
        d.foundation_tilt_azimuth_rad = math.radians(col.foundation_tilt_azimuth_deg)
    if plain and as_built.placed(col):   # a plain column as built (pycolfrag/structure/as_built.py)
        scene_run.setup_as_built(solver, d, col, monolithic, caller)
    else:
        scene_run.setup(solver, d, parts, caller)
    if options.dt_solver is not None:
        crit = float(lib.cf_solver_dt_crit(solver))
        if options.dt_solver > crit:
            warnings.warn(f"{caller}: dt_solver = {options.dt_solver:.4g} s exceeds the whole-stack stability limit "
                          f"{crit:.4g} s: the run may go unstable (it stops with SolverError when the energy balance "
                          "breaks)", StepWarning, stacklevel=3)
    return solver, options, None if plain else parts


class _Job:
    """One run's ground motion (:func:`_motion`), with the C buffers of its outputs."""

    def __init__(self, solver, col, options, motion: tuple, history: bool, caller, parts=None):
        self.ax, self.dt, self.ay, self.az = ax, dt, ay, _ = motion
        self.history = history
        if options.planar and ay is not None:
            raise ParameterError("planar=True takes one horizontal component: acc_y must be None")
        if options.dt_solver is not None and options.dt_solver > dt:
            warnings.warn(f"{caller}: dt_solver = {options.dt_solver:.4g} s is longer than the record's dt = "
                          f"{dt:.4g} s: the solver skips record samples", StepWarning, stacklevel=3)
        step = options.dt_solver or options.dt_factor * float(lib.cf_solver_dt_crit(solver))
        run_steps = (ax.size * dt + options.tail_s) / step
        if run_steps > step_cause.MAX_RUN_STEPS:   # a dowel law or an epistyle that forces a tiny step: say so
            long_run = step_cause.run_steps_warning(col, run_steps, step, ax.size * dt + options.tail_s, caller)
            if long_run:                           # before the run takes hours (a row never comes here)
                warnings.warn(long_run, StepWarning, stacklevel=3)
        nb = len(col.blocks) if parts is None else parts.n_blocks   # parts None: a plain Column, a joint per block
        nj = nb if parts is None else parts.n_joints
        self.cap = 0
        self.h = None
        if history:
            cap = int(lib.cf_solver_history_capacity(solver, ax.size, dt))
            nbytes = 8 * cap * (1 + 2 + 8 + 7 * nb + 4 * nj)
            if cap < 0 or nbytes > MAX_HISTORY_BYTES:
                raise ParameterError(f"history_dt = {options.history_dt!r} s needs "
                                     f"{'over %d' % lib.CF_SOLVER_MAX_HISTORY if cap < 0 else cap} history samples for "
                                     f"this record ({'more than' if cap < 0 else f'{nbytes / 2**30:.1f} GiB,'} over the "
                                     f"{MAX_HISTORY_BYTES / 2**30:.0f} GiB limit): choose a longer history_dt")
            self.cap = cap
            self.h = dict(
                t=np.zeros(cap), top=np.zeros((cap, 2)), pos=np.zeros((cap, nb, 3)), quat=np.zeros((cap, nb, 4)),
                open=np.zeros((cap, nj)), slip=np.zeros((cap, nj, 2)), en=np.zeros((cap, lib.CF_SOLVER_N_ENERGY)),
                fn=np.zeros((cap, nj)))
        self.resid = np.zeros(nj)
        self.out = scene_run.Outputs(parts, self.cap) if parts is not None else None

    def fill(self, cj) -> None:
        """Point a cf_solver_batch_job at this job's arrays (which must outlive the run)."""
        opt = lambda a: ptr(a) if a is not None else ffi.NULL
        cj.acc_x = ptr(self.ax); cj.acc_y = opt(self.ay); cj.acc_z = opt(self.az)
        cj.n = self.ax.size; cj.dt_rec = self.dt
        cj.residual_dislocation = ptr(self.resid)
        cj.history_capacity = self.cap
        if self.h is not None:
            h = self.h
            cj.h_t = ptr(h["t"]); cj.h_top = ptr(h["top"]); cj.h_pos = ptr(h["pos"]); cj.h_quat = ptr(h["quat"])
            cj.h_open = ptr(h["open"]); cj.h_slip = ptr(h["slip"]); cj.h_energy = ptr(h["en"]); cj.h_normal = ptr(h["fn"])
        if self.out is not None:   # a dowelled column's outputs (its scene's)
            self.out.fill(cj)

    def set_history(self, solver, caller) -> None:
        """Point the solver itself at this job's history buffers and outputs (a single run)."""
        h = self.h
        if h is not None:
            check(lib.cf_solver_set_history(solver, self.cap, ptr(h["t"]), ptr(h["top"]), ptr(h["pos"]),
                                            ptr(h["quat"]), ptr(h["open"]), ptr(h["slip"]), ptr(h["en"])),
                  lib.cf_solver_message(solver), caller)
            check(lib.cf_solver_set_history_normal(solver, ptr(h["fn"])), lib.cf_solver_message(solver), caller)
        else:
            lib.cf_solver_set_history(solver, 0, *([ffi.NULL] * 7))
        if self.out is not None:
            self.out.attach(solver)

    def run(self, solver, r) -> int:
        """This job as one run of the solver (its buffers attached): the C status."""
        return lib.cf_solver_run(solver, ptr(self.ax), ptr(self.ay) if self.ay is not None else ffi.NULL,
                                 ptr(self.az) if self.az is not None else ffi.NULL, self.ax.size, self.dt,
                                 ptr(self.resid), r)

    def response(self, r, message, options) -> Response:
        """The Response of a finished run (its cf_solver_result r; options: a SolverOptions, or its to_dict())."""
        hist = None
        extra = self.out.report(r) if self.out is not None else {}
        if self.history:
            n = r.n_history
            h = self.h
            assert h is not None   # allocated with history=True
            en = h["en"][:n]
            ch = self.out.history(n) if self.out is not None else {}
            energy = {k: en[:, i].copy() for i, k in enumerate(_ENERGY_KEYS)}
            energy.update(ch.get("connector_energy", {}))
            hist = History(t=h["t"][:n].copy(), top_disp=h["top"][:n].copy(), block_pos=h["pos"][:n].copy(),
                           block_quat=h["quat"][:n].copy(), joint_opening=h["open"][:n].copy(),
                           joint_slip=h["slip"][:n].copy(), joint_normal_force=h["fn"][:n].copy(),
                           energy=energy, dowels=ch.get("dowels"))
        reason = _REASONS.get(r.collapse_reason, "unknown")
        part = ""
        if r.collapsed and extra.get("columns") is not None:
            cols = np.flatnonzero(extra["columns"]["collapsed"])
            beams: np.ndarray | list = np.flatnonzero(extra["epistyles"]["collapsed"]) if extra.get("epistyles") else []
            part = f"column {cols[0]}" if len(cols) else f"epistyle {beams[0]}" if len(beams) else ""
            if part.startswith("epistyle") and reason == "off_footprint":
                reason = "unseated"
        return Response(
            u_top=float(r.u_top), u_d=float(r.u_d), collapsed=bool(r.collapsed),
            collapse_block=int(r.collapse_block) if r.collapsed else None,
            collapse_time=float(r.collapse_time) if r.collapsed else math.nan,
            collapse_reason=reason,
            n_steps=int(r.n_steps), t_end=float(r.t_end), dt=float(r.dt), dt_crit=float(r.dt_crit),
            energy_error=float(r.energy_error), energy_scale=float(r.energy_scale),
            energy_warning=bool(r.energy_warning), residual_dislocation=self.resid, history=hist, message=message,
            options=dict(options) if isinstance(options, dict) else options.to_dict(), collapse_part=part,
            at_rest_exit=bool(r.at_rest_exit), max_top_disp=float(r.max_top_disp), **extra)


def simulate(col, acc_x, dt=None, acc_y=None, acc_z=None, history=False, options=None, initial_state=None,
             **overrides) -> Response:
    """Simulate the column under one ground-motion record.

    Parameters
    ----------
    col : Column
        The column (blocks, density, joint properties).
    acc_x : array (n,) or Record
        Horizontal ground acceleration along x, m/s^2 (the paper's fault-normal component). Or a
        :class:`~pycolfrag.ground_motion.Record`, given alone: its ``acc`` along x, its ``h2`` along y
        and its ``v`` vertical, at its ``dt`` (e.g. ``record.motion("both", 0.5)``).
    dt : float
        Sampling interval of the record, s (> 0). The record is interpolated linearly to the
        solver step; after its end the ground is at rest.
    acc_y, acc_z : array (n,), optional
        Second horizontal and vertical components, m/s^2, on the same time axis.
    history : bool (True or False)
        Also return time histories (:class:`History`) sampled every ``history_dt``.
    options : SolverOptions, optional
        The solver options (default ``SolverOptions()``, whose defaults are the C library's).
    **overrides
        Any :class:`SolverOptions` field by name (``contact="exact"``, ``dt_factor=0.4``,
        ``dt_solver=1e-4``, ``damping_alpha=...``, ...), applied on top of ``options``; an unknown
        name raises :class:`ParameterError`. See :class:`SolverOptions` for each option's unit,
        meaning and default.

    Returns
    -------
    Response
        ``u_top``, ``u_d`` (dimensionless; ``u_d`` is NaN after a collapse), ``collapsed``,
        ``collapse_block`` (0-based or None), ``collapse_time`` (s or nan), ``collapse_reason``,
        ``n_steps``, ``t_end`` (s), ``dt``, ``dt_crit`` (s), ``energy_error``,
        ``residual_dislocation`` (m per joint, NaN after a collapse), ``options`` (the
        :class:`SolverOptions` as a dict), ``history``, ``final_state`` (a :class:`~pycolfrag.solver.state.State`).
    initial_state : State, optional
        Continue from this state (a ``final_state`` of the same model, contact model and code) instead
        of rest: steps, times, EDPs and history go on from it (docs/sequences.md).

    Warns
    -----
    EnergyWarning
        The energy balance error exceeded ``energy_tolerance``.
    StepWarning
        An explicit ``dt_solver`` longer than the stability limit or than the record's dt.

    See :func:`simulate_batch` for many records on one column (the same results, faster).
    """
    _model(col)   # a bad model fails first
    motion = _motion(acc_x, dt, acc_y, acc_z)   # before the set-up: a bad record fails fast
    history = flag(history, "history")
    solver, options, parts = _setup(col, options, overrides, "simulate")
    state.prepare(solver, col, options, initial_state, "simulate")
    job = _Job(solver, col, options, motion, history, "simulate", parts)
    job.set_history(solver, "simulate")
    r = ffi.new("cf_solver_result *")
    with _interruptible(solver):
        st = job.run(solver, r)
    check(st, lib.cf_solver_message(solver), "simulate")
    message = ffi.string(lib.cf_solver_message(solver)).decode(errors="replace")
    if r.energy_warning:
        warnings.warn(f"simulate: {message}", EnergyWarning, stacklevel=2)
    res = job.response(r, message, options)
    res.final_state = state.take(solver, col, options)
    return res


def batch_width(col=None, options=None, n_runs=None, **overrides) -> int:
    """How many runs :func:`simulate_batch` integrates side by side on this CPU for a column and
    options: the most it can (``n_runs`` None): 8 (AVX-512), 4 (AVX2), 2 (SSE2) or 1 (the exact-interface
    contact model, whose runs go one after the other; dowelled columns and colonnades run in lanes as a
    column does); or the width it takes by
    default for ``n_runs`` records (8 from 5 runs on, 4 from 3 on, else 1: the widths that are
    faster than one run after the other, docs/performance.md)."""
    col = Column.parthenon() if col is None else col
    solver, _, _ = _setup(col, options, overrides, "batch_width")
    if n_runs is None:
        return int(lib.cf_solver_batch_max_width(solver))
    return int(lib.cf_solver_batch_width(solver, int(n_runs)))


def _batch_entry(i: int, rec) -> tuple:
    """A run's ground motion (:func:`_motion`) from entry ``i`` of simulate_batch's records."""
    if isinstance(rec, Record):
        return _motion(rec, None, None, None, f"records[{i}]: ")
    if isinstance(rec, dict):
        unknown = set(rec) - {"acc_x", "dt", "acc_y", "acc_z"}
        if unknown:
            raise ParameterError(f"records[{i}] has unknown keys {sorted(unknown)} (acc_x, dt, acc_y, acc_z)")
        args = (rec.get("acc_x"), rec.get("dt"), rec.get("acc_y"), rec.get("acc_z"))
    elif isinstance(rec, (tuple, list)) and len(rec) in (2, 4):
        args = (rec[0], rec[1], *(rec[2:] if len(rec) == 4 else (None, None)))
    else:
        raise ParameterError(f"records[{i}] must be a Record, a dict (acc_x, dt[, acc_y, acc_z]) or a tuple "
                             f"(acc_x, dt) or (acc_x, dt, acc_y, acc_z), got {type(rec).__name__}")
    if args[1] is None:
        raise ParameterError(f"records[{i}] has no dt (record sampling interval, s)")
    if isinstance(args[0], Record):
        raise ParameterError(f"records[{i}]: a Record is an entry of its own, not an acc_x")
    return _motion(*args)


def _run_one_by_one(solver, options, jobs: list, out: list) -> None:
    """The jobs of a structure with parts that has no lanes (the exact interface, a build without SIMD),
    one run after the other, each with its own outputs; each one's Response (or exception) into ``out``."""
    for i, job in jobs:
        r = ffi.new("cf_solver_result *")
        job.set_history(solver, "simulate_batch")
        with _interruptible(solver):
            st = job.run(solver, r)
        message = ffi.string(lib.cf_solver_message(solver)).decode(errors="replace")
        try:   # a run's error reads as simulate's
            check(st, message, "simulate")
        except Exception as exc:
            out[i] = exc
            continue
        if r.energy_warning:
            warnings.warn(f"simulate_batch: run {i}: {message}", EnergyWarning, stacklevel=3)
        out[i] = job.response(r, message, options)


def _run_batch(solver, options, width: int, jobs: list, out: list) -> None:
    """Run the jobs ((index, _Job) pairs) side by side; each one's Response (or exception) into ``out``."""
    cjobs = ffi.new("cf_solver_batch_job[]", len(jobs))
    couts = ffi.new("cf_solver_batch_out[]", len(jobs))
    for c, (_, job) in zip(cjobs, jobs):
        job.fill(c)
    with _interruptible(solver):
        st = lib.cf_solver_batch_run(solver, int(width), len(jobs), cjobs, couts)
    check(st, lib.cf_solver_message(solver), "simulate_batch")
    for o, (i, job) in zip(couts, jobs):
        message = ffi.string(o.message).decode(errors="replace")
        try:   # a run's error reads as simulate's
            check(o.status, message, "simulate")
        except Exception as exc:
            out[i] = exc
            continue
        if o.result.energy_warning:
            warnings.warn(f"simulate_batch: run {i}: {message}", EnergyWarning, stacklevel=3)
        out[i] = job.response(o.result, message, options)


def simulate_batch(col, records, history=False, options=None, *, width=None, errors="raise",
                   **overrides) -> list:
    """Simulate the column under many records at once: one run per SIMD lane.

    Every run is bitwise the :func:`simulate` of its record with the same options (the batch
    integrates ``width`` runs side by side, each lane doing the single run's operations in its
    order, and gives a lane the next record when its run ends); only the speed differs
    (docs/performance.md).

    Parameters
    ----------
    col : Column
    records : sequence
        One entry per run: a :class:`~pycolfrag.ground_motion.Record` (as :func:`simulate` takes one),
        a mapping with ``acc_x`` and ``dt`` (and optionally ``acc_y``, ``acc_z``), or a tuple
        ``(acc_x, dt)`` / ``(acc_x, dt, acc_y, acc_z)`` -- as :func:`simulate` takes them.
    history, options, **overrides
        As :func:`simulate`, for every run.
    width : int, optional
        Runs side by side: 1, 2, 4 or 8 up to :func:`batch_width` (default: the fastest for this many
        records, ``batch_width(col, options, n_runs=len(records))``). The results do not depend on it.
    errors : {"raise", "return"}
        A run that :func:`simulate` would end with an exception: raise it (after the batch), or put
        the exception in that run's place of the returned list.

    Returns
    -------
    list of Response (or of exceptions, with ``errors="return"``), in the order of ``records``.

    Warns
    -----
    EnergyWarning, StepWarning
        As :func:`simulate`, per run.
    """
    if errors not in ("raise", "return"):
        raise ParameterError(f"errors must be 'raise' or 'return', got {errors!r}")
    if isinstance(records, (str, bytes, Record)) or not hasattr(records, "__iter__"):
        raise ParameterError(f"records must be a sequence of records, got {type(records).__name__}")
    records = list(records)
    history = flag(history, "history")
    solver, options, parts = _setup(col, options, overrides, "simulate_batch")
    widest = int(lib.cf_solver_batch_max_width(solver))
    if width is None:
        width = 0   # the C library's choice for the number of runs
    elif isinstance(width, bool) or not isinstance(width, (int, np.integer)) or int(width) not in (1, 2, 4, 8) \
            or int(width) > widest:
        raise ParameterError(f"width must be 1, 2, 4 or 8 up to {widest} (this CPU and contact model), got {width!r}")
    out: list = [None] * len(records)
    jobs = []
    for i, rec in enumerate(records):
        try:
            jobs.append((i, _Job(solver, col, options, _batch_entry(i, rec), history, "simulate_batch", parts)))
        except Exception as exc:   # a bad record is that run's error, as simulate would raise it
            out[i] = exc
    if jobs and parts is not None and widest == 1:   # dowels and colonnades run in lanes, each with its outputs
        _run_one_by_one(solver, options, jobs, out)
    elif jobs:
        _run_batch(solver, options, width, jobs, out)
    if errors == "raise":
        for r in out:
            if isinstance(r, BaseException):
                raise r
    return out


def automatic_step(model, options) -> float:
    """The solver's automatic step of ``model`` with ``options`` (``dt_factor`` x the stability limit),
    s, from the set-up solver: no step is run (a run of a few samples at a tiny step took minutes)."""
    s, opts, _ = _setup(model, options, {}, "automatic_step")
    return opts.dt_factor * float(lib.cf_solver_dt_crit(s))
