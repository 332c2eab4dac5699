"""Runs in SIMD lanes (pycolfrag.solver.run.simulate_batch, csrc/solver_batch.c) against the single run.

The reference of every test here is :func:`pycolfrag.simulate` on the same record and options (the
single-run path, validated on its own by test_solver.py and test_solver_physics.py): a batch must give
each run *bitwise* its result -- EDPs, step count, collapse, residual dislocations, every history --
whatever the width (runs side by side) and the position of the run in the batch, so the tolerance is
zero. The records make lanes finish at different steps (different lengths, a collapse with early exit,
a run at rest), so lanes are refilled mid-batch.
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import pycolfrag as pcf  # noqa: E402
import record_suite as rs  # noqa: E402
from pycolfrag import grid
from pycolfrag.core.errors import ParameterError, SolverError  # noqa: E402
from pycolfrag.ground_motion import record_suites as records
from pycolfrag.solver import sample  # noqa: E402
from pycolfrag.solver.run import batch_width, simulate_batch  # noqa: E402

COL = pcf.Column.parthenon()
DT = 0.005


def _sine(amp_g, f_hz, dur_s, phase=0.0):
    t = np.arange(0.0, dur_s, DT)
    return amp_g * 9.81 * np.sin(2 * np.pi * f_hz * t + phase)


def _records():
    """Nine runs that end at different steps: rocking, sliding, a collapse (early exit), a run at rest
    early (a weak record), and two synthetic near-fault records of the default grid's kind."""
    recs = [dict(acc_x=_sine(a, f, d), dt=DT) for a, f, d in
            [(0.25, 2.0, 3.0), (0.05, 3.0, 1.0), (0.6, 1.0, 4.0), (0.35, 2.5, 2.0), (0.15, 1.5, 5.0),
             (0.45, 1.2, 2.5), (0.3, 4.0, 1.5)]]
    for mw, r, seed in [(7.0, 5.0, 3), (6.5, 10.0, 8)]:
        rec = pcf.ground_motion.synthesize(mw, r, seed=seed)
        recs.append(dict(acc_x=rec.acc[: int(6.0 / rec.dt)], dt=rec.dt))
    return recs


def _assert_same(a, b, what):
    """Every field of two Responses bitwise equal (NaN == NaN), histories included."""
    for key in ("u_top", "u_d", "collapsed", "collapse_block", "collapse_time", "collapse_reason", "n_steps", "t_end",
                "dt", "dt_crit", "energy_error", "energy_scale", "energy_warning", "at_rest_exit", "max_top_disp",
                "message", "options"):
        va, vb = getattr(a, key), getattr(b, key)
        if isinstance(va, float) and math.isnan(va):
            assert isinstance(vb, float) and math.isnan(vb), f"{what}: {key}"
        else:
            assert va == vb, f"{what}: {key} {va!r} != {vb!r}"
    np.testing.assert_array_equal(a.residual_dislocation, b.residual_dislocation, err_msg=f"{what}: residuals")
    if a.history is not None or b.history is not None:
        for key in ("t", "top_disp", "block_pos", "block_quat", "joint_opening", "joint_slip", "joint_normal_force"):
            np.testing.assert_array_equal(getattr(a.history, key), getattr(b.history, key), err_msg=f"{what}: {key}")
        for key in a.history.energy:
            np.testing.assert_array_equal(a.history.energy[key], b.history.energy[key], err_msg=f"{what}: {key}")


@pytest.fixture(scope="module")
def singles():
    return [pcf.simulate(COL, r["acc_x"], r["dt"], history=True) for r in _records()]


WIDTHS = [w for w in (1, 2, 4, 8) if w <= batch_width(COL)]


@pytest.mark.parametrize("width", WIDTHS)
def test_batch_equals_single_runs(singles, width):
    """Default options (vertex contacts, early exit): each run of a batch of nine, at every width this
    CPU runs, is bitwise its single run; one collapses, the others end at other steps."""
    assert sum(r.collapsed for r in singles) >= 1 and len({r.n_steps for r in singles}) >= 6
    batch = simulate_batch(COL, _records(), history=True, width=width)
    for i, (a, b) in enumerate(zip(batch, singles)):
        _assert_same(a, b, f"width {width}, run {i}")


@pytest.mark.parametrize("opts", [dict(contact="perimeter", points_per_edge=2), dict(planar=True),
                                  dict(monolithic=True), dict(contact="exact"), dict(early_exit=False, dt_factor=0.5),
                                  dict(damping_alpha=0.8, damping_start_s=1.0)])
def test_batch_equals_single_runs_for_other_models(opts):
    """The other contact models and options: the same equality (the exact interface runs one after the
    other, width 1; the others in lanes)."""
    recs = [dict(acc_x=_sine(a, f, d), dt=DT) for a, f, d in [(0.3, 2.0, 1.5), (0.5, 1.0, 2.0), (0.1, 3.0, 1.0)]]
    single = [pcf.simulate(COL, r["acc_x"], r["dt"], **opts) for r in recs]
    for width in [w for w in (2, 4, 8) if w <= batch_width(COL, **opts)] or [1]:
        for i, (a, b) in enumerate(zip(simulate_batch(COL, recs, width=width, **opts), single)):
            _assert_same(a, b, f"{opts} width {width}, run {i}")


def test_two_component_batch_equals_single_runs():
    """Two horizontal components and a vertical one (acc_y, acc_z), as a record pair runs."""
    recs = [dict(acc_x=_sine(a, 2.0, 2.0), acc_y=_sine(0.7 * a, 1.3, 2.0, 0.4), acc_z=_sine(0.2 * a, 5.0, 2.0), dt=DT)
            for a in (0.2, 0.4, 0.3, 0.5, 0.25)]
    single = [pcf.simulate(COL, r["acc_x"], r["dt"], acc_y=r["acc_y"], acc_z=r["acc_z"]) for r in recs]
    for i, (a, b) in enumerate(zip(simulate_batch(COL, recs), single)):
        _assert_same(a, b, f"two components, run {i}")


def test_a_record_runs_as_its_arrays():
    """A Record (its acc along x, h2 along y, v vertical, at its dt) is a run of simulate and an entry of
    simulate_batch: bitwise the run of its arrays. Given with a dt or components besides, it is refused:
    the Record carries them."""
    from pycolfrag.ground_motion import Record
    x, y, z = _sine(0.3, 2.0, 2.0), _sine(0.2, 1.3, 2.0, 0.4), _sine(0.1, 5.0, 2.0)
    rec = Record(x, DT, h2=y, v=z)
    ref = pcf.simulate(COL, x, DT, acc_y=y, acc_z=z)
    _assert_same(pcf.simulate(COL, rec), ref, "simulate(col, Record)")
    for i, r in enumerate(simulate_batch(COL, [rec, (x, DT, y, z), rec])):
        _assert_same(r, ref, f"batch entry {i}")
    with pytest.raises(ParameterError, match="a Record carries its step and components"):
        pcf.simulate(COL, rec, DT)
    with pytest.raises(ParameterError, match="exceeds 100 m/s\\^2"):      # the solver's range, for a Record too
        pcf.simulate(COL, Record(200.0 * np.ones(10), DT))


def test_batch_errors_are_those_of_simulate():
    """A bad record fails its own run with simulate's exception and message; the others run."""
    recs = [(_sine(0.2, 2.0, 1.0), DT), (np.array([1.0, np.nan]), DT), (_sine(0.2, 2.0, 1.0), DT, None, None)]
    out = simulate_batch(COL, recs, errors="return")
    with pytest.raises(ParameterError) as single:
        pcf.simulate(COL, np.array([1.0, np.nan]), DT)
    assert isinstance(out[1], ParameterError) and str(out[1]) == str(single.value)
    _assert_same(out[0], out[2], "runs around a failed one")
    with pytest.raises(ParameterError, match="non-finite"):
        simulate_batch(COL, recs)
    with pytest.raises(ParameterError, match="width must be 1, 2, 4 or 8"):
        simulate_batch(COL, recs[:1], width=3)
    with pytest.raises(ParameterError, match="errors must be"):
        simulate_batch(COL, recs[:1], errors="ignore")
    with pytest.raises(ParameterError, match=r"records\[0\] must be a Record, a dict"):
        simulate_batch(COL, [np.zeros(3)])
    # an unstable run (a step far beyond the stability limit) fails alone, as simulate's SolverError
    with pytest.warns(pcf.solver.run.StepWarning):
        bad = simulate_batch(COL, [(_sine(0.3, 2.0, 1.0), DT)] * 5, dt_solver=5e-3, errors="return")
    with pytest.raises(SolverError) as single:
        with pytest.warns(pcf.solver.run.StepWarning):
            pcf.simulate(COL, _sine(0.3, 2.0, 1.0), DT, dt_solver=5e-3)
    assert all(isinstance(b, SolverError) and str(b) == str(single.value) for b in bad)


def test_default_width_pays():
    """The default width for n runs: 1 for one or two runs (a batch with idle lanes is slower than the
    runs one after the other), the widest lanes from five runs on (docs/performance.md)."""
    widest = batch_width(COL)
    assert batch_width(COL, n_runs=1) == 1 and batch_width(COL, n_runs=2) == 1
    assert batch_width(COL, n_runs=64) == (widest if widest >= 4 else 1)
    assert batch_width(COL, contact="exact") == 1


@pytest.mark.parametrize("pulse", ["mp03", "none"])
def test_grid_rows_in_a_batch_equal_rows_one_by_one(pulse):
    """grid.run_samples (the grid's chunk, runs side by side) gives every row of grid.run_sample bit for
    bit (apart from wall_s), with pulses and without (--pulse none)."""
    spec = grid.GridSpec(mw=(7.5, 6.0), dist_km=(5.0,), samples=4, max_record_s=3.0, pulse=pulse)
    ctx = grid.SampleContext(spec)
    rows = list(range(spec.n_rows))
    batch = grid.run_samples(ctx, rows)
    for row, b in zip(rows, batch):
        a = grid.run_sample(ctx, row)
        assert set(a) == set(b)
        for key in a:
            if key != "wall_s":
                np.testing.assert_array_equal(np.asarray(a[key]), np.asarray(b[key]), err_msg=f"row {row} {key}")
        assert b["wall_s"] > 0


# an explicit step above the stability limit (0.001001 s for this column): every run warns (StepWarning,
# kept in the row's message), and the message must be the row's own run's, as when it runs alone
@pytest.mark.parametrize("solver_options", [None, {"dt_solver": 0.00105}])
def test_record_rows_in_a_batch_equal_rows_one_by_one(tmp_path, solver_options):
    """sample.run_record_samples (record suites: h1, h2 and the two-component pair, scaled) gives every
    row of run_record_sample bit for bit (apart from wall_s), a missing component failing alone."""
    suite = records.load_records(rs.write_suite(tmp_path))
    jobs = [(suite[k], c, f) for k in range(len(suite)) for c in ("h1", "both") for f in (0.5, 2.0)]
    jobs.append((suite[0], "bad", 1.0))
    batch = sample.run_record_samples(jobs, column=COL, max_record_s=3.0, solver_options=solver_options)
    if solver_options:
        assert all(b["message"].startswith(("StepWarning: simulate: ", "SolverError")) for b in batch[:-1])
    for (rec, c, f), b in zip(jobs, batch):
        a = sample.run_record_sample(rec, column=COL, component=c, scale=f, max_record_s=3.0,
                                     solver_options=solver_options)
        assert set(a) == set(b)
        for key in a:
            if key != "wall_s":
                np.testing.assert_array_equal(np.asarray(a[key]), np.asarray(b[key]), err_msg=f"{c} {f} {key}")
    assert batch[-1]["status"] == sample.STATUS["record"]
