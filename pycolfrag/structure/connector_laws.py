"""The kinds of connector law, read from the C library's registry (``csrc/solver_connector_law.c``):
each kind's name, its one-sentence documentation and its own values (name, default, unit, doc), as
the contact models' options are read (:mod:`pycolfrag.solver.options`). A new kind of law is its C file and
one line of that registry; this module, :class:`~pycolfrag.structure.connectors.DowelLaw` and the files'
``[[connectors]]`` tables take it from there. The named laws with their numbers and provenance
(``"titanium"``, ``"wood"``) are data: ``pycolfrag/data/connector_laws.json``.

The values every kind shares -- the shear stiffness and strength, the break, the axial part -- are
:data:`COMMON` (fields of ``cf_solver_connector``, checked by ``cf_solver_connectors_check``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pycolfrag.core.ffi import ffi, lib

__all__ = ["LawValue", "LawKind", "COMMON", "LAW_KINDS"]

#: The values of every connector, in their order, with their defaults (docs: ``csrc/solver.h``).
COMMON: dict[str, float] = {"k_shear": 0.0, "f_yield": math.inf, "u_ultimate": math.inf, "k_axial": 0.0,
                            "n_yield": math.inf, "d_ultimate": math.inf}


@dataclass(frozen=True)
class LawValue:
    """One value of a kind's own (``cf_solver_connector.law[k]``)."""

    name: str
    default: float
    unit: str
    doc: str


@dataclass(frozen=True)
class LawKind:
    """One kind of connector law: its index in the C registry (``cf_solver_connector.kind``), its
    name, its documentation and its own values in the order of ``law[]``."""

    index: int
    name: str
    doc: str
    values: tuple[LawValue, ...]


def _text(p) -> str:
    return ffi.string(p).decode() if p != ffi.NULL else ""


def _kinds() -> dict[str, LawKind]:
    out = {}
    for i in range(lib.cf_solver_connector_law_count()):
        values = []
        for k in range(lib.cf_solver_connector_law_n_values(i)):
            o = lib.cf_solver_connector_law_value(i, k)
            values.append(LawValue(_text(o.name), float(o.value), _text(o.unit), _text(o.doc)))
        name = _text(lib.cf_solver_connector_law_name(i))
        out[name] = LawKind(i, name, _text(lib.cf_solver_connector_law_doc(i)), tuple(values))
    return out


#: The kinds of law by name, in the registry's order.
LAW_KINDS: dict[str, LawKind] = _kinds()
