"""A run signed by its code: what identifies the code that computes a grid's rows, and the resume
rule that keeps one results file from mixing rows of two versions.

Two marks go into every grid signature (the results file's ``grid_signature``):

* ``code_digest`` (:func:`code_digest`, also the root attribute ``code_digest``): a SHA-256 over the
  package's Python sources and data files, the digest the *loaded* C library carries of the sources
  it was compiled from (:func:`library_digest`), and the resolved solver options. Any edit on any
  path a row may take changes it -- also one that the reference computation below never reaches (a
  pulse-model constant above Mw 7, a collapse criterion) -- and it reads contents, not paths, so the
  same code in another checkout signs alike. In a checkout (``csrc/`` beside the package) a library
  built from other sources than those on disk -- a stale build -- is refused
  (:class:`~pycolfrag.core.errors.StaleBuildError`): the run would be signed by code the sources do not
  show.
* ``build`` (:func:`build_identity`): the package version and the *result hash* of a short
  reference computation, which also moves with what the sources do not hold (numpy, libm, the CPU's
  floating-point paths) and is computed by every rank, so ranks of different builds are refused.

A resume whose only differences are these two marks is refused with its own message unless the user
allows it (``--allow-code-change``); the file then records every code that wrote rows (the root
attribute ``code_digests``: digest, result hash, start time and rows done before it).
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from pycolfrag import ground_motion as _gm
from pycolfrag import results as _results
from pycolfrag.core import source_digest as _source_digest
from pycolfrag.core.errors import ResultsFileError, StaleBuildError
from pycolfrag.core.ffi import ffi, lib
from pycolfrag.core.version import __version__
from pycolfrag.solver import run as _solver
from pycolfrag.solver import sample as _sample
from pycolfrag.structure.column import Column

__all__ = ["build_identity", "code_digest", "share_code_digest", "CODE_KEYS", "resume_signature",
           "code_entry", "git_revision", "library_digest", "sources_digest", "checked_library_digest"]

PACKAGE = Path(__file__).resolve().parent.parent
#: Signature entries that identify the code (a difference in them alone is a code change).
CODE_KEYS = ("build", "code_digest")

_BUILD: dict = {}
_CODE: dict = {}


def build_identity() -> dict:
    """The package version and the *result hash*: a SHA-256 over the numbers of a short reference
    computation through the whole chain -- a synthetic record (Mw 7, R 5 km, seed 1, dt 0.01 s,
    first 5 s), its IMs and the default column's response with the default solver options. It moves
    with numpy, libm and the CPU's floating-point paths as well as with the code on that path; a
    rebuild that changes nothing keeps it. Computed once per process (about 40 ms), by every rank,
    so MPI ranks of different builds are refused."""
    if not _BUILD:
        rec = _gm.synthesize(7.0, 5.0, 1, dt=0.01)
        acc = np.asarray(rec.acc, dtype=float)[:500]
        ims = _sample.ims_row(acc, 0.01)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = _solver.simulate(Column.parthenon(), acc, 0.01)
        h = hashlib.sha256(acc.tobytes())
        for name in sorted(ims):
            h.update(np.asarray(ims[name], dtype=float).tobytes())
        h.update(np.array([res.u_top, res.u_d, res.n_steps, res.t_end, res.dt, res.energy_error],
                          dtype=float).tobytes())
        h.update(np.asarray(res.residual_dislocation, dtype=float).tobytes())
        _BUILD.update(version=__version__, result_hash=h.hexdigest()[:16])
    return dict(_BUILD)


def code_files() -> list[tuple[str, Path]]:
    """The Python side of :func:`code_digest`: [(name, path)] of the package's Python sources and
    data files, except ``pycolfrag/analysis/``, which reads results files and never computes a row
    (``tests/test_analysis_package.py`` checks that the driver imports none of it). Names are
    relative, so a copy signs alike. The C library is not read here: it is signed by the digest it
    carries (:func:`checked_library_digest`)."""
    return [(p.relative_to(PACKAGE.parent).as_posix(), p) for p in sorted(PACKAGE.rglob("*"))
            if p.is_file() and (p.suffix == ".py" or p.parent.name == "data")
            and "__pycache__" not in p.parts and p.relative_to(PACKAGE).parts[0] != "analysis"]


def library_digest() -> str:
    """The digest the loaded C library carries of the sources it was compiled from
    (``cf_common_source_digest()``, computed by ``pycolfrag/_build.py``; "none" for a library built
    otherwise)."""
    return ffi.string(lib.cf_common_source_digest()).decode()


def sources_digest() -> str | None:
    """The same digest (:func:`pycolfrag.core.source_digest.source_digest`) of the sources on disk, or None
    where there are none (an installed package has no ``csrc/``: only the library speaks then)."""
    root = PACKAGE.parent
    return _source_digest.source_digest(root) if (root / "csrc").is_dir() else None


def checked_library_digest() -> str:
    """:func:`library_digest`, after checking that the library was built by ``pycolfrag/_build.py`` and,
    in a checkout, from the sources on disk; raises :class:`~pycolfrag.core.errors.StaleBuildError` (naming
    both digests and the rebuild) otherwise. Checked when a run is signed, not at import: reading
    the sources costs a few ms, and a stale build may still read results files."""
    built = library_digest()
    rebuild = ("rebuild it: `python setup.py build_ext --inplace` (or `make build`, `pip install -e .`) in "
               f"{PACKAGE.parent}")
    if built == _source_digest.UNSIGNED:
        raise StaleBuildError(f"the loaded C library ({lib_path()}) carries no digest of its sources (it was "
                              f"not built by pycolfrag/_build.py), so no run can be signed by it; {rebuild}")
    disk = sources_digest()
    if disk is not None and disk != built:
        raise StaleBuildError(
            f"stale build: the loaded C library ({lib_path()}) was compiled from other sources than those in "
            f"{PACKAGE.parent / 'csrc'} (library source digest {built}, sources on disk {disk}); its rows would "
            f"be signed by code the sources do not show, so nothing was run; {rebuild}")
    return built


def lib_path() -> str:
    """Where the loaded C library lies (for messages)."""
    from pycolfrag import _libcolfrag
    return str(getattr(_libcolfrag, "__file__", "pycolfrag._libcolfrag"))


def _python_part() -> str:
    """SHA-256 of :func:`code_files`, the Python side (read on rank 0 alone)."""
    h = hashlib.sha256(b"pycolfrag code digest v2; Python sources and data\n")
    for name, path in code_files():
        data = path.read_bytes()
        h.update(f"{name}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _code_part() -> str:
    """The code's digest: the Python side (:func:`_python_part`, once per process, or rank 0's) and
    this process's loaded C library (:func:`checked_library_digest`)."""
    if "sources" not in _CODE:
        if "python" not in _CODE:
            # both read before either is kept: a refused (stale) library must be refused again on the next call
            python, library = _python_part(), checked_library_digest()
            _CODE["python"], _CODE["library"] = python, library
        else:   # rank 0 checked its sources; this rank's own library is what it runs
            _CODE["library"] = library_digest()
        _CODE["sources"] = hashlib.sha256(
            f"pycolfrag code digest v2\npython {_CODE['python']}\nC library {_CODE['library']}\n".encode()).hexdigest()
    return _CODE["sources"]


def code_digest(solver_options) -> str:
    """The digest a run is signed by (64 hex digits): the code (:func:`code_files`) and the resolved
    solver options (``SolverOptions.to_dict()``), so that the digest alone tells whether two files'
    rows were computed by the same code with the same solver."""
    opts = json.dumps(solver_options.to_dict(), sort_keys=True)
    return hashlib.sha256(f"{_code_part()}\n{opts}".encode()).hexdigest()


def share_code_digest(comm) -> None:
    """Rank 0 reads the code once and hands the digest of its Python side to every rank (the other
    ranks then read no file: on a cluster they would all read the same shared sources at start-up);
    each rank adds the digest its own loaded C library carries, so ranks running another binary
    sign otherwise (and the ranks' signatures, compared by rank 0, refuse them). A stale build on
    rank 0 is refused on every rank (:class:`~pycolfrag.core.errors.StaleBuildError`)."""
    if comm is None or comm.Get_size() == 1:
        _code_part()
        return
    sent = None
    if comm.Get_rank() == 0:
        try:
            sent = ("ok", _python_part(), checked_library_digest())
        except StaleBuildError as exc:
            sent = ("stale", str(exc), "")
    kind, text, _ = comm.bcast(sent, root=0)
    if kind == "stale":
        raise StaleBuildError(text)
    _CODE.clear()
    _CODE["python"] = text
    _code_part()


def git_revision() -> str:
    """``git rev-parse HEAD`` of the package's checkout (``-dirty`` with changes), or "unknown"."""
    here = PACKAGE.parent
    try:
        rev = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=10).stdout.strip()
        if not rev:
            return "unknown"
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return rev + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


# ---------------------------------------------------------------------------------------
# the resume rule
# ---------------------------------------------------------------------------------------

def code_entry(signature: dict, started: str, rows_done_before: int) -> dict:
    """One line of the root attribute ``code_digests``: the code that wrote rows from ``started`` on."""
    return {"code_digest": signature.get("code_digest"), "build": signature.get("build"), "started": started,
            "rows_done_before": int(rows_done_before)}


def _stored_run(path: Path):
    """(signature, root attributes) of the run ``path`` holds -- from the HDF5 file, else its journal's
    header -- or None when there is none or it cannot be read (:func:`pycolfrag.results.open_for_run`
    then decides: a new file, a rebuild from the journal, or a refusal naming the damage)."""
    try:
        with _results.h5open(path, "r") as f:
            attrs = {k: f.attrs[k] for k in ("grid_signature", "code_digests", "created") if k in f.attrs}
        return json.loads(attrs["grid_signature"]), attrs
    except Exception:
        pass
    try:
        header, _ = _results.read_journal(_results.journal_path(path))
        return dict(header["signature"]), dict(header["attrs"])
    except Exception:
        return None


def _history(old_sig: dict, old_attrs: dict) -> list:
    """The ``code_digests`` a file holds; a file begun before runs were signed by their code has none,
    and its first code is then the one its signature names (``code_digest`` None: not recorded)."""
    raw = old_attrs.get("code_digests")
    if raw is not None:
        return list(json.loads(raw.decode() if isinstance(raw, bytes) else raw))
    created = old_attrs.get("created", "")
    return [code_entry(old_sig, created.decode() if isinstance(created, bytes) else str(created), 0)]


def resume_signature(path, signature: dict, allow_code_change: bool, log) -> tuple[dict, list | None]:
    """The signature to open ``path`` with, and the code history to extend (None: nothing to record).

    A file whose signature differs from ``signature`` in the code marks alone (:data:`CODE_KEYS`) is
    refused with :class:`~pycolfrag.core.errors.ResultsFileError`, unless ``allow_code_change``: then the
    file is opened with its own code marks (so it resumes) and its ``code_digests`` are returned for the
    caller to extend with this run's entry. Any other difference is left to
    :func:`pycolfrag.results.open_for_run`, whose refusal lists every difference."""
    path = Path(os.path.realpath(path))
    # a file another run is writing: its lock refuses this run first (exit code 5, naming the holder)
    old = None if _results.lock_held(path) else _stored_run(path)
    if old is None:
        return signature, None
    old_sig, old_attrs = old
    diffs = _results.signature_mismatch(old_sig, signature)
    code = [d for d in diffs if d.split(":", 1)[0] in CODE_KEYS]
    if not code or len(code) < len(diffs):
        return signature, None
    if not allow_code_change:
        raise ResultsFileError(
            f"{path} holds a different run: its rows were computed by another build of pycolfrag (the code "
            "changed since it began):\n  - " + "\n  - ".join(code)
            + "\nResuming would mix rows of two versions in one file. Rerun with --allow-code-change to resume "
            "anyway (the file then records every code that wrote rows, root attribute code_digests), --overwrite "
            "to recompute every row, or --out for another file. The digest reads the package's sources and the "
            "digest the loaded C library carries of the sources it was built from (a rebuild from other "
            "csrc/ counts).")
    opened = {k: v for k, v in signature.items() if k not in CODE_KEYS}
    opened.update({k: old_sig[k] for k in CODE_KEYS if k in old_sig})
    log(f"resuming {path} with other code (--allow-code-change): its rows so far carry code_digest "
        f"{old_sig.get('code_digest')}, the rest this code's {signature.get('code_digest')}; the file records "
        "both (root attribute code_digests)")
    return opened, _history(old_sig, old_attrs)


def now() -> str:
    """The time stamp of the results file's attributes (UTC, seconds)."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")
