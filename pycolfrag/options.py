"""Solver options: :class:`SolverOptions`, the one home of every option of the C solver.

The defaults are read from the C library (``cf_solver_def_default`` in csrc/solver.c),
so Python, the grid driver and results files cannot drift from C. Ranges are checked
by the C library's own check (``cf_solver_check_def``) when an instance is built, so a
bad value fails here, naming the option and the value, before any run starts.

Example::

    import pycolfrag as pcf
    opts = pcf.SolverOptions(contact="exact", dt_factor=0.4)
    res = pcf.simulate(col, acc, dt, options=opts)           # or simulate(col, acc, dt, dt_factor=0.4)
    opts.to_dict(); pcf.SolverOptions.from_dict(opts.to_dict()) == opts
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from ._ffi import ffi, lib
from ._validate import flag, real
from .errors import ParameterError

__all__ = ["SolverOptions", "CONTACT_OPTIONS", "CONTACT_DOCS"]

#: contact models understood by the solver (names -> C codes), read from the C library's
#: registry of contact models (csrc/solver_contact_model.c): a model added there is an option here
CONTACT_OPTIONS = {ffi.string(lib.cf_solver_contact_model_name(i)).decode(): i
                   for i in range(lib.cf_solver_contact_model_count())}
#: each contact model's one-sentence description, from the same registry
CONTACT_DOCS = {name: ffi.string(lib.cf_solver_contact_model_doc(i)).decode() for name, i in CONTACT_OPTIONS.items()}
_CONTACT_NAMES = {v: k for k, v in CONTACT_OPTIONS.items()}


def _c_defaults():
    d = ffi.new("cf_solver_def *")
    lib.cf_solver_def_default(d)
    return d


_C = _c_defaults()

# Python field -> (C field, kind); kinds: "float", "int", "bool", "contact", "dt"
_FIELDS = {
    "contact": ("contact", "contact"),
    "points_per_edge": ("points_per_edge", "int"),
    "dt_solver": ("dt", "dt"),
    "dt_factor": ("dt_factor", "float"),
    "tail_s": ("tail_s", "float"),
    "residual_window_s": ("residual_window_s", "float"),
    "planar": ("planar", "bool"),
    "monolithic": ("monolithic", "bool"),
    "early_exit": ("early_exit", "bool"),
    "damping_alpha": ("damping_alpha", "float"),
    "damping_start_s": ("damping_start_s", "float"),
    "history_dt": ("history_dt", "float"),
    "g": ("g", "float"),
    "energy_tolerance": ("energy_tolerance", "float"),
    "unstable_tolerance": ("unstable_tolerance", "float"),
    "initial_tilt_rad": ("initial_tilt_rad", "float"),
    "contact_tolerance": ("contact_tolerance", "float"),
    "reentry_depth": ("reentry_depth", "float"),
}


def _default(name):
    cname, kind = _FIELDS[name]
    v = getattr(_C, cname)
    if kind == "contact":
        return _CONTACT_NAMES[v]
    if kind == "bool":
        return bool(v)
    if kind == "int":
        return int(v)
    if kind == "dt":
        return None if v == 0 else float(v)
    return float(v)


def _opt(name: str, doc: str):
    return field(default=_default(name), metadata={"doc": doc})


@dataclass(frozen=True)
class SolverOptions:
    """Every option of the rigid-drum solver, with the C library's defaults.

    Attributes (units and meaning; defaults come from ``cf_solver_def_default``)
    ----------
    contact : {"vertex", "perimeter", "exact"}
        Joint discretisation: sub-contacts at the polygon vertices of both faces (3DEC-like,
        default); a refined face mesh with ``points_per_edge`` points per edge plus interior
        nodes (converges to "exact"); or the exact integral of kn * overlap over the compressed
        part of the face overlap polygon. The names are those of the C library's registry
        (``CONTACT_OPTIONS``; ``CONTACT_DOCS`` describes each).
    points_per_edge : int
        Refinement of "perimeter", in [1, 64].
    dt_solver : float or None
        Explicit solver step, s; None: ``dt_factor`` times the whole-stack stability limit.
    dt_factor : float
        Fraction of the stability limit, in (0, 4].
    tail_s : float
        Free response after the end of the record, s.
    residual_window_s : float
        u_d is the residual dislocation averaged over this last part of the response, s.
    planar : bool
        Motion restricted to the x-z plane (one horizontal component only).
    monolithic : bool
        The whole column as one rigid body on its base joint.
    early_exit : bool
        Stop at collapse, or once the column is at rest after the record.
    damping_alpha : float
        Mass-proportional damping, 1/s (0: none, as in the paper).
    damping_start_s : float
        Damping acts from this time on, s.
    history_dt : float
        History sampling interval, s.
    g : float
        Gravity, m/s^2.
    energy_tolerance : float
        Relative energy-balance error above which a run warns (``energy_warning``).
    unstable_tolerance : float
        Relative energy-balance error above which a run stops as unstable (SolverError).
    initial_tilt_rad : float
        Rigid initial tilt of the whole column about its +x base edge, rad, in [-1, 1].
    contact_tolerance : float
        A sub-contact overhanging the other face by less than this fraction of the face's
        circumradius still bears, in [0, 0.1).
    reentry_depth : float
        Sub-contact models ("vertex", "perimeter"): a point that was off the face (beside it, below
        its plane) and comes back onto it at most this fraction of the face's circumradius deep
        takes contact with its spring compressed to that depth (the energy it brings is booked as
        ``contact_switch``); a deeper one takes contact with its spring unstretched. In [0, 0.1]; 0:
        every re-entry unstretched. See docs/accuracy.md, "Two-component motion".
    """

    contact: str = _opt("contact", "contact model")
    points_per_edge: int = _opt("points_per_edge", "points per polygon edge (perimeter)")
    dt_solver: float | None = _opt("dt_solver", "explicit solver step, s")
    dt_factor: float = _opt("dt_factor", "fraction of the stability limit")
    tail_s: float = _opt("tail_s", "free response after the record, s")
    residual_window_s: float = _opt("residual_window_s", "residual averaging window, s")
    planar: bool = _opt("planar", "x-z plane only")
    monolithic: bool = _opt("monolithic", "one rigid body")
    early_exit: bool = _opt("early_exit", "stop at collapse or at rest")
    damping_alpha: float = _opt("damping_alpha", "mass-proportional damping, 1/s")
    damping_start_s: float = _opt("damping_start_s", "damping start, s")
    history_dt: float = _opt("history_dt", "history interval, s")
    g: float = _opt("g", "gravity, m/s^2")
    energy_tolerance: float = _opt("energy_tolerance", "balance error that warns")
    unstable_tolerance: float = _opt("unstable_tolerance", "balance error that stops the run")
    initial_tilt_rad: float = _opt("initial_tilt_rad", "initial tilt, rad")
    contact_tolerance: float = _opt("contact_tolerance", "overhang tolerance / circumradius")
    reentry_depth: float = _opt("reentry_depth", "stretched re-entry depth / circumradius")

    def __post_init__(self):
        # types first (a clear message naming the option), then the C library's ranges
        for name, (_, kind) in _FIELDS.items():
            v = getattr(self, name)
            if kind == "contact":
                if not isinstance(v, str) or v not in CONTACT_OPTIONS:
                    raise ParameterError(f"contact must be one of {sorted(CONTACT_OPTIONS)}, got {v!r}")
            elif kind == "bool":
                object.__setattr__(self, name, flag(v, name))
            elif kind == "int":
                # any integer type (numpy's too) or a whole real number, within C's int
                if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Integral, numbers.Real)) \
                        or not math.isfinite(v) or int(v) != v or abs(int(v)) > 2**31 - 1:
                    raise ParameterError(f"{name} must be an integer, got {v!r}")
                object.__setattr__(self, name, int(v))
            elif kind == "dt":
                if v is not None:
                    x = real(v, name)
                    if not (math.isfinite(x) and x > 0):
                        raise ParameterError(f"{name} must be None (automatic) or a finite step > 0 s, got {v!r}")
                    object.__setattr__(self, name, x)
            else:
                if v is None and name == "damping_start_s":
                    v = 0.0   # simulate()'s documented None: damping from the start
                x = real(v, name)
                if not math.isfinite(x):
                    raise ParameterError(f"{name} must be finite, got {v!r}")
                object.__setattr__(self, name, x)
        s = ffi.gc(lib.cf_solver_create(), lib.cf_solver_free)
        if s == ffi.NULL:
            raise MemoryError("cf_solver_create failed")
        if lib.cf_solver_check_def(s, self.to_c()) != lib.CF_OK:
            msg = ffi.string(lib.cf_solver_message(s)).decode(errors="replace")
            # name the Python option where the C name differs (the C message starts with the field's name)
            for name, (cname, _) in _FIELDS.items():
                if cname != name and msg.startswith(f"{cname} "):
                    msg = name + msg[len(cname):]
                    break
            raise ParameterError(f"solver options: {msg}")

    def to_c(self):
        """A new ``cf_solver_def *`` holding these options."""
        d = ffi.new("cf_solver_def *")
        lib.cf_solver_def_default(d)
        for name, (cname, kind) in _FIELDS.items():
            v = getattr(self, name)
            if kind == "contact":
                v = CONTACT_OPTIONS[v]
            elif kind == "bool":
                v = int(v)
            elif kind == "dt":
                v = 0.0 if v is None else v
            setattr(d, cname, v)
        return d

    def replace(self, **changes) -> "SolverOptions":
        """A copy with some options changed; an unknown name raises ParameterError naming it."""
        unknown = sorted(set(changes) - set(_FIELDS))
        if unknown:
            raise ParameterError(f"unknown solver option(s) {unknown}; known: {sorted(_FIELDS)}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain JSON-ready dict of every option (what results files store)."""
        return {name: getattr(self, name) for name in _FIELDS}

    @classmethod
    def from_dict(cls, d: dict) -> "SolverOptions":
        """Options from a dict (e.g. a results file's ``solver`` attribute); missing keys take the
        defaults, unknown keys raise ParameterError naming them."""
        if not isinstance(d, dict):
            raise ParameterError(f"solver options must be a dict, got {type(d).__name__}")
        return cls().replace(**d)

    @classmethod
    def names(cls) -> tuple:
        """The option names, in order."""
        return tuple(_FIELDS)
