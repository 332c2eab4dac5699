"""The journal of a results file (``<file>.journal``, JSON lines): what makes a run crash-safe.

Rank 0 appends every finished row here and flushes it to the operating system before the HDF5 file is
touched; a header line holds what rebuilding the HDF5 file needs (signature, root attributes, size).
Every line carries the CRC-32 of its JSON text. A journal belongs to one file: the same grid signature
and ``run_id`` (:func:`journal_mismatch`).
"""
from __future__ import annotations

import json
import os
import time
import warnings
import zlib
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.layout import FORMAT_VERSION, row_to_json


def journal_path(path) -> Path:
    """The journal sidecar of a results file: ``<path>.journal``."""
    return Path(os.fspath(path) + ".journal")


class JournalHeaderError(ResultsFileError):
    """A journal whose first line is not a complete pycolfrag journal header (e.g. cut by a full disk)."""


_HEADER_KEYS = {"kind": str, "n_rows": int, "periods_s": list, "signature": dict, "attrs": dict}


def _check_header(jp: Path, obj) -> dict:
    if not isinstance(obj, dict) or obj.get("kind") != "pycolfrag-grid-journal":
        raise JournalHeaderError(f"{jp} is not a pycolfrag journal (first line has no journal header)")
    for k, t in _HEADER_KEYS.items():
        if not isinstance(obj.get(k), t):
            raise JournalHeaderError(f"{jp}: journal header has no valid {k!r}")
    return obj


def _journal_line(text: str) -> str:
    """One journal line: the JSON text, a tab, its CRC-32 (8 hex digits), a newline. JSON text never
    holds a raw tab (json.dumps escapes it), so the last tab separates the checksum."""
    return f"{text}\t{zlib.crc32(text.encode('utf-8')):08x}\n"


def _journal_obj(line: bytes):
    """The JSON object of one journal line, or None when its checksum is missing or wrong."""
    body, tab, crc = line.rpartition(b"\t")
    if not tab or len(crc) != 8:
        return None
    try:
        if int(crc, 16) != zlib.crc32(body):
            return None
        return json.loads(body.decode("utf-8"))
    except (ValueError, UnicodeDecodeError):
        return None


def read_journal(path, truncate: bool = False, report=None):
    """Read a journal: ``(header dict or None, {row index: row dict})``.

    A last line without its newline (a kill in the middle of an append) or that does not
    parse is ignored; with ``truncate=True`` the file is cut back to the last good line so
    that appending can go on. A journal whose first line is not a complete, valid header
    (empty, cut, not JSON, keys missing, checksum wrong) raises :class:`JournalHeaderError`;
    callers set such a journal aside (the resume) or ignore it with a warning (the reader).

    Every line carries the CRC-32 of its JSON text: a complete line whose checksum fails (edited or
    damaged after it was written) is skipped -- its row is not used -- and ``report`` (default
    :func:`warnings.warn`) is told which lines.
    """
    jp = Path(path)
    if not jp.exists():
        return None, {}
    header, rows = None, {}
    good_end = 0
    with open(jp, "rb") as fh:
        data = fh.read()
    pos = 0
    bad_lines = []
    line_no = 0
    while pos < len(data):
        nl = data.find(b"\n", pos)
        if nl < 0:
            break  # incomplete last line
        line_no += 1
        obj = _journal_obj(data[pos:nl])
        if header is None:
            if obj is None:
                raise JournalHeaderError(f"{jp}: the journal header (line 1) is damaged (not JSON or its "
                                         "checksum fails)")
            header = _check_header(jp, obj)
        elif obj is None or not isinstance(obj, dict) or not isinstance(obj.get("row"), int):
            bad_lines.append(line_no)  # edited or damaged after it was written: its row is not used
        else:
            rows[int(obj["row"])] = obj
        pos = good_end = nl + 1
    if bad_lines:
        (report or (lambda m: warnings.warn(m, stacklevel=3)))(
            f"{jp}: line(s) {', '.join(map(str, bad_lines[:10]))}{' ...' if len(bad_lines) > 10 else ''} fail "
            f"their checksum (changed after they were written): {len(bad_lines)} row(s) not used from the journal")
    if header is None:
        raise JournalHeaderError(f"{jp}: the journal header (line 1) is missing or cut "
                                 f"({len(data)} bytes, no complete first line)")
    if truncate and good_end < len(data):
        with open(jp, "r+b") as fh:
            fh.truncate(good_end)
    return header, rows


def journal_run_id(jp: Path):
    """The ``run_id`` in a journal's header (None if absent or unreadable); reads line 1 only."""
    try:
        with open(jp, "rb") as fh:
            obj = _journal_obj(fh.readline(1 << 22).rstrip(b"\n"))
        return obj["attrs"].get("run_id")
    except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError, AttributeError):
        return None


def journal_mismatch(header: Mapping, h5_attrs: Mapping) -> list[str]:
    """Why a journal does not belong to a results file (empty when it does): its signature
    must equal the file's ``grid_signature`` and, when both carry one, its ``run_id`` the file's."""
    try:
        sig = json.loads(h5_attrs["grid_signature"])
    except (KeyError, TypeError, ValueError):
        return ["the results file has no readable grid_signature"]
    diffs = signature_mismatch(sig, header.get("signature", {}), ("file", "journal"))
    a, b = h5_attrs.get("run_id"), header.get("attrs", {}).get("run_id")
    if a and b and a != b:
        diffs.append(f"run_id: file {a}, journal {b}")
    return diffs


def set_aside(p: Path, reason: str, log) -> Path:
    """Rename a damaged or foreign sidecar/file out of the way (kept for inspection), say so."""
    stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
    dest = p.with_name(f"{p.name}.set-aside-{stamp}")
    n = 1
    while dest.exists():
        n += 1
        dest = p.with_name(f"{p.name}.set-aside-{stamp}-{n}")
    os.replace(p, dest)
    log(f"set aside {p} as {dest.name}: {reason}")
    return dest


class Journal:
    """A journal open for appending rows (its header is written by :func:`write_journal_header`)."""

    def __init__(self, path: Path):
        self.path = path
        self.fh = open(path, "a", encoding="utf-8")

    def append(self, rows: Iterable[Mapping]) -> None:
        self.fh.write("".join(_journal_line(row_to_json(r)) for r in rows))
        self.fh.flush()  # in the OS page cache: survives a kill of this process

    def sync(self) -> None:
        self.fh.flush()
        os.fsync(self.fh.fileno())  # survives a machine crash too

    def close(self) -> None:
        if not self.fh.closed:
            self.fh.close()


def signature_mismatch(old: Mapping, new: Mapping, names=("file has", "this run asks for")) -> list[str]:
    """Human-readable differences between two grid signatures (empty when they agree). A value that
    is a table on both sides is compared key by key (``settings: batch: ...``), and a long value is
    shown around its first difference, so the key and the part that differ are always in the text
    (they were cut off after 120 characters)."""
    diffs: list[str] = []
    _mismatch(old, new, names, "", diffs)
    return diffs


def _mismatch(old: Mapping, new: Mapping, names, prefix: str, diffs: list) -> None:
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k, "<absent>"), new.get(k, "<absent>")
        if isinstance(a, Mapping) and isinstance(b, Mapping):   # "settings: batch.size: ..." (the top key first,
            _mismatch(a, b, names, f"{prefix}{k}." if prefix else f"{k}: ", diffs)   # as callers split on ":")
            continue
        sa, sb = (json.dumps(v, sort_keys=True) for v in (a, b))
        if sa != sb:
            diffs.append(f"{prefix}{k}: {names[0]} {_around(sa, sb)}, {names[1]} {_around(sb, sa)}")


def _around(v: str, other: str, width: int = 120) -> str:
    """``v`` whole when short, else ``width`` characters of it around where it first differs from ``other``."""
    if len(v) <= width:
        return v
    i = next((n for n, (x, y) in enumerate(zip(v, other)) if x != y), min(len(v), len(other)))
    lo = max(0, min(i - width // 3, len(v) - width))
    return ("..." if lo > 0 else "") + v[lo:lo + width] + ("..." if lo + width < len(v) else "")


def write_journal_header(jp: Path, n_rows: int, periods_s, signature: Mapping, attrs: Mapping) -> None:
    """Start a journal: its first line holds what rebuilding the HDF5 file needs (fsynced)."""
    def plain(v):  # list/array attributes are float arrays in the HDF5 file (the writer's attribute values)
        if isinstance(v, (list, tuple, np.ndarray)):
            return [float(x) for x in v]
        return v.item() if isinstance(v, np.generic) else v

    header = {"kind": "pycolfrag-grid-journal", "format_version": FORMAT_VERSION, "n_rows": int(n_rows),
              "periods_s": [float(p) for p in periods_s], "signature": signature,
              "attrs": {k: plain(v) for k, v in attrs.items()}}
    tmp = jp.with_name(jp.name + ".tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(_journal_line(json.dumps(header, sort_keys=True, default=str)))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, jp)  # a reader never meets a journal without its header
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
