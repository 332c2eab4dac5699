"""Record-suite grids (docs/records.md): ``scripts/run_grid.py --records SOURCE`` on the demo suite
(:mod:`pycolfrag.ground_motion.demo_records`: three closed-form records, 2 components each), run as users do, in
child processes (helpers of tests/test_grid.py: ``mpirun`` children get an environment without the
``PMIX_*``/``OMPI_*`` variables an MPI-initialised parent leaves, which make a child ``mpirun``
exit 1). The demo records are 4-6 s long; a row takes a few hundredths of a second, so every run
here is short.
"""
import json
import os
import shutil
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import record_suite as rs  # noqa: E402
from pycolfrag import grid  # noqa: E402
from pycolfrag import results as R  # noqa: E402
from pycolfrag.analysis.data import Results, load  # noqa: E402
from pycolfrag.analysis.summary import format_table, summary_table  # noqa: E402
from test_grid import SCRIPT, _env, _kill_after, _mpirun, _ok, _same_rows, _serial  # noqa: E402

QUIET = ["--no-figures", "--no-progress"]


@pytest.fixture
def suite(tmp_path):
    return rs.write_suite(tmp_path / "suite")


def _rows_by_key(r: Results):
    s = r.samples
    return {(s["record_id"][i], s["component"][i], float(s["scale"][i])): i for i in range(len(r))}


@pytest.mark.mpi
def test_record_grid_one_and_two_ranks_identical(suite, tmp_path):
    """Rows depend on (record, component, scale) only, never on the rank or order of work: the
    file of 1 rank and of 2 ranks are equal in every dataset but the wall times."""
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    args = ["--records", str(suite), "--scale", "0.5", "1", *QUIET]
    p1 = _ok(_serial([*args, "--out", str(one)]))
    p2 = _ok(_mpirun(2, [*args, "--out", str(two)]))
    assert "3 records x h1/h2 x 2 scales = 12 runs on 1 rank" in p1.stdout
    assert "on 2 ranks" in p2.stdout
    a, b = load(one), load(two)
    assert len(a) == len(b) == 12 and a.complete and b.complete
    assert (a.samples["status"] == 0).all(), a.samples["message"]
    _same_rows(a, b)
    assert a.attrs["grid_signature"] == b.attrs["grid_signature"] and a.attrs["layout"] == "records"
    assert a.attrs["n_ranks"] == 1 and b.attrs["n_ranks"] == 2
    # row order: sample.record_jobs (record-major, then component, then scale)
    assert list(a.samples["record_id"]) == ["RSN9001"] * 4 + ["RSN9002"] * 4 + ["RSN9003"] * 4
    assert list(a.samples["component"]) == ["h1", "h1", "h2", "h2"] * 3
    assert list(a.samples["scale"]) == [0.5, 1.0] * 6
    # every documented record-suite field, with h5py alone (docs/results_format.md)
    import h5py
    with h5py.File(two, "r") as f:
        assert set(f["samples"]) == set(R.RECORD_SAMPLE_FIELDS)
        assert f.attrs["layout"] == "records" and json.loads(f.attrs["components"]) == ["h1", "h2"]
        assert f["samples/record_id"][0] == b"RSN9001" and f["samples/station"][4] == b"Station B_ North"
        assert f["spectra/sa_g"].shape == (12, len(f["spectra"].attrs["periods_s"]))
    assert not R.journal_path(two).exists()


def test_scale_rows_and_closing_table(suite, tmp_path):
    """``--scale 1 2``: one row per record x component x scale. The IMs are those of the scaled
    motion, and doubling a float is exact, so PGA and PGV at scale 2 are exactly twice those at 1.
    PGA of RSN9001 H1 is the sine's amplitude 0.30 g (demo_records: a sample on every crest; 1e-7 is
    the AT2 file's 8 significant digits), metadata from its _SearchResults.csv line."""
    out = tmp_path / "s.h5"
    p = _ok(_serial(["--records", str(suite), "--scale", "1", "2", *QUIET, "--out", str(out)]))
    r = load(out)
    s = r.samples
    assert len(r) == 12
    keys = _rows_by_key(r)
    for (rid, comp, f), i in keys.items():
        if f == 2.0:
            j = keys[(rid, comp, 1.0)]
            assert s["pga_g"][i] == 2 * s["pga_g"][j], (rid, comp)
            assert s["pgv_cm_s"][i] == 2 * s["pgv_cm_s"][j], (rid, comp)
            np.testing.assert_array_equal(r.spectra["sa_g"][i], 2 * r.spectra["sa_g"][j])
    i = keys[("RSN9001", "h1", 1.0)]
    assert s["pga_g"][i] == pytest.approx(0.30, rel=1e-7)
    assert (s["event"][i], s["station"][i], s["mw"][i], s["rrup_km"][i], s["dist_km"][i]) == \
        ("Sine Quake", "Station A", 6.5, 20.0, 20.0)
    assert s["rjb_km"][i] == 19.0 and s["vs30_m_s"][i] == 400.0 and s["dt_s"][i] == 0.005
    # the closing table: per scale when several scales, per record otherwise
    assert "scale" in p.stdout.splitlines()[1] and "12 runs computed" in p.stdout
    by_record = summary_table(out, by="record")
    assert [t["record_id"] for t in by_record] == ["RSN9001", "RSN9002", "RSN9003"]
    assert all(t["done"] == 4 for t in by_record)
    assert "Pulse Quake" in format_table(by_record)


def test_record_grid_kill_and_resume_equals_uninterrupted(suite, tmp_path):
    """SIGKILL part-way (rows slowed to 0.15 s by record_grid_fakes:slow), then the same command:
    only the missing rows are computed, and the file equals an uninterrupted run's."""
    out = tmp_path / "kill.h5"
    args = ["--records", str(suite), "--scale", "0.5", "1", "--sample-function", "record_grid_fakes:slow",
            "--flush-s", "0.2", *QUIET, "--out", str(out)]
    _kill_after([sys.executable, str(SCRIPT), *args], _env(PCF_FAKE_SLEEP_S="0.15"), out, 4, signal.SIGKILL)
    before = load(out)
    n_before = len(before)
    assert 4 <= n_before < 12, n_before
    p = _ok(_serial(args, PCF_FAKE_SLEEP_S="0"))
    assert f"{n_before} of 12 rows already done, {12 - n_before} to compute" in p.stdout
    after = load(out)
    assert after.complete and len(after) == 12 and (after.samples["status"] == 0).all()
    _same_rows(before, after, rows=before.rows)
    fresh = tmp_path / "fresh.h5"
    _ok(_serial([*args[:-1], str(fresh)], PCF_FAKE_SLEEP_S="0"))
    _same_rows(load(fresh), after)


def test_a_different_suite_or_options_is_refused(suite, tmp_path):
    """The grid signature holds the suite (record ids, data digests, file hashes) and the options:
    a changed AT2 file, another --components or --scale is refused (exit 2) and the file kept; the
    same files copied to another folder are the same suite (nothing to compute)."""
    out = tmp_path / "r.h5"
    base = ["--records", str(suite), *QUIET, "--out", str(out)]
    _ok(_serial(base))
    stamp = load(out).attrs["created"]
    for change in (["--components", "both"], ["--scale", "2"]):
        p = _serial([*base, *change])
        assert p.returncode == 2 and "holds a different run" in p.stdout, (change, p.stdout, p.stderr)
    moved = shutil.copytree(suite, tmp_path / "moved")
    p = _ok(_serial(["--records", str(moved), *QUIET, "--out", str(out)]))
    assert "6 of 6 rows already done, 0 to compute" in p.stdout
    at2 = Path(moved) / "RSN9003_FAR_C045.AT2"
    lines = at2.read_text().splitlines()
    lines[4] = lines[4].replace("0.", "1.", 1)   # one sample changed
    at2.write_text("\n".join(lines) + "\n")
    p = _serial(["--records", str(moved), *QUIET, "--out", str(out)])
    assert p.returncode == 2 and "holds a different run" in p.stdout and "suite" in p.stdout, p.stdout
    assert load(out).attrs["created"] == stamp  # untouched
    # options of the synthetic grid make no sense with --records
    p = _serial([*base, "--mw", "6.5"])
    assert p.returncode == 2 and "--mw describe the synthetic grid" in p.stdout, p.stdout


def test_a_corrupt_record_is_recorded_and_the_others_run(suite, tmp_path):
    """RSN9002's H1 file made unreadable ('zz' among the numbers): its two rows (h1, h2) are failed
    with status 1 (record) and a message naming the file and line; the 4 other rows are computed;
    the run exits 0 and says which record it could not read."""
    at2 = Path(suite) / "RSN9002_PULSE_B-N.AT2"
    lines = at2.read_text().splitlines()
    lines[6] = "zz " + lines[6]
    at2.write_text("\n".join(lines) + "\n")
    out = tmp_path / "bad.h5"
    p = _ok(_serial(["--records", str(suite), *QUIET, "--out", str(out)]))
    assert "record RSN9002 cannot be read" in p.stdout and "2 failed" in p.stdout
    r = load(out)
    s = r.samples
    assert len(r) == 6 and r.complete
    bad = s["record_id"] == "RSN9002"
    assert list(s["component"][bad]) == ["h1", "h2"]
    assert (s["status"][bad] == R.STATUS_RECORD_FAILED).all()
    assert all("RSN9002_PULSE_B-N.AT2, line 7" in m and "'zz' is not a number" in m for m in s["message"][bad])
    assert (s["status"][~bad] == 0).all() and np.isfinite(s["u_top"][~bad]).all()
    assert s["mw"][bad][0] == 7.0 and s["event"][bad][0] == "Pulse Quake"  # metadata kept from the table


def test_in_process_rows_equal_run_suite_and_a_raising_function_keeps_the_identity(suite, tmp_path):
    """In process (grid.run_grid with a RecordGridSpec): the grid's rows are sample.run_suite's rows
    (one definition of a record sample, bitwise); a sample function that raises on a row leaves that
    row with status 9, the exception text, and the row's identity (record, component, scale)."""
    from pycolfrag.solver import sample
    spec = grid.RecordGridSpec(records=str(suite), scales=(1.0,), periods_s=(0.5, 1.0))
    out = tmp_path / "p.h5"
    grid.run_grid(spec, out, progress=False, log=lambda s: None)
    r = load(out)
    t = sample.run_suite(spec.suite, periods_s=(0.5, 1.0))
    for k in ("pga_g", "pgv_cm_s", "u_top", "u_d", "n_steps", "scale", "mw"):
        np.testing.assert_array_equal(r.samples[k], t[k], err_msg=k)
    np.testing.assert_array_equal(r.spectra["sa_g"], t["sa_g"])
    assert list(r.samples["record_id"]) == t["record_id"]

    def boom(ctx, row):
        if row == 3:
            raise RuntimeError("forced failure of row 3")
        return grid.run_record_row(ctx, row)
    out2 = tmp_path / "q.h5"
    grid.run_grid(spec, out2, sample_fn=boom, progress=False, log=lambda s: None)
    s = load(out2).samples
    assert s["status"][3] == R.STATUS_OTHER_FAILED and "forced failure of row 3" in s["message"][3]
    assert (s["record_id"][3], s["component"][3], s["scale"][3], s["record"][3]) == ("RSN9002", "h2", 1.0, 1)
    assert s["mw"][3] == 7.0 and (np.delete(s["status"], 3) == 0).all()


def test_record_file_rebuilt_from_its_journal(tmp_path):
    """A record-suite file whose HDF5 part is lost (killed during its creation or deleted) is read
    from the journal alone and rebuilt on resume in the records layout, string fields included:
    the layout travels in the journal header's attributes."""
    out = tmp_path / "j.h5"
    sig = {"kind": "records", "suite": {"records": [["A", 0.01, 10, "x", ""]]}}
    w = R.open_for_run(out, sig, {"layout": "records"}, 2, [1.0], log=lambda s: None)
    w.add([{"row": 1, "record": 0, "record_id": "A", "event": "Événement", "component": "h2", "scale": 2.0,
            "status": 0, "pga_g": 0.5, "sa_g": [1.5]}])
    w.close()   # no finish: the journal holds the row
    out.unlink()
    with pytest.warns(UserWarning, match="from the journal"):
        r = load(out)
    assert r.attrs["layout"] == "records" and list(r.rows) == [1]
    assert r.samples["event"][0] == "Événement" and r.samples["scale"][0] == 2.0
    w = R.open_for_run(out, sig, {"layout": "records"}, 2, [1.0], log=lambda s: None)
    w.close()
    r = load(out)
    assert set(r.samples) == set(R.RECORD_SAMPLE_FIELDS) and r.samples["component"][0] == "h2"
    assert r.spectra["sa_g"][0, 0] == 1.5


@pytest.mark.mpi
def test_record_grid_sigterm_under_mpirun_then_resume_on_two_ranks(suite, tmp_path):
    """SIGTERM to mpirun part-way (rows slowed to 0.15 s), then the same command on 2 ranks: the
    rows kept from before are unchanged and the completed file equals a serial uninterrupted run.
    48 rows (3 records x 2 components x 8 scales): the drain finishes the chunks in flight (at most a
    worker's two chunks of 8 and rank 0's), so fewer than all are done when the ranks have gone."""
    out = tmp_path / "term.h5"
    scales = ["0.5", "0.75", "1", "1.25", "1.5", "1.75", "2", "2.5"]
    args = ["--records", str(suite), "--scale", *scales, "--sample-function", "record_grid_fakes:slow",
            *QUIET, "--out", str(out)]
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed")
    cmd = ["timeout", "-k", "10", "120", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py",
           str(SCRIPT), *args]
    _kill_after(cmd, _env(PCF_FAKE_SLEEP_S="0.15"), out, 4, signal.SIGTERM)
    before = load(out)
    assert 4 <= len(before) < 48, len(before)
    _ok(_mpirun(2, args, PCF_FAKE_SLEEP_S="0"))
    after = load(out)
    assert after.complete and len(after) == 48 and (after.samples["status"] == 0).all()
    _same_rows(before, after, rows=before.rows)
    fresh = tmp_path / "fresh.h5"
    _ok(_serial([*args[:-1], str(fresh)]))
    _same_rows(load(fresh), after)


def test_ranks_that_read_another_suite_are_refused(suite, tmp_path):
    """Every rank reads the suite itself; rank 0 compares the ranks' signatures before touching the
    file. A stand-in communicator (rank 0 of 2) whose other rank reports another signature: the run is
    refused with ParameterError and no file is made."""
    spec = grid.RecordGridSpec(records=str(suite))

    class Comm:
        def Get_rank(self):
            return 0

        def Get_size(self):
            return 2

        def gather(self, x, root=0):
            return [x, x.replace("RSN9001", "RSN9999")]

        def bcast(self, x, root=0):
            return x

    out = tmp_path / "x.h5"
    with pytest.raises(grid.ParameterError, match=r"ranks \[1\] read other inputs"):
        grid.run_grid(spec, out, comm=Comm(), progress=False, log=lambda s: None)
    assert not out.exists()
