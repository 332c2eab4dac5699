"""pycolfrag.solver.sample: one definition of a sample row, for synthetic scenarios and natural records."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402
from pycolfrag.core import names
from pycolfrag.ground_motion import Record  # noqa: E402
from pycolfrag.ground_motion import record_suites as records
from pycolfrag.solver import sample  # noqa: E402
from pycolfrag.structure.column import Column  # noqa: E402


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    return records.load_records(rs.write_suite(tmp_path_factory.mktemp("suite")))


def test_synthetic_sample_equals_the_grid_row():
    """run_synthetic_sample is the grid's sample: every field of grid.run_sample's row, bit for bit
    (same record, same IMs, same solver call), apart from the grid's bookkeeping and the wall time."""
    from pycolfrag import grid
    spec = grid.GridSpec(mw=(6.5,), dist_km=(10.0,), samples=2, max_record_s=2.0)
    ctx = grid.SampleContext(spec)
    a = grid.run_sample(ctx, 1)
    sc, k, mw, dist = ctx.locate(1)
    b = sample.run_synthetic_sample(ctx.column, mw, dist, ctx.hf_seed(sc, k), ctx.pulse(sc, k),
                                    record_dt_s=spec.record_dt_s, vp_scale=spec.vp_scale, periods_s=spec.periods_s,
                                    damping=spec.damping, solver_options=spec.solver_options,
                                    max_record_s=spec.max_record_s)
    assert set(a) - set(b) == {"row", "scenario", "sample"} and set(b) <= set(a)
    for key, va in a.items():
        if key in ("row", "scenario", "sample", "wall_s"):
            continue
        np.testing.assert_array_equal(np.asarray(va), np.asarray(b[key]), err_msg=key)
    assert a["status"] == 0


def _bits(x):
    """Every bit of a row's or a record's value (floats and arrays by their bytes)."""
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    return (np.asarray(x).dtype.str, np.asarray(x).tobytes()) if isinstance(x, (float, np.ndarray)) else x


@pytest.mark.parametrize("shape", ["mp03", None])
def test_a_prepared_scenario_gives_synthesize_record(shape):
    """A scenario prepared once (ground_motion.synthesis: what the grid's rows reuse) gives, record by
    record, bitwise the record of synthesize with the row's pulse (stochastic without a pulse): acc,
    meta and components."""
    from pycolfrag import ground_motion as gm
    from pycolfrag.ground_motion import synthesis
    synth = synthesis.prepare(6.5, 10.0, 0.005, 1.2, shape)
    table = gm.sample_pulse_parameters(6.5, 10.0, 2, 5, vp_scale=1.2)
    for k, seed in enumerate((3, 2**40)):
        row = {name: v[k] for name, v in table.items()}
        mine = synth.record(*gm._checked_row(synth, seed, row)[:2])
        theirs = gm.synthesize(6.5, 10.0, seed, vp_scale=1.2, pulse=row) if shape else gm.stochastic(6.5, 10.0, seed)
        assert _bits(mine.acc) == _bits(theirs.acc) and mine.dt == theirs.dt
        assert _bits(mine.meta) == _bits(theirs.meta)
        assert _bits(mine.components) == _bits(theirs.components)


def test_the_grid_chunks_on_one_context_equal_a_fresh_context():
    """A rank's chunks reuse what every row shares (the column's C set-up, the scenario's synthesis): the
    rows of its later chunks are bitwise those of the same rows run first on a fresh context."""
    from pycolfrag import grid
    spec = grid.GridSpec(mw=(6.5, 7.5), dist_km=(5.0,), samples=3, max_record_s=3.0, vp_scale=2.0)
    ctx = grid.SampleContext(spec)
    rows = [r for i in range(0, 6, 2) for r in grid.run_samples(ctx, [i, i + 1])]
    fresh = grid.run_samples(grid.SampleContext(spec), [4, 5])
    for a, b in zip(rows[4:], fresh):
        a.pop("wall_s"), b.pop("wall_s")
        assert _bits(a) == _bits(b) and a["status"] == 0


def test_record_sample_row(suite):
    """A scaled natural record: metadata of the row, IMs of the scaled motion (PGA = scale x 0.40 g,
    the pulse's closed-form amplitude; 1e-7 = the AT2 file's 8 digits), EDPs from the solver."""
    col = Column.parthenon()
    row = sample.run_record_sample(suite["RSN9002"], column=col, component="h1", scale=0.5)
    assert row["status"] == 0, row["message"]
    assert (row["record_id"], row["event"], row["station"], row["component"]) == \
        ("RSN9002", "Pulse Quake", "Station B_ North", "h1")
    assert (row["mw"], row["rrup_km"], row["dist_km"], row["scale"], row["tp_s"]) == (7.0, 16.0, 16.0, 0.5, 1.0)
    assert row["pga_g"] == pytest.approx(0.5 * 0.40, rel=1e-7)
    for name, q in names.IMS.items():
        assert name in row and (np.shape(row[name]) == (len(sample.DEFAULT_PERIODS_S),) if q.spectral
                                else np.isfinite(row[name]))
    for name in list(names.EDPS) + list(names.RECORD_FIELDS):
        assert name in row
    assert math.isfinite(row["u_top"]) and row["u_top"] >= 0


def test_record_sample_components(suite):
    """h2 runs the second file; both drives x and y, and its IMs are the geometric mean of the two
    components' (PGA sqrt(0.40 x 0.20) g for the pulse record)."""
    col = Column.parthenon()
    h2 = sample.run_record_sample(suite["RSN9002"], column=col, component="h2")
    assert h2["pga_g"] == pytest.approx(0.20, rel=1e-7)
    both = sample.run_record_sample(suite["RSN9002"], column=col, component="both", max_record_s=2.0)
    assert both["status"] == 0, both["message"]
    assert both["pga_g"] == pytest.approx(math.sqrt(0.40 * 0.20), rel=1e-7)
    assert both["record_s"] == pytest.approx(401 * 0.005)


def test_record_sample_failures_are_rows(suite):
    """A bad choice or a failing solver gives a row with the phase's status, never an exception."""
    col = Column.parthenon()
    bad = sample.run_record_sample(suite["RSN9002"], column=col, component="x")
    assert bad["status"] == sample.STATUS["record"] and "component must be one of" in bad["message"]
    bad = sample.run_record_sample(suite["RSN9002"], column=col, scale=-1.0)
    assert bad["status"] == sample.STATUS["record"] and "scale must be finite and > 0" in bad["message"]
    one = Record(np.zeros(10), 0.01, record_id="ONE")
    bad = sample.run_record_sample(one, column=col, component="both")
    assert bad["status"] == sample.STATUS["record"] and "has no h2 component" in bad["message"]
    bad = sample.run_record_sample(suite["RSN9002"], column=col, solver_options={"contact": "glue"})
    assert bad["status"] == sample.STATUS["solver"] and "contact must be one of" in bad["message"]
    assert bad["pga_g"] == pytest.approx(0.40, rel=1e-7)      # the IMs before the failure are kept


def test_record_jobs_order_and_checks():
    """Record-major, then component, then scale; a one-component record gets no h2/both rows."""
    two = Record(np.zeros(5), 0.01, h2=np.zeros(5), record_id="TWO")
    one = Record(np.zeros(5), 0.01, record_id="ONE")
    jobs = sample.record_jobs(records.RecordSet([two, one]), ("h1", "h2"), (0.5, 2.0))
    assert jobs == [(0, "h1", 0.5), (0, "h1", 2.0), (0, "h2", 0.5), (0, "h2", 2.0), (1, "h1", 0.5), (1, "h1", 2.0)]
    with pytest.raises(Exception, match="scales must be distinct"):
        sample.record_jobs(records.RecordSet([two]), ("h1",), (1.0, 1.0))
    with pytest.raises(Exception, match="component must be one of"):
        sample.record_jobs(records.RecordSet([two]), ("x",), (1.0,))
