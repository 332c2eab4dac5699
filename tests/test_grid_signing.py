"""A run signed by its code (pycolfrag/grid/signing.py): what the code digest reads, that it reads
contents and not paths, that it signs the loaded C library (the digest the library carries of the
sources it was built from) and refuses a stale build, that rank 0 alone reads the code, and the
resume rule for a code change.

The digest is computed over scratch copies of the package and of ``csrc/`` (``signing.PACKAGE``
pointed at them), each with one edit, so every input is shown to count on its own; a "rebuilt"
library is played by patching the digest the library reports (``signing.library_digest``). The
end-to-end reproduction (a killed grid rerun after an edit) is in tests/test_faults_grid.py; the
build's side (the digest compiled in, a rebuild after a header edit) in tests/test_build_inputs.py.
"""
from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from pycolfrag import SolverOptions
from pycolfrag import results as R
from pycolfrag.core import source_digest as _source_digest
from pycolfrag.core.errors import ResultsFileError, StaleBuildError
from pycolfrag.grid import signing

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    """A function making a copy of the package and csrc/ with one edit; returns the digest of the copy.
    ``csrc=False``: a copy without csrc/ (an installed package); ``library``: the digest the loaded
    library reports (a library built from other sources; default: the real one)."""
    def digest_of(name, rel=None, old=None, new=None, options=None, csrc=True, library=None):
        root = tmp_path / name
        skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.so")
        shutil.copytree(ROOT / "pycolfrag", root / "pycolfrag", ignore=skip)
        if csrc:
            shutil.copytree(ROOT / "csrc", root / "csrc", ignore=skip)
        if rel is not None:   # old None: append ``new`` (whitespace or a comment: still an edit of the sources)
            text = (root / rel).read_text()
            assert old is None or text.count(old) == 1, (rel, old)
            (root / rel).write_text(text + new if old is None else text.replace(old, new))
        monkeypatch.setattr(signing, "PACKAGE", root / "pycolfrag")
        if library is not None:
            monkeypatch.setattr(signing, "library_digest", lambda: library)
        signing._CODE.clear()
        try:
            return signing.code_digest(options or SolverOptions())
        finally:
            signing._CODE.clear()
            monkeypatch.undo()
    return digest_of


def test_the_digest_reads_contents_not_paths(scratch):
    here = signing.code_digest(SolverOptions())
    assert scratch("a") == scratch("b") == here
    assert len(here) == 64 and int(here, 16) >= 0


def test_the_library_carries_the_digest_of_the_sources_it_was_built_from():
    """pycolfrag/_build.py compiles the digest of the build inputs into the library (CF_SOURCE_DIGEST);
    this checkout's library was built from its sources (a stale build fails here too: rebuild)."""
    built = signing.library_digest()
    assert built != _source_digest.UNSIGNED and len(built) == 64 and int(built, 16) >= 0
    assert built == _source_digest.source_digest(ROOT) == signing.sources_digest()
    assert signing.checked_library_digest() == built
    names = [name for name, _ in _source_digest.build_inputs(ROOT)]
    # every header (the contact and connector laws live there), flags.mk, the build script, the constants
    assert {f"csrc/{p.name}" for p in (ROOT / "csrc").glob("*.[ch]")} | {"csrc/flags.mk"} <= set(names)
    assert {"pycolfrag/_build.py", "pycolfrag/data/constants.json"} <= set(names)


@pytest.mark.parametrize("rel, old, new", [
    ("pycolfrag/ground_motion/rupakhety_2011.py", "M_SAT = 7.0", "M_SAT = 7.3"),    # off the reference path
    ("pycolfrag/grid/rows.py", "_STREAM_HF = 2", "_STREAM_HF = 3"),                  # the driver itself
    ("pycolfrag/data/as00.json", None, "\n"),                                        # a model's numbers
])
def test_every_python_input_of_a_row_changes_the_digest(scratch, rel, old, new):
    assert scratch("edited", rel, old, new) != scratch("same")


@pytest.mark.parametrize("rel", ["csrc/solver_monitor.c", "csrc/contact_law.h", "csrc/connector_law.h",
                                 "csrc/flags.mk", "pycolfrag/_build.py", "pycolfrag/data/constants.json"])
def test_sources_edited_but_not_rebuilt_are_refused_as_a_stale_build(scratch, rel):
    """The library that runs was built from the sources before the edit: signing its rows by the
    sources on disk would lie, and signing them by the library would run code the user does not see."""
    comment = "# edited\n" if rel.endswith((".mk", ".py")) else "/* edited */\n"
    comment = "\n" if rel.endswith(".json") else comment
    with pytest.raises(StaleBuildError, match=r"stale build: the loaded C library .* was compiled from other "
                       r"sources .*build_ext --inplace") as exc:
        scratch("edited", rel, None, comment)
    assert signing.library_digest() in str(exc.value)


def test_the_digest_signs_the_loaded_library_not_the_sources(scratch):
    """The sources on disk unchanged, a library of other sources loaded (the reported case: sources reverted
    beside a binary of an edit): refused in a checkout; without csrc/ (an installed package, where
    nothing on disk can be compared) the run is signed by that library, so its digest differs."""
    here = scratch("same")
    with pytest.raises(StaleBuildError, match="stale build"):
        scratch("other-binary", library="0" * 64)
    assert scratch("installed", csrc=False) == here          # the same library: the same code
    assert scratch("installed-other", csrc=False, library="0" * 64) != here
    with pytest.raises(StaleBuildError, match="carries no digest of its sources"):
        scratch("unsigned", csrc=False, library=_source_digest.UNSIGNED)


def test_a_stale_build_is_refused_on_every_call_not_only_the_first(monkeypatch):
    """The code's digest is kept once per process; a refusal must not leave half of it kept, or the next
    run in the same process (a retry in a notebook, a script's loop) signs its rows with the stale library."""
    monkeypatch.setattr(signing, "sources_digest", lambda: "f" * 64)
    signing._CODE.clear()
    try:
        for _ in range(2):
            with pytest.raises(StaleBuildError, match="stale build"):
                signing.code_digest(SolverOptions())
    finally:
        signing._CODE.clear()


def test_the_analysis_and_the_options_count_as_they_should(scratch):
    same = scratch("same")
    # the analysis reads results files and computes no row: editing it changes no run's signature
    assert scratch("analysis", "pycolfrag/analysis/report.py", None, "# edited\n") == same
    # the resolved solver options are part of the digest
    other = SolverOptions().replace(dt_factor=SolverOptions().dt_factor / 2)
    assert scratch("options", options=other) != same


class _Rank1:
    """Rank 1 of two: sends nothing and gets rank 0's ``sent``."""
    def __init__(self, sent):
        self.sent = sent

    def Get_size(self):
        return 2

    def Get_rank(self):
        return 1

    def bcast(self, x, root=0):
        assert x is None and root == 0
        return self.sent


def test_rank_0_reads_the_code_and_the_others_take_its_digest(monkeypatch):
    def never():
        raise AssertionError("a rank other than 0 read the code")

    signing._CODE.clear()
    monkeypatch.setattr(signing, "code_files", never)
    monkeypatch.setattr(signing, "sources_digest", never)
    try:
        signing.share_code_digest(_Rank1(("ok", "f" * 64, "e" * 64)))
        mine = signing._code_part()
        # rank 0's Python side and this rank's own library: a rank running another binary signs otherwise
        lib = signing.library_digest()
        assert mine == hashlib.sha256(f"pycolfrag code digest v2\npython {'f' * 64}\nC library {lib}\n"
                                      .encode()).hexdigest()
        signing._CODE.clear()
        monkeypatch.setattr(signing, "library_digest", lambda: "0" * 64)
        signing.share_code_digest(_Rank1(("ok", "f" * 64, "e" * 64)))
        assert signing._code_part() != mine
        # a stale build on rank 0 is refused on every rank (none waits for the others)
        signing._CODE.clear()
        with pytest.raises(StaleBuildError, match="stale build: x"):
            signing.share_code_digest(_Rank1(("stale", "stale build: x", "")))
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


def test_a_file_begun_by_another_binary_is_refused_on_resume(tmp_path, scratch):
    """The reported case, signed by real digests: a file begun with one library and resumed with a library
    built from other sources is refused as a code change (before this, both signed the sources on
    disk alike and the resume mixed rows of two builds), unless --allow-code-change. Without csrc/ on
    disk (an installed package), so that the refusal comes from the signature, not the stale check."""
    begun = dict(SIG, code_digest=scratch("installed", csrc=False))
    out = _file(tmp_path, begun)
    rebuilt = dict(SIG, code_digest=scratch("rebuilt", csrc=False, library="0" * 64))
    with pytest.raises(ResultsFileError, match="another build of pycolfrag") as exc:
        signing.resume_signature(out, rebuilt, False, log=lambda s: None)
    assert begun["code_digest"] in str(exc.value) and rebuilt["code_digest"] in str(exc.value)
    opened, _ = signing.resume_signature(out, rebuilt, True, log=lambda s: None)
    assert opened == begun


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
