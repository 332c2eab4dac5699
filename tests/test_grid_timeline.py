"""A grid run's timeline in its results file (``/timeline``), ``pycolfrag timeline``, the drain on SIGTERM
under a host-file launch (Slurm's ``--signal=TERM@T`` signals every task) and the results file created
while the ranks compute.

Runs are tiny and most use ``tests/grid_fakes.py``'s ``fake`` rows (``PCF_FAKE_SLEEP_S``: each row takes
that long), started as users start them (``scripts/run_grid.py``, ``mpirun ... python -m mpi4py``).
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings

import h5py
import numpy as np
import pytest

from pycolfrag import results as R
from pycolfrag.analysis.data import load
from pycolfrag.results.timeline import KINDS, read_timeline
from test_grid import ROOT, SCRIPT, SMALL, _env, _mpirun, _ok, _same_rows, _serial

FAKE = ["--sample-function", "grid_fakes:fake", "--no-figures", "--no-progress"]


def _kinds(sess):
    return np.array([sess["kinds"][k] for k in sess["rows"]["kind"]])


@pytest.mark.mpi
def test_every_rank_records_its_timeline_in_the_results_file(tmp_path):
    """Three ranks (oversubscribed on two cores), 12 rows of the real solver: one session's timeline with
    every rank's start-up phases and chunks; the chunks' rows are the rows computed, each once; intervals
    end after they begin; the times are on one clock (a worker's first chunk after rank 0 released it);
    the CRC-32 holds; the file's own checksums are untouched by it (it loads verified)."""
    out = tmp_path / "tl.h5"
    _ok(_mpirun(3, [*SMALL, "--out", str(out)], OMPI_MCA_rmaps_base_oversubscribe="1"))
    sessions = read_timeline(out)
    assert list(sessions) == ["session_0"]
    sess = sessions["session_0"]
    rows, kinds, attrs = sess["rows"], _kinds(sess), sess["attrs"]
    assert sess["crc_ok"] and sess["kinds"] == list(KINDS)
    assert attrs["n_ranks"] == 3 and len(attrs["hosts"]) == 3 and attrs["launcher"] == "mpirun"
    assert attrs["lanes"] in (1, 2, 4, 8) and attrs["chunk_max"] == 32
    assert np.all(rows["t1"] >= rows["t0"])
    for rank in range(3):
        mine = set(kinds[rows["rank"] == rank])
        assert {"imports", "mpi_init", "checks", "identity", "gather"} <= mine, (rank, mine)
        assert ("open" if rank == 0 else "release") in mine
    chunks = rows[kinds == "chunk"]
    # which ranks computed is the scheduler's and the machine's business (3 ranks on 2 cores: a late worker
    # may find 12 rows gone); that every row was computed once, by a rank of the run, is the timeline's
    assert int(chunks["n_rows"].sum()) == 12 and set(chunks["rank"].tolist()) <= {0, 1, 2}
    res = load(out)
    assert res.complete and sorted(chunks["first_row"]) == sorted(set(chunks["first_row"]))
    release_end = {int(r["rank"]): r["t1"] for r in rows[kinds == "release"]}
    for c in chunks[chunks["rank"] > 0]:
        assert c["t0"] >= release_end[int(c["rank"])]
    # the timeline is outside the file's checksums: a changed interval is the timeline's CRC's business
    with h5py.File(out, "r+", locking=False) as f:
        ds = f["timeline/session_0"]
        first = ds[0]
        first["t1"] += 1.0
        ds[0] = first
    assert load(out).complete                      # the rows still verify
    assert not read_timeline(out)["session_0"]["crc_ok"]


def test_the_timeline_command_prints_utilisation_and_draws(tmp_path):
    out = tmp_path / "one.h5"
    _ok(_serial([*SMALL, "--out", str(out)]))
    png, js = tmp_path / "tl.png", tmp_path / "tl.json"
    p = subprocess.run([sys.executable, "-m", "pycolfrag", "timeline", str(out), "--plot", str(png), "--json", str(js)],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert "utilisation (computing / rank-seconds)" in p.stdout and "computing rows (chunks)" in p.stdout
    assert png.stat().st_size > 5000
    s = json.loads(js.read_text())["session_0"]
    assert s["rows"] == 12 and s["n_ranks"] == 1
    # one rank: its rank-seconds from its launch to its final write are all accounted for, and "computing"
    # is the chunks' intervals as the file holds them (a share of the job would depend on the machine's load:
    # start-up dominates 12 short rows)
    assert abs(sum(s["causes"].values()) - s["job_s"]) < 1e-6
    with h5py.File(out, "r") as f:
        t = f["timeline/session_0"][()]
    chunk = t["kind"] == list(KINDS).index("chunk")
    assert chunk.any() and s["causes"]["computing"] == pytest.approx(float(np.sum(t["t1"][chunk] - t["t0"][chunk])),
                                                                     abs=1e-6)
    p = subprocess.run([sys.executable, "-m", "pycolfrag.analysis.timeline", str(out), "--session", "3"],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 2 and "holds no timeline of session 3" in p.stderr


def _journal_rows(path):
    return len(R.read_journal(R.journal_path(path))[1]) if R.journal_path(path).exists() else 0


def _children(pid):
    """Process ids whose parent is ``pid`` (from /proc)."""
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    if int(fh.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(d))
            except (OSError, ValueError, IndexError):
                pass
    return out


@pytest.mark.mpi
def test_sigterm_to_every_task_drains_then_the_next_job_resumes_bitwise(tmp_path):
    """What a Slurm job's --signal=TERM@T does, with mpirun and a host file of 2 slots and 4 ranks
    (oversubscribed): SIGTERM to every rank once rows are journalled. The workers finish their chunks,
    rank 0 hands out nothing more, collects them and writes the file: the launcher exits 75, the file opens
    verified with every journalled row (none lost in flight), its timeline shows the drain. The same
    command (the chain's next job) then finishes the file, bitwise the rows of an uninterrupted run."""
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed")
    hosts = tmp_path / "hosts"
    hosts.write_text("localhost slots=2\n")
    out = tmp_path / "drain.h5"
    args = ["--mw", "6", "7", "--dist", "5", "10", "15", "--samples", "16", *FAKE, "--flush-s", "0.5",
            "--out", str(out)]
    cmd = ["timeout", "-k", "10", "200", "mpirun", "--allow-run-as-root", "--hostfile", str(hosts), "--oversubscribe",
           "-np", "4", sys.executable, "-m", "mpi4py", str(SCRIPT), *args]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S="0.15"), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    t0 = time.time()
    while _journal_rows(out) < 16 and time.time() - t0 < 120:
        time.sleep(0.05)
    mpirun = [p for p in _children(proc.pid)] or [proc.pid]
    ranks = [c for m in mpirun for c in _children(m)]
    assert len(ranks) == 4, ranks
    before = _journal_rows(out)
    for pid in ranks:
        os.kill(pid, signal.SIGTERM)
    text, _ = proc.communicate(timeout=120)
    assert proc.returncode == 75, text
    assert "SIGTERM: no new chunks" in text and "row(s) left (exit 75)" in text
    got = load(out)                                          # verified: the final write was whole
    assert not got.complete and len(got) == _journal_rows(out) >= before
    assert R.journal_path(out).exists()
    tl = read_timeline(out)["session_0"]
    assert "drain" in set(_kinds(tl))
    p = _ok(_mpirun(4, args, PCF_FAKE_SLEEP_S="0", OMPI_MCA_rmaps_base_oversubscribe="1"))
    assert f"{len(got)} of 96 rows already done" in p.stdout
    done = load(out)
    assert done.complete and len(done) == 96 and list(read_timeline(out)) == ["session_0", "session_1"]
    ref = tmp_path / "ref.h5"
    _ok(_serial([*args[:-1], str(ref)], PCF_FAKE_SLEEP_S="0"))
    _same_rows(load(ref), done)


def test_sigterm_to_a_single_rank_finishes_its_chunk_and_exits_75(tmp_path):
    out = tmp_path / "one.h5"
    args = ["--mw", "6", "7", "--dist", "5", "10", "--samples", "12", *FAKE, "--chunk-max", "4", "--out", str(out)]
    cmd = [sys.executable, str(SCRIPT), *args]
    proc = subprocess.Popen(cmd, env=_env(PCF_FAKE_SLEEP_S="0.1"), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    t0 = time.time()
    while _journal_rows(out) < 4 and time.time() - t0 < 60:
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    text, _ = proc.communicate(timeout=60)
    assert proc.returncode == 75, text
    got = load(out)
    assert 4 <= len(got) < 48 and len(got) % 4 == 0   # whole chunks of 4 only: the one in flight came in


def test_a_file_created_in_the_background_keeps_the_rows_when_creating_fails(tmp_path):
    """open_for_run(background=True) returns before the HDF5 file exists; rows are journalled meanwhile.
    A value HDF5 cannot store makes the creating child fail: the first write raises that error, and the
    journal keeps the row added meanwhile (the exit-4 line of the command says so); without any row the
    journal goes too, nothing is left behind."""
    sig, attrs = {"kind": "test"}, {"bad": object()}
    path = tmp_path / "bg.h5"
    w = R.open_for_run(path, sig, attrs, 3, [1.0], background=True)
    assert not path.exists() and R.journal_path(path).exists()
    w.add([{"row": 1, "status": 0, "scenario": 0, "sample": 1}])
    with pytest.raises(TypeError):
        w.flush()
    w.close()
    assert not path.exists() and len(R.read_journal(R.journal_path(path))[1]) == 1
    path2 = tmp_path / "bg2.h5"
    w = R.open_for_run(path2, sig, attrs, 3, [1.0], background=True)
    with pytest.raises(TypeError):
        w.finish()
    assert not path2.exists() and not R.journal_path(path2).exists()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        good = R.open_for_run(tmp_path / "ok.h5", sig, {}, 3, [1.0], background=True)
        good.add([{"row": 0, "status": 0, "scenario": 0, "sample": 0}])
        good.finish()
    assert load(tmp_path / "ok.h5", any_layout=True).samples["status"].tolist() == [0]


@pytest.mark.mpi
def test_the_slurm_job_script_runs_and_chains(tmp_path):
    """examples/grid.sbatch end to end with stand-ins for Slurm's commands: ``srun`` runs mpirun with a host
    file (2 slots, SLURM_NTASKS = 3 ranks, oversubscribed), ``sbatch`` records what it was asked. The first
    job queues its successor (afterany on its own job id) and completes the file; the successor finds it
    complete, ends at once and queues nothing."""
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed")
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    (tmp_path / "hosts").write_text("localhost slots=2\n")
    (bin_ / "srun").write_text("#!/bin/bash\nwhile [[ $1 == --* ]]; do shift; done\n"
                               f"exec mpirun --allow-run-as-root --hostfile {tmp_path}/hosts --oversubscribe "
                               "-np $SLURM_NTASKS \"$@\"\n")
    (bin_ / "sbatch").write_text(f"#!/bin/bash\necho \"$@\" >> {tmp_path}/sbatch.log\n")
    for f in bin_.iterdir():
        f.chmod(0o755)
    out = tmp_path / "chain.h5"
    env = _env(PATH=f"{bin_}:{os.environ['PATH']}", SRC=str(ROOT), OUT=str(out), SLURM_JOB_ID="1001",
               SLURM_NTASKS="3", CHAIN_LEFT="2", PCF_FAKE_SLEEP_S="0",
               GRID_ARGS="--mw 6 7 --dist 5 10 --samples 4 --sample-function grid_fakes:fake")
    job = ["bash", str(ROOT / "examples" / "grid.sbatch")]
    p = subprocess.run(job, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    assert load(out).complete and "pycolfrag grid exit 0" in p.stdout
    queued = (tmp_path / "sbatch.log").read_text().splitlines()
    assert len(queued) == 1 and "--dependency=afterany:1001" in queued[0] and "CHAIN_LEFT=1" in queued[0]
    p = subprocess.run(job, env=dict(env, SLURM_JOB_ID="1002", CHAIN_LEFT="1"), capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0 and f"{out} is complete" in p.stdout
    assert len((tmp_path / "sbatch.log").read_text().splitlines()) == 1


def test_the_replay_takes_its_costs_from_a_files_rows_and_timeline(tmp_path):
    """A file written by this scheduler (it has one session's timeline) is replayed with this scheduler's
    policy and its timeline's fixed costs, calibrated so that the replay of its own session's chunks costs
    the CPU its timeline measured (exactly: one scale), and ``pycolfrag replay`` prints the prediction."""
    from pycolfrag.grid import replay
    out = tmp_path / "r.h5"
    _ok(_serial([*SMALL, "--out", str(out)]))
    rows, costs, info = replay.measured(out)
    assert rows.n == 12 and info["policy"] == "current" and info["n_ranks"] == 1
    own = replay.simulate(rows, 1, replay.CURRENT, costs)
    assert own["chunk_cpu"] == pytest.approx(info["chunk_s"], rel=1e-9)
    js = tmp_path / "p.json"
    p = subprocess.run([sys.executable, "-m", "pycolfrag", "replay", str(out), "--ranks", "1", "2", "--json", str(js)],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    got = json.loads(js.read_text())
    assert [r["size"] for r in got["results"]] == [1, 2] and got["results"][0]["E_job"] == 1.0
    assert "written by the current scheduler on 1 rank(s)" in p.stdout
