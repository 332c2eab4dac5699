"""The registry of connector laws (csrc/solver_connector_law.c): the kinds of shear law, their names,
docs and own values are C's, and Python (pycolfrag/structure/connector_laws.py, DowelLaw) takes them from there,
so that a new law is its C file and one registry line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib
from pycolfrag.structure import connector_laws
from pycolfrag.structure.connectors import KINDS, LAWS, DowelLaw


def test_the_kinds_are_the_c_registry():
    """KINDS and LAW_KINDS list C's laws in its order, with C's docs and each law's own values (the
    clearance law: its initial clearance, m, default 0; the elastoplastic law: none)."""
    names = [ffi.string(lib.cf_solver_connector_law_name(i)).decode() for i in range(lib.cf_solver_connector_law_count())]
    assert KINDS == {n: i for i, n in enumerate(names)}
    assert names[:2] == ["elastoplastic", "clearance"]
    assert (KINDS["elastoplastic"], KINDS["clearance"]) == (lib.CF_SOLVER_CONNECTOR_ELASTOPLASTIC,
                                                            lib.CF_SOLVER_CONNECTOR_CLEARANCE)
    kinds = connector_laws.LAW_KINDS
    assert all(k.doc for k in kinds.values())
    assert kinds["elastoplastic"].values == ()
    (c,) = kinds["clearance"].values
    assert (c.name, c.default, c.unit) == ("clearance", 0.0, "m") and c.doc
    assert lib.cf_solver_connector_law_name(len(names)) == ffi.NULL
    assert lib.cf_solver_connector_law_value(0, 0) == ffi.NULL


def test_a_law_s_own_values_travel_in_its_order():
    """A clearance law's clearance is law[0] of the C connector and reads back as an attribute; its
    table round-trips through to_dict / from_dict (the default clearance left out, as before)."""
    lw = DowelLaw("clearance", k_shear=2e6, f_yield=3e3, u_ultimate=0.01, clearance=1e-3, k_axial=1e7)
    c = ffi.new("cf_solver_connector *")
    lw.fill(c)
    assert c.kind == KINDS["clearance"] and c.law[0] == 1e-3 and list(c.law)[1:] == [0.0, 0.0, 0.0]
    assert lw.clearance == 1e-3 and lw.own == (1e-3,)
    assert DowelLaw.from_dict(lw.to_dict()) == lw
    assert "clearance" not in DowelLaw("clearance", k_shear=1e6).to_dict()
    with pytest.raises(AttributeError, match="no value 'clearance'"):
        _ = LAWS["titanium"].clearance


def test_a_value_of_another_law_is_refused_in_python_and_in_c():
    """The elastoplastic law has no clearance: DowelLaw names it; C refuses a nonzero law[0] for it."""
    with pytest.raises(ParameterError, match="an elastoplastic connector has no clearance"):
        DowelLaw("elastoplastic", k_shear=1e7, clearance=1e-3)
    c = ffi.new("cf_solver_connector *")
    LAWS["titanium"].fill(c)
    c.law[0] = 1e-3
    msg = ffi.new("char[]", 256)
    assert lib.cf_solver_connectors_check(c, msg) == lib.CF_EINVAL
    assert "elastoplastic law has no value law[0]" in ffi.string(msg).decode()
    c.law[0] = 0.0
    c.kind = lib.cf_solver_connector_law_count()
    assert lib.cf_solver_connectors_check(c, msg) == lib.CF_EINVAL
    assert "a law of the registry" in ffi.string(msg).decode()


def test_the_yield_displacement_is_the_law_s_own():
    """u_yield from C: F_y / k (elastoplastic), F_y / k + the clearance (clearance), inf without
    stiffness; the drive of the wood law starts to crush there (its first yielded sample)."""
    assert LAWS["titanium"].u_yield == 5e4 / 5e7
    assert LAWS["wood"].u_yield == 1e4 / 5e6 + 0.002
    assert math.isinf(DowelLaw("clearance", k_shear=0.0, clearance=1e-3).u_yield)
    u = np.zeros((100, 3))
    u[:, 0] = np.linspace(0.0, 0.01, 100)
    state = LAWS["wood"].drive(u)["state"]
    assert u[np.argmax(state == 1), 0] > LAWS["wood"].u_yield > u[np.argmax(state == 1) - 1, 0]
