"""A run signed by its code (pycolfrag/grid/signing.py): what the code digest reads, that it reads
contents and not paths, that rank 0 alone reads it, and the resume rule for a code change.

The digest is computed over scratch copies of the package and of ``csrc/`` (``signing.PACKAGE`` and
``signing.CSRC`` pointed at them), each with one edit, so every input is shown to count on its own;
the end-to-end reproduction (a killed grid rerun after an edit) is in tests/test_faults_grid.py.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from pycolfrag import SolverOptions
from pycolfrag import results as R
from pycolfrag.errors import ResultsFileError
from pycolfrag.grid import signing

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    """A function making a copy of the package and csrc/ with one edit; returns the digest of the copy."""
    def digest_of(name, rel=None, old=None, new=None, options=None):
        root = tmp_path / name
        skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.so")
        shutil.copytree(ROOT / "pycolfrag", root / "pycolfrag", ignore=skip)
        shutil.copytree(ROOT / "csrc", root / "csrc", ignore=skip)
        if rel is not None:   # old None: append ``new`` (whitespace or a comment: still an edit of the sources)
            text = (root / rel).read_text()
            assert old is None or text.count(old) == 1, (rel, old)
            (root / rel).write_text(text + new if old is None else text.replace(old, new))
        monkeypatch.setattr(signing, "PACKAGE", root / "pycolfrag")
        monkeypatch.setattr(signing, "CSRC", root / "csrc")
        signing._CODE.clear()
        try:
            return signing.code_digest(options or SolverOptions())
        finally:
            signing._CODE.clear()
    return digest_of


def test_the_digest_reads_contents_not_paths(scratch):
    here = signing.code_digest(SolverOptions())
    assert scratch("a") == scratch("b") == here
    assert len(here) == 64 and int(here, 16) >= 0


@pytest.mark.parametrize("rel, old, new", [
    ("pycolfrag/ground_motion/rupakhety_2011.py", "M_SAT = 7.0", "M_SAT = 7.3"),    # off the reference path
    ("pycolfrag/grid/rows.py", "_STREAM_HF = 2", "_STREAM_HF = 3"),                  # the driver itself
    ("pycolfrag/data/as00.json", None, "\n"),                                        # a model's numbers
    ("csrc/solver_monitor.c", None, "/* edited */\n"),                              # C, before make build
    ("csrc/flags.mk", None, "# edited\n"),                                          # the compiler flags
])
def test_every_input_of_a_row_changes_the_digest(scratch, rel, old, new):
    assert scratch("edited", rel, old, new) != scratch("same")


def test_the_analysis_and_the_options_count_as_they_should(scratch):
    same = scratch("same")
    # the analysis reads results files and computes no row: editing it changes no run's signature
    assert scratch("analysis", "pycolfrag/analysis/report.py", None, "# edited\n") == same
    # the resolved solver options are part of the digest
    other = SolverOptions().replace(dt_factor=SolverOptions().dt_factor / 2)
    assert scratch("options", options=other) != same


def test_rank_0_reads_the_code_and_the_others_take_its_digest(monkeypatch):
    class Rank1:
        def Get_size(self):
            return 2

        def Get_rank(self):
            return 1

        def bcast(self, x, root=0):
            assert x is None and root == 0   # rank 1 sends nothing and gets rank 0's
            return "f" * 64

    def never():
        raise AssertionError("a rank other than 0 read the code")

    signing._CODE.clear()
    monkeypatch.setattr(signing, "code_files", never)
    try:
        signing.share_code_digest(Rank1())
        assert signing._code_part() == "f" * 64
    finally:
        signing._CODE.clear()


def _file(tmp_path, signature):
    out = tmp_path / "g.h5"
    R.create(out, signature, {"created": "2026-11-27T00:00:00+00:00"}, 2, [1.0])
    return out


SIG = {"grid": "tiny", "build": {"version": "0.1.0", "result_hash": "a" * 16}, "code_digest": "1" * 64}


def test_a_code_change_alone_is_refused_unless_allowed(tmp_path):
    out = _file(tmp_path, SIG)
    new = dict(SIG, code_digest="2" * 64)
    with pytest.raises(ResultsFileError, match="--allow-code-change") as exc:
        signing.resume_signature(out, new, False, log=lambda s: None)
    assert f'code_digest: file has "{"1" * 64}", this run asks for "{"2" * 64}"' in str(exc.value)
    said = []
    opened, history = signing.resume_signature(out, new, True, log=said.append)
    assert opened == SIG and len(said) == 1 and "2" * 64 in said[0]
    # a file without code_digests (begun before they were recorded) starts its history from its signature
    assert history == [{"code_digest": "1" * 64, "build": SIG["build"], "started": "2026-11-27T00:00:00+00:00",
                        "rows_done_before": 0}]


def test_other_differences_are_left_to_the_full_refusal(tmp_path):
    out = _file(tmp_path, SIG)
    other = dict(SIG, code_digest="2" * 64, grid="large")
    # with the flag too: the grid differs, so open_for_run refuses with every difference listed
    assert signing.resume_signature(out, other, True, log=print) == (other, None)
    assert signing.resume_signature(out, SIG, False, log=print) == (SIG, None)      # the same code
    assert signing.resume_signature(tmp_path / "none.h5", SIG, False, log=print) == (SIG, None)
    with pytest.raises(ResultsFileError, match="holds a different run"):
        R.open_for_run(out, other, {}, 2, [1.0])


def test_the_history_is_read_back_from_a_signed_file(tmp_path):
    out = tmp_path / "g.h5"
    first = [signing.code_entry(SIG, "2026-11-27T00:00:00+00:00", 0)]
    R.create(out, SIG, {"created": "x", "code_digests": json.dumps(first)}, 2, [1.0])
    _, history = signing.resume_signature(out, dict(SIG, build={"version": "0.2.0"}), True, log=lambda s: None)
    assert history == first


def test_a_file_being_written_is_left_to_its_lock(tmp_path):
    # another run holds the file: the lock's refusal (exit code 5, naming the holder) comes first,
    # not a verdict on rows that run is still writing
    out = _file(tmp_path, SIG)
    new = dict(SIG, code_digest="2" * 64)
    lock = R.RunLock.acquire(out)
    try:
        assert signing.resume_signature(out, new, False, log=print) == (new, None)
        with pytest.raises(R.ResultsLockedError):
            R.open_for_run(out, new, {}, 2, [1.0])
    finally:
        lock.release()
    with pytest.raises(ResultsFileError, match="--allow-code-change"):
        signing.resume_signature(out, new, False, log=print)
