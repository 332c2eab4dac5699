"""Response of a column to one ground-motion record: :func:`simulate`.

The physics lives in C (``csrc/solver.c``, documented in ``docs/solver.md``): rigid
blocks with soft Coulomb joints, leapfrog integration in the frame that moves with
the ground, step from the stability limit of the whole linearised stack. This module
validates the input, passes it to C and wraps the output in :class:`Response` and
:class:`History`.

Example::

    import numpy as np, pycolfrag as pcf
    col = pcf.Column.parthenon()
    t = np.arange(0, 3.0, 0.005)
    res = pcf.simulate(col, 0.25 * 9.81 * np.sin(2 * np.pi * 2 * t), 0.005, history=True)
    res.u_top, res.u_d, res.collapsed, res.history.top_disp
"""
from __future__ import annotations

import math
import threading
import warnings
from dataclasses import dataclass

import numpy as np

from ._ffi import check, ffi, lib, ptr
from ._validate import flag, float_array, positive_float
from .column import Column
from .errors import ParameterError
from .options import CONTACT_OPTIONS, SolverOptions

__all__ = ["simulate", "Response", "History", "EnergyWarning", "StepWarning", "CONTACT_OPTIONS", "MAX_ABS_ACC",
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
        balance_error = kinetic + gravity + spring + dissipated + contact_switch - ground_work
    """

    t: np.ndarray
    top_disp: np.ndarray
    block_pos: np.ndarray
    block_quat: np.ndarray
    joint_opening: np.ndarray
    joint_slip: np.ndarray
    energy: dict
    joint_normal_force: np.ndarray = None


@dataclass
class Response:
    """EDPs and diagnostics of one run (see :func:`simulate`)."""

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


def _acc(a, name, n_expected=None):
    if a is None:
        return None
    arr = float_array(a, name)
    if n_expected is not None and arr.size != n_expected:
        raise ParameterError(f"{name} has {arr.size} samples but acc_x has {n_expected}: components must "
                             "share one time axis")
    big = np.abs(arr) > MAX_ABS_ACC
    if big.any():
        i = int(np.argmax(big))
        raise ParameterError(
            f"{name}[{i}] = {arr[i]!r} m/s^2 exceeds {MAX_ABS_ACC:g} m/s^2 (about 10 g): accelerations must be in "
            "m/s^2 (a record in cm/s^2 or a g-factor applied twice?)")
    return arr


def _segments(col: Column, monolithic: bool):
    segs = [s for b in col.blocks for s in b.segments]
    arr = ffi.new("cf_geometry_segment[]", len(segs))
    for i, s in enumerate(segs):
        arr[i].height = s.height
        arr[i].r_bottom = s.r_bottom
        arr[i].r_top = s.r_top
        arr[i].phase_rad = s.phase_rad
        arr[i].n_sides = int(s.n_sides)
    nseg = ffi.new("int[]", [len(b.segments) for b in col.blocks])
    return arr, nseg


def simulate(col, acc_x, dt, acc_y=None, acc_z=None, history=False, options=None, **overrides) -> Response:
    """Simulate the column under one ground-motion record.

    Parameters
    ----------
    col : Column
        The column (blocks, density, joint properties).
    acc_x : array (n,)
        Horizontal ground acceleration along x, m/s^2 (the paper's fault-normal component).
    dt : float
        Sampling interval of the record, s (> 0). The record is interpolated linearly to the
        solver step; after its end the ground is at rest.
    acc_y, acc_z : array (n,), optional
        Second horizontal and vertical components, m/s^2, on the same time axis.
    history : bool
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
        :class:`SolverOptions` as a dict), ``history``.

    Warns
    -----
    EnergyWarning
        The energy balance error exceeded ``energy_tolerance``.
    StepWarning
        An explicit ``dt_solver`` longer than the stability limit or than the record's dt.
    """
    if not isinstance(col, Column):
        raise ParameterError(f"col must be a Column, got {type(col).__name__}")
    dt = float(positive_float(dt, "dt (record sampling interval, s)"))
    if acc_x is None:
        raise ParameterError("acc_x must be an array of accelerations (m/s^2), got None")
    ax = _acc(acc_x, "acc_x")
    ay = _acc(acc_y, "acc_y", ax.size)
    az = _acc(acc_z, "acc_z", ax.size)
    history = flag(history, "history")
    if options is None:
        options = SolverOptions()
    elif not isinstance(options, SolverOptions):
        raise ParameterError(f"options must be a SolverOptions, got {type(options).__name__}")
    if overrides:
        options = options.replace(**overrides)
    if options.planar and ay is not None:
        raise ParameterError("planar=True takes one horizontal component: acc_y must be None")
    d = options.to_c()
    monolithic = options.monolithic

    solver = ffi.gc(lib.cf_solver_create(), lib.cf_solver_free)
    if solver == ffi.NULL:
        raise MemoryError("cf_solver_create failed")
    segs, nseg = _segments(col, monolithic)
    if monolithic and any(j > 0 for j in col.joint_overrides):
        warnings.warn(f"simulate: monolithic=True has the base joint only; joint_overrides of joints "
                      f"{sorted(j for j in col.joint_overrides if j > 0)} do not act", UserWarning, stacklevel=2)
    props = [col.joint(i) for i in range(col.n_blocks)]
    kn = np.array([p.kn for p in props]); ks = np.array([p.ks for p in props]); mu = np.array([p.mu for p in props])
    st = lib.cf_solver_setup_joints(solver, d, col.n_blocks, nseg, segs, col.density, ptr(kn), ptr(ks), ptr(mu))
    check(st, lib.cf_solver_message(solver), "simulate")
    if options.dt_solver is not None:
        crit = float(lib.cf_solver_dt_crit(solver))
        if options.dt_solver > crit:
            warnings.warn(f"simulate: dt_solver = {options.dt_solver:.4g} s exceeds the whole-stack stability limit "
                          f"{crit:.4g} s: the run may go unstable (it stops with SolverError when the energy balance "
                          "breaks)", StepWarning, stacklevel=2)
        if options.dt_solver > dt:
            warnings.warn(f"simulate: dt_solver = {options.dt_solver:.4g} s is longer than the record's dt = {dt:.4g} s: "
                          "the solver skips record samples", StepWarning, stacklevel=2)

    nb = col.n_blocks
    hist_arrays = None
    if history:
        cap = int(lib.cf_solver_history_capacity(solver, ax.size, dt))
        nbytes = 8 * cap * (1 + 2 + 8 + 11 * nb)
        if cap < 0 or nbytes > MAX_HISTORY_BYTES:
            raise ParameterError(f"history_dt = {options.history_dt!r} s needs "
                                 f"{'over %d' % lib.CF_SOLVER_MAX_HISTORY if cap < 0 else cap} history samples for "
                                 f"this record ({'more than' if cap < 0 else f'{nbytes / 2**30:.1f} GiB,'} over the "
                                 f"{MAX_HISTORY_BYTES / 2**30:.0f} GiB limit): choose a longer history_dt")
        hist_arrays = dict(
            t=np.zeros(cap), top=np.zeros((cap, 2)), pos=np.zeros((cap, nb, 3)), quat=np.zeros((cap, nb, 4)),
            open=np.zeros((cap, nb)), slip=np.zeros((cap, nb, 2)), en=np.zeros((cap, lib.CF_SOLVER_N_ENERGY)), fn=np.zeros((cap, nb)))
        h = hist_arrays
        check(lib.cf_solver_set_history(solver, cap, ptr(h["t"]), ptr(h["top"]), ptr(h["pos"]), ptr(h["quat"]),
                                        ptr(h["open"]), ptr(h["slip"]), ptr(h["en"])),
              lib.cf_solver_message(solver), "simulate")
        check(lib.cf_solver_set_history_normal(solver, ptr(h["fn"])), lib.cf_solver_message(solver), "simulate")
    resid = np.zeros(nb)
    r = ffi.new("cf_solver_result *")
    # every CF_SOLVER_CHECK_STEPS steps (about 10 ms) the run calls back into Python, where a
    # pending Ctrl-C (or any signal handler's exception) is raised; the run then stops at once
    _runs.caught = caught = []
    lib.cf_solver_set_check(solver, lib._pcf_solver_check, ffi.NULL)
    try:
        st = lib.cf_solver_run(solver, ptr(ax), ptr(ay) if ay is not None else ffi.NULL,
                               ptr(az) if az is not None else ffi.NULL, ax.size, dt, ptr(resid), r)
    finally:
        _runs.caught = []
    if caught:
        raise caught[0]
    check(st, lib.cf_solver_message(solver), "simulate")
    message = ffi.string(lib.cf_solver_message(solver)).decode(errors="replace")
    if r.energy_warning:
        warnings.warn(f"simulate: {message}", EnergyWarning, stacklevel=2)

    hist = None
    if history:
        n = r.n_history
        h = hist_arrays
        en = h["en"][:n]
        hist = History(t=h["t"][:n].copy(), top_disp=h["top"][:n].copy(), block_pos=h["pos"][:n].copy(),
                       block_quat=h["quat"][:n].copy(), joint_opening=h["open"][:n].copy(),
                       joint_slip=h["slip"][:n].copy(), joint_normal_force=h["fn"][:n].copy(),
                       energy={k: en[:, i].copy() for i, k in enumerate(_ENERGY_KEYS)})
    return Response(
        u_top=float(r.u_top), u_d=float(r.u_d), collapsed=bool(r.collapsed),
        collapse_block=int(r.collapse_block) if r.collapsed else None,
        collapse_time=float(r.collapse_time) if r.collapsed else math.nan,
        collapse_reason=_REASONS.get(r.collapse_reason, "unknown"),
        n_steps=int(r.n_steps), t_end=float(r.t_end), dt=float(r.dt), dt_crit=float(r.dt_crit),
        energy_error=float(r.energy_error), energy_scale=float(r.energy_scale),
        energy_warning=bool(r.energy_warning), residual_dislocation=resid, options=options.to_dict(), history=hist,
        message=message, at_rest_exit=bool(r.at_rest_exit), max_top_disp=float(r.max_top_disp))
