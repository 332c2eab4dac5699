"""The state that carries over (docs/sequences.md): a run continued from the state at the end of
record 1 equals, bit for bit, one run over record 1, the same still ground, and record 2; states
save and load losslessly; a state of another model, contact model, version or code is refused."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.names import G
from pycolfrag.solver.state import State
from pycolfrag.structure.connectors import Connectors
from pycolfrag.structure.scene import Colonnade

DT = 0.01


def _records():
    """Two bursts at 0.01 s; record 1 ends on a zero sample (a single run drops the ground to zero
    after its last sample, the long record would ramp to its padding over one sample)."""
    t1 = np.arange(0.0, 2.0, DT)
    a1 = 0.3 * G * np.sin(2 * np.pi * 1.5 * t1)
    a1[-1] = 0.0
    t2 = np.arange(0.0, 1.5, DT)
    a2 = 0.25 * G * np.sin(2 * np.pi * 2.0 * t2 + 0.3)   # starts off zero: the ramp into it is tested
    return a1, a2


def _sequence(model, **opts):
    """(the run over record 1, the run continued from its state over record 2, the one long run)."""
    a1, a2 = _records()
    r1 = pcf.simulate(model, a1, DT, history=True, **opts)
    s = r1.final_state
    i0 = int(s.time / DT) + 2   # the continued record's first sample (solver_state.c, first_sample)
    long_rec = np.concatenate([a1, np.zeros(i0 - a1.size), a2])
    r2 = pcf.simulate(model, a2, DT, history=True, initial_state=s, **opts)
    rl = pcf.simulate(model, long_rec, DT, history=True, **opts)
    return r1, r2, rl


def _assert_bitwise(r1, r2, rl):
    np.testing.assert_array_equal(r2.final_state.values, rl.final_state.values)   # bodies, contacts, monitor
    for k in ("u_top", "u_d", "n_steps", "t_end", "max_top_disp", "energy_error"):
        assert getattr(r2, k) == getattr(rl, k), k
    np.testing.assert_array_equal(r2.residual_dislocation, rl.residual_dislocation)
    for k in ("t", "top_disp", "block_pos", "block_quat", "joint_slip", "joint_opening"):
        np.testing.assert_array_equal(np.concatenate([getattr(r1.history, k), getattr(r2.history, k)]),
                                      getattr(rl.history, k), err_msg=k)


@pytest.mark.parametrize("contact", ["vertex", "exact"])
def test_continuation_is_the_long_run_bitwise_default_column(contact):
    """The default column (early_exit off: a run that ends at rest before its tail's end leaves a
    state the long run never passes through)."""
    r1, r2, rl = _sequence(pcf.Column.parthenon(), contact=contact, early_exit=False, tail_s=0.5)
    assert r1.u_top > 0.01   # the column rocked in record 1: its state is not the rest state
    _assert_bitwise(r1, r2, rl)


def test_continuation_is_the_long_run_bitwise_dowelled_column():
    col = pcf.Column.parthenon().with_connectors(Connectors.of("titanium", "all"))
    r1, r2, rl = _sequence(col, early_exit=False, tail_s=0.3)
    assert r1.dowels["yielded"].any()   # the yield carries over
    _assert_bitwise(r1, r2, rl)
    for k in ("peak_shear", "peak_slip", "yielded", "broken", "dissipated"):
        np.testing.assert_array_equal(r2.dowels[k], rl.dowels[k], err_msg=k)


def test_continuation_is_the_long_run_bitwise_portal():
    r1, r2, rl = _sequence(Colonnade.portal(2), early_exit=False, tail_s=0.3)
    _assert_bitwise(r1, r2, rl)
    np.testing.assert_array_equal(r2.columns["u_top"], rl.columns["u_top"])
    assert r2.epistyle_slip_mm == rl.epistyle_slip_mm


@pytest.mark.parametrize("suffix", [".h5", ".json"])
def test_state_saves_and_loads_losslessly(tmp_path, suffix):
    a1, a2 = _records()
    col = pcf.Column.parthenon()
    s = pcf.simulate(col, a1, DT, early_exit=False, tail_s=0.2).final_state
    path = tmp_path / f"state{suffix}"
    s.save(path)
    back = State.load(path)
    np.testing.assert_array_equal(back.values, s.values)
    assert back.identity() == s.identity()
    assert back.bodies()["x"].shape == (col.n_blocks + 1, 3) and back.time == s.time
    direct = pcf.simulate(col, a2, DT, initial_state=s, early_exit=False, tail_s=0.2)
    loaded = pcf.simulate(col, a2, DT, initial_state=back, early_exit=False, tail_s=0.2)
    np.testing.assert_array_equal(loaded.final_state.values, direct.final_state.values)


def test_a_state_of_another_model_is_refused_naming_the_difference():
    a1, _ = _records()
    col = pcf.Column.parthenon()
    s = pcf.simulate(col, a1[:50], DT, tail_s=0.0).final_state
    other = col.with_joints(friction_deg=30.0)
    with pytest.raises(pcf.ParameterError, match="another model digest"):
        pcf.simulate(other, a1, DT, initial_state=s)
    with pytest.raises(pcf.ParameterError, match="another kind: 'column', this run's 'scene'"):
        pcf.simulate(Colonnade.portal(2), a1, DT, initial_state=s)
    with pytest.raises(pcf.ParameterError, match="another contact: 'vertex', this run's 'exact'"):
        pcf.simulate(col, a1, DT, initial_state=s, contact="exact")
    with pytest.raises(pcf.ParameterError, match="another version"):
        pcf.simulate(col, a1, DT, initial_state=dataclasses.replace(s, version="0.0.1"))
    with pytest.raises(pcf.ParameterError, match="another code digest"):
        pcf.simulate(col, a1, DT, initial_state=dataclasses.replace(s, code_digest="0" * 64))
    # the C library checks the shape and the step itself (a state edited past the Python checks)
    with pytest.raises(pcf.ParameterError, match="solver step dt"):
        pcf.simulate(col, a1, DT, initial_state=s, dt_factor=0.4)
    with pytest.raises(pcf.ParameterError, match="must be a State"):
        pcf.simulate(col, a1, DT, initial_state=s.values)


def test_a_collapsed_state_is_not_continued():
    """One long run stops at its collapse, so a state taken at a collapse has no continuation: refused by name
    (it used to go on simulating the fallen drums). A 1.5 g, 1 Hz sine topples the default column (its
    quasi-static threshold is about 0.15 g, tests/test_hard_cases.py)."""
    col = pcf.Column.parthenon()
    dt = 0.01
    t = np.arange(0.0, 6.0, dt)
    res = pcf.simulate(col, 1.5 * 9.81 * np.sin(2 * np.pi * t), dt)
    assert res.collapsed and res.final_state is not None and res.final_state.collapsed
    with pytest.raises(pcf.ParameterError, match="collapsed"):
        pcf.simulate(col, np.zeros(100), dt, initial_state=res.final_state)
