"""Sleeping joints (option ``sleep``, csrc/solver_sleep.h; docs/performance.md, "Sleeping joints").

A joint whose points all stick with a margin takes its linear law until a bound on its motion says a
point could open, slip or leave the face; the law is the full law in exact arithmetic, so sleeping
changes results by round-off only. Here: the options refused by name; with sleeping on, a batch gives
each run bitwise its run alone at every width (the tolerance of test_batch.py: zero), a continued run is
the long run bitwise (test_sequences.py's), the energy balance holds as tightly as without sleeping, a
firmly closed column's response is the full law's to round-off, and the exact model reads no such
option (sleeping does not apply to it: the same bits). tests/c/test_sleep.c counts the joint-steps
taken asleep and holds the Housner block's lift-off threshold.
"""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import pycolfrag as pcf  # noqa: E402
import test_batch as tb  # noqa: E402
import test_sequences as seq  # noqa: E402
from pycolfrag.core.errors import ParameterError  # noqa: E402
from pycolfrag.solver.run import batch_width, simulate_batch  # noqa: E402

COL = pcf.Column.parthenon()


@pytest.mark.parametrize("value", [-0.1, 0.0, 1.0, 1.5, float("nan"), float("inf")])
def test_sleep_margin_out_of_range_is_refused_by_name(value):
    with pytest.raises(ParameterError, match="sleep_margin must be"):
        pcf.SolverOptions(sleep_margin=value)
    with pytest.raises(ParameterError, match="sleep_margin"):
        pcf.simulate(COL, np.zeros(4), 0.01, sleep=True, sleep_margin=value)


@pytest.mark.parametrize("value", [2, -1, 0.5])
def test_sleep_must_be_a_flag(value):
    with pytest.raises(ParameterError, match="sleep must be True or False"):
        pcf.SolverOptions(sleep=value)


def test_exact_model_reads_no_such_option():
    acc = tb._sine(0.3, 2.0, 1.5)
    a = pcf.simulate(COL, acc, tb.DT, contact="exact", tail_s=0.5, sleep=False)
    b = pcf.simulate(COL, acc, tb.DT, contact="exact", tail_s=0.5, sleep=True)
    assert (a.u_top, a.u_d, a.n_steps, a.energy_error) == (b.u_top, b.u_d, b.n_steps, b.energy_error)


@pytest.mark.parametrize("opts", [dict(sleep=True), dict(sleep=True, sleep_margin=0.1),
                                  dict(sleep=True, contact="perimeter", points_per_edge=2)])
def test_batch_equals_single_runs_with_sleeping(opts):
    """test_batch.py's nine records (rocking, sliding, a collapse, a run at rest, near-fault records):
    with sleeping on, every run of the batch at every width is bitwise its run alone."""
    recs = tb._records()
    single = [pcf.simulate(COL, r["acc_x"], r["dt"], history=True, **opts) for r in recs]
    for width in [w for w in (1, 2, 4, 8) if w <= batch_width(COL, **opts)]:
        for i, (a, b) in enumerate(zip(simulate_batch(COL, recs, history=True, width=width, **opts), single)):
            tb._assert_same(a, b, f"{opts} width {width}, run {i}")


def test_two_component_batch_equals_single_runs_with_sleeping():
    recs = [dict(acc_x=tb._sine(a, 2.0, 2.0), acc_y=tb._sine(0.7 * a, 1.3, 2.0, 0.4), acc_z=tb._sine(0.2 * a, 5.0, 2.0),
                 dt=tb.DT) for a in (0.02, 0.4, 0.1, 0.5, 0.25)]
    single = [pcf.simulate(COL, r["acc_x"], r["dt"], acc_y=r["acc_y"], acc_z=r["acc_z"], sleep=True) for r in recs]
    for i, (a, b) in enumerate(zip(simulate_batch(COL, recs, sleep=True), single)):
        tb._assert_same(a, b, f"two components, run {i}")


def test_continuation_is_the_long_run_bitwise_with_sleeping():
    """The sleep state is in the model's state (CF_SLEEP_ND = 53 doubles a joint): a run continued from
    record 1's state equals the long run, bit for bit; the state carries them (its length)."""
    r1, r2, rl = seq._sequence(COL, early_exit=False, tail_s=0.5, sleep=True)
    assert r1.u_top > 0.01
    seq._assert_bitwise(r1, r2, rl)
    off = pcf.simulate(COL, np.zeros(2), 0.01, early_exit=False, tail_s=0.1, sleep=False).final_state
    assert r1.final_state.values.size == off.values.size + 53 * COL.n_blocks
    with pytest.raises(ParameterError, match="the state belongs to another solver"):   # the other setting: refused
        pcf.simulate(COL, np.zeros(2), 0.01, initial_state=off, sleep=True)


def test_weak_motion_is_the_full_law_to_round_off_and_balances_energy():
    """A 0.02 g sine keeps every joint closed and sticking: with sleeping on (asleep most of the steps,
    tests/c/test_sleep.c) the top's history is the full law's within 1e-9 of its peak (the sleeping law
    is the full law in exact arithmetic: measured 2e-14) but not bitwise (the sleeping law was taken),
    and the energy balance error is the same to 1e-6 of the energy scale."""
    acc = tb._sine(0.02, 2.0, 4.0)
    a = pcf.simulate(COL, acc, tb.DT, history=True, sleep=False)
    b = pcf.simulate(COL, acc, tb.DT, history=True, sleep=True)
    ua, ub = a.history.top_disp[:, 0], b.history.top_disp[:, 0]
    peak = np.abs(ua).max()
    assert peak > 1e-4
    assert np.abs(ua - ub).max() <= 1e-9 * peak
    assert not np.array_equal(ua, ub)
    assert abs(a.energy_error - b.energy_error) <= 1e-6


@pytest.mark.parametrize("amp_g", [0.25, 0.6])
def test_strong_motion_energy_balance_as_good_with_sleeping(amp_g):
    """Rocking and impacts wake the joints and they fall asleep again: the energy balance error with
    sleeping on stays within the energy_tolerance (0.05) as the run without it does."""
    acc = tb._sine(amp_g, 2.0, 3.0)
    a = pcf.simulate(COL, acc, tb.DT, early_exit=False, tail_s=1.0, sleep=False)
    b = pcf.simulate(COL, acc, tb.DT, early_exit=False, tail_s=1.0, sleep=True)
    assert abs(a.energy_error) < 0.05 and abs(b.energy_error) < 0.05
    assert not b.energy_warning


def test_slip_wakes_the_joint_at_the_coulomb_threshold():
    """A squat block (2 m x 2 m x 0.5 m, mu = tan 37 deg: rocking would need 4 g) under a slow ramp of
    ground acceleration, a(t) = g t / 4 s, slips when a = mu g (quasi-statics: m a = mu m g). With
    sleeping on the joint sleeps through the ramp's sticking part and must wake before any point
    reaches the cap: the slip (beyond 2e-5 m, twice the elastic shear displacement mu W / (ks A) =
    1e-5 m) starts at the same history sample (1 ms) as without sleeping, within 2 % of a = mu g (the
    ramp's dynamics and the threshold: 0.9 % measured), and the final slip agrees to 1e-9 relative
    (round-off only) without being bitwise the same (the sleeping law was taken)."""
    col = pcf.Column.single_block(2.0, 0.5, n_sides=4, joints=pcf.JointProperties(friction_deg=37.0))
    mu, dt, T = np.tan(np.radians(37.0)), 0.01, 4.0
    acc = 9.81 * np.arange(0.0, T, dt) / T
    onset, final = [], []
    for sleep in (False, True):
        res = pcf.simulate(col, acc, dt, history=True, history_dt=0.001, tail_s=0.0, early_exit=False, sleep=sleep)
        x = res.history.block_pos[:, 0, 0] - res.history.block_pos[0, 0, 0]
        i = int(np.argmax(np.abs(x) > 2e-5))
        assert i > 0
        onset.append(i)
        final.append(x[-1])
        assert res.history.t[i] / T / mu == pytest.approx(1.0, abs=0.02)
    assert onset[0] == onset[1]
    assert final[1] == pytest.approx(final[0], rel=1e-9) and final[1] != final[0]


def test_a_history_does_not_change_a_sleeping_run():
    """Joints try to fall asleep at the run's ledger steps only (every 4th), never at the history's
    samples or the run's last step: a run with a history (at an odd interval) is bitwise the run
    without one, and a continued run is the long run (test above)."""
    acc = tb._sine(0.25, 2.0, 3.0)
    a = pcf.simulate(COL, acc, tb.DT, sleep=True)
    b = pcf.simulate(COL, acc, tb.DT, sleep=True, history=True, history_dt=0.0037)
    # (the energy error is the balance's worst over the steps it is evaluated at: history samples too)
    assert (a.u_top, a.u_d, a.n_steps, a.max_top_disp) == (b.u_top, b.u_d, b.n_steps, b.max_top_disp)
    np.testing.assert_array_equal(a.residual_dislocation, b.residual_dislocation)
