"""The ``/timeline`` group of a results file: what every rank of each session did and when.

One dataset per session (``/timeline/session_<k>``, k = 0, 1, ... in the order the sessions began),
one row per interval of one rank (:data:`DTYPE`), appended at every HDF5 write of the session and at
its end. The group is diagnostic: it is not journalled (a killed session loses at most the intervals
since its last write, never a row), it is outside the rows' checksums and the file's ``checksums``
attribute (a timeline can neither damage nor vouch for a row), and each session's dataset carries a
CRC-32 of its own bytes (attribute ``crc32``) and one of its attributes with the group's ``kinds``
(attribute ``attrs_crc32``). Reading refuses what would make a reader hang or loop: a path that is not a
regular file (a FIFO blocks ``open``), an ``n_ranks`` that is not a positive integer within
:data:`MAX_RANKS` covering the ranks of the rows, a ``kinds`` that is not a list of known kind names.
Written by :class:`pycolfrag.results.ResultsWriter`, read by :func:`read_timeline` (``pycolfrag timeline``,
:mod:`pycolfrag.analysis.timeline`); documented in docs/results_format.md.
"""
from __future__ import annotations

import json
import os
import stat
import zlib
from typing import Mapping, Sequence

import numpy as np

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.layout import h5open

__all__ = ["GROUP", "KINDS", "DTYPE", "MAX_RANKS", "kind_code", "records", "append_timeline", "next_session",
           "read_timeline", "check_regular_file"]

#: The most ranks a session's ``n_ranks`` may claim: a reader loops over the ranks (``pycolfrag timeline``)
#: or replays them (``pycolfrag replay``), so a tampered count must not run for hours.
MAX_RANKS = 1 << 16

#: The group of a results file that holds the sessions' timelines.
GROUP = "timeline"

#: What an interval is (its ``kind``, stored as the index in this table; the table is stored too, as
#: the group's attribute ``kinds``, so a file says what its codes mean):
KINDS = {
    "launch": "process start (the launcher's exec) to the package's first line: interpreter, mpi4py",
    "imports": "the package's first line to the command's first (numpy, cffi and the C library, pycolfrag)",
    "mpi_init": "importing mpi4py.MPI and MPI_Init, when the run started them",
    "checks": "the command's checks before the run (options, probe record, solver probe, free space)",
    "identity": "the code digest shared and the run's signature (its reference computation) on this rank",
    "gather": "waiting for every rank's signature (rank 0) or for rank 0 to take this one's",
    "open": "rank 0: the results file locked and created (in the background) or resumed, the queue built",
    "release": "a worker waiting for rank 0's go after the gather (rank 0 opening the file)",
    "chunk": "computing a chunk: n_rows rows from first_row (the queue's order), batch width",
    "wait": "a worker waiting for its next chunk (its request sent before it computed the last one)",
    "serve": "rank 0 answering requests and journalling the rows they bring (n_rows rows)",
    "idle": "rank 0 with nothing to answer or compute (short sleeps, merged)",
    "flush": "rank 0 writing the HDF5 file (with, the first time, waiting for its creation)",
    "finish": "rank 0's final write (rows, checksums, session), up to this timeline's last append",
    "drain": "rank 0 after a SIGTERM: from the signal to the last chunk in flight collected",
}
_CODES = {name: i for i, name in enumerate(KINDS)}

#: One interval: the rank, its kind (:data:`KINDS`), start and end (s on rank 0's clock from the
#: session's start, the attribute ``epoch_unix``; start-up intervals are negative), the rank's CPU time
#: in it (thread CPU s; NaN when not measured), rows, batch width and first row (chunks; serve: rows
#: journalled; -1/0 when they do not apply).
DTYPE = np.dtype([("rank", "u4"), ("kind", "u1"), ("t0", "f8"), ("t1", "f8"), ("cpu_s", "f4"),
                  ("n_rows", "i4"), ("width", "i1"), ("first_row", "i8")])


def kind_code(name: str) -> int:
    """The stored code of a kind of :data:`KINDS` (KeyError naming an unknown one)."""
    return _CODES[name]


def records(rank: int, events: Sequence[tuple], epoch: float) -> np.ndarray:
    """Intervals of one rank as stored rows. ``events``: tuples (kind name, t0, t1, cpu_s, n_rows,
    width, first_row) with times in s on rank 0's clock (``time.time()``); ``epoch``: the session's start
    on that clock."""
    out = np.zeros(len(events), dtype=DTYPE)
    for i, (kind, t0, t1, cpu, n, w, first) in enumerate(events):
        out[i] = (rank, _CODES[kind], t0 - epoch, t1 - epoch, cpu, n, w, first)
    return out


def append_timeline(f, session: str, attrs: Mapping, rows: np.ndarray) -> None:
    """Append ``rows`` (:data:`DTYPE`) to ``/timeline/<session>`` of the open file ``f`` (created on the
    first call), set its attributes ``attrs`` and store the dataset's CRC-32."""
    g = f.require_group(GROUP)
    if "kinds" not in g.attrs:
        g.attrs["kinds"] = json.dumps(list(KINDS))
        g.attrs["description"] = ("what every rank of each session did and when (docs/results_format.md); "
                                  "diagnostic, outside the rows' checksums")
    if session not in g:
        g.create_dataset(session, shape=(0,), maxshape=(None,), dtype=DTYPE, chunks=(1024,))
    ds = g[session]
    for k, v in attrs.items():  # at every append: what is learnt as the session goes (hosts) is kept
        ds.attrs[k] = json.dumps(v) if isinstance(v, (list, dict)) else v
    n = ds.shape[0]
    if len(rows):
        ds.resize((n + len(rows),))
        ds[n:] = rows
    ds.attrs["crc32"] = zlib.crc32(np.ascontiguousarray(ds[...]).tobytes())
    ds.attrs["attrs_crc32"] = _attrs_crc(g.attrs["kinds"], ds.attrs)


def _text(v):
    return v.decode() if isinstance(v, bytes) else v


def _attrs_crc(kinds, attrs) -> int:
    """CRC-32 of a session's attributes (but its two CRCs) and the group's ``kinds``, as read back."""
    items = sorted((k, _text(v)) for k, v in attrs.items() if k not in ("crc32", "attrs_crc32"))
    text = json.dumps([_text(kinds), [[k, v if isinstance(v, (str, int, float, bool)) else np.asarray(v).tolist()]
                                      for k, v in items]], default=str)
    return zlib.crc32(text.encode("utf-8", errors="surrogateescape"))


def next_session(path) -> str:
    """The name the next session's timeline takes in the file at ``path``: ``session_<k>``, k the number
    of timelines it holds (a session killed before its first write left none)."""
    try:
        with h5open(path, "r") as f:
            k = len(f[GROUP]) if GROUP in f else 0
    except (OSError, KeyError):
        k = 0
    return f"session_{k}"


def check_regular_file(path) -> None:
    """Refuse a path that is not a regular file (:class:`ResultsFileError`): opening a FIFO waits for a
    writer forever, a device never ends. A missing file raises ``FileNotFoundError``."""
    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        what = "a FIFO" if stat.S_ISFIFO(mode) else "a folder" if stat.S_ISDIR(mode) else "not a regular file"
        raise ResultsFileError(f"{path} is {what}: a results file is a regular HDF5 file")


def _kinds(g, path) -> list:
    raw = _text(g.attrs.get("kinds", json.dumps(list(KINDS))))
    try:
        kinds = json.loads(raw)
    except (TypeError, ValueError):
        kinds = None
    if (not isinstance(kinds, list) or not all(isinstance(k, str) and k in KINDS for k in kinds)
            or len(set(kinds)) != len(kinds)):
        raise ResultsFileError(f"{path}: the timeline's kinds attribute {str(raw)[:200]!r} is not a list of distinct "
                               f"kind names of {', '.join(KINDS)} (edited or damaged)")
    return kinds


def _check_n_ranks(path, name: str, attrs: Mapping, rows: np.ndarray) -> None:
    """A session's ``n_ranks``: an integer in 1..:data:`MAX_RANKS` above every rank of its rows."""
    if "n_ranks" not in attrs:
        return
    v = attrs["n_ranks"]
    v = v.item() if isinstance(v, np.generic) else v
    top = int(rows["rank"].max()) + 1 if len(rows) else 1
    ok = isinstance(v, int) and not isinstance(v, bool) and top <= v <= MAX_RANKS
    if not ok:
        raise ResultsFileError(f"{path}: timeline {name} has n_ranks {v!r}: not an integer from {top} (its rows' "
                               f"ranks) to {MAX_RANKS} (edited or damaged)")


def read_timeline(path) -> dict:
    """Every session's timeline of a results file: ``{name: {"attrs": dict, "rows": array of DTYPE,
    "kinds": [kind names by code], "crc_ok": bool}}`` in session order ({} when the file has none).
    A dataset whose bytes or attributes fail their CRC-32 is returned with ``crc_ok`` False (the caller
    says so); a file written before ``attrs_crc32`` was stored is checked on its rows alone. A path that
    is not a regular file, a ``kinds`` or an ``n_ranks`` that cannot be right raise
    :class:`~pycolfrag.core.errors.ResultsFileError` naming them."""
    check_regular_file(path)
    out: dict[str, dict] = {}
    with h5open(path, "r") as f:
        if GROUP not in f:
            return out
        g = f[GROUP]
        kinds = _kinds(g, path)
        for name in sorted(g, key=lambda s: int(s.rsplit("_", 1)[-1]) if s.rsplit("_", 1)[-1].isdigit() else -1):
            ds = g[name]
            rows = ds[...]
            attrs = {}
            for k, v in ds.attrs.items():
                v = v.decode() if isinstance(v, bytes) else v
                if isinstance(v, str) and v[:1] in "[{":
                    try:
                        v = json.loads(v)
                    except ValueError:
                        pass
                attrs[k] = v
            crc, attrs_crc = attrs.pop("crc32", None), attrs.pop("attrs_crc32", None)
            ok = crc is not None and int(crc) == zlib.crc32(np.ascontiguousarray(rows).tobytes())
            if attrs_crc is not None:
                ok = ok and int(attrs_crc) == _attrs_crc(g.attrs.get("kinds"), ds.attrs)
            _check_n_ranks(path, name, attrs, rows)
            out[name] = {"attrs": attrs, "rows": rows, "kinds": kinds, "crc_ok": ok}
    return out
