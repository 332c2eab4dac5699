"""The Monte Carlo grid driver (docs/grid.md): rank independence, resume after a kill, failed samples,
refused arguments, documented fields and attributes.

Runs start ``scripts/run_grid.py`` in child processes, as users do. ``mpirun`` children get an
environment without the ``PMIX_*``/``OMPI_*`` variables an MPI-initialised parent would leave
(with them a child ``mpirun`` exits 1 with no output), and this process never imports
``mpi4py.MPI``. Grids are tiny (a few scenarios, a few samples, records cut to a few seconds with
``--max-record-s``) to keep the file under a minute or two; ``tests/grid_fakes.py`` supplies the
injected sample functions.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.data import Results, load
from pycolfrag.grid import GridSpec, derive_seed
from pycolfrag.grid.command import _parse_values

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "run_grid.py"
TESTS = Path(__file__).resolve().parent
# a tiny grid: 2 Mw x 2 R x 3 samples = 12 rows, records cut to 4 s
SMALL = ["--mw", "6.0", "7.5", "--dist", "5", "15", "--samples", "3", "--max-record-s", "4",
         "--no-figures", "--no-progress"]
# (the default per-sample function: real records, IMs and solver)


def _env(**extra):
    env = {k: v for k, v in os.environ.items()
           if not (k.startswith("PMIX_") or k.startswith("OMPI_")) or k.startswith("OMPI_ALLOW_RUN_AS_ROOT")}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", PYTHONPATH=os.pathsep.join([str(TESTS), env.get("PYTHONPATH", "")]))
    env.update(extra)
    return env


def _serial(args, timeout=120, **env):
    cmd = ["timeout", "-k", "10", str(timeout), sys.executable, str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=_env(**env), cwd=ROOT)


def _mpirun(n, args, timeout=150, **env):
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    cmd = ["timeout", "-k", "10", str(timeout), "mpirun", "--allow-run-as-root", "-n", str(n),
           sys.executable, "-m", "mpi4py", str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=_env(**env), cwd=ROOT)


def _ok(proc):
    assert proc.returncode == 0, f"exit {proc.returncode}\nstdout:\n{proc.stdout}\nstderr:\n{proc.stderr}"
    return proc


def _same_rows(a: Results, b: Results, rows=None):
    """Every dataset equal (bitwise; NaN == NaN) except the timing field."""
    ia = np.arange(len(a)) if rows is None else np.searchsorted(a.rows, rows)
    ib = np.arange(len(b)) if rows is None else np.searchsorted(b.rows, rows)
    for k in a.samples:
        if k in R.TIMING_FIELDS:
            continue
        x, y = a.samples[k][ia], b.samples[k][ib]
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), k
    for k in a.spectra:
        assert np.array_equal(a.spectra[k][ia], b.spectra[k][ib], equal_nan=True), k


# ---------------------------------------------------------------------------------------------

def test_value_lists_and_ranges():
    assert _parse_values(["5.5:7.5:0.5"], "--mw") == (5.5, 6.0, 6.5, 7.0, 7.5)
    assert _parse_values(["5:20:2.5"], "--dist") == (5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0)
    assert _parse_values(["6", "7,7.5"], "--mw") == (6.0, 7.0, 7.5)
    with pytest.raises(ValueError):
        _parse_values(["6", "6.0"], "--mw")
    assert len(GridSpec().scenarios) == 35 and GridSpec().n_rows == 3500


def test_streams_depend_only_on_seed_scenario_sample():
    # the same key gives the same seed in any process; any changed part of the key changes it
    s = derive_seed(7, 2, 6500, 10000, 3)
    assert s == derive_seed(7, 2, 6500, 10000, 3)
    others = {derive_seed(8, 2, 6500, 10000, 3), derive_seed(7, 1, 6500, 10000, 3),
              derive_seed(7, 2, 7000, 10000, 3), derive_seed(7, 2, 6500, 12500, 3), derive_seed(7, 2, 6500, 10000, 4)}
    assert s not in others and len(others) == 5


@pytest.mark.mpi
def test_one_rank_and_two_ranks_give_identical_datasets(tmp_path):
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    _ok(_serial([*SMALL, "--out", str(one)]))
    p2 = _ok(_mpirun(2, [*SMALL, "--out", str(two)]))
    assert "on 2 ranks" in p2.stdout
    a, b = load(one), load(two)
    assert len(a) == len(b) == 12 and a.complete and b.complete
    assert (a.samples["status"] == 0).all(), a.samples["message"]
    _same_rows(a, b)
    assert a.attrs["n_ranks"] == 1 and b.attrs["n_ranks"] == 2
    for k in ("seed", "column", "solver", "grid_signature", "version"):
        assert a.attrs[k] == b.attrs[k], k
    # rows are ordered by (scenario, sample) whatever the order of computation
    assert list(a.samples["scenario"]) == [0] * 3 + [1] * 3 + [2] * 3 + [3] * 3
    assert list(a.samples["sample"]) == [0, 1, 2] * 4
    # every documented field and attribute (docs/architecture.md, docs/results_format.md) with h5py alone
    import h5py
    with h5py.File(two, "r") as f:
        required = ["mw", "dist_km", "scenario", "sample", "vp_cm_s", "fp_hz", "nu_rad", "gamma", "pga_g",
                    "pgv_cm_s", "u_top", "u_d", "collapsed", "status", "wall_s", "ap_g", "a_cm_s", "t0_s", "pgd_cm",
                    "arias_m_s", "d5_95_s", "n_steps", "t_end_s", "collapse_block", "collapse_time_s",
                    "energy_error", "message"]
        assert set(required) <= set(f["samples"]), set(required) - set(f["samples"])
        assert set(R.SAMPLE_FIELDS) == set(f["samples"])
        assert all(f["samples"][k].shape == (12,) for k in f["samples"])
        periods = f["spectra"].attrs["periods_s"]
        assert f["spectra/sa_g"].shape == f["spectra/sv_cm_s"].shape == (12, len(periods))
        for k in ("seed", "n_ranks", "version", "git_revision", "column", "solver", "created", "mw", "dist_km",
                  "samples", "vp_scale", "periods_s", "grid_signature", "format_version", "complete"):
            assert k in f.attrs, k
        json.loads(f.attrs["column"]), json.loads(f.attrs["solver"])
    assert not R.journal_path(two).exists()  # a complete run leaves no journal


def test_worker_gets_the_first_chunk_before_rank_0_computes(tmp_path):
    """Rank 0 answers the worker's first request before it takes rows of its own, so the head of the
    queue (the longest rows) goes to the worker, which would otherwise idle through rank 0's first
    batches. 12 rows on 2 ranks: every chunk is one row (a quarter of an equal share rounds down to 0,
    raised to 1), so the first row of the queue is the worker's whatever the rows take."""
    out = tmp_path / "ranked.h5"
    args = ["--mw", "6", "7.5", "--dist", "5", "15", "--samples", "3", "--sample-function", "grid_fakes:ranked",
            "--no-figures", "--no-progress", "--out", str(out)]
    _ok(_mpirun(2, args, PCF_FAKE_SLEEP_S="0.2"))
    res = load(out)
    first = GridSpec(mw=(6.0, 7.5), dist_km=(5.0, 15.0), samples=3).order(range(12))[0]
    by_row = dict(zip(res.samples["scenario"] * 3 + res.samples["sample"], res.samples["message"]))
    assert sorted(set(by_row.values())) == ["rank 0", "rank 1"]  # both ranks computed rows
    assert by_row[first] == "rank 1"


def _journal_rows(path):
    return len(R.read_journal(R.journal_path(path))[1]) if R.journal_path(path).exists() else 0


def _kill_after(cmd, env, out, rows, sig):
    """Start ``cmd``, send ``sig`` once the journal of ``out`` holds ``rows`` rows (or after 60 s)."""
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        t0 = time.time()
        while _journal_rows(out) < rows and time.time() - t0 < 60:
            time.sleep(0.05)
    finally:
        proc.send_signal(sig)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    # mpirun (and timeout) may exit while a draining rank still holds the file: a rerun then is refused as
    # "being written by another run" (tests/test_faults_grid.py); the user waits, and so does the test
    t0 = time.time()
    while R.lock_held(out) and time.time() - t0 < 60:
        time.sleep(0.05)


def test_killed_run_resumes_and_keeps_finished_rows(tmp_path):
    out = tmp_path / "kill.h5"
    args = ["--mw", "6", "7", "--dist", "5", "10", "15", "--samples", "8", "--sample-function", "grid_fakes:fake",
            "--no-figures", "--no-progress", "--flush-s", "0.2", "--out", str(out)]
    _kill_after([sys.executable, str(SCRIPT), *args], _env(PCF_FAKE_SLEEP_S="0.05"), out, 12, signal.SIGKILL)
    before = load(out)  # HDF5 + journal: every row that reached rank 0
    n_before = len(before)
    assert 12 <= n_before < 48, n_before
    assert R.journal_path(out).exists()
    # rerun the same command: computes only what is missing
    p = _ok(_serial(args, PCF_FAKE_SLEEP_S="0"))
    assert f"{n_before} of 48 rows already done, {48 - n_before} to compute" in p.stdout
    after = load(out)
    assert after.complete and len(after) == 48 and (after.samples["status"] == 0).all()
    pairs = set(zip(after.samples["scenario"].tolist(), after.samples["sample"].tolist()))
    assert len(pairs) == 48  # each (scenario, sample) exactly once
    _same_rows(before, after, rows=before.rows)
    # the rows kept from before the kill are the very same numbers, wall_s included
    idx = np.searchsorted(after.rows, before.rows)
    assert np.array_equal(before.samples["wall_s"], after.samples["wall_s"][idx])
    # and a fresh uninterrupted run agrees on every row
    fresh = tmp_path / "fresh.h5"
    _ok(_serial([*args[:-1], str(fresh)]))
    _same_rows(load(fresh), after)
    sessions = json.loads(after.attrs["sessions"])
    assert len(sessions) == 1 and sessions[0]["rows_computed"] == 48 - n_before  # the killed one never closed


@pytest.mark.mpi
def test_sigterm_under_mpirun_then_resume(tmp_path):
    out = tmp_path / "term.h5"
    args = ["--mw", "6", "7", "--dist", "5", "10", "--samples", "10", "--sample-function", "grid_fakes:fake",
            "--no-figures", "--no-progress", "--out", str(out)]
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed")
    cmd = ["timeout", "-k", "10", "120", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py",
           str(SCRIPT), *args]
    _kill_after(cmd, _env(PCF_FAKE_SLEEP_S="0.1"), out, 6, signal.SIGTERM)
    before = load(out)
    assert 6 <= len(before) < 40
    _ok(_mpirun(2, args, PCF_FAKE_SLEEP_S="0"))
    after = load(out)
    assert after.complete and len(after) == 40 and (after.samples["status"] == 0).all()
    _same_rows(before, after, rows=before.rows)


def test_failed_sample_is_recorded_and_the_others_complete(tmp_path):
    out = tmp_path / "fail.h5"
    p = _ok(_serial([*SMALL, "--sample-function", "grid_fakes:failing", "--out", str(out)], PCF_FAIL_ROWS="4"))
    r = load(out)
    assert len(r) == 12 and r.complete
    assert r.samples["status"][4] == R.STATUS_OTHER_FAILED
    assert "forced failure of row 4" in r.samples["message"][4]
    others = np.arange(12) != 4
    assert (r.samples["status"][others] == 0).all(), r.samples["message"][others]
    assert np.isfinite(r.samples["u_top"][others]).all()
    assert " 1 failed" in p.stdout


def test_bad_solver_options_are_refused_before_any_file_is_made(tmp_path):
    out = tmp_path / "bad.h5"
    base = ["--mw", "6", "--dist", "10", "--samples", "1", "--no-figures", "--no-progress", "--out", str(out)]
    p = _serial([*base, "--solver", "no_such_option_xyz=1"])
    assert p.returncode == 2 and "unknown solver option(s) ['no_such_option_xyz']" in p.stdout, p.stdout + p.stderr
    p = _serial([*base, "--contact", "glue"])
    assert p.returncode == 2 and "contact" in p.stdout, p.stdout + p.stderr
    assert not out.exists()


def test_a_no_pulse_grid_outside_the_pulse_models_range_runs(tmp_path):
    """A no-pulse grid makes no pulse, so the pulse model's range (Mw 5-8) does not bind it: Mw 4.5
    is inside the stochastic model's range and runs, while the same grid with pulses is refused
    naming the pulse model's range. The pre-run probe builds the row's own record (sample 0), so a
    probe that made a pulse anyway refused the no-pulse grid."""
    base = ["--mw", "4.5", "--dist", "5", "--samples", "2", "--no-figures", "--no-progress"]
    out = tmp_path / "np.h5"
    _ok(_serial([*base, "--pulse", "none", "--out", str(out)]))
    r = load(out)
    assert r.complete and (r.samples["status"] == 0).all() and np.isnan(r.samples["tp_s"]).all()
    p = _serial([*base, "--out", str(tmp_path / "p.h5")])
    assert p.returncode == 2 and "outside the pulse model's range" in p.stdout, p.stdout + p.stderr


def test_mismatched_arguments_are_refused(tmp_path):
    out = tmp_path / "m.h5"
    base = ["--mw", "6", "--dist", "5", "10", "--samples", "2", "--sample-function", "grid_fakes:fake",
            "--no-figures", "--no-progress", "--out", str(out)]
    _ok(_serial(base))
    stamp = load(out).attrs["created"]
    for change in (["--samples", "3"], ["--seed", "5"], ["--mw", "6.5"], ["--kn", "2e9"], ["--vp-scale", "1.2"],
                   ["--pulse", "none"], ["--tp-model", "baker_2007"]):
        p = _serial([*base, *change])
        assert p.returncode == 2, (change, p.stdout, p.stderr)
        assert "holds a different run" in p.stdout and "--overwrite" in p.stdout, p.stdout
    assert load(out).attrs["created"] == stamp  # untouched
    # the same command on a complete file computes nothing
    p = _ok(_serial(base))
    assert "4 of 4 rows already done, 0 to compute" in p.stdout
    # --overwrite replaces it
    _ok(_serial([*base, "--samples", "3", "--overwrite"]))
    assert len(load(out)) == 6


def test_not_a_results_file_is_refused(tmp_path):
    import h5py
    out = tmp_path / "other.h5"
    with h5py.File(out, "w") as f:
        f["x"] = 1
    p = _serial(["--mw", "6", "--dist", "5", "--samples", "1", "--sample-function", "grid_fakes:fake",
                 "--no-figures", "--out", str(out)])
    assert p.returncode == 2 and "not a pycolfrag grid results file" in p.stdout
