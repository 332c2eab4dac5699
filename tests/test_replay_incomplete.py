"""``pycolfrag replay`` of an interrupted grid's file: the prediction is marked, in its text and ``--json``,
as resting on part of the rows, and says on which.

The file: the tiny real-solver grid of tests/test_grid.py (2 Mw x 2 R x 3 samples, records cut to 4 s) whose
rows each wait 0.1 s first (a sample function written here), flushed every 0.2 s and killed with SIGKILL once
its journal holds 8 rows. Expected counts come from the file itself (its status column and journal), read
here with h5py and the journal reader, not from the replay; a complete file says none of it.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys

import numpy as np
import pytest

from pycolfrag import results as R

h5py = pytest.importorskip("h5py")

from test_grid import ROOT, SCRIPT, SMALL, _env, _kill_after, _ok, _serial  # noqa: E402

SLOW = "import time\nfrom pycolfrag.grid import run_sample\n\n\ndef slow(ctx, row):\n    time.sleep(0.1)\n" \
       "    return run_sample(ctx, row)\n"


def _replay(path, js):
    return subprocess.run([sys.executable, "-m", "pycolfrag", "replay", str(path), "--ranks", "1", "2", "--json",
                           str(js)], capture_output=True, text=True, cwd=ROOT, env=_env())


def test_the_replay_of_an_interrupted_file_says_so_and_on_what_it_rests(tmp_path):
    (tmp_path / "slowrows.py").write_text(SLOW)
    out = tmp_path / "cut.h5"
    args = [*SMALL, "--sample-function", "slowrows:slow", "--flush-s", "0.2", "--out", str(out)]
    _kill_after([sys.executable, str(SCRIPT), *args], _env(PYTHONPATH=f"{ROOT}:{tmp_path}"), out, 8, signal.SIGKILL)
    with h5py.File(out, "r") as f:
        status = f["samples/status"][:]
        steps = f["samples/n_steps"][:]
    in_h5 = status != R.STATUS_PENDING
    used = int(np.count_nonzero((status == 0) & (steps > 0)))
    _, jrows = R.read_journal(R.journal_path(out))
    journal_only = sum(1 for i in jrows if not in_h5[int(i)])
    if not 0 < in_h5.sum() < 12:
        pytest.skip(f"the kill left {int(in_h5.sum())} of 12 rows in the HDF5 file (timing): nothing to test")
    p = _replay(out, tmp_path / "p.json")
    assert p.returncode == 0, p.stdout + p.stderr
    first = p.stdout.splitlines()[0]
    assert first.startswith("INCOMPLETE FILE") and f"asked for 12 rows, the HDF5 file holds {int(in_h5.sum())}" in first
    assert f"rests on the {used} successful rows" in first and "(INCOMPLETE, above)" in p.stdout
    assert (f"{journal_only} more finished row(s) in its journal only" in first) == (journal_only > 0)
    got = json.loads((tmp_path / "p.json").read_text())
    assert got["complete"] is False and got["incomplete"] == first
    assert got["rests_on"]["rows_asked"] == 12 and got["rests_on"]["rows_in_h5"] == int(in_h5.sum())
    assert got["rests_on"]["rows_used"] == used == got["rows"]
    assert got["rests_on"]["rows_in_journal_only"] == journal_only
    # finished (the rerun resumes it with the same rows): no mark
    _ok(_serial([*args], PYTHONPATH=f"{ROOT}:{tmp_path}"))
    p = _replay(out, tmp_path / "q.json")
    assert p.returncode == 0 and "INCOMPLETE" not in p.stdout, p.stdout + p.stderr
    got = json.loads((tmp_path / "q.json").read_text())
    assert got["complete"] is True and got["incomplete"] is None and got["rests_on"]["rows_used"] == 12
