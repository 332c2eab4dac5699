"""The paper's natural-record checks: Fig. 10 (pycolfrag.record_figures) and Table II
(pycolfrag.records.table_ii), and the serial suite runner they use (pycolfrag.sample.run_suite)."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from scipy import optimize

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402

from pycolfrag import record_figures as rf  # noqa: E402
from pycolfrag import records, sample  # noqa: E402
from pycolfrag.errors import ParameterError  # noqa: E402


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    return records.load_records(rs.write_suite(tmp_path_factory.mktemp("suite")))


@pytest.fixture(scope="module")
def table(suite):
    return sample.run_suite(suite, components=("h1", "h2"), scales=(1.0,))


def test_run_suite_rows(table):
    """3 two-component records x (h1, h2) = 6 rows, in record order, each with its own IMs."""
    assert table["record_id"] == ["RSN9001", "RSN9001", "RSN9002", "RSN9002", "RSN9003", "RSN9003"]
    assert table["component"] == ["h1", "h2"] * 3
    assert np.all(table["status"] == 0)
    np.testing.assert_allclose(table["pga_g"][:4], [0.30, 0.20, 0.40, 0.20], rtol=1e-7)   # closed form
    assert table["sa_g"].shape == (6, len(sample.DEFAULT_PERIODS_S))


def _synthetic():
    # mean u_top at R = 20 km: Mw 5.5 -> (0.1 + 0.3) / 2, 6.5 -> (0.5 + 0.7) / 2 (0.9 collapsed: left out)
    return {"mw": np.array([5.5, 5.5, 5.5, 6.5, 6.5, 6.5, 6.5]),
            "dist_km": np.array([20, 20, 10, 20, 20, 20, 10.0]),
            "u_top": np.array([0.1, 0.3, 5.0, 0.5, 0.7, 0.9, 5.0]),
            "collapsed": np.array([0, 0, 0, 0, 0, 1, 0]), "status": np.zeros(7, dtype=int)}


def test_fig_10_points_and_line(table):
    """Points: the components of the records with Rrup in 15-25 km (RSN9001 at 20, RSN9002 at 16;
    RSN9003 at 42 km is out), at their Mw and u_top; the line: the synthetic means at R = 20 km."""
    fig = rf.fig_10(table, _synthetic())
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    h1 = lines["natural records, h1"]
    np.testing.assert_array_equal(h1.get_xdata(), [6.5, 7.0])
    np.testing.assert_array_equal(h1.get_ydata(), table["u_top"][[0, 2]])
    assert len(lines["natural records, h2"].get_xdata()) == 2
    syn = lines["synthetic, mean u_top at R = 20 km"]
    np.testing.assert_allclose(syn.get_ydata(), [0.2, 0.6])
    assert "4 components from 2 records" in ax.get_title()
    with pytest.raises(ParameterError, match="no runs at R = 17.5 km"):
        rf.fig_10(table, _synthetic(), dist_km=17.5)


def test_fig_10_from_a_results_file(table, tmp_path):
    """The synthetic line from an HDF5 file in the documented /samples layout (figures.read_results)."""
    import h5py
    s = _synthetic()
    with h5py.File(tmp_path / "g.h5", "w") as f:
        for k, v in s.items():
            f.create_dataset(f"samples/{k}", data=v)
        f.create_dataset("samples/u_d", data=np.zeros(7))
    mws, mean = rf.synthetic_mean_u_top(tmp_path / "g.h5")
    np.testing.assert_allclose(mean, [0.2, 0.6])


def test_strong_motion_end_of_the_pulse(suite):
    """One sine cycle a = Ap sin(2 pi t) on [0, 1] s: the Husid fraction is t - sin(4 pi t) / (4 pi),
    so the end of D5-95 solves t - sin(4 pi t)/(4 pi) = 0.95. Tolerance 2e-3 s: the Husid integral is
    trapezoidal and interpolated linearly between samples 0.005 s apart."""
    t95 = optimize.brentq(lambda t: t - math.sin(4 * math.pi * t) / (4 * math.pi) - 0.95, 0.5, 1.0)
    r = suite["RSN9002"]
    assert records.strong_motion_end(r.h1, r.dt) == pytest.approx(t95, abs=2e-3)


def test_table_ii_procedure(suite):
    """Damping starts at the end of D5-95; the ensemble is 1 -/+ 1e-4; error = (no - with) / with.
    With damping_alpha = 0 the two runs are the same run, so the errors are exactly 0 -- which fails
    if the damped run were not the undamped one plus damping."""
    sub = suite[1:2]                                              # the pulse record, 4 s
    rows = records.table_ii(sub, n_ensemble=3, solver_options={"tail_s": 1.0, "residual_window_s": 0.5})
    r = rows[0]
    assert r["record_id"] == "RSN9002" and r["scales"] == [1 - 1e-4, 1.0, 1 + 1e-4]
    assert r["t_strong_end_s"] == records.strong_motion_end(sub[0].h1, sub[0].dt)
    assert r["damping_alpha"] == records.DEFAULT_TABLE_II_ALPHA
    assert r["u_d_undamped_min"] <= r["u_d_undamped"] <= r["u_d_undamped_max"]
    if math.isfinite(r["u_d_damped"]) and r["u_d_damped"] > 0:
        assert r["error_pct"] == pytest.approx(100 * (r["u_d_undamped"] - r["u_d_damped"]) / r["u_d_damped"])
    zero = records.table_ii(sub, damping_alpha=0.0, n_ensemble=1, solver_options={"tail_s": 1.0,
                                                                                 "residual_window_s": 0.5})[0]
    assert zero["u_d_damped"] == zero["u_d_undamped"]
    assert "error" in records.format_table_ii(rows)
    with pytest.raises(ParameterError, match="sets damping_start_s itself"):
        records.table_ii(sub, solver_options={"damping_start_s": 1.0})


def test_table_ii_passes_the_damping_switch(suite, monkeypatch):
    """The damped run gets damping_alpha and damping_start_s = end of D5-95; the undamped run neither."""
    from pycolfrag import solver
    calls = []
    real = solver.simulate

    def spy(col, acc, dt, **kw):
        calls.append(kw)
        return real(col, acc, dt, **kw)

    monkeypatch.setattr(solver, "simulate", spy)
    sub = suite[1:2]
    records.table_ii(sub, n_ensemble=1, damping_alpha=3.0, solver_options={"tail_s": 0.5, "residual_window_s": 0.2})
    t95 = records.strong_motion_end(sub[0].h1, sub[0].dt)
    assert [("damping_alpha" in c) for c in calls] == [False, True]
    assert calls[1]["damping_alpha"] == 3.0 and calls[1]["damping_start_s"] == t95


def test_record_checks_script(tmp_path, capsys):
    """scripts/record_checks.py: fig10 writes the figure and the run table; table2 prints the table."""
    import importlib.util
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "scripts" / "record_checks.py"
    spec = importlib.util.spec_from_file_location("record_checks", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["demo-suite", str(tmp_path / "suite")]) == 0
    folder = tmp_path / "suite"
    assert mod.main(["fig10", "--records", str(folder), "--out", str(tmp_path / "out"), "--max-record-s", "1"]) == 0
    assert (tmp_path / "out" / "fig10_records.png").exists()
    t = np.load(tmp_path / "out" / "fig10_suite.npz")
    assert list(t["record_id"]) == ["RSN9001", "RSN9001", "RSN9002", "RSN9002"]   # RSN9003 (42 km) is out
    assert mod.main(["table2", "--records", str(folder / "suite.csv"), "--ids", "RSN9002", "--ensemble", "1"]) == 0
    assert "RSN9002" in capsys.readouterr().out
