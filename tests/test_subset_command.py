"""``pycolfrag subset`` (pycolfrag/cli/subset.py) and subset simulation over MPI ranks
(pycolfrag/rare/subset_mpi.py).

Where the expected numbers come from: the command's result must be bitwise the in-process
:func:`pycolfrag.rare.subset.subset_simulation` of the same problem and seed (JSON floats are written
by ``repr``, which round-trips every double), and an MPI run's file bitwise a one-rank run's (a run's
row depends only on its explicit inputs; the ranks only share the batches). The tiny problem is the
monolithic Parthenon column (about 2 ms a run) under Mw 6.25, 10 km pulse records, u_top >= 0.35,
N = 20 or 50: two or three levels, well under a second of runs.
"""
from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import pycolfrag as pcf
from pycolfrag.cli import subset as cmd
from pycolfrag.rare import subset as sus
from pycolfrag.rare.subset_mpi import MPIEvaluator

ROOT = Path(__file__).resolve().parent.parent
from test_grid import _env, _ok  # noqa: E402

TINY = ["--mw", "6.25", "--dist", "10", "--levels", "0.2", "0.35", "--solver", "monolithic=true"]


def _pycolfrag(*args, timeout=120):
    return subprocess.run(["timeout", "-k", "10", str(timeout), sys.executable, "-m", "pycolfrag", "subset", *args],
                          capture_output=True, text=True, env=_env(), cwd=ROOT)


def _without_run(doc: dict) -> dict:
    """The file less what differs between runs of the same estimate: command line, ranks, wall time."""
    return {k: v for k, v in doc.items() if k not in ("command", "ranks", "runs_by_rank", "wall_s")}


def test_help_in_the_house_style(capsys):
    with pytest.raises(SystemExit) as exc:
        cmd.main(["--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith("usage: pycolfrag subset ")
    assert "--levels LEVEL [LEVEL ...]" in out and "(default: 500)" in out and "(default: mp03)" in out
    assert "mpirun -n N python -m mpi4py -m pycolfrag subset" in out


@pytest.mark.parametrize("args, words", [
    (["--mw", "9", "--dist", "10", "--levels", "collapse"], "Mw = 9"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "abc"], "'abc' is not a number"),
    (["--mw", "6.25", "--dist", "10", "--levels", "-0.3"], "'-0.3' must be > 0"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "0.30"], "repeated"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--pulse", "ricker"], "unknown pulse shape 'ricker'"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--n", "505"], "n = 505"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--p0", "0.7"], "p0 must be in (0, 0.5], got 0.7"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--seed", "-1"], "seed"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--solver", "monolithic"], "'monolithic'"),
    (["--mw", "6.25", "--dist", "10", "--levels", "0.3", "--column", "no_such_column.toml"], "no_such_column.toml"),
])
def test_bad_input_is_refused_naming_the_value(tmp_path, capsys, args, words):
    assert cmd.main([*args, "--out", str(tmp_path / "p.json")]) == cmd.EXIT_ARGS
    err = capsys.readouterr().err
    assert err.startswith("pycolfrag subset: error: ") and words in err, err
    assert not (tmp_path / "p.json").exists()


def test_an_output_in_a_missing_folder_or_a_folder_is_refused(tmp_path, capsys):
    for out in (tmp_path / "nowhere" / "p.json", tmp_path):
        assert cmd.main([*TINY, "--n", "20", "--out", str(out)]) == cmd.EXIT_ARGS
        assert str(out) in capsys.readouterr().err


def test_the_command_writes_the_estimate_of_the_library(tmp_path):
    """Through ``python -m pycolfrag subset``: the file holds the estimate, CoVs, interval, the lower level
    from the same runs (``at``), the algorithm's levels, and every row; all equal to the library's."""
    out, rows = tmp_path / "p.json", tmp_path / "rows.jsonl"
    p = _ok(_pycolfrag(*TINY, "--n", "20", "--seed", "11", "--out", str(out), "--rows", str(rows)))
    assert p.stdout.startswith("P = ") and "level 0: 20 runs" in p.stderr
    doc = json.loads(out.read_text())
    prob = sus.SubsetProblem(pcf.Column.parthenon(), 6.25, 10.0, threshold=0.35, solver_options={"monolithic": True})
    res = sus.subset_simulation(prob, seed=11, n=20)
    assert doc["kind"] == cmd.KIND and doc["command"].startswith("pycolfrag subset --mw 6.25")
    assert (doc["probability"], doc["cov"], doc["cov_uncorrelated"], doc["cov_bound"], doc["interval"]) == \
        (res.probability, res.cov, res.cov_uncorrelated, res.cov_bound, list(res.interval))
    assert doc["levels"][1] == {"level": 0.35, "probability": res.probability, "cov": res.cov,
                                "interval": list(res.interval)}
    p2, c2 = res.at(0.2)
    assert (doc["levels"][0]["probability"], doc["levels"][0]["cov"]) == (p2, c2)
    assert [lv["next_threshold"] for lv in doc["subset_levels"]] == [lv.next_threshold for lv in res.levels]
    assert doc["runs"] == res.runs and doc["settings"]["seed"] == 11 and doc["problem"]["threshold"] == 0.35
    lines = [json.loads(x) for x in rows.read_text().splitlines()]
    assert len(lines) == res.runs and [r["u_top"] for r in lines] == [r["u_top"] for r in res.rows]
    assert [r["score"] for r in lines] == [r["score"] for r in res.rows]


def test_collapse_level_is_written_without_infinity(tmp_path):
    """``collapse`` is the level inf: written as the string "inf", never JSON's non-standard Infinity."""
    out = tmp_path / "p.json"
    assert cmd.main(["--mw", "6.25", "--dist", "10", "--levels", "0.35", "collapse", "--solver", "monolithic=true",
                     "--n", "20", "--max-levels", "2", "--out", str(out)]) == cmd.EXIT_OK
    text = out.read_text()
    assert "Infinity" not in text and "NaN" not in text
    doc = json.loads(text)
    assert doc["levels"][-1]["level"] == "collapse" and doc["problem"]["threshold"] == "inf"


class _FakeComm:
    """Two ranks in one process: rank 1's part is computed at once, as its serve() would."""

    def __init__(self):
        self.parts = None

    def Get_rank(self):
        return 0

    def Get_size(self):
        return 2

    def scatter(self, parts, root=0):
        self.parts = parts
        return parts[0]

    def gather(self, mine, root=0):
        return [mine, self.other(self.parts[1])]


def test_mpi_evaluator_cuts_gathers_in_order_and_reports_a_failed_rank():
    comm = _FakeComm()
    comm.other = lambda part: [{"u_top": b["i"]} for b in part]
    ev = MPIEvaluator(comm, worker=lambda part: [{"u_top": b["i"]} for b in part])
    assert ev([{"i": i} for i in range(5)]) == [{"u_top": i} for i in range(5)]
    assert comm.parts == [[{"i": 0}, {"i": 1}, {"i": 2}], [{"i": 3}, {"i": 4}]] and ev.runs_by_rank == [3, 2]
    comm.other = lambda part: cmd_error()
    with pytest.raises(sus.RareEventError, match="rank 1 failed on its part of batch 2: ValueError: boom"):
        ev([{"i": i} for i in range(4)])


def cmd_error():
    from pycolfrag.rare.subset_mpi import _compute

    def boom(part):
        raise ValueError("boom")
    return _compute(boom, [])


@pytest.mark.mpi
def test_mpirun_one_and_two_ranks_give_the_same_file_bit_for_bit(tmp_path):
    """``mpirun -n 1`` and ``-n 2`` ``python -m mpi4py -m pycolfrag subset``, N = 50: the same estimate, levels and
    rows; the two ranks shared the runs (rank 1 computed its part of every batch)."""
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun not installed (make system)")
    docs, rows = {}, {}
    for n in (1, 2):
        out, rw = tmp_path / f"p{n}.json", tmp_path / f"rows{n}.jsonl"
        c = ["timeout", "-k", "10", "200", "mpirun", "--allow-run-as-root", "-n", str(n), sys.executable, "-m", "mpi4py",
             "-m", "pycolfrag", "subset", *TINY, "--n", "50", "--seed", "3", "--out", str(out), "--rows", str(rw)]
        _ok(subprocess.run(c, capture_output=True, text=True, env=_env(), cwd=ROOT))
        docs[n], rows[n] = json.loads(out.read_text()), rw.read_text()
    assert docs[1]["runs_by_rank"] == [docs[1]["runs"]]
    assert len(docs[2]["runs_by_rank"]) == 2 and sum(docs[2]["runs_by_rank"]) == docs[2]["runs"]
    assert min(docs[2]["runs_by_rank"]) >= docs[2]["runs"] // 2 - 5     # a contiguous half of every batch
    assert _without_run(docs[1]) == _without_run(docs[2])
    assert rows[1] == rows[2] and len(rows[1].splitlines()) == docs[1]["runs"] > 50
    assert math.isfinite(docs[1]["probability"]) and docs[1]["probability"] > 0


# --------------------------------------------------------------------------- the journal: a stopped estimate resumes
_RUN_BATCH = sus.run_batch


def _main_counting(monkeypatch, argv) -> tuple[int, list]:
    """``cmd.main(argv)`` in this process, the sizes of the batches it ran (not read back) counted."""
    ran = []

    def counting(batch):
        ran.append(len(batch))
        return _RUN_BATCH(batch)
    monkeypatch.setattr(sus, "run_batch", counting)
    return cmd.main(argv), ran


def test_a_stopped_estimate_resumes_from_its_journal_bit_for_bit(tmp_path, monkeypatch, capsys):
    """An estimate stopped after its first two batches (its journal cut there, with a torn third line, as a
    kill while writing leaves it) resumes by the same command: the two batches are read back, not run, and
    the file and the rows are bitwise the uninterrupted estimate's (the estimate is a pure function of the
    seed and the rows; JSON floats round-trip every double). Expected: N = 20 and p0 = 0.1, so level 0 is
    one batch of 20 runs and every later batch one step of the N p0 = 2 chains: the first two batches hold
    20 + 2 runs."""
    whole, rows_whole = tmp_path / "whole.json", tmp_path / "whole.jsonl"
    code, ran_whole = _main_counting(monkeypatch, [*TINY, "--n", "20", "--seed", "11", "--out", str(whole),
                                                   "--rows", str(rows_whole)])
    assert code == cmd.EXIT_OK and sum(ran_whole) == json.loads(whole.read_text())["runs"]
    lines = Path(str(whole) + ".journal").read_text().splitlines(keepends=True)
    assert len(lines) == 1 + len(ran_whole) > 3                        # the identity, then a line per batch
    cut = tmp_path / "cut.json"
    Path(str(cut) + ".journal").write_text("".join(lines[:3]) + lines[3][:40])
    capsys.readouterr()
    code, ran = _main_counting(monkeypatch, [*TINY, "--n", "20", "--seed", "11", "--out", str(cut),
                                             "--rows", str(tmp_path / "cut.jsonl")])
    assert code == cmd.EXIT_OK
    err = capsys.readouterr().err
    assert "cut short" in err and "resuming from" in err and "2 batches done" in err
    assert ran == ran_whole[2:]                                        # the first two batches were not run again
    a, b = json.loads(whole.read_text()), json.loads(cut.read_text())
    assert b["runs_read_back"] == sum(ran_whole[:2]) == 22 and a["runs_read_back"] == 0
    drop = ("command", "runs_by_rank", "wall_s", "runs_read_back")
    assert {k: v for k, v in a.items() if k not in drop} == {k: v for k, v in b.items() if k not in drop}
    assert rows_whole.read_text() == (tmp_path / "cut.jsonl").read_text()
    assert Path(str(cut) + ".journal").read_text() == "".join(lines)   # the journal now the whole run's


def test_a_journal_of_another_estimate_is_refused_naming_what_differs(tmp_path, capsys):
    """A journal begun with another seed (or N) is refused before any run, exit 2, naming the setting; a
    journal whose identity matches but whose batch holds other runs (another code's normals, here a
    changed key) is refused by the batch; a lower level or the confidence changed resumes (the runs do not
    depend on them)."""
    out = tmp_path / "p.json"
    assert cmd.main([*TINY, "--n", "20", "--seed", "11", "--max-levels", "2", "--out", str(out)]) == cmd.EXIT_OK
    jp = Path(str(out) + ".journal")
    capsys.readouterr()
    assert cmd.main([*TINY, "--n", "20", "--seed", "12", "--max-levels", "2", "--out", str(out)]) == cmd.EXIT_ARGS
    err = capsys.readouterr().err
    assert str(jp) in err and "seed: 11 in the journal, 12 now" in err and "another --journal" in err
    again = ["--mw", "6.25", "--dist", "10", "--levels", "0.25", "0.35", "--solver", "monolithic=true", "--n", "20",
             "--seed", "11", "--max-levels", "2", "--confidence", "0.8", "--out", str(tmp_path / "q.json"),
             "--journal", str(jp)]
    assert cmd.main(again) == cmd.EXIT_OK
    assert json.loads((tmp_path / "q.json").read_text())["runs_read_back"] == json.loads(out.read_text())["runs"]
    lines = jp.read_text().splitlines()
    second = json.loads(lines[1])
    second["key"] = "0" * 64
    jp.write_text("\n".join([lines[0], json.dumps(second), *lines[2:]]) + "\n")
    capsys.readouterr()
    assert cmd.main(again) == cmd.EXIT_ARGS
    assert "its batch 0 holds other runs" in capsys.readouterr().err


def test_a_journal_held_by_a_running_estimate_is_refused(tmp_path, capsys):
    """Two estimates on one journal: the second is refused (exit 5, the grid's code) while the first holds
    its lock (the journal's lock of every run, :class:`pycolfrag.results.lock.RunLock`)."""
    from pycolfrag.results.lock import RunLock
    out = tmp_path / "p.json"
    lock = RunLock.acquire(Path(str(out) + ".journal"), log=lambda m: None)
    try:
        assert cmd.main([*TINY, "--n", "20", "--out", str(out)]) == cmd.EXIT_LOCKED == 5
    finally:
        lock.release()
    assert "p.json.journal" in capsys.readouterr().err and not out.exists()


def test_a_file_that_is_no_journal_is_refused_untouched_and_paths_must_differ(tmp_path, capsys):
    """``--journal`` naming a file that is not a subset journal is refused (exit 2) before anything is cut
    from it -- a torn last line is only ever cut from a journal --, and ``--journal`` or ``--rows`` that
    are ``--out`` (or each other) are refused by name before any run (the result would overwrite the
    journal)."""
    notes = tmp_path / "notes.txt"
    notes.write_text("first line\nsecond line without a newline")
    before = notes.read_bytes()
    out = tmp_path / "p.json"
    assert cmd.main([*TINY, "--n", "20", "--out", str(out), "--journal", str(notes)]) == cmd.EXIT_ARGS
    assert "is not a subset journal" in capsys.readouterr().err and notes.read_bytes() == before
    for extra in (["--journal", str(out)], ["--rows", str(out)], ["--rows", str(out) + ".journal"]):
        assert cmd.main([*TINY, "--n", "20", "--out", str(out), *extra]) == cmd.EXIT_ARGS
        assert "are the same file" in capsys.readouterr().err and not out.exists()
