"""Hostile but fair use of the grid, its results file and record suites: runs that must not mix
versions, stored values that must not change unnoticed, options that must be refused before a
run, readers and signals that must not break a run, suites that must not reach outside their folder.

Grids use the fake sample function of ``tests/grid_fakes.py`` where the physics does not matter
(seconds per case); the few cases about the physics (step limits, the pre-run probes) run the
solver on a 3-sample zero record or one short record.

Cases, by the number of the defect in the report they guard: 1 a resume across a code or default
change, and one signature for one physics; 4 a solver step above the stability limit; 5 changed
attributes, signature, journal lines and status bytes; 6 a reader holding the file open; 7 a
signal to rank 0 under plain mpirun; 8 a full disk at creation; 9 suite files outside their
folder, devices, bounded hashing, the lock through a symlink; 10 options that fail every row, a
tiny step, absurd sizes, expected work, Ctrl-C inside simulate(); 12 a pair of unequal lengths
(FEMA P695 FF15) and a failing record's reason in the summary; and the grid's misleading messages
(--out DIR, "rows are in the journal", history_dt).
"""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.data import load
from pycolfrag.core.errors import ParameterError
from test_faults import FAKE, _fresh, _kill9, _rank_pids, _start, _wait_gone, _wait_rows, tmpfs  # noqa: F401 (tmpfs: a fixture)
from test_grid import ROOT, SCRIPT, _env, _journal_rows, _mpirun, _ok, _same_rows, _serial


def _partial(tmp_path, n=3, name="g.h5", extra=()):
    """A fake grid killed (SIGKILL) after ``n`` journalled rows: the state a resume starts from."""
    out = tmp_path / name
    p = _start([*FAKE, *extra, "--out", str(out)], PCF_FAKE_SLEEP_S="0.2")
    _wait_rows(out, n, p)
    _kill9(p)
    return out


def _partial_whole(tmp_path, n=3):
    """:func:`_partial` whose HDF5 file the kill left readable and consistent. A kill that lands inside
    a batch write (between the rows and the attributes' checksums, or mid-chunk) leaves a file read
    from its journal alone -- no row is lost, but a test that damages the file on purpose would then
    see the kill's damage instead of its own: take a file the kill left whole (most attempts)."""
    for attempt in range(8):
        out = _partial(tmp_path, n=n, name=f"g{attempt}.h5")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            load(out)
        if not any("journal" in str(w.message) or "damaged" in str(w.message) for w in caught):
            return out
    pytest.fail("every kill landed inside a batch write")


def _main_patched(patch, args, **env):
    """``cli.main(args)`` in a child process after ``patch`` (Python source) has run: another build."""
    code = textwrap.dedent(patch) + "\nimport sys\nfrom pycolfrag.cli.grid import main\nsys.exit(main(sys.argv[1:]))\n"
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
import pycolfrag.solver.options as o, pycolfrag.solver.run as so
@dataclasses.dataclass(frozen=True)
class Rebuilt(o.SolverOptions):
    dt_factor: float = 0.7
o.SolverOptions = so.SolverOptions = Rebuilt
"""
# a build that computes other numbers with the same options (a changed formula in the C library)
_PATCH_PHYSICS = """
import pycolfrag.solver.run as so
_orig = so.simulate
def simulate(col, acc_x, dt, *a, **k):
    return _orig(col, acc_x * (1 + 1e-12), dt, *a, **k)
so.simulate = simulate
"""


@pytest.mark.parametrize("patch, named", [(_PATCH_DEFAULT, "dt_factor"), (_PATCH_PHYSICS, "result_hash")])
def test_resume_across_a_code_change_is_refused(tmp_path, patch, named):
    # Reported: kill a grid, change a C default (dt_factor 0.8 -> 0.7), rebuild, rerun the same
    # command: 121 rows with the old step and 39 with the new in one file.
    out = _partial_whole(tmp_path)
    before = load(out)
    p = _main_patched(patch, [*FAKE, "--out", str(out)])
    assert p.returncode == 2, p.stdout + p.stderr
    assert "holds a different run" in p.stdout and named in p.stdout, p.stdout
    assert "another build of pycolfrag" in p.stdout and "mix rows of two versions" in p.stdout, p.stdout
    _same_rows(before, load(out))  # untouched
    sig = json.loads(load(out).attrs["grid_signature"])
    assert set(sig["build"]) == {"version", "result_hash"}
    # the same build resumes it
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert f"{len(before)} of 16 rows already done" in p.stdout


def _scratch_package(tmp_path, name, edit=None):
    """A copy of the package as a checkout holds it -- ``pycolfrag/`` (sources, data, built extension)
    beside ``csrc/`` -- in ``tmp_path/name``, with ``edit`` = (file, old text, new text) applied: another
    version of the code, importable by putting the folder first on PYTHONPATH."""
    import shutil
    root = tmp_path / name
    skip = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "pycolfrag", root / "pycolfrag", ignore=skip)
    shutil.copytree(ROOT / "csrc", root / "csrc", ignore=skip)
    if edit is not None:
        rel, old, new = edit
        text = (root / rel).read_text()
        assert text.count(old) == 1, f"{old!r} is not once in {rel}"
        (root / rel).write_text(text.replace(old, new))
    return root


def _run_with(package, args):
    """The grid command (scripts/run_grid.py) with the package imported from ``package``."""
    return _serial(args, PYTHONPATH=os.pathsep.join([str(package), str(ROOT / "tests")]))


# the reproduction: the pulse model's saturation magnitude, a constant off the path of the
# short reference computation behind the result hash (Mw 7 is not above 7.0 nor 7.3)
_M_SAT = ("pycolfrag/ground_motion/rupakhety_2011.py", "M_SAT = 7.0", "M_SAT = 7.3")


@pytest.mark.mpi
def test_resume_after_a_change_off_the_reference_path_is_refused_unless_allowed(tmp_path):
    # Reported: kill a grid after 6 journal rows, change M_SAT 7.0 -> 7.3, rerun: it resumed, and
    # 10 of 16 rows differed from either version. The run is now signed by its code.
    out = _partial_whole(tmp_path)
    before = load(out)
    digest = before.attrs["code_digest"]
    assert len(digest) == 64 and json.loads(before.attrs["grid_signature"])["code_digest"] == digest
    # a copy of the same code elsewhere signs alike (the digest reads contents, not paths): it resumes
    same = _scratch_package(tmp_path, "same")
    edited = _scratch_package(tmp_path, "edited", _M_SAT)
    p = _run_with(edited, [*FAKE, "--out", str(out)])
    assert p.returncode == 2, p.stdout + p.stderr
    line = p.stdout
    assert "holds a different run" in line and "another build of pycolfrag" in line, line
    assert f"code_digest: file has \"{digest}\"" in line and "--allow-code-change" in line, line
    _same_rows(before, load(out))  # untouched
    assert _journal_rows(out) == len(before)
    # allowed: resumed (on 2 MPI ranks: rank 0 reads the code, rank 1 takes its digest), and the file
    # names both versions with the time each began writing rows
    p = _ok(_mpirun(2, [*FAKE, "--out", str(out), "--allow-code-change"],
                    PYTHONPATH=os.pathsep.join([str(edited), str(ROOT / "tests")])))
    assert f"{len(before)} of 16 rows already done" in p.stdout and "--allow-code-change" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and after.attrs["code_digest"] == digest
    _same_rows(before, after, rows=before.rows)
    history = json.loads(after.attrs["code_digests"])
    assert [h["code_digest"] for h in history][0] == digest and len(history) == 2
    assert history[1]["code_digest"] != digest and history[1]["rows_done_before"] == len(before)
    assert all(h["started"] for h in history)
    sessions = json.loads(after.attrs["sessions"])
    assert sessions[-1]["code_digest"] == history[1]["code_digest"]
    # the copy of the unedited code is the file's first version: no flag needed to rerun it
    p = _ok(_run_with(same, [*FAKE, "--out", str(out)]))
    assert "16 of 16 rows already done" in p.stdout, p.stdout


@pytest.mark.mpi
def test_a_resume_by_a_library_of_other_sources_is_refused(tmp_path):
    # Reported: with the sources reverted and a library built from other sources loaded,
    # a resume exited 0 and mixed rows of two builds -- the digest read csrc/, not the library. Here a
    # checkout whose library (copied) was built from this csrc/ while its csrc/ holds an edit of a
    # header (the contact law's): the run is refused as a stale build before any row, even with
    # --allow-code-change (the sources would not say which code wrote the rows).
    out = _partial_whole(tmp_path)
    before = load(out)
    law = ' * contact_law.h -- THE sub-contact law of the soft joints, written once.'
    stale = _scratch_package(tmp_path, "stale", ("csrc/contact_law.h", law, law + " (edited)"))
    for extra in ([], ["--allow-code-change"]):
        p = _run_with(stale, [*FAKE, "--out", str(out), *extra])
        assert p.returncode == 2, p.stdout + p.stderr
        assert "stale build: the loaded C library" in p.stdout and "build_ext --inplace" in p.stdout, p.stdout
        assert "Traceback" not in p.stderr, p.stderr
        _same_rows(before, load(out))  # untouched
        assert _journal_rows(out) == len(before)
    # on 2 MPI ranks: rank 0 reads the sources, and every rank stops (none waits for the others)
    p = _mpirun(2, [*FAKE, "--out", str(out)], PYTHONPATH=os.pathsep.join([str(stale), str(ROOT / "tests")]))
    assert p.returncode == 2 and "stale build: the loaded C library" in p.stdout, p.stdout + p.stderr
    _same_rows(before, load(out))


# ------------------------------------------------------------------------------ 4: StepWarning

def _refused(argv, capsys, tmp_path):
    """main(argv) in process: exit code 2, one line, no file made; returns the line."""
    from pycolfrag.cli.grid import main
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
    from pycolfrag import Column
    from pycolfrag.ground_motion import Record
    from pycolfrag.solver import sample
    row = sample.response_row(Column.parthenon(), Record(np.zeros(40), 0.01), solver_options={"dt_solver": 0.00102})
    assert row["status"] == 0 and row["message"].startswith("StepWarning: simulate: dt_solver = 0.00102 s exceeds"), row


def test_history_dt_zero_is_reported_under_its_own_name():
    from pycolfrag import SolverOptions
    with pytest.raises(ParameterError, match=r"^solver options: history_dt must be > 0, got 0$"):
        SolverOptions(history_dt=0)


# ------------------------------------------------------------------------------ 5: integrity

def _flip_in_file(path, text: bytes, at: int, new: bytes):
    """Change the file's bytes where ``text`` occurs: byte ``at`` of it becomes ``new`` (in every
    copy: HDF5 may keep the heap object of an attribute rewritten later)."""
    data = Path(path).read_bytes()
    start = data.find(text)
    assert start >= 0
    with open(path, "r+b") as fh:
        while start >= 0:
            fh.seek(start + at)
            fh.write(new)
            start = data.find(text, start + 1)


@pytest.mark.parametrize("attr, key", [("grid_signature", b'"seed": 2016060'), ("column", b'"density": '),
                                       ("solver", b'"dt_factor": 0.')])
def test_a_changed_root_attribute_of_a_complete_file_is_damage_not_another_run(tmp_path, attr, key):
    # Reported: 140 of 3000 bit flips changed grid_signature, column or solver silently; a flipped
    # signature made the next run advise --overwrite, which deletes every row.
    out = tmp_path / "g.h5"
    _ok(_serial([*FAKE, "--out", str(out)]))
    good = load(out)
    with h5py.File(out, "r") as f:
        value = f.attrs[attr].encode()
    i = value.index(key) + len(key)
    assert value[i:i + 1].isdigit()
    _flip_in_file(out, value, i, b"9" if value[i:i + 1] != b"9" else b"8")  # still valid JSON, another value
    with pytest.raises(R.ResultsDamagedError, match=f"checksum mismatch in .*attribute {attr}\\b"):
        load(out)
    p = _serial([*FAKE, "--out", str(out)])
    assert p.returncode == 2, p.stdout + p.stderr
    line = p.stdout.strip().splitlines()[-1]
    assert "damaged" in line and f"attribute {attr}" in line and "holds a different run" not in line, line
    assert "its rows are intact" in line and f"mv {out} {out}.damaged" in line and "--overwrite would delete" in line
    _same_rows(good, load(out, verify=False))  # the salvage path the line names
    assert out.exists()


def test_a_changed_signature_of_an_interrupted_file_is_rebuilt_from_its_journal(tmp_path):
    out = _partial_whole(tmp_path, n=4)
    before = load(out)
    with h5py.File(out, "r") as f:
        value = f.attrs["grid_signature"].encode()
    key = b'"seed": 2016060'
    _flip_in_file(out, value, value.index(key) + len(key), b"9")
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert "checksum mismatch in attribute grid_signature" in p.stdout and "rebuilding it from" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(before, after, rows=before.rows)
    _same_rows(_fresh(tmp_path, FAKE), after)


def test_an_edited_journal_value_is_detected_and_not_used(tmp_path):
    out = _partial(tmp_path, n=4, extra=["--flush-s", "60"])  # the rows are in the journal only
    jp = R.journal_path(out)
    lines = jp.read_bytes().split(b"\n")
    row = json.loads(lines[2].rsplit(b"\t", 1)[0])
    edited = dict(row, u_top=123.0)
    lines[2] = json.dumps(edited, separators=(",", ":")).encode() + b"\t" + lines[2].rsplit(b"\t", 1)[1]
    jp.write_bytes(b"\n".join(lines))
    with pytest.warns(UserWarning, match=r"line\(s\) 3 fail their checksum"):
        r = load(out)
    assert row["row"] not in r.rows.tolist() and not (r.samples["u_top"] == 123.0).any()
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert "fail their checksum" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and not (after.samples["u_top"] == 123.0).any()
    _same_rows(_fresh(tmp_path, FAKE), after)  # the edited row was recomputed


def test_zeroed_status_bytes_of_an_interrupted_file_are_recomputed(tmp_path):
    # Reported: zeroed status bytes gave OK rows of NaN that were never recomputed. The pending rows
    # now marked "ok" fail their row checksums: the file is damaged, and its journal holds every row.
    out = _partial_whole(tmp_path, n=4)
    before = load(out)
    with h5py.File(out, "r") as f:
        off, n = f["samples/status"].id.get_offset(), f["samples/status"].size
    with open(out, "r+b") as fh:
        fh.seek(off)
        fh.write(b"\0" * 4 * n)  # every status 0 = "ok", pending rows included
    with pytest.warns(UserWarning, match=r"checksum mismatch in \d+ finished row\(s\).*the rows come from the journal"):
        r = load(out)
    assert r.rows.tolist() == before.rows.tolist()  # the journal's rows, and no "ok" row of NaN
    _ok(_serial([*FAKE, "--out", str(out)]))
    after = load(out)
    assert after.complete and len(after) == 16 and np.isfinite(after.samples["u_top"]).all()
    _same_rows(_fresh(tmp_path, FAKE), after)


# ------------------------------------------------------------------------------ 10: options that fail every row

BASE = ["--mw", "6", "--dist", "5", "--samples", "1"]


@pytest.mark.parametrize("change, expect", [
    # the weakest scenario's record at 1e300 x Vp is ~1e300 m/s^2: simulate() refuses |a| > MAX_ABS_ACC
    (["--vp-scale", "1e300"], "--vp-scale: the record of Mw 6, R 5 km, sample 0 reaches |a| = "),
    # intensity.measures: a damping ratio must be in [0, 1)
    (["--damping", "1.5"], "the IMs of the record of Mw 6, R 5 km, sample 0 fail (damping must be a ratio in [0, 1), "
                           "got 1.5)"),
    (["--samples", "10000000"], "samples must be at most 1e+06 per scenario, got 10000000"),
])
def test_options_that_fail_every_row_are_refused_before_the_run(tmp_path, capsys, change, expect):
    # Reported: exit 0 with every row failed (--vp-scale 1e300, --damping 1.5); --samples 1e7 built a
    # 6.6 GB file and computed nothing for an hour (the scenario's Latin hypercube, ~0.3 ms a sample)
    line = _refused(BASE + change, capsys, tmp_path)
    assert expect in line and "Traceback" not in line, line


def test_a_tiny_solver_step_is_refused_before_it_runs_for_minutes(tmp_path, capsys):
    # Reported: --solver dt_solver=1e-8 was silent for minutes (the pre-run check itself ran 3e8 steps).
    # Steps of the check: (3 samples x 0.005 s + the solver's tail) / 1e-8.
    from pycolfrag import SolverOptions
    from pycolfrag.grid import MAX_CHECK_STEPS
    steps = (3 * 0.005 + SolverOptions().tail_s) / 1e-8
    assert steps > MAX_CHECK_STEPS
    t0 = time.perf_counter()
    line = _refused(BASE + ["--solver", "dt_solver=1e-8"], capsys, tmp_path)
    assert f"a step of 1e-08 s needs {steps:.3g} steps" in line, line
    assert time.perf_counter() - t0 < 30  # not the minutes of the 3e8 steps (a bound, not a timing)


def test_a_long_grid_says_its_expected_work_and_a_long_record_is_named():
    # The estimate: solver steps (record + tail) / dt times the measured time per step.
    import tempfile

    from pycolfrag.grid import GridSpec, RecordGridSpec, check_work
    from pycolfrag.ground_motion import record_suites as records
    from record_suite import write_suite
    said = []
    spec = GridSpec(mw=(6.0,), dist_km=(5.0,), samples=10000)
    tail = spec.solver_options.tail_s
    check_work(spec, [("Mw 6, R 5 km", 40.0)], {"dt_s": 8e-4, "step_s": 3e-6}, said.append)
    per_row = (40.0 + tail) / 8e-4 * 3e-6
    assert said == [f"run_grid: expected work about {10000 * per_row / 60:.3g} min of CPU time (10000 rows; the longest "
                    "records, 3 us per solver step as measured now)"]
    with pytest.raises(ParameterError, match=r"needs 5\.1e\+07 solver steps"):  # (40 + 3) s / 8.43e-7 s
        check_work(spec, [("Mw 6, R 5 km", 40.0)], {"dt_s": (40.0 + tail) / 5.1e7, "step_s": 3e-6}, said.append)
    with tempfile.TemporaryDirectory() as d:
        suite = records.load_records(write_suite(Path(d)) / "suite.csv")
        rspec = RecordGridSpec(records="demo", suite=suite)
    said.clear()
    check_work(rspec, [("RSN9001", 1e6)], {"dt_s": 8e-4, "step_s": 3e-6}, said.append)  # a 1e8-sample record at 0.01 s
    assert said[0] == (f"run_grid: record RSN9001 is 1e+06 s long: about {(1e6 + tail) / 8e-4:.3g} solver steps, "
                       f"{(1e6 + tail) / 8e-4 * 3e-6 / 3600:.3g} h per row (2 rows)"), said


# ------------------------------------------------------------------------------ misleading messages

def test_out_naming_a_folder_is_refused_as_such_not_called_damaged(tmp_path, capsys):
    from pycolfrag.cli.grid import main
    code = main([*FAKE, "--mpi", "no", "--out", str(tmp_path)])
    line = capsys.readouterr().out.strip()
    assert code == 2 and line == f"run_grid: --out {tmp_path} is a folder: give the results file's path, e.g. " \
                                 f"{tmp_path / 'grid.h5'}", line
    assert list(tmp_path.iterdir()) == []


def test_an_os_error_before_any_row_does_not_claim_rows_in_the_journal(tmp_path):
    # Reported: "Rows finished so far are in the journal" when none were.
    from pycolfrag.grid.command import _os_error_line
    out = tmp_path / "g.h5"
    err = OSError(30, "Read-only file system", str(out))
    assert _os_error_line(err, out) == (f"run_grid: cannot write the results at {out}: Read-only file system (errno 30); "
                                        "no row was computed; fix the cause and rerun the same command.")
    w = R.open_for_run(out, {"a": 1}, {}, 4, [1.0])
    w.add([{"row": 0, "scenario": 0, "status": 0}, {"row": 1, "scenario": 0, "status": 0}])
    w.close()
    assert f"the 2 row(s) finished so far are in the journal {R.journal_path(out)}" in _os_error_line(err, out)


# ------------------------------------------------------------------------------ 12: natural records

def test_a_pair_of_unequal_lengths_runs_as_recorded_and_a_failing_record_says_why(tmp_path):
    # Reported: the 22 FEMA P695 far-field records written as AT2 files plus a CSV gave 2 of 44
    # failed rows: FF15 (Manjil) has components of 2676 and 2300 samples, and the CSV reader refused
    # the pair (align="error") where simulate() runs either component. Here a pair of 601 and 451
    # samples, and a record whose H1 file is not an AT2: its rows fail and the summary says why.
    import pycolfrag as pcf
    from pycolfrag.ground_motion import read_at2
    from pycolfrag.ground_motion.demo_records import pulse, write_at2
    dt = 0.01
    h1, h2 = pulse(0.30, 1.0, 6.0, dt), pulse(0.25, 0.8, 4.5, dt)
    assert (h1.size, h2.size) == (601, 451)
    write_at2(tmp_path / "U_H1.AT2", h1, dt, title="UNEVEN")
    write_at2(tmp_path / "U_H2.AT2", h2, dt, title="UNEVEN")
    (tmp_path / "B_H1.AT2").write_text("not an AT2 file\n")
    (tmp_path / "suite.csv").write_text("record_id,file_h1,file_h2,mw,rrup_km,event\n"
                                        "UNEVEN,U_H1.AT2,U_H2.AT2,7.4,12.6,Manjil-like\n"
                                        "BROKEN,B_H1.AT2,,6.5,10,Broken\n")
    out = tmp_path / "r.h5"
    p = _ok(_serial(["--records", str(tmp_path / "suite.csv"), "--no-figures", "--no-progress", "--out", str(out)]))
    r = load(out)
    s = r.samples
    uneven = {s["component"][i]: i for i in range(len(r)) if s["record_id"][i] == "UNEVEN"}
    assert set(uneven) == {"h1", "h2"} and all(s["status"][i] == 0 for i in uneven.values()), s["message"]
    for comp, name in (("h1", "U_H1.AT2"), ("h2", "U_H2.AT2")):
        rec = read_at2(tmp_path / name)  # the component as recorded, straight into simulate()
        direct = pcf.simulate(pcf.Column.parthenon(), rec.acc, rec.dt)
        i = uneven[comp]
        assert s["u_top"][i] == direct.u_top and s["n_steps"][i] == direct.n_steps, comp  # the same run, bit for bit
        assert s["record_s"][i] == rec.acc.size * dt
    broken = [i for i in range(len(r)) if s["record_id"][i] == "BROKEN"]
    assert len(broken) == 1 and s["status"][broken[0]] == R.STATUS_RECORD_FAILED
    msg = s["message"][broken[0]]
    assert "B_H1.AT2" in msg and msg.startswith("RecordFileError"), msg
    lines = p.stdout.splitlines()
    k = lines.index("failed rows (status > 0; the message is stored in each row):")
    assert lines[k + 1] == f"  1 failed [BROKEN h1]: {msg}", lines[k:k + 3]


# ------------------------------------------------------------------------------ 6: readers

def test_a_reader_holding_the_file_open_does_not_abort_the_run(tmp_path):
    # Reported: h5py.File(out, "r") held open (HDF5's default file locking) or load polling
    # made the grid's next HDF5 write fail "unable to lock file" (exit 4).
    out = tmp_path / "g.h5"
    run = _start([*FAKE, "--out", str(out)], PCF_FAKE_SLEEP_S="0.15")
    holder = None
    try:
        _wait_rows(out, 1, run)
        holder = subprocess.Popen([sys.executable, "-c", "import h5py, sys, time\n"
                                   "f = h5py.File(sys.argv[1], 'r')\nprint('open', flush=True)\ntime.sleep(30)\n",
                                   str(out)], stdout=subprocess.PIPE, text=True, env=_env())
        assert holder.stdout.readline().strip() == "open"  # a plain h5py reader, locks as HDF5 does by default
        seen = 0
        while run.poll() is None:  # and load polling meanwhile
            with warnings.catch_warnings():
                warnings.simplefilter("error", UserWarning)  # no read called the file damaged
                seen = max(seen, len(load(out)))
            time.sleep(0.05)
        text = run.stdout.read()
        assert run.returncode == 0, text
        assert seen >= 1
    finally:
        for p in (run, holder):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(_fresh(tmp_path, FAKE), after)


# ------------------------------------------------------------------------------ 7: signals under plain mpirun

@pytest.mark.mpi
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_to_rank_0_under_plain_mpirun_ends_every_rank_after_the_final_write(tmp_path, sig):
    # Reported: SIGTERM/SIGINT to rank 0 alone under "mpirun -n 2 python scripts/run_grid.py" (the
    # README's form, without -m mpi4py): the final write completed, then rank 1 spun at 99 % CPU forever.
    # SIGTERM now drains (docs/grid.md, "Signals"): rank 1 ends normally after its chunk; SIGINT aborts.
    import shutil
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    out = tmp_path / "g.h5"
    args = [*FAKE[:-2], "--flush-s", "60", "--out", str(out)]  # no HDF5 batch before the signal: only the final write
    cmd = ["timeout", "-k", "10", "120", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, str(SCRIPT), *args]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S="0.2"), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        _wait_rows(out, 4, proc)
        rank0 = json.loads(R.lock_path(out).read_text())["pid"]
        ranks = _rank_pids(out, marker=str(SCRIPT).encode())
        assert rank0 in ranks and len(ranks) == 2, (rank0, ranks)
        os.kill(rank0, sig)
        text, _ = proc.communicate(timeout=60)  # before the fix: never (rank 1 waits forever; timeout ends it at 120 s)
        _wait_gone(ranks, 10, "ranks still alive after mpirun ended")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    if sig == signal.SIGTERM:  # rank 0 drains: the chunks in flight come back, then the final write, exit 75
        assert proc.returncode == 75, text
        assert "SIGTERM: no new chunks" in text and "row(s) left (exit 75)" in text, text
    else:
        assert proc.returncode == 128 + sig and proc.returncode != 124, text  # 124: the timeout had to end it
        assert "interrupted" in text and "ending the other ranks" in text, text
    n_journal = _journal_rows(out)
    with h5py.File(out, "r") as f:
        in_h5 = int((f["samples/status"][...] != R.STATUS_PENDING).sum())
    assert in_h5 == n_journal >= 4  # the final write holds every row that reached rank 0


# ------------------------------------------------------------------------------ 9: suite paths, the lock's path

def _suite_csv(folder, file_h1, rid="R1"):
    (folder / "suite.csv").write_text(f"record_id,file_h1,mw,rrup_km\n{rid},{file_h1},6.5,10\n")
    return folder / "suite.csv"


def test_suite_files_outside_the_suite_folder_are_refused_unless_allowed(tmp_path):
    # Reported: a row naming ../somewhere/.token stored that file's 4th line in the results.
    from pycolfrag.ground_motion import record_suites as records
    from pycolfrag.ground_motion.demo_records import write_at2
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / ".token").write_text("line 1\nline 2\nline 3\nTOKEN-VALUE-42\n")
    write_at2(tmp_path / "secret" / "ok.AT2", np.full(100, 0.01), 0.01)
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "link.AT2").symlink_to(tmp_path / "secret" / "ok.AT2")  # a symlink leading out, too
    for name in ("../secret/.token", str(tmp_path / "secret" / "ok.AT2"), "link.AT2"):
        csv = _suite_csv(suite, name)
        with pytest.raises(records.RecordFileError, match="is outside the suite's folder") as exc:
            records.load_records(csv)
        assert "TOKEN" not in str(exc.value)
        kept = records.load_records(csv, on_error="keep")  # the grid's way: the record's rows fail, naming why
        assert "is outside the suite's folder" in kept[0].error and "TOKEN" not in kept[0].error
    rec = records.load_records(csv, allow_outside=True)[0]  # the explicit opt-out
    assert rec.n == 100 and rec.h1[0] == 0.01 * 9.81
    out = tmp_path / "r.h5"
    p = _ok(_serial(["--records", str(_suite_csv(suite, "../secret/.token")), "--no-figures", "--no-progress",
                     "--out", str(out)]))
    s = load(out).samples
    assert s["status"][0] == R.STATUS_RECORD_FAILED and "outside the suite's folder" in s["message"][0]
    assert "TOKEN" not in p.stdout and not any("TOKEN" in m for m in s["message"])


def test_devices_are_refused_as_tables_and_record_files(tmp_path):
    # Reported: /dev/zero was hashed without bound.
    from pycolfrag.ground_motion import record_suites as records
    from pycolfrag.ground_motion import record_tables
    with pytest.raises(records.RecordFileError, match="suite table /dev/zero is not a regular file"):
        records.load_records("/dev/zero")
    csv = _suite_csv(tmp_path, "/dev/zero")
    with pytest.raises(records.RecordFileError, match="'/dev/zero' is not a regular file"):
        records.load_records(csv, allow_outside=True)
    assert len(record_tables.files_sha1(["/dev/zero"])) == 40  # a device hashes as its name, at once


def test_record_file_hash_is_that_of_its_bytes_and_bounded(tmp_path, monkeypatch):
    import hashlib

    from pycolfrag.ground_motion import record_tables
    p = tmp_path / "a.bin"
    data = bytes(range(256)) * 40
    p.write_bytes(data)
    assert record_tables.files_sha1([p]) == hashlib.sha1(data + b"\0").hexdigest()  # whole small files, as before
    monkeypatch.setattr(record_tables, "MAX_HASH_BYTES", 1000)
    assert record_tables.files_sha1([p]) == hashlib.sha1(data[:1000] + b"size:10240" + b"\0").hexdigest()


def test_a_symlink_to_a_results_file_meets_its_lock(tmp_path):
    # Reported: a symlink to the results file bypassed the run lock (the lock was <link>.lock).
    out = tmp_path / "g.h5"
    link = tmp_path / "link.h5"
    a = _start([*FAKE, "--out", str(out)], PCF_FAKE_SLEEP_S="0.5")
    try:
        _wait_rows(out, 1, a)
        link.symlink_to(out)
        p = _serial([*FAKE, "--out", str(link)])
        assert p.returncode == 5 and f"pid {a.pid}" in p.stdout, p.stdout + p.stderr
        assert not R.lock_path(link).exists()
        assert len(load(link)) >= 1  # readers through the link see the journal beside the real file
    finally:
        _kill9(a)
    _ok(_serial([*FAKE, "--out", str(link)]))  # resumes the real file through the link
    assert link.is_symlink() and load(out).complete
    _same_rows(_fresh(tmp_path, FAKE), load(out))


def test_a_hard_link_to_a_results_file_meets_its_lock(tmp_path):
    # Reported: two runs on two hard links of one file both wrote (exit 4 for both, an orphaned
    # journal): the lock was one per name. The run's lock covers the file's inode too.
    out = tmp_path / "g.h5"
    link = tmp_path / "link.h5"
    a = _start([*FAKE, "--out", str(out)], PCF_FAKE_SLEEP_S="0.5")
    try:
        _wait_rows(out, 1, a)
        os.link(out, link)
        p = _serial([*FAKE, "--out", str(link)])
        assert p.returncode == 5 and "hard link" in p.stdout and f"pid {a.pid}" in p.stdout, p.stdout + p.stderr
        assert not R.journal_path(link).exists() and not R.lock_path(link).exists()
    finally:
        _kill9(a)
    _ok(_serial([*FAKE, "--out", str(out)]))  # the first run's name resumes it (its journal is beside it)
    _same_rows(_fresh(tmp_path, FAKE), load(link))


# ------------------------------------------------------------------------------ 8: full disk at creation

def test_a_results_file_larger_than_the_disk_is_one_clear_line(tmpfs):  # noqa: F811 (tmpfs: test_faults's fixture)
    # Reported: a full disk while the HDF5 file was created gave a RuntimeError traceback and a
    # segfault (exit 139). 4 x 4 x 500 rows of ~900 bytes do not fit 1 MB: refused before creating.
    from pycolfrag.results import row_bytes
    from pycolfrag.solver.sample import DEFAULT_PERIODS_S
    mnt, _ = tmpfs
    n_p = len(DEFAULT_PERIODS_S)   # the grid's spectral periods per row
    out = mnt / "g.h5"
    p = _serial([*FAKE[:FAKE.index("--samples")], "--samples", "500", *FAKE[FAKE.index("--samples") + 2:],
                 "--out", str(out)])
    assert p.returncode == 4, p.stdout + p.stderr
    need = 4 * 500 * row_bytes(n_p)
    line = p.stdout.strip().splitlines()[-1]
    assert line.startswith(f"run_grid: cannot write the results at {out}: No space left on device: the results "
                           f"file needs {need / 1e9:.3g} GB (2000 rows of {row_bytes(n_p)} bytes)"), line
    assert "no row was computed" in line and "Traceback" not in p.stdout + p.stderr
    assert list(mnt.iterdir()) == []


def test_a_disk_filling_up_while_the_file_is_created_raises_enospc_and_leaves_nothing(tmpfs):  # noqa: F811 (tmpfs: test_faults's fixture)
    # The free-space check passed (another process filled the disk meanwhile): creating the file
    # must give the OSError of a full disk, leave no .tmp or .journal, and not crash the process.
    mnt, _ = tmpfs
    (mnt / "filler").write_bytes(b"\0" * 600_000)
    code = ("import sys\nfrom pycolfrag import results as R\n"
            "try:\n    R.create(sys.argv[1], {'a': 1}, {}, 2000, [0.5, 1.0])\n"
            "except OSError as e:\n    print('OSError', e.errno, e.strerror)\n")
    p = subprocess.run([sys.executable, "-c", code, str(mnt / "g.h5")], capture_output=True, text=True,
                       env=_env(), timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "OSError 28 No space left on device", p.stdout + p.stderr
    assert "Traceback" not in p.stderr
    assert sorted(x.name for x in mnt.iterdir()) == ["filler"]


# ------------------------------------------------------------------------------ 10: Ctrl-C inside simulate()

@pytest.mark.parametrize("call", ["pcf.simulate(col, acc, 0.005, dt_solver=5e-7)",
                                  "pcf.simulate_batch(col, [{'acc_x': acc, 'dt': 0.005}] * 8, dt_solver=5e-7)"])
def test_ctrl_c_inside_simulate_interrupts_the_c_run_promptly(call):
    # Reported: Ctrl-C inside simulate() waited 94 s (the C run never returned to Python). The run
    # here needs (5 s + the 3 s tail) / 5e-7 s = 1.6e7 steps, about a minute (the batch: 8 of them
    # side by side, as the grid's chunks run); the C run now calls back every CF_SOLVER_CHECK_STEPS
    # steps (a few ms), where Python raises the KeyboardInterrupt.
    # The child takes Python's own Ctrl-C handler, which a run at a terminal has: a test run started in
    # the background of a script (`cmd &`) inherits SIGINT ignored, and Python then keeps it ignored.
    code = textwrap.dedent("""
        import signal, sys, time, numpy as np, pycolfrag as pcf
        signal.signal(signal.SIGINT, signal.default_int_handler)
        col = pcf.Column.parthenon()
        t = np.arange(0, 5.0, 0.005)
        acc = 0.25 * 9.81 * np.sin(2 * np.pi * 2 * t)
        print("start", flush=True)
        try:
            CALL
            print("finished", flush=True)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
        short = pcf.simulate(col, acc[:200], 0.005)  # the next run is a normal one (no check left over)
        ref = pcf.simulate(col, acc[:200], 0.005)
        print("after", short.u_top == ref.u_top and short.n_steps == ref.n_steps, flush=True)
    """).replace("CALL", call)
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=_env())
    try:
        assert p.stdout.readline().strip() == "start"
        time.sleep(1.0)
        t0 = time.time()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
        waited = time.time() - t0
    finally:
        if p.poll() is None:
            p.kill()
    assert out.split() == ["interrupted", "after", "True"], out + err
    assert waited < 20, waited  # a bound far below the minute of the uninterrupted run, not a timing


def test_a_sample_function_that_cannot_be_imported_is_refused_in_one_line(tmp_path, capsys):
    line = _refused(BASE + ["--sample-function", "no_such_module_xyz:fake"], capsys, tmp_path)
    assert line == ("run_grid: --sample-function no_such_module_xyz:fake: ModuleNotFoundError: No module named "
                    "'no_such_module_xyz'"), line
