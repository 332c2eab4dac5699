"""Solver options: :class:`SolverOptions`, built from the C library's option tables.

The C library declares every option as data (csrc/solver_options.c for the solver's own, each
contact model's registry entry for its own: name, kind, unit, accepted range, default, doc). This
module reads those declarations (:data:`OPTIONS`) and builds from them, and from nowhere else:
the fields of :class:`SolverOptions` with their defaults, its type checks (the ranges are C's own
check, ``cf_solver_check_def``, run when an instance is built, so a bad value fails here naming the
option and the value, before any run starts), its documentation and the options table of
docs/solver.md (:func:`docs_table`). A contact model added to the C registry with an option of its
own adds that option here.

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
from typing import TYPE_CHECKING, Any, ClassVar, cast

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib
from pycolfrag.core.validate import flag, real

__all__ = ["SolverOptions", "Option", "OPTIONS", "CONTACT_OPTIONS", "CONTACT_DOCS", "docs_table", "solver_defaults",
           "resolve_solver_options"]

#: contact models understood by the solver (names -> C codes), read from the C library's
#: registry of contact models (csrc/solver_contact_model.c): a model added there is an option here
CONTACT_OPTIONS = {ffi.string(lib.cf_solver_contact_model_name(i)).decode(): i
                   for i in range(lib.cf_solver_contact_model_count())}
#: each contact model's one-sentence description, from the same registry
CONTACT_DOCS = {name: ffi.string(lib.cf_solver_contact_model_doc(i)).decode() for name, i in CONTACT_OPTIONS.items()}
_CONTACT_NAMES = {v: k for k, v in CONTACT_OPTIONS.items()}

# The one option whose Python name differs from C's: results files store ``dt_solver`` (the C
# definition's ``dt``, whose automatic value 0 is None here).
_PY_NAME = {"dt": "dt_solver"}

_KINDS = {lib.CF_SOLVER_OPTION_REAL: "real", lib.CF_SOLVER_OPTION_INT: "int", lib.CF_SOLVER_OPTION_FLAG: "flag",
          lib.CF_SOLVER_OPTION_STEP: "step", lib.CF_SOLVER_OPTION_MODEL: "model"}
_TYPES = {"real": "float", "int": "int", "flag": "bool", "step": "float or None", "model": "str"}


@dataclass(frozen=True)
class Option:
    """One solver option as the C library declares it (``cf_solver_option``).

    ``name`` is the :class:`SolverOptions` field (``c_name`` the C one); ``kind`` one of "real", "int",
    "flag", "step" (a step in s, None for automatic), "model" (a contact model's name); ``lo``/``hi``
    the accepted range with ``lo_open``/``hi_open`` (an open bound refused, an infinite one that is
    open: finite values only); ``default`` in Python terms; ``models`` the contact models that declare
    it (empty: an option of the solver itself, read by every model)."""

    name: str
    c_name: str
    kind: str
    lo: float
    hi: float
    lo_open: bool
    hi_open: bool
    default: object
    unit: str
    doc: str
    models: tuple = ()

    def accepted(self) -> str:
        """The accepted values, as the docs print them: "(0, 4]", ">= 0", "finite", ..."""
        if self.kind == "model":
            return ", ".join(f"`{m}`" for m in CONTACT_OPTIONS)
        if self.kind == "flag":
            return "True, False"
        lo_inf, hi_inf = math.isinf(self.lo), math.isinf(self.hi)
        integer = "integer " if self.kind == "int" else ""
        if self.kind == "step":   # 0 is C's automatic: None here, so a given step is > lo
            text = f"> {self.lo:g}" if hi_inf else f"in ({self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"
            return f"None (automatic) or {text}"
        if lo_inf and hi_inf:
            return f"{integer}finite"
        if hi_inf:
            return f"{integer}{'>' if self.lo_open else '>='} {self.lo:g}"
        if lo_inf:
            return f"{integer}{'<' if self.hi_open else '<='} {self.hi:g}"
        return f"{integer}in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"


def _text(p) -> str:
    return ffi.string(p).decode()


def _python_value(kind: str, v: float):
    """A C value (a double) of an option of this kind in Python terms."""
    if kind == "model":
        return _CONTACT_NAMES[int(v)]
    if kind == "flag":
        return bool(v)
    if kind == "int":
        return int(v)
    if kind == "step":
        return None if v == 0 else float(v)
    return float(v)


def _read_options() -> dict:
    """Every option of the C library's tables, in their order (name -> :class:`Option`)."""
    declared_by: dict[str, list] = {}
    for name, m in CONTACT_OPTIONS.items():
        for k in range(lib.cf_solver_contact_model_n_options(m)):
            declared_by.setdefault(_text(lib.cf_solver_contact_model_option(m, k).name), []).append(name)
    out = {}
    for i in range(lib.cf_solver_options_count()):
        o = lib.cf_solver_options_get(i)
        c_name, kind = _text(o.name), _KINDS[o.kind]
        name = _PY_NAME.get(c_name, c_name)
        out[name] = Option(name, c_name, kind, float(o.lo), float(o.hi), bool(o.lo_open), bool(o.hi_open),
                           _python_value(kind, o.value), _text(o.unit), _text(o.doc),
                           tuple(declared_by.get(c_name, ())))
    return out


#: Every solver option (the :class:`SolverOptions` field name -> :class:`Option`), read from C.
OPTIONS = _read_options()


def _check_int(v, name):
    # any integer type (numpy's too) or a whole real number, within C's int
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Integral, numbers.Real)) \
            or not math.isfinite(v) or int(v) != v or abs(int(v)) > 2**31 - 1:
        raise ParameterError(f"{name} must be an integer, got {v!r}")
    return int(v)


def _checked(opt: Option, v):
    """The value of option ``opt`` with its type checked (a clear message naming it), in Python terms."""
    name = opt.name
    if opt.kind == "model":
        if not isinstance(v, str) or v not in CONTACT_OPTIONS:
            raise ParameterError(f"{name} must be one of {sorted(CONTACT_OPTIONS)}, got {v!r}")
        return v
    if opt.kind == "flag":
        return flag(v, name)
    if opt.kind == "int":
        return _check_int(v, name)
    if opt.kind == "step":
        if v is None:
            return None
        x = real(v, name)
        if not (math.isfinite(x) and x > 0):
            raise ParameterError(f"{name} must be None (automatic) or a finite step > 0 s, got {v!r}")
        return x
    if v is None and name == "damping_start_s":
        v = 0.0   # simulate()'s documented None: damping from the start
    x = real(v, name)
    if not math.isfinite(x):
        raise ParameterError(f"{name} must be finite, got {v!r}")
    return x


def _c_value(opt: Option, v) -> float:
    """A checked Python value as the C definition holds it."""
    if opt.kind == "model":
        return float(CONTACT_OPTIONS[v])
    if opt.kind == "step":
        return 0.0 if v is None else float(v)
    return float(v)


class _SolverOptionsMethods:
    """What :class:`SolverOptions` does beside holding its fields (the fields come from :data:`OPTIONS`)."""

    def __post_init__(self):
        # types first (a clear message naming the option), then the C library's ranges
        for name, opt in OPTIONS.items():
            object.__setattr__(self, name, _checked(opt, getattr(self, name)))
        s = ffi.gc(lib.cf_solver_create(), lib.cf_solver_free)
        if s == ffi.NULL:
            raise MemoryError("cf_solver_create failed")
        if lib.cf_solver_check_def(s, self.to_c()) != lib.CF_OK:
            msg = ffi.string(lib.cf_solver_message(s)).decode(errors="replace")
            # name the Python option where the C name differs (the C message starts with the option's name)
            for c_name, name in _PY_NAME.items():
                if msg.startswith(f"{c_name} "):
                    msg = name + msg[len(c_name):]
            raise ParameterError(f"solver options: {msg}")

    def to_c(self):
        """A new ``cf_solver_def *`` holding these options."""
        d = ffi.new("cf_solver_def *")
        lib.cf_solver_def_default(d)
        for name, opt in OPTIONS.items():
            v = getattr(self, name)
            if lib.cf_solver_options_set(d, opt.c_name.encode(), _c_value(opt, v)) != lib.CF_OK:
                raise ParameterError(f"{name} = {v!r} does not fit the C definition")
        return d

    def replace(self, **changes) -> SolverOptions:
        """A copy with some options changed; an unknown name raises ParameterError naming it."""
        unknown = sorted(set(changes) - set(OPTIONS))
        if unknown:
            raise ParameterError(f"unknown solver option(s) {unknown}; known: {sorted(OPTIONS)}")
        return dataclasses.replace(cast("SolverOptions", self), **changes)   # self: the dataclass built below

    def to_dict(self) -> dict:
        """Plain JSON-ready dict of every option (what results files store)."""
        return {name: getattr(self, name) for name in OPTIONS}

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
        return tuple(OPTIONS)


def _default_text(opt: Option) -> str:
    return "None (automatic)" if opt.default is None else repr(opt.default)


def _docstring() -> str:
    lines = ["Every option of the rigid-drum solver, with the C library's defaults.", "",
             "The fields, their defaults and ranges are the C library's option tables (:data:`OPTIONS`):",
             "the solver's own options, then each contact model's (``CONTACT_OPTIONS``; ``CONTACT_DOCS``",
             "describes each model). Build with keywords; a bad value raises ParameterError naming it.", "",
             "Attributes", "----------"]
    for opt in OPTIONS.values():
        lines.append(f"{opt.name} : {_TYPES[opt.kind]}")
        unit = "" if opt.unit == "-" else f" Unit: {opt.unit}."
        models = f" Contact models: {', '.join(opt.models)}." if opt.models else ""
        lines.append(f"    {opt.doc}{unit} Accepted: {opt.accepted()}. Default: {_default_text(opt)}.{models}")
    return "\n".join(lines)


def _annotation(kind: str):
    return {"real": float, "int": int, "flag": bool, "step": "float | None", "model": str}[kind]


if TYPE_CHECKING:
    class SolverOptions(_SolverOptionsMethods):
        """What a type checker knows of the class below: a frozen dataclass whose fields (names, types,
        defaults) are the C library's option tables, so known only at run time."""

        __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

        def __init__(self, **options: Any) -> None: ...

        def __getattr__(self, name: str) -> Any: ...
else:
    SolverOptions = dataclasses.make_dataclass(
        "SolverOptions",
        [(name, _annotation(opt.kind), field(default=opt.default, metadata={"option": opt}))
         for name, opt in OPTIONS.items()],
        bases=(_SolverOptionsMethods,), frozen=True)
    SolverOptions.__module__ = __name__
    SolverOptions.__doc__ = _docstring()


def docs_table() -> str:
    """The options table of docs/solver.md, as this build's C tables declare it (a test keeps the page
    equal to it; ``python -c "from pycolfrag import options; print(options.docs_table())"`` prints it)."""
    rows = ["| option | unit | accepted | default | contact models | meaning |", "|---|---|---|---|---|---|"]
    for opt in OPTIONS.values():
        models = ", ".join(f"`{m}`" for m in opt.models) if opt.models else "all"
        rows.append(f"| `{opt.name}` | {opt.unit} | {opt.accepted()} | {_default_text(opt)} | {models} | "
                    f"{opt.doc} |")
    return "\n".join(rows) + "\n"


def solver_defaults() -> dict:
    """The solver options' defaults (:class:`pycolfrag.SolverOptions`, read from the C library)."""
    return SolverOptions().to_dict()


def resolve_solver_options(opts) -> SolverOptions:
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
