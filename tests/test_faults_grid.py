"""Hostile but fair use of the grid, its results file and record suites: runs that must not mix
versions, stored values that must not change unnoticed, options that must be refused before a
run, readers and signals that must not break a run, suites that must not reach outside their folder.

Grids use the fake sample function of ``tests/grid_fakes.py`` where the physics does not matter
(seconds per case); the few cases about the physics (step limits, the pre-run probes) run the
solver on a 3-sample zero record or one short record.
"""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.errors import ParameterError

from test_grid import ROOT, SCRIPT, _env, _journal_rows, _ok, _same_rows, _serial

FAKE = ["--mw", "6", "7", "--dist", "5", "10", "--samples", "4", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress", "--flush-s", "0.2"]


def _start(args, **env):
    return subprocess.Popen([sys.executable, str(SCRIPT), *args], env=_env(**env), cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _wait_rows(out, n, proc=None, limit=60):
    t0 = time.time()
    while _journal_rows(out) < n:
        assert time.time() - t0 < limit, f"journal of {out} never reached {n} rows"
        assert proc is None or proc.poll() is None, f"run ended early: {proc.stdout.read()}"
        time.sleep(0.02)


def _kill9(proc):
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)


def _partial(tmp_path, n=3, name="g.h5", extra=()):
    """A fake grid killed (SIGKILL) after ``n`` journalled rows: the state a resume starts from."""
    out = tmp_path / name
    p = _start([*FAKE, *extra, "--out", str(out)], PCF_FAKE_SLEEP_S="0.2")
    _wait_rows(out, n, p)
    _kill9(p)
    return out


def _main_patched(patch, args, **env):
    """``grid.main(args)`` in a child process after ``patch`` (Python source) has run: another build."""
    code = textwrap.dedent(patch) + "\nimport sys\nfrom pycolfrag.grid import main\nsys.exit(main(sys.argv[1:]))\n"
    return subprocess.run(["timeout", "-k", "10", "120", sys.executable, "-c", code, *args], capture_output=True,
                          text=True, env=_env(**env), cwd=ROOT)


# ------------------------------------------------------------------------------ 1: no version mixing

def test_specs_of_the_same_physics_have_one_signature():
    # the raw options dict used to be signed: {} and {"dt_factor": <its default>} are the same
    # physics but refused each other's files; the resolved SolverOptions is signed now
    from pycolfrag import SolverOptions
    from pycolfrag.grid import GridSpec
    d = SolverOptions().to_dict()
    a = GridSpec(mw=(6.0,), dist_km=(5.0,), samples=2)
    b = GridSpec(mw=(6.0,), dist_km=(5.0,), samples=2, solver_options={"dt_factor": d["dt_factor"],
                                                                       "contact": d["contact"]})
    c = GridSpec(mw=(6.0,), dist_km=(5.0,), samples=2, solver_options=SolverOptions())
    assert a.signature() == b.signature() == c.signature()
    assert a.signature()["solver"] == d  # every option, defaults filled in
    assert isinstance(b.solver_options, SolverOptions)
    other = GridSpec(mw=(6.0,), dist_km=(5.0,), samples=2, solver_options={"dt_factor": d["dt_factor"] / 2})
    assert other.signature() != a.signature()


# a build whose C default dt_factor is 0.7 instead of the library's (what a rebuild after editing
# cf_solver_def_default gives): Python reads its defaults from C, so this is the same change
_PATCH_DEFAULT = """
import dataclasses
import pycolfrag.options as o, pycolfrag.solver as so
@dataclasses.dataclass(frozen=True)
class Rebuilt(o.SolverOptions):
    dt_factor: float = 0.7
o.SolverOptions = so.SolverOptions = Rebuilt
"""
# a build that computes other numbers with the same options (a changed formula in the C library)
_PATCH_PHYSICS = """
import pycolfrag.solver as so
_orig = so.simulate
def simulate(col, acc_x, dt, *a, **k):
    return _orig(col, acc_x * (1 + 1e-12), dt, *a, **k)
so.simulate = simulate
"""


@pytest.mark.parametrize("patch, named", [(_PATCH_DEFAULT, "dt_factor"), (_PATCH_PHYSICS, "result_hash")])
def test_resume_across_a_code_change_is_refused(tmp_path, patch, named):
    # Reported: kill a grid, change a C default (dt_factor 0.8 -> 0.7), rebuild, rerun the same
    # command: 121 rows with the old step and 39 with the new in one file.
    out = _partial(tmp_path)
    before = R.load(out)
    p = _main_patched(patch, [*FAKE, "--out", str(out)])
    assert p.returncode == 2, p.stdout + p.stderr
    assert "holds a different run" in p.stdout and named in p.stdout, p.stdout
    assert "another build of pycolfrag" in p.stdout and "mix rows of two versions" in p.stdout, p.stdout
    _same_rows(before, R.load(out))  # untouched
    sig = json.loads(R.load(out).attrs["grid_signature"])
    assert set(sig["build"]) == {"version", "result_hash"}
    # the same build resumes it
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert f"{len(before)} of 16 rows already done" in p.stdout


# ------------------------------------------------------------------------------ 4: StepWarning

def _refused(argv, capsys, tmp_path):
    """main(argv) in process: exit code 2, one line, no file made; returns the line."""
    from pycolfrag.grid import main
    out = tmp_path / "o" / "g.h5"
    code = main([*argv, "--no-figures", "--no-progress", "--mpi", "no", "--out", str(out)])
    text = capsys.readouterr().out.strip()
    assert code == 2, text
    assert len(text.splitlines()) == 1, text
    assert not out.parent.exists() or not any(out.parent.iterdir())
    return text


@pytest.mark.parametrize("dt_solver", ["0.0011", "0.0012", "1"])
def test_a_step_above_the_stability_limit_is_refused_before_the_run(tmp_path, capsys, dt_solver):
    # Reported: --solver dt_solver=0.0011 (1.1x the limit) exited 0 with every row stored as OK,
    # the StepWarning swallowed; 0.0012 gave a SolverError traceback. The limit is the solver's own
    # whole-stack stability limit (Response.dt_crit), asked here independently of the grid.
    import pycolfrag as pcf
    crit = pcf.simulate(pcf.Column.parthenon(), np.zeros(3), 0.005).dt_crit
    assert 0.0009 < crit < 0.0011  # the Parthenon column's limit (docs/solver.md): 1.1 and 1.2x are above it
    line = _refused(["--mw", "6", "--dist", "5", "--samples", "1", "--solver", f"dt_solver={dt_solver}"],
                    capsys, tmp_path)
    assert f"dt_solver = {float(dt_solver):.4g} s exceeds the whole-stack stability limit {crit:.4g} s" in line, line
    assert f"choose dt_solver <= {crit:.4g} s" in line and "Traceback" not in line


def test_a_step_longer_than_the_records_dt_is_refused(tmp_path, capsys):
    line = _refused(["--mw", "6", "--dist", "5", "--samples", "1", "--record-dt", "0.0005",
                     "--solver", "dt_solver=0.0008"], capsys, tmp_path)
    assert "is longer than the record's dt = 0.0005 s" in line, line


def test_a_row_keeps_the_step_warning_in_its_message():
    # outside the grid (run_suite, run_record_sample) a row computed with such a step says so
    from pycolfrag import Column, sample
    row = sample.response_row(Column.parthenon(), np.zeros(40), 0.01, solver_options={"dt_solver": 0.00102})
    assert row["status"] == 0 and row["message"].startswith("StepWarning: simulate: dt_solver = 0.00102 s exceeds"), row


def test_history_dt_zero_is_reported_under_its_own_name():
    from pycolfrag import SolverOptions
    with pytest.raises(ParameterError, match=r"^solver options: history_dt must be > 0, got 0$"):
        SolverOptions(history_dt=0)
