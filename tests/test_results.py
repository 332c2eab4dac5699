"""pycolfrag.results: the HDF5 layout, the journal, rebuilding after a kill, load().

The damage cases are the ones a kill can leave (docs/results_format.md): an HDF5 file that lags the
journal, an HDF5 file that no longer opens, a journal whose last line was cut mid-write.
"""
import math

import h5py
import numpy as np
import pytest

from pycolfrag import ResultsFileError
from pycolfrag import results as R
from pycolfrag.analysis.data import load

SIG = {"grid": "tiny", "samples": 3}
PERIODS = [0.5, 1.0, 2.0]


def _row(i, **kw):
    r = {"row": i, "scenario": i // 3, "sample": i % 3, "mw": 6.0, "dist_km": 10.0, "status": 0, "message": "",
         "u_top": 0.01 * (i + 1), "u_d": 0.001 * i, "collapsed": i == 2, "pga_g": 0.1 + i,
         "sa_g": np.array([1.0, 2.0, 3.0]) * i, "sv_cm_s": np.array([4.0, 5.0, 6.0]), "wall_s": 0.5}
    r.update(kw)
    return r


def _new(path, n=6):
    return R.open_for_run(path, SIG, {"seed": 1, "n_ranks": 1, "mw": [6.0]}, n, PERIODS)


def test_new_file_has_pending_rows_and_every_field(tmp_path):
    p = tmp_path / "r.h5"
    w = _new(p)
    assert not w.done.any() and not w.resumed
    w.close()
    with h5py.File(p, "r") as f:
        assert set(f["samples"]) == set(R.SAMPLE_FIELDS)
        assert (f["samples/status"][...] == R.STATUS_PENDING).all()
        assert np.isnan(f["samples/u_top"][...]).all()
        assert f["spectra/sa_g"].shape == (6, 3)
        assert list(f["spectra"].attrs["periods_s"]) == PERIODS
        assert f.attrs["seed"] == 1 and not f.attrs["complete"]
    assert len(load(p)) == 0 and len(load(p, pending=True)) == 6


def test_rows_round_trip_exactly_through_journal_and_hdf5(tmp_path):
    p = tmp_path / "r.h5"
    w = _new(p)
    x = 0.1 + 0.2  # not representable in few digits: JSON must keep every bit
    w.add([_row(1, u_top=x, message="ValueError: é" * 50), _row(4, status=3, u_top=math.nan)])
    lagging = load(p, journal=False)  # not flushed yet: only the journal has them
    assert len(lagging) == 0
    via_journal = load(p)
    w.flush()
    via_h5 = load(p, journal=False)
    for r in (via_journal, via_h5):
        assert list(r.rows) == [1, 4]
        assert r.samples["u_top"][0] == x and math.isnan(r.samples["u_top"][1])
        assert list(r.samples["status"]) == [0, 3]
        assert r.samples["message"][0].startswith("ValueError: é")
        assert len(r.samples["message"][0].encode()) <= R.MESSAGE_BYTES
        assert np.array_equal(r.spectra["sa_g"][0], [1.0, 2.0, 3.0])
    w.finish()
    assert R.journal_path(p).exists()  # not complete: the journal stays


def test_complete_run_deletes_the_journal(tmp_path):
    p = tmp_path / "r.h5"
    w = _new(p, n=2)
    w.add([_row(0), _row(1)])
    w.finish({"n_ranks": 2})
    r = load(p)
    assert r.complete and r.attrs["n_ranks"] == 2 and r.attrs["n_done"] == 2
    assert not R.journal_path(p).exists()


def test_unreadable_hdf5_is_rebuilt_from_the_journal(tmp_path):
    p = tmp_path / "r.h5"
    w = _new(p)
    w.add([_row(0), _row(2)])
    w.flush()
    w.add([_row(5)])  # journalled only
    w.close()
    p.write_bytes(p.read_bytes()[:300])  # a kill in the middle of an HDF5 write
    r = load(p)  # readers fall back to the journal
    assert list(r.rows) == [0, 2, 5]
    w = R.open_for_run(p, SIG, {}, 6, PERIODS)
    assert list(np.flatnonzero(w.done)) == [0, 2, 5]
    w.close()
    r = load(p, journal=False)
    assert list(r.rows) == [0, 2, 5] and r.attrs["rebuilt_from_journal"]
    assert r.samples["collapsed"][1] and r.attrs["seed"] == 1


def test_cut_journal_line_is_ignored_and_trimmed(tmp_path):
    p = tmp_path / "r.h5"
    w = _new(p)
    w.add([_row(0), _row(1)])
    w.close()
    jp = R.journal_path(p)
    data = jp.read_bytes()
    jp.write_bytes(data[:-20])  # the last row lost its tail
    header, rows = R.read_journal(jp)
    assert header is not None and list(rows) == [0]
    w = R.open_for_run(p, SIG, {}, 6, PERIODS)  # trims, then appends after the last good line
    w.add([_row(3)])
    w.close()
    assert list(R.read_journal(jp)[1]) == [0, 3]


def test_other_run_and_foreign_files_are_refused(tmp_path):
    p = tmp_path / "r.h5"
    _new(p).close()
    with pytest.raises(ResultsFileError, match="samples: file has 3, this run asks for 4"):
        R.open_for_run(p, {"grid": "tiny", "samples": 4}, {}, 8, PERIODS)
    R.open_for_run(p, {"grid": "tiny", "samples": 4}, {}, 8, PERIODS, overwrite=True).close()
    assert len(load(p, pending=True)) == 8
    q = tmp_path / "foreign.h5"
    with h5py.File(q, "w") as f:
        f["x"] = 1
    with pytest.raises(ResultsFileError, match="not a pycolfrag grid results file"):
        R.open_for_run(q, SIG, {}, 6, PERIODS)
    with pytest.raises(ResultsFileError):
        load(q)


def test_journal_wins_over_a_damaged_hdf5_row(tmp_path):
    # a field of a finished row changed in the HDF5 file (a kill mid-batch leaves its rows pending, since
    # status is written last; this is damage): the row fails its checksum, and readers and the resume
    # take every journalled row from the journal
    p = tmp_path / "r.h5"
    w = _new(p)
    w.add([_row(1, gamma=2.5)])
    w.flush()
    w.close()
    with h5py.File(p, "r+") as f:
        f["samples/gamma"][1] = np.nan
    with pytest.raises(R.ResultsDamagedError, match=r"checksum mismatch in 1 finished row\(s\) \(1\)"):
        load(p, journal=False)
    assert math.isnan(load(p, journal=False, verify=False).samples["gamma"][0])
    with pytest.warns(UserWarning, match="the rows come from the journal"):
        assert load(p).samples["gamma"][0] == 2.5
    with pytest.warns(UserWarning, match="rebuilding it from r.h5.journal"):
        R.open_for_run(p, SIG, {}, 6, PERIODS).close()  # the resume rebuilds the file from the journal
    assert load(p, journal=False).samples["gamma"][0] == 2.5


def test_resuming_a_finished_file_journals_its_rows_first(tmp_path):
    # A finished run has no journal. Rerunning it (figures, --retry-failed) writes the HDF5 file
    # again; a kill in that write must not cost the finished rows: the new journal holds them.
    p = tmp_path / "r.h5"
    w = _new(p, n=3)
    w.add([_row(0), _row(1, status=3, message="SolverError: x"), _row(2, gamma=0.1 + 0.2)])
    w.finish()
    assert not R.journal_path(p).exists()
    before = load(p)
    R.open_for_run(p, SIG, {}, 3, PERIODS).close()  # resumed, then killed before finish()
    p.write_bytes(p.read_bytes()[:300])  # ... in the middle of an HDF5 write
    w = R.open_for_run(p, SIG, {}, 3, PERIODS)
    assert w.done.all()
    w.close()
    after = load(p, journal=False)
    assert after.attrs["rebuilt_from_journal"] and after.attrs["seed"] == 1
    for name, v in before.samples.items():
        assert np.array_equal(v, after.samples[name], equal_nan=v.dtype.kind == "f"), name
    for name, v in before.spectra.items():
        assert np.array_equal(v, after.spectra[name], equal_nan=True), name
