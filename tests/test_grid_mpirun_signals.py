"""SIGTERM to ``mpirun`` itself: what Open MPI 4.1 does with it (it aborts the job), as docs/grid.md
("Signals") says.

mpirun does not forward SIGTERM (nor SIGINT, SIGHUP) to the ranks: it aborts the job. Its local
daemon sends every rank SIGCONT, waits ``odls_base_sigkill_timeout`` seconds (MCA parameter, default 1),
sends SIGTERM, waits as long again, sends SIGKILL, and mpirun exits 1 whatever the ranks exited with
(measured: 2.1 s from the signal to mpirun's exit with the default, 58.6 s with 30). So the ranks drain
(docs/grid.md) only if the chunks in flight and rank 0's final write fit in that one second; otherwise
they are killed, and what the journal holds is what the run kept. These tests pin both outcomes with
the grid's fake rows (tests/grid_fakes.py: no physics, a sleep per row): with rows of 0.8 s (chunks of
several seconds) the drain is cut, every journalled row is kept and the resume completes the file
bitwise as an uninterrupted run; with ``OMPI_MCA_odls_base_sigkill_timeout=4`` the drain finishes and
the file holds every row the journal does. Timing bounds are loose (a shared 2-core machine): the
default's sequence takes 2 s, so 1.5 s to 15 s.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import h5py
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.data import load
from test_faults import _fresh, _rank_pids, _wait_gone, _wait_rows
from test_grid import ROOT, SCRIPT, _env, _journal_rows, _mpirun, _ok, _same_rows

pytestmark = pytest.mark.mpi

#: 2 Mw x 2 R x 20 samples = 80 fake rows.
ARGS = ["--mw", "6", "7", "--dist", "5", "10", "--samples", "20", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress", "--flush-s", "0.2"]


def _term_mpirun(out, sleep_s: str, **env):
    """Start the grid under mpirun (2 ranks, rows of ``sleep_s`` seconds), SIGTERM mpirun once the
    journal holds 6 rows; (exit code, seconds from the signal to mpirun's exit, output). Waits until
    the ranks are gone."""
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    cmd = ["mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py", str(SCRIPT), *ARGS,
           "--out", str(out)]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S=sleep_s, **env), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        _wait_rows(out, 6, proc)
        ranks = _rank_pids(out)
        assert len(ranks) == 2, ranks
        t0 = time.time()
        proc.send_signal(signal.SIGTERM)
        text, _ = proc.communicate(timeout=60)
        took = time.time() - t0
        _wait_gone(ranks, 10, "ranks still alive after mpirun ended")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return proc.returncode, took, text


def _rows_in_h5(out) -> int:
    with h5py.File(out, "r") as f:
        return int((f["samples/status"][...] != R.STATUS_PENDING).sum())


def _resume_completes(tmp_path, out, before):
    _ok(_mpirun(2, [*ARGS, "--out", str(out)], PCF_FAKE_SLEEP_S="0"))
    after = load(out)
    assert after.complete and len(after) == 80 and (after.samples["status"] == 0).all()
    _same_rows(before, after, rows=before.rows)          # the rows kept are not recomputed
    _same_rows(_fresh(tmp_path, ARGS), after)            # bitwise an uninterrupted run


def test_sigterm_to_mpirun_aborts_the_job_and_keeps_every_journalled_row(tmp_path):
    out = tmp_path / "g.h5"
    code, took, text = _term_mpirun(out, "0.8")
    assert code == 1, text                               # Open MPI's abort, not the drain's 75
    assert 1.5 < took < 15, took                          # SIGCONT, 1 s, SIGTERM, 1 s, SIGKILL
    n = _journal_rows(out)
    before = load(out)                                   # the HDF5 file and its journal: every row rank 0 got
    assert 6 <= n == len(before) < 80, (n, len(before))
    _resume_completes(tmp_path, out, before)


def test_a_longer_sigkill_timeout_lets_the_ranks_drain(tmp_path):
    out = tmp_path / "g.h5"
    code, took, text = _term_mpirun(out, "0.2", OMPI_MCA_odls_base_sigkill_timeout="4")
    assert code == 1, text                               # mpirun's own status, whatever rank 0 exits with
    assert 7 < took < 30, took                            # SIGTERM 4 s after the signal, SIGKILL 4 s later
    assert "SIGTERM: no new chunks" in text and "row(s) left (exit 75)" in text, text
    assert not R.lock_path(out).exists()                  # rank 0 made its final write and let go of the file
    n = _journal_rows(out)
    assert 6 <= n == _rows_in_h5(out) < 80, (n, _rows_in_h5(out))   # the file holds every journalled row
    _resume_completes(tmp_path, out, load(out))
