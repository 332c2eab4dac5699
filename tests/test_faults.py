"""Fault injection: the grid and its results file under the faults a hostile or unlucky user meets.

Each case ends with no finished row lost and no row of another run kept: "finished" means the row
reached rank 0's journal before the fault; "kept" rows are compared bit for bit (all fields but
``wall_s``) with an uninterrupted run of the same arguments. Grids use the fake sample function of
``tests/grid_fakes.py`` (no physics: deterministic numbers from the row's seeds, optional sleep per
row so a run can be hit part-way), so every case takes seconds.

Cases: two runs on one path (the lock, and the silent-corruption scenario: seed 1, then seed 2 with
--overwrite on the same path, killed and resumed), a stale lock, a stale journal of another run,
a journal with a bad header, a damaged HDF5 file (hang and silent zeroes), kill -9 of each rank
under ``mpirun -n 2``, a full disk and a read-only folder (tmpfs mounts, root only), arguments
refused before any file is made, and the hostile inputs of ``read_at2`` and ``Column``.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import h5py
import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.data import load
from pycolfrag.core.errors import ParameterError, RecordFileError, ResultsFileError
from test_grid import ROOT, SCRIPT, _env, _journal_rows, _ok, _same_rows, _serial

# 2 Mw x 2 R x 4 samples = 16 rows of the fake sample function
FAKE = ["--mw", "6", "7", "--dist", "5", "10", "--samples", "4", "--sample-function", "grid_fakes:fake",
        "--no-figures", "--no-progress", "--flush-s", "0.2"]
PERIODS = [0.5, 1.0, 2.0]
SIG_A = {"grid": "tiny", "samples": 3, "seed": 1}
SIG_B = {"grid": "tiny", "samples": 3, "seed": 2}


def _row(i, **kw):
    r = {"row": i, "scenario": i // 3, "sample": i % 3, "mw": 6.0, "dist_km": 10.0, "status": 0, "message": "",
         "u_top": 0.01 * (i + 1), "sa_g": np.array([1.0, 2.0, 3.0]) * i, "sv_cm_s": np.ones(3), "wall_s": 0.5}
    r.update(kw)
    return r


def _start(args, **env):
    """A serial grid in the background (this process's child: its pid is the lock holder's)."""
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


def _wait_gone(pids, limit_s, message):
    """Wait until none of ``pids`` exists any more; fail with ``message`` after ``limit_s`` seconds."""
    t0 = time.time()
    while any(Path(f"/proc/{r}").exists() for r in pids):
        assert time.time() - t0 < limit_s, message
        time.sleep(0.1)


def _fresh(tmp_path, args, name="fresh.h5"):
    """The same grid, uninterrupted, in another file: the reference for every kept row."""
    out = tmp_path / name
    _ok(_serial([*args, "--out", str(out)]))
    return load(out)


# ------------------------------------------------------------------------------ the lock

def test_second_run_on_one_path_is_refused_naming_the_holder(tmp_path):
    out = tmp_path / "g.h5"
    a = _start([*FAKE, "--out", str(out)], PCF_FAKE_SLEEP_S="1")  # 16 s: outlives the checks below
    try:
        _wait_rows(out, 1, a)
        p = _serial([*FAKE, "--out", str(out)])
        assert p.returncode == 5, p.stdout + p.stderr
        line = p.stdout.strip().splitlines()[-1]
        assert f"pid {a.pid} on host {os.uname().nodename}, started 20" in line, line
        p = _serial([*FAKE, "--overwrite", "--seed", "2", "--out", str(out)])  # --overwrite does not break in
        assert p.returncode == 5, p.stdout + p.stderr
        assert a.poll() is None  # the holder was running all along
    finally:
        _kill9(a)  # its flock dies with it; the lock file stays, naming a dead pid
    before = load(out)
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert f"took over a stale lock on {out} left by pid {a.pid}" in p.stdout and "no longer running" in p.stdout
    r = load(out)
    assert r.complete and len(r) == 16 and not R.lock_path(out).exists()
    _same_rows(before, r, rows=before.rows)


def test_stale_lock_of_a_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "g.h5"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # its pid no longer exists (and held no flock)
    R.lock_path(out).write_text(json.dumps({"pid": dead.pid, "host": os.uname().nodename,
                                            "started": "2026-01-01T00:00:00Z"}))
    msgs = []
    w = R.open_for_run(out, SIG_A, {}, 6, PERIODS, log=msgs.append)
    assert any("stale lock" in m and f"pid {dead.pid}" in m and "no longer running" in m for m in msgs), msgs
    assert json.loads(R.lock_path(out).read_text())["pid"] == os.getpid()
    with pytest.raises(R.ResultsLockedError, match=f"pid {os.getpid()} on host"):
        R.open_for_run(out, SIG_A, {}, 6, PERIODS)  # a second writer, even in the same process
    w.finish()
    assert not R.lock_path(out).exists()


def test_scenario_1_two_seeds_on_one_path_overwrite_kill_resume(tmp_path):
    # The silent-corruption report: run seed 1; start seed 2 with --overwrite on the same path while
    # it runs; kill -9 the seed-2 run; rerun seed 2. Without the lock the file ended "120 of 120 rows
    # done", signed seed 2, with 29 seed-1 rows in it (run 1 kept writing its batches into the new file).
    out = tmp_path / "g.h5"
    seed1 = [*FAKE, "--seed", "1", "--out", str(out)]
    seed2 = [*FAKE, "--seed", "2", "--out", str(out)]
    a = _start(seed1, PCF_FAKE_SLEEP_S="0.5")  # 8 s: outlives the start of run 2
    try:
        _wait_rows(out, 2, a)
        b = _start([*seed2, "--overwrite"], PCF_FAKE_SLEEP_S="0.1")
        b_out, _ = b.communicate(timeout=60)
        assert b.returncode == 5 and f"pid {a.pid}" in b_out, b_out  # refused: run 1 holds the path
    finally:
        a.wait(timeout=60)
    assert a.returncode == 0 and load(out).attrs["seed"] == 1
    b = _start([*seed2, "--overwrite"], PCF_FAKE_SLEEP_S="0.1")
    _wait_rows(out, 5, b)
    _kill9(b)
    n_before = _journal_rows(out)
    before = load(out)
    assert before.attrs["seed"] == 2 and 5 <= len(before) < 16
    p = _ok(_serial(seed2))
    assert f"{len(before)} of 16 rows already done" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and after.attrs["seed"] == 2 and len(after) == 16 and n_before >= 5
    ref = _fresh(tmp_path, [*FAKE, "--seed", "2"])
    _same_rows(ref, after)  # every row is seed 2's: no foreign row kept
    _same_rows(before, after, rows=before.rows)  # and none finished before the kill lost


def test_a_writer_never_writes_into_a_file_another_run_replaced(tmp_path):
    # Without the lock (e.g. two hosts on a file system without flock), a run that replaces the
    # file must not receive the first run's rows, and the first run must not delete its journal.
    p = tmp_path / "r.h5"
    w = R.open_for_run(p, SIG_A, {}, 6, PERIODS)
    w.add([_row(0)])
    w.flush()
    R.create(p, SIG_B, {}, 6, PERIODS)  # another run replaces file and journal behind w's back
    w.add([_row(1, u_top=99.0)])
    with pytest.raises(ResultsFileError, match="replaced by another run"):
        w.flush()
    w.close()
    header, rows = R.read_journal(R.journal_path(p))
    assert header["signature"] == SIG_B and rows == {}
    assert len(load(p)) == 0  # nothing of run A in run B's file


def test_finish_leaves_the_journal_of_another_run_alone(tmp_path):
    p = tmp_path / "r.h5"
    w = R.open_for_run(p, SIG_A, {}, 2, PERIODS)
    w.add([_row(0), _row(1)])
    w.flush()
    # a journal of another run (another run_id) appears at the path
    q = tmp_path / "q.h5"
    R.create(q, SIG_B, {}, 2, PERIODS)
    shutil.copy(R.journal_path(q), R.journal_path(p))
    with pytest.warns(UserWarning, match="belongs to another run"):
        w.finish()
    assert R.journal_path(p).exists() and R.read_journal(R.journal_path(p))[0]["signature"] == SIG_B


# ------------------------------------------------------------------------------ journals

def test_stale_journal_of_another_run_is_never_merged(tmp_path):
    p = tmp_path / "r.h5"
    w = R.open_for_run(p, SIG_B, {"seed": 2}, 6, PERIODS)
    w.add([_row(0), _row(1)])
    w.flush()
    w.close()  # a partial seed-2 file with its journal
    for sig in (SIG_A, SIG_B):  # another seed; the same signature but another file's lineage (run_id)
        q = tmp_path / f"other-{sig['seed']}.h5"
        wq = R.open_for_run(q, sig, {}, 6, PERIODS)
        wq.add([_row(i, u_top=99.0) for i in range(6)])
        wq.close()
        shutil.copy(R.journal_path(q), R.journal_path(p))  # the stale journal beside the file
        with pytest.warns(UserWarning, match="belongs to another run"):
            r = load(p)
        assert list(r.rows) == [0, 1] and not (r.samples["u_top"] == 99.0).any()
        msgs = []
        w = R.open_for_run(p, SIG_B, {}, 6, PERIODS, log=msgs.append)
        assert list(np.flatnonzero(w.done)) == [0, 1]
        w.close()
        assert any("set aside" in m and "another run" in m for m in msgs), msgs
        r = load(p)
        assert list(r.rows) == [0, 1] and not (r.samples["u_top"] == 99.0).any()
        assert R.read_journal(R.journal_path(p))[0]["signature"] == SIG_B  # a journal of its own again


@pytest.mark.parametrize("content", [b"", b'{"kind": "pycolfrag-grid-jou', b'{"kind": "pycolfrag-grid-journal"}\n',
                                     b"\x00" * 40 + b"\n" + b'{"row": 0}\n'])
def test_journal_with_a_bad_header_is_set_aside(tmp_path, content):
    # a full disk can cut the header; before the fix every later run crashed (TypeError) until
    # the journal was deleted by hand
    p = tmp_path / "r.h5"
    jp = R.journal_path(p)
    jp.write_bytes(content)
    msgs = []
    w = R.open_for_run(p, SIG_A, {}, 6, PERIODS, log=msgs.append)
    assert not w.resumed
    w.add([_row(0)])
    w.finish()
    aside = list(tmp_path.glob("r.h5.journal.set-aside-*"))
    assert len(aside) == 1 and aside[0].read_bytes() == content
    assert any("set aside" in m and "header" in m for m in msgs), msgs
    assert list(load(p).rows) == [0]
    # beside a readable file, readers ignore it with a warning
    jp.write_bytes(content)
    with pytest.warns(UserWarning, match="journal is ignored"):
        assert list(load(p).rows) == [0]


def test_cut_journal_header_then_grid_rerun_runs(tmp_path):
    out = tmp_path / "g.h5"
    R.journal_path(out).write_bytes(b'{"kind": "pycolfrag-grid-journal", "n_ro')
    p = _ok(_serial([*FAKE, "--out", str(out)]))
    assert "set aside" in p.stdout and "header" in p.stdout, p.stdout
    assert load(out).complete and len(load(out)) == 16


# ------------------------------------------------------------------------------ damaged HDF5

def _zero(path, offset, n=3000):
    with open(path, "r+b") as fh:
        fh.seek(offset)
        fh.write(b"\0" * n)


def _load_in_child(path, timeout_s):
    """load in a child process, so that a hang fails this test instead of stalling it."""
    code = ("import warnings, sys; from pycolfrag import results as R; from pycolfrag.analysis.data import load\n"
            "warnings.simplefilter('ignore')\n"
            "try:\n    r = load(sys.argv[1], timeout_s=float(sys.argv[2])); print('rows', len(r))\n"
            "except R.ResultsDamagedError as e:\n    print('damaged', e)\n")
    t0 = time.time()
    p = subprocess.run([sys.executable, "-c", code, str(path), str(timeout_s)], capture_output=True, text=True,
                       timeout=60, env=_env())
    return p.stdout.strip(), time.time() - t0


def test_damaged_hdf5_neither_hangs_load_nor_resume_and_is_rebuilt(tmp_path):
    # 3000 zeroed bytes at offset 3000 of this layout make the HDF5 library loop forever (found by
    # zeroing 3000 bytes every 1000 bytes of such a file: offsets 3000 and 32000-36000 hang)
    out = tmp_path / "g.h5"
    args = [*FAKE, "--out", str(out)]
    b = _start(args, PCF_FAKE_SLEEP_S="0.05")
    _wait_rows(out, 6, b)
    _kill9(b)
    before = load(out)
    _zero(out, 3000)
    text, took = _load_in_child(out, 3)
    assert text == f"rows {len(before)}" and took < 30, (text, took)  # from the journal alone
    p = _ok(_serial(args, PYCOLFRAG_OPEN_TIMEOUT_S="3"))
    assert "set aside" in p.stdout and "rebuilding it from g.h5.journal" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and len(after) == 16 and after.attrs["rebuilt_from_journal"]
    _same_rows(before, after, rows=before.rows)
    _same_rows(_fresh(tmp_path, FAKE), after)
    # a complete file of one session (no journal left; the layout of the probe above) damaged the
    # same way: reported, never a hang
    fresh = tmp_path / "fresh.h5"
    _zero(fresh, 3000)
    text, took = _load_in_child(fresh, 3)
    assert text.startswith("damaged") and "did not open within 3 s" in text and took < 30, (text, took)
    p = _serial([*FAKE, "--out", str(fresh)], PYCOLFRAG_OPEN_TIMEOUT_S="3")
    assert p.returncode == 2 and "damaged" in p.stdout and "--overwrite" in p.stdout, p.stdout + p.stderr


def test_zeroed_data_of_a_complete_file_fail_its_checksums(tmp_path):
    # zeroes in a dataset's data open without any HDF5 error; status 0 means "ok", so pending or
    # failed rows would silently read as successful zeros
    out = tmp_path / "g.h5"
    _ok(_serial([*FAKE, "--out", str(out)]))
    with h5py.File(out, "r") as f:
        off = f["samples/u_top"].id.get_offset()
    _zero(out, off, 16 * 8)
    with pytest.raises(R.ResultsDamagedError, match="checksum mismatch in samples/u_top"):
        load(out)


# ------------------------------------------------------------------------------ kill -9 under MPI

def _rank_pids(out, marker=b"mpi4py"):
    """pids of the python ranks of an mpirun writing ``out`` (from /proc: argv[0] is this python, and
    ``marker`` -- ``-m mpi4py``'s, or the script's path under plain ``mpirun python script`` -- in argv)."""
    pids = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            argv = (d / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if argv and argv[0].decode(errors="replace") == sys.executable and marker in argv \
                and str(out).encode() in argv:
            pids.append(int(d.name))
    return pids


@pytest.mark.mpi
@pytest.mark.parametrize("victim", ["rank 0", "rank 1"])
def test_kill9_of_either_rank_under_mpirun_loses_no_finished_row(tmp_path, victim):
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    out = tmp_path / "g.h5"
    args = [*FAKE, "--out", str(out)]
    cmd = ["timeout", "-k", "10", "120", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py",
           str(SCRIPT), *args]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S="0.1"), cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        _wait_rows(out, 4, proc)
        rank0 = json.loads(R.lock_path(out).read_text())["pid"]  # the lock names its holder: rank 0
        ranks = _rank_pids(out)
        assert rank0 in ranks and len(ranks) == 2, (rank0, ranks)
        os.kill(rank0 if victim == "rank 0" else next(p for p in ranks if p != rank0), signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    before = load(out)
    assert 4 <= len(before) < 16
    p = _ok(_serial(args))  # rank 0's lock died with it (or was released): the rerun takes the path
    assert f"{len(before)} of 16 rows already done" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(before, after, rows=before.rows)
    _same_rows(_fresh(tmp_path, FAKE), after)


# ------------------------------------------------------------------------------ full disk, read-only folder

@pytest.fixture
def tmpfs(tmp_path):
    """A small tmpfs (root only): yields (mount point, remount function)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root (as a user, permissions cannot emulate a full or read-only disk "
                    "reliably)")
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)], capture_output=True, text=True)
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {p.stderr.strip()}")

    def remount(mode):
        subprocess.run(["mount", "-o", f"remount,{mode}", str(mnt)], check=True)

    try:
        yield mnt, remount
    finally:
        subprocess.run(["umount", "-l", str(mnt)])


def test_full_disk_is_one_clear_line_and_the_rerun_keeps_every_journalled_row(tmp_path, tmpfs):
    mnt, _ = tmpfs
    out = mnt / "g.h5"
    args = [*FAKE, "--out", str(out)]
    b = _start(args, PCF_FAKE_SLEEP_S="0.1")
    _wait_rows(out, 4, b)
    filler = mnt / "filler"
    with open(filler, "wb", buffering=0) as fh:  # fill the disk while the run goes on
        try:
            while True:
                fh.write(b"\0" * 4096)
                fh.flush()
        except OSError:
            pass
    text, _ = b.communicate(timeout=60)
    assert b.returncode == 4, text
    lines = text.strip().splitlines()
    assert "No space left on device" in lines[-1] and str(mnt) in lines[-1], text
    assert "Traceback" not in text
    before = load(out)  # the journal holds every row journalled before the disk filled
    assert len(before) >= 4
    filler.unlink()
    _ok(_serial(args))
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(before, after, rows=before.rows)
    _same_rows(_fresh(tmp_path, FAKE), after)


def test_read_only_folder_is_one_clear_line_and_nothing_is_lost(tmp_path, tmpfs):
    mnt, remount = tmpfs
    out = mnt / "g.h5"
    args = [*FAKE, "--out", str(out)]
    b = _start(args, PCF_FAKE_SLEEP_S="0.05")
    _wait_rows(out, 4, b)
    _kill9(b)
    before = load(out)
    remount("ro")
    try:
        for target in (out, mnt / "sub" / "new.h5"):
            p = _serial([*FAKE, "--out", str(target)])
            assert p.returncode == 4, p.stdout + p.stderr
            line = p.stdout.strip().splitlines()[-1]
            assert "Read-only file system" in line and str(mnt) in line and "Traceback" not in p.stderr, p.stdout
        assert load(out).rows.tolist() == before.rows.tolist()
    finally:
        remount("rw")
    _ok(_serial(args))
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(before, after, rows=before.rows)


# ------------------------------------------------------------------------------ refused up front

@pytest.mark.parametrize("change, expect", [
    (["--seed", str(2**64)], "seed must be an integer in [0, 2**63 - 1], got 18446744073709551616"),
    (["--mw", "9"], "scenario Mw 9, R 5 km is refused: Mw = 9"),
    (["--dist", "100"], "scenario Mw 6, R 100 km is refused: dist_km = 100.0"),
    (["--record-dt", "0.5"], "--record-dt 0.5 s is outside the record generator's range"),
    (["--kn", "1"], "the column collapses under gravity alone"),
    (["--chunk-max", "0"], "--chunk-max must be >= 1, got 0"),
    (["--samples", str(10**9)], "at most 100000000 fit one file"),
])
def test_bad_grid_arguments_are_refused_before_any_file(tmp_path, capsys, change, expect):
    # in process (main() is what scripts/run_grid.py calls), a dozen runs in a second
    from pycolfrag.cli.grid import main
    out = tmp_path / "o" / "g.h5"
    base = ["--mw", "6", "--dist", "5", "--samples", "2", "--no-figures", "--no-progress", "--mpi", "no",
            "--out", str(out)]
    argv = base + change if change[0] not in ("--mw", "--dist") else \
        [a for a in base if a not in ("--mw", "6", "--dist", "5")] + change + (["--dist", "5"] if change[0] == "--mw"
                                                                               else ["--mw", "6"])
    assert main(argv) == 2
    text = capsys.readouterr().out.strip()
    assert len(text.splitlines()) == 1 and expect in text, text
    assert not out.parent.exists() or not any(out.parent.iterdir())  # no .h5, .journal, .tmp or .lock


def test_a_failed_create_leaves_no_journal_or_tmp(tmp_path):
    # a value HDF5 cannot store (here an int beyond int64) used to leave a .journal and a .tmp that
    # made every later run refuse the path
    p = tmp_path / "r.h5"
    with pytest.raises(TypeError, match="no native HDF5 equivalent"):  # h5py's words for it
        R.create(p, SIG_A, {"seed": 2**64}, 6, PERIODS)
    assert list(tmp_path.iterdir()) == []


def test_seed_beyond_int64_from_the_command_line_leaves_no_file(tmp_path):
    out = tmp_path / "g.h5"
    p = _serial([*FAKE, "--seed", str(2**64), "--out", str(out)])
    assert p.returncode == 2 and "seed must be an integer" in p.stdout and "Traceback" not in p.stderr
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------ read_at2

def _at2_header(npts):
    return ("PEER NGA STRONG MOTION DATABASE RECORD\nTEST\nACCELERATION TIME SERIES IN UNITS OF G\n"
            f"NPTS=  {npts}, DT=   .0100 SEC\n")


def test_read_at2_stops_after_npts_values_of_a_huge_file(tmp_path):
    # A 1 GB file with a valid header cost 13.4 GB and 43 s when the reader took the whole file.
    # 50 MB here: the reader must stop at value NPTS + 1, so time and memory do not grow with the file;
    # line 130 is where value 1001 sits (8 values per line from line 5).
    from pycolfrag.ground_motion.at2 import read_at2
    p = tmp_path / "huge.AT2"
    with open(p, "w") as fh:
        fh.write(_at2_header(1000))
        line = "  .1234E-02" * 8 + "\n"
        fh.write(line * (50_000_000 // len(line)))
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(RecordFileError, match="line 130: more values than NPTS = 1000"):
        read_at2(p)
    took = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert took < 2.0 and peak < 5e6, (took, peak)  # the whole file read costs > 500 MB and seconds


def test_read_at2_quotes_a_short_excerpt_of_a_bad_token(tmp_path):
    from pycolfrag.ground_motion.at2 import read_at2
    p = tmp_path / "bad.AT2"
    p.write_text(_at2_header(3) + "  .1E-02  " + "x" * 5_000_000 + "  .2E-02\n")  # one 5 MB "token"
    tracemalloc.start()
    with pytest.raises(RecordFileError) as exc:
        read_at2(p)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    msg = str(exc.value)
    assert "line 5: 'xxxxxxxx" in msg and "...' is not a number" in msg and len(msg) < len(str(p)) + 100, msg
    assert peak < 2e6, peak


# ------------------------------------------------------------------------------ Column input

def _col(**change):
    d = json.loads((ROOT / "pycolfrag" / "data" / "column_parthenon.json").read_text())
    for k, v in change.items():
        where = d
        *path, last = k.split(".")
        for part in path:
            where = where[part]
        where[last] = v
    return d


@pytest.mark.parametrize("change, named", [
    ({"joints.friction_angle_deg": "37"}, "'37'"),
    ({"joints.kn": "1e9"}, "'1e9'"),
    ({"joints.friction_angle_deg": None}, "None"),
    ({"joints.friction_angle_deg": True}, "True"),
    ({"shaft.drum_heights": [0.9, "1", 0.9]}, "'1'"),
    ({"shaft.drum_heights": [0.9, None]}, "None"),
    ({"density": True}, "True"),
    ({"n_sides": 65}, "65"),
    ({"n_sides": True}, "True"),
    ({"capital": {}}, "capital is empty"),
])
def test_column_file_input_is_type_checked_where_it_enters(tmp_path, change, named):
    from pycolfrag import Column
    p = tmp_path / "c.json"
    p.write_text(json.dumps(_col(**change)))
    with pytest.raises(ParameterError, match="^.*" + __import__("re").escape(named)):
        Column.from_file(p)


def test_column_constructors_refuse_strings_none_bools_and_too_many_sides():
    from pycolfrag.structure.column import Column, JointProperties, Segment
    for bad in ("1", None, True):
        with pytest.raises(ParameterError, match=repr(bad)):
            Segment(bad, 0.5, 0.5)
        with pytest.raises(ParameterError, match=repr(bad)):
            JointProperties(friction_deg=bad)
        with pytest.raises(ParameterError, match=repr(bad)):
            Column.from_drums([1.0, 1.0], 1.0, density=bad)
    with pytest.raises(ParameterError, match="n_sides must be an integer in \\[3, 64\\], got 65"):
        Segment(1.0, 0.5, 0.5, 65)
    with pytest.raises(ParameterError, match="65"):
        Column.single_block(1.0, 2.0, n_sides=65)
    j = JointProperties(friction_deg=np.float64(30.0), kn=np.int64(10**9))
    assert type(j.friction_deg) is float and type(j.kn) is float  # numpy numbers are fine, stored as float


@pytest.mark.mpi
def test_ctrl_c_under_mpirun_keeps_every_journalled_row(tmp_path):
    # docs/grid.md says what happens: Ctrl-C signals the whole foreground process group. Measured
    # (Open MPI 4.1.4): mpirun exits at once (exit 1); the ranks do not react to SIGINT, go on for a
    # second or two, then are killed without any cleanup, so rank 0 makes no final HDF5 write (its
    # finally-block never runs) and the HDF5 file lags by up to --flush-s seconds of rows; the
    # journal holds every row that reached rank 0. A rerun while they linger is refused (exit 5).
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    out = tmp_path / "g.h5"
    args = [*FAKE[:-2], "--flush-s", "60", "--out", str(out)]  # no HDF5 batch before the interrupt
    cmd = ["timeout", "-k", "10", "120", "mpirun", "--allow-run-as-root", "-n", "2", sys.executable, "-m", "mpi4py",
           str(SCRIPT), *args]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S="0.2"), cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        _wait_rows(out, 4, proc)
        ranks = _rank_pids(out)
        os.killpg(proc.pid, signal.SIGINT)  # what the terminal does on Ctrl-C
        proc.wait(timeout=60)
        _wait_gone(ranks, 30, "ranks still alive 30 s after Ctrl-C")  # the lingering ranks
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode != 0
    n_journal = _journal_rows(out)
    with h5py.File(out, "r") as f:
        in_h5 = int((f["samples/status"][...] != R.STATUS_PENDING).sum())
    before = load(out)
    assert len(before) == max(n_journal, in_h5) >= 4, (n_journal, in_h5)  # readers see every finished row
    p = _ok(_serial(args))
    assert f"{len(before)} of 16 rows already done" in p.stdout, p.stdout
    after = load(out)
    assert after.complete and len(after) == 16
    _same_rows(before, after, rows=before.rows)
