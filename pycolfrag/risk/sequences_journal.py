"""A sequences run's journal (:mod:`pycolfrag.risk.sequences_run`, :mod:`pycolfrag.risk.sequences_rare_run`): its
identity line and the refusal of another run's, its lines (a torn last one cut off), its lock, and the exit codes;
``pycolfrag subset`` keeps its batches' rows by the same text (:mod:`pycolfrag.cli.subset`).

A journal is a text file of JSON lines written by rank 0 alone: the first line ``{"pycolfrag_sequences": 1,
"identity": ...}``, then one line per finished entry, flushed and synced before the next is taken.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
from pathlib import Path

from pycolfrag.core.errors import ParameterError, PycolfragError, ResultsFileError
from pycolfrag.core.version import __version__
from pycolfrag.grid.command import EXIT_ARGS, EXIT_LOCKED, EXIT_OK, EXIT_OS_ERROR  # the grid's codes
from pycolfrag.grid.signing import code_digest
from pycolfrag.results.lock import ResultsLockedError, RunLock
from pycolfrag.solver.options import SolverOptions

__all__ = ["EXIT_OK", "EXIT_ARGS", "EXIT_OS_ERROR", "EXIT_LOCKED", "identity", "read_lines", "Journal", "open_journal",
           "abort_others"]


def identity(site_path, model, st) -> dict:
    """What a journal's sequences are of (see the module's text); ``n_sequences`` is not part of it. The code
    is the grid's code digest (the package's Python sources, the loaded C library and the solver options:
    :func:`pycolfrag.grid.signing.code_digest`), so a journal is resumed only by the code that began it."""
    settings = {f.name: getattr(st, f.name) for f in dataclasses.fields(st) if f.name != "n_sequences"}
    settings["restoration"] = dataclasses.asdict(st.restoration)
    settings["settle"] = dataclasses.asdict(st.settle)
    settings["aftershocks"] = None if st.aftershocks is None else dataclasses.asdict(st.aftershocks)
    return json.loads(json.dumps({
        "site_sha256": hashlib.sha256(Path(site_path).read_bytes()).hexdigest(), "structure": model.to_dict(),
        "settings": settings, "version": __version__,
        "code_digest": code_digest(SolverOptions(**st.solver_options))}, default=float))


def _differences(a: dict, b: dict, where: str = "") -> list:
    keys = sorted(set(a) | set(b))
    out = []
    for k in keys:
        x, y = a.get(k), b.get(k)
        if isinstance(x, dict) and isinstance(y, dict):
            out += _differences(x, y, f"{where}{k}.")
        elif x != y and not (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)):
            out.append(f"{where}{k}: {x!r} in the journal, {y!r} now")
    return out


def read_lines(path: Path, ident: dict, log, name: str = "sequences", remedy: str = "give another folder") -> list:
    """The entries of a journal after its identity line (dicts); an absent journal has none. Refused
    (:class:`ParameterError`) when its identity is not ``ident``; a torn last line is cut off. ``name``: what
    the journal is of, and ``remedy`` what to do, in the messages (``pycolfrag subset``'s journal is read by
    the same text)."""
    if not path.exists():
        return []
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    head_key = f'{{"pycolfrag_{name}": 1'.encode()
    if raw and not raw.startswith(head_key):   # checked before anything is cut: another file is never touched
        raise ParameterError(f"{path} is not a {name} journal: {remedy}")
    if lines and lines[-1] == b"":
        lines.pop()
    elif lines:   # no newline after the last line: a write cut short
        log(f"{name}: {path}: its last line was cut short (a run stopped while writing it); dropped")
        with open(path, "r+b") as f:
            f.truncate(len(raw) - len(lines[-1]))
        lines.pop()
    if not lines:
        return []
    try:
        head = json.loads(lines[0])
        found = head["identity"]
    except (ValueError, KeyError, TypeError):
        raise ParameterError(f"{path} is not a {name} journal: {remedy}") from None
    diff = _differences(found, ident)
    if diff:
        raise ParameterError(f"{path} holds the {name} of another run ({'; '.join(diff[:4])}"
                             f"{'; ...' if len(diff) > 4 else ''}): {remedy}")
    out = []
    for i, line in enumerate(lines[1:], start=2):
        try:
            out.append(json.loads(line))
        except ValueError as exc:
            raise ParameterError(f"{path}, line {i}: damaged ({exc}): {remedy}") from None
    return out


class Journal:
    """Rank 0's journal: one line per sequence, flushed and synced before the next is taken."""

    def __init__(self, path: Path, ident: dict, fresh: bool, name: str = "sequences"):
        self.f = open(path, "a", encoding="utf-8")
        if fresh:
            self._write({f"pycolfrag_{name}": 1, "identity": ident})

    def _write(self, d: dict) -> None:
        self.f.write(json.dumps(d) + "\n")
        self.f.flush()
        os.fsync(self.f.fileno())

    def add(self, entry: dict) -> None:
        self._write(entry)

    def add_rows(self, rows: list) -> None:
        """Rows of the rare sequences, one line each, synced once."""
        self.f.write("".join(json.dumps(r) + "\n" for r in rows))
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        self.f.close()


def open_journal(path: Path, ident: dict, log, read=None, name: str = "sequences", remedy: str = "give another folder"):
    """Rank 0's journal at ``path``, locked: ``(lock, entries, journal, error)``; ``entries`` are
    :func:`read_lines`'s, or ``read(path, ident, log)``'s; ``error`` is None or ``(exit code, message)`` (the
    folder held by a running run, a journal of another run, an operating-system error), the lock released."""
    lock = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = RunLock.acquire(path, log=log)
        entries = read(path, ident, log) if read is not None else read_lines(path, ident, log, name, remedy)
        journal = Journal(path, ident, fresh=not path.exists() or path.stat().st_size == 0, name=name)
        return lock, entries, journal, None
    except ResultsLockedError as exc:
        error = (EXIT_LOCKED, str(exc))
    except (PycolfragError, ResultsFileError) as exc:
        error = (EXIT_ARGS, str(exc))
    except OSError as exc:
        error = (EXIT_OS_ERROR, str(exc))
    if lock is not None:
        lock.release()
    return None, None, None, error


def abort_others(exc, comm, log) -> None:
    """A rank's failure ends every rank (the others would wait for it in a receive or a collective): said on
    stderr, then ``Abort`` (exit 4; the journal keeps every finished line). No-op in one process."""
    if comm is None or comm.Get_size() == 1 or isinstance(exc, SystemExit):
        return
    import traceback
    print(f"sequences: rank {comm.Get_rank()} failed ({type(exc).__name__}: {exc}); every finished sequence is "
          "in the journal", file=sys.stderr, flush=True)
    traceback.print_exc()
    comm.Abort(EXIT_OS_ERROR)
