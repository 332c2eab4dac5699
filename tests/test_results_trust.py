"""What a results file proves about itself, and who may write it: the defects a hostile run of the
project found in them, each with the reproduction it reported.

* checksums: a file without its ``checksums`` attribute read silently; an edited finished row of an
  interrupted file without a journal was kept, and the resume wrote fresh checksums over it;
* one writer: two runs on two hard links of one file both wrote (exit 4 for both, an orphaned journal);
* the salvage hint: the report and the risk command said only "checksum mismatch" of a tampered file;
* completeness: a reader must say how many rows a file lacks, so outputs can refuse or mark it.

Files are written through the writer itself (:func:`pycolfrag.results.open_for_run`), in this process:
a few rows of the synthetic layout whose values are set here.
"""
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.completeness import IncompleteResultsError, check_complete, incomplete_note
from pycolfrag.analysis.data import load, read_results
from pycolfrag.results.checksums import store_checksums

ROOT = Path(__file__).resolve().parents[1]
SIG = {"grid": "tiny", "samples": 3}
PERIODS = [0.5, 1.0, 2.0]


def _row(i, **kw):
    r = {"row": i, "scenario": i // 3, "sample": i % 3, "mw": 6.0 + i // 3, "dist_km": 10.0, "status": 0,
         "message": "", "u_top": 0.01 * (i + 1), "u_d": 0.001 * i, "collapsed": False, "pga_g": 0.1 + i,
         "sa_g": np.array([1.0, 2.0, 3.0]) * i, "sv_cm_s": np.array([4.0, 5.0, 6.0]), "wall_s": 0.5}
    r.update(kw)
    return r


def _open(path, n=6):
    return R.open_for_run(path, SIG, {"seed": 1, "n_ranks": 1}, n, PERIODS)


def _complete(path, n=6):
    w = _open(path, n)
    w.add([_row(i) for i in range(n)])
    w.finish()
    return path


def _interrupted(path, n=6, done=3, journal=False):
    """``done`` of ``n`` rows in the HDF5 file; the journal deleted unless ``journal``."""
    w = _open(path, n)
    w.add([_row(i) for i in range(done)])
    w.flush()
    w.close()
    if not journal:
        R.journal_path(path).unlink()
    return path


# ------------------------------------------------------------------------------ checksums


@pytest.mark.parametrize("state", ["complete", "interrupted"])
def test_a_file_without_its_checksums_attribute_is_damaged(tmp_path, state):
    # Reported: deleting the checksums attribute made the file read silently.
    p = _complete(tmp_path / "r.h5") if state == "complete" else _interrupted(tmp_path / "r.h5")
    with h5py.File(p, "r+") as f:
        del f.attrs["checksums"]
    before = p.read_bytes()
    for read in (load, read_results):  # read_results reads files of other code too (any_layout)
        with pytest.raises(R.ResultsDamagedError, match="no checksums attribute .*nothing it holds can be verified"):
            read(p)
    with pytest.raises(R.ResultsDamagedError, match=r"no journal to rebuild it from.*load\('.*r\.h5', verify=False\)"):
        _open(p)
    assert p.read_bytes() == before and not R.journal_path(p).exists()  # the resume left it as it was
    assert len(load(p, verify=False)) == (6 if state == "complete" else 3)  # the salvage the error names


def test_an_edited_row_of_an_interrupted_file_without_journal_is_not_resumed(tmp_path):
    # Reported: in an interrupted file without a journal, an edited finished row was kept and the
    # resume wrote fresh checksums over it. Its row checksum (written with the row) fails now.
    p = _interrupted(tmp_path / "r.h5")
    good = load(p)
    with h5py.File(p, "r+") as f:
        f["samples/u_top"][1] = 123.0
    before = p.read_bytes()
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(1\)"):
        load(p)
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(1\).*no journal"):
        _open(p)
    assert p.read_bytes() == before and not R.journal_path(p).exists()
    salvaged = load(p, verify=False)
    assert salvaged.samples["u_top"][1] == 123.0 and salvaged.samples["u_top"][0] == good.samples["u_top"][0]


@pytest.mark.parametrize("change", ["status", "spectra", "message"])
def test_every_part_of_a_finished_row_is_under_its_checksum(tmp_path, change):
    """The status (a failed row made "ok"), a spectral value and a text field: each is part of the row's bytes."""
    p = _interrupted(tmp_path / "r.h5")
    with h5py.File(p, "r+") as f:
        if change == "status":
            f["samples/status"][2] = 3
        elif change == "spectra":
            f["spectra/sa_g"][2, 1] = 7.0
        else:
            f["samples/message"][2] = b"edited"
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(2\)"):
        load(p)


def test_a_pending_row_marked_done_fails_its_checksum(tmp_path):
    # A pending row has checksum 0, which no row's bytes give here: status bytes set to "ok" by damage
    p = _interrupted(tmp_path / "r.h5")
    with h5py.File(p, "r+") as f:
        f["samples/status"][4] = 0
        f["samples/scenario"][4] = 1   # with an identity, so the status check of the layout does not catch it
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(4\)"):
        load(p)


def test_removed_row_checksums_or_dataset_checksums_are_damage(tmp_path):
    p = _interrupted(tmp_path / "a.h5")
    with h5py.File(p, "r+") as f:
        del f[R.layout.ROW_CRC]
        store_checksums(f, datasets=False)  # the attributes' checksums made to agree: only the rows' are gone
    with pytest.raises(R.ResultsDamagedError, match="checksums cover no dataset and it has no row checksums"):
        load(p)
    # a complete file whose dataset checksums were cut out of its checksums attribute falls back to the
    # row checksums, and an edited row is caught by them
    q = _complete(tmp_path / "b.h5")
    with h5py.File(q, "r+") as f:
        f["samples/u_d"][5] = 1.0
        store_checksums(f, datasets=False)
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(5\)"):
        load(q)


@pytest.mark.parametrize("mark", ["run_id", "row_crc32"])
def test_files_that_carry_no_checksums_by_rule(tmp_path, mark):
    """The stated rule: a file of the documented layout written by other code -- neither a ``run_id`` nor a
    ``/row_crc32``, which the grid's writer stores in every file it creates; a ``grid_signature`` of its
    own is allowed -- has nothing to verify and reads as it is; the same file with either mark claims to
    be the writer's and is damaged without checksums."""
    p = tmp_path / "other.h5"
    cols, spectra = R.empty_columns(2, len(PERIODS))
    for i in range(2):
        R.layout.put_row(cols, spectra, i, _row(i))
    with h5py.File(p, "w") as f:
        for name, v in cols.items():
            f.create_dataset(f"samples/{name}", data=v)
        f.attrs["grid_signature"] = '{"seed": 1}'
    assert load(p, any_layout=True).samples["u_top"].tolist() == [0.01, 0.02]
    assert load(p).samples["u_top"].tolist() == [0.01, 0.02]
    with h5py.File(p, "r+") as f:
        if mark == "run_id":
            f.attrs["run_id"] = "0123"
        else:
            f[mark] = np.zeros(2, dtype="u4")
    with pytest.raises(R.ResultsDamagedError, match="no checksums attribute"):
        load(p, any_layout=True)


def test_a_complete_file_of_format_1_reads_and_its_resume_adds_row_checksums(tmp_path):
    """Format 1 (before /row_crc32): a complete file is verified by its dataset checksums; a resume, which
    writes into it, first adds the checksums of its rows, so the file stays verifiable while it is open."""
    p = _complete(tmp_path / "r.h5")
    good = load(p)
    with h5py.File(p, "r+") as f:
        del f[R.layout.ROW_CRC]
        f.attrs["format_version"] = 1
        store_checksums(f, datasets=True)
    assert load(p).samples["u_top"].tolist() == good.samples["u_top"].tolist()
    w = _open(p)
    w.flush({"note": "resumed"})  # an attribute write: the file is no longer sealed by dataset checksums
    w.close()
    r = load(p, journal=False)
    assert r.attrs["format_version"] == R.FORMAT_VERSION and r.attrs["note"] == "resumed"
    assert r.samples["u_top"].tolist() == good.samples["u_top"].tolist()


# ------------------------------------------------------------------------------ one writer


def test_a_hard_link_to_a_file_being_written_meets_its_lock(tmp_path):
    # Reported: two runs on a hard link of the same file both wrote (exit 4 for both, an orphaned
    # journal): the lock was <name>.lock, one per name. The file's inode is locked too now.
    p, q = tmp_path / "r.h5", tmp_path / "link.h5"
    w = _open(p)  # creates the file: a new inode, locked after it exists
    w.add([_row(0)])
    w.flush()
    os.link(p, q)
    with pytest.raises(R.ResultsLockedError, match=rf"another name of the same file .*hard link\): pid {os.getpid()} "
                                                   r".*\(as r\.h5\)"):
        _open(q)
    assert not R.journal_path(q).exists() and not R.lock_path(q).exists()
    assert R.lock_held(q)
    w.close()
    assert not R.lock_held(q)
    _open(q).close()  # the run on the other name is over: this one may write


def test_a_hard_link_to_an_interrupted_file_is_refused_before_anything_is_read(tmp_path):
    """A resume is the case that wrote before: the run on the second name found no journal beside its
    name and started one (the orphan), then wrote the HDF5 file. The inode lock comes first now."""
    p, q = _interrupted(tmp_path / "r.h5", journal=True), tmp_path / "link.h5"
    os.link(p, q)
    w = _open(p)
    assert list(np.flatnonzero(w.done)) == [0, 1, 2]
    with pytest.raises(R.ResultsLockedError, match="hard link"):
        _open(q)
    assert not R.journal_path(q).exists()
    w.close()


def test_a_file_that_does_not_exist_yet_is_locked_under_every_name_of_its_folder(tmp_path):
    """The lock sidecar lives in the folder, which any name of it reaches: a second run through a
    symlinked folder meets the first run's lock before either has created the file."""
    (tmp_path / "d").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "d")
    lock = R.RunLock.acquire(tmp_path / "d" / "new.h5")
    try:
        assert not (tmp_path / "d" / "new.h5").exists()
        with pytest.raises(R.ResultsLockedError, match=f"pid {os.getpid()}"):
            _open(tmp_path / "alias" / "new.h5")
    finally:
        lock.release()
    _open(tmp_path / "alias" / "new.h5").close()


# ------------------------------------------------------------------------------ the salvage hint


def _tampered(tmp_path):
    p = _complete(tmp_path / "grid.h5")
    with h5py.File(p, "r+") as f:
        f["samples/u_top"][3] = 0.5
    return p


@pytest.mark.parametrize("command", [
    ["-m", "pycolfrag.analysis.report", "{h5}", "{tmp}/report.md"],
    ["-m", "pycolfrag.risk.site_risk", str(ROOT / "examples" / "site_athens.toml"), "{h5}", "{tmp}/risk"],
])
def test_readers_of_a_tampered_file_say_how_to_salvage_it(tmp_path, command):
    # Reported: the report and risk on a tampered file said only "checksum mismatch". The hint is in
    # the error itself, so every reader shows it without code of its own.
    p = _tampered(tmp_path)
    args = [a.format(h5=p, tmp=tmp_path) for a in command]
    out = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert out.returncode == 2, out.stdout + out.stderr
    err = " ".join(out.stderr.split())
    assert "checksum mismatch in samples/u_top" in err and "there is no journal to rebuild it from" in err, err
    assert f"pycolfrag.analysis.data.load('{p}', verify=False)" in err and f"mv {p} {p}.damaged" in err, err
    assert "Traceback" not in out.stderr


def test_the_hint_survives_the_reading_child_and_names_a_journal_beside_the_file(tmp_path):
    p = _interrupted(tmp_path / "r.h5", journal=True)
    with h5py.File(p, "r+") as f:
        f["samples/u_top"][0] = 9.0
    with pytest.raises(R.ResultsDamagedError) as info:
        R.read_h5_bounded(p)
    e = info.value
    assert e.reason.endswith("they changed after they were written (damaged on disk or edited)")
    assert str(e).startswith(e.reason + ". The file is left as it is and its journal r.h5.journal lies beside it")


# ------------------------------------------------------------------------------ completeness


def test_readers_say_how_many_rows_a_file_lacks(tmp_path):
    # Reported: risk on an interrupted grid (33 of 36 rows) gave another rate, unmarked. The readers
    # count the rows not computed yet; the outputs refuse or mark the file with these.
    p = _interrupted(tmp_path / "r.h5", journal=True)
    w = _open(p)
    w.add([_row(3)])  # journalled only: a killed run's rows count as computed
    w.close()
    r, d = load(p), read_results(p)
    for x in (r, d):
        assert (x.n_rows, x.n_missing, x.complete) == (6, 2, False)
        assert incomplete_note(x, p) == (f"INCOMPLETE RESULTS: {p} holds 4 of the 6 rows (its run was interrupted or "
                                         "is still going); every number here changes when the remaining rows are "
                                         "computed")
    with pytest.raises(IncompleteResultsError, match="a report refused: .* 4 of the 6 rows .*--allow-incomplete"):
        check_complete(d, False, "a report")
    assert check_complete(d, True, "a report").startswith("INCOMPLETE RESULTS: ")
    w = _open(p)
    w.add([_row(4), _row(5)])
    w.finish()
    r, d = load(p), read_results(p)
    for x in (r, d):
        assert (x.n_rows, x.n_missing, x.complete, incomplete_note(x)) == (6, 0, True, "")
    assert check_complete(d, False, "a report") == ""
