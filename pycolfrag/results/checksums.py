"""What a results file stores to prove its integrity, how it is checked, and what a damaged file says.

* every attribute's CRC-32 (root, groups, datasets), rewritten at every write (root attribute ``checksums``);
* every dataset's CRC-32 when the file is complete (in ``checksums`` too);
* each finished row's CRC-32 (dataset ``/row_crc32``), written with the row, before its ``status``:
  the rows of an interrupted file, which a resume keeps, are verified one by one.

A file the grid's writer created (one with a ``run_id`` or a ``/row_crc32``) that lacks any of these is
damaged: missing integrity data cannot be told from removed integrity data.
"""
from __future__ import annotations

import json
import zlib
from typing import Mapping

import numpy as np

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.journal import journal_path
from pycolfrag.results.layout import ROW_CRC, STATUS_PENDING


class ResultsDamagedError(ResultsFileError):
    """The HDF5 file cannot be trusted: a read error, a checksum mismatch, missing checksums, or no answer
    within the time limit. Its text is the ``reason`` followed by what to do about it (:func:`salvage_hint`),
    so every reader shows the same advice without code of its own.
    ``data_intact``: every dataset passed its checksum (only attributes are damaged)."""

    def __init__(self, reason="", data_intact: bool = False, path=None):
        self.reason, self.data_intact, self.path = str(reason), bool(data_intact), path
        super().__init__(self.reason if path is None else f"{self.reason}. {salvage_hint(path, self.data_intact)}")

    def __reduce__(self):  # crosses the pipe of the reading child intact
        return (type(self), (self.reason, self.data_intact, self.path))


def salvage_hint(path, data_intact: bool) -> str:
    """What to do with a damaged results file: it is never deleted, its rows may still be worth keeping,
    and a journal beside it (a killed or interrupted run's) is what the grid rebuilds it from."""
    if data_intact:
        rows = ("every dataset passes its checksum, so its rows are intact: read them with "
                f"pycolfrag.analysis.data.load('{path}', verify=False) and check the attributes by hand")
    else:
        rows = (f"the rows that can still be read come from pycolfrag.analysis.data.load('{path}', verify=False) "
                "(check them: part of the file is damaged)")
    jp = journal_path(path)
    journal = (f"its journal {jp.name} lies beside it: rerunning the grid command that wrote it rebuilds the file "
               "from the journal, if the journal is that run's" if jp.exists()
               else "there is no journal to rebuild it from")
    return (f"The file is left as it is and {journal}; {rows}. To recompute, move it aside first "
            f"(mv {path} {path}.damaged) and rerun the grid command that wrote it, or write elsewhere with --out "
            "(--overwrite would delete it)")


def written_by_the_grid(raw: Mapping) -> bool:
    """Whether a file read (``raw``: its root ``attrs`` and its ``row_crc``, None when absent) is one the
    grid's writer created: it carries a ``run_id`` or a ``/row_crc32``, which the writer stores in every
    file and other code has no reason to, and it must carry its checksums. A file in the documented layout
    written by other code (a ``grid_signature`` of its own included) has nothing to verify."""
    return "run_id" in raw["attrs"] or raw.get("row_crc") is not None


def dataset_checksums(groups) -> dict:
    """CRC-32 of every dataset's bytes (stored in the root attribute ``checksums`` when complete).
    ``groups``: an open file, or {"samples": {name: array}, "spectra": {...}, "row_crc32": array} already
    read from one."""
    out = {}
    for grp in ("samples", "spectra"):
        for name in (groups[grp] if grp in groups else ()):
            out[f"{grp}/{name}"] = zlib.crc32(np.ascontiguousarray(groups[grp][name][...]).tobytes())
    if ROW_CRC in groups and groups[ROW_CRC] is not None:
        out[ROW_CRC] = zlib.crc32(np.ascontiguousarray(groups[ROW_CRC][...]).tobytes())
    return out


def row_checksums(samples: Mapping, spectra: Mapping, rows) -> np.ndarray:
    """CRC-32 of each row of ``rows``: the bytes of its value in every ``/samples`` field, then in every
    ``/spectra`` dataset, each in name order (``uint32``). The writer stores it with the row, before the
    row's ``status``; the reader recomputes it from what it read."""
    rows = np.asarray(rows, dtype=np.int64)
    if rows.size == 0:
        return np.zeros(0, dtype=np.uint32)
    parts = [np.ascontiguousarray(np.asarray(group[name])[rows]).view(np.uint8).reshape(rows.size, -1)
             for group in (samples, spectra) for name in sorted(group)]
    table = np.concatenate(parts, axis=1)
    return np.array([zlib.crc32(r.tobytes()) for r in table], dtype=np.uint32)


def _attr_crc(value) -> int:
    """CRC-32 of one attribute value as h5py reads it back (type and bytes)."""
    if isinstance(value, str):
        data = b"str:" + value.encode("utf-8", errors="surrogateescape")
    elif isinstance(value, bytes):
        data = b"bytes:" + value
    else:
        a = np.asarray(value)
        data = a.dtype.str.encode() + b":" + str(a.shape).encode() + b":" + np.ascontiguousarray(a).tobytes()
    return zlib.crc32(data)


def _attr_checksums(attrs_by_object: Mapping) -> dict:
    """CRC-32 of every attribute: ``{"attr:<object>/<name>": crc}``; ``attrs_by_object`` maps an
    object's path ("/", "samples", "samples/u_top", ...) to its attributes. The root attribute
    ``checksums`` itself is left out."""
    out = {}
    for obj, attrs in attrs_by_object.items():
        for k, v in attrs.items():
            if obj == "/" and k == "checksums":
                continue
            out[f"attr:{obj.rstrip('/')}/{k}"] = _attr_crc(v)
    return out


def all_attrs(f) -> dict:
    """Every attribute of a results file (root, groups, datasets) as {object path: {name: value}}."""
    out = {"/": dict(f.attrs)}
    if ROW_CRC in f:
        out[ROW_CRC] = dict(f[ROW_CRC].attrs)
    for grp in ("samples", "spectra"):
        if grp in f:
            out[grp] = dict(f[grp].attrs)
            for name in f[grp]:
                out[f"{grp}/{name}"] = dict(f[grp][name].attrs)
    return out


def store_checksums(f, datasets: bool) -> None:
    """Store the root attribute ``checksums``: every attribute's CRC always, every dataset's when
    ``datasets`` (a complete file; the datasets of a file being written change at every batch)."""
    f.flush()
    sums = _attr_checksums(all_attrs(f))
    if datasets:
        sums.update(dataset_checksums(f))
    f.attrs["checksums"] = json.dumps(sums, sort_keys=True)


def verify_checksums(path, raw: Mapping, attrs_by_object: Mapping) -> None:
    """Raise :class:`ResultsDamagedError` naming what fails its stored checksum, or what integrity data a
    file of the grid lacks. ``raw``: what was read (``samples``, ``spectra``, ``row_crc``: arrays;
    ``attrs``: root attributes). Checked: every attribute; every dataset when the file stored dataset
    checksums (complete files); else each finished row against ``/row_crc32``."""
    attrs = raw["attrs"]
    if "checksums" not in attrs:
        if written_by_the_grid(raw):
            raise ResultsDamagedError(f"{path}: it has no checksums attribute (removed, or written by a pycolfrag "
                                      "from before checksums were stored): nothing it holds can be verified", path=path)
        return
    stored = _stored_checksums(path, attrs["checksums"])
    now = _attr_checksums(attrs_by_object)
    has_data = any(not k.startswith("attr:") for k in stored)
    if has_data:
        now.update(dataset_checksums({"samples": raw["samples"], "spectra": raw["spectra"], ROW_CRC: raw["row_crc"]}))
    else:  # a file being written: its attributes here, its finished rows below
        stored = {k: v for k, v in stored.items() if k.startswith("attr:")}
    bad = sorted(k for k in set(stored) | set(now) if stored.get(k) != now.get(k))
    if bad:
        what = [f"attribute {k[5:].lstrip('/')}" if k.startswith("attr:") else k for k in bad]
        raise ResultsDamagedError(f"{path}: checksum mismatch in {', '.join(what)} (the file changed after its "
                                  "checksums were written: damaged on disk, edited, or a run stopped in the middle of a "
                                  "write)", data_intact=has_data and all(k.startswith("attr:") for k in bad), path=path)
    if not has_data and written_by_the_grid(raw):  # complete or not: a resume rewrites a complete file's attributes
        _verify_rows(path, raw)


def _stored_checksums(path, stored_json) -> dict:
    try:
        stored = json.loads(stored_json)
        if not isinstance(stored, dict):
            raise ValueError
    except (TypeError, ValueError):
        raise ResultsDamagedError(f"{path}: its checksums attribute is damaged", path=path) from None
    return stored


def _verify_rows(path, raw: Mapping) -> None:
    """Each finished row of an interrupted file against its stored CRC-32 (what a resume keeps)."""
    if raw["row_crc"] is None:
        raise ResultsDamagedError(f"{path}: its checksums cover no dataset and it has no row checksums ({ROW_CRC}; "
                                  "removed, or an interrupted file of a pycolfrag from before they were stored): its "
                                  "finished rows cannot be verified", path=path)
    status = np.asarray(raw["samples"]["status"])
    done = np.flatnonzero(status != STATUS_PENDING)
    stored = np.asarray(raw["row_crc"])
    if stored.shape != status.shape:
        raise ResultsDamagedError(f"{path}: {ROW_CRC} holds {stored.size} values for {status.size} rows", path=path)
    bad = done[row_checksums(raw["samples"], raw["spectra"], done) != stored[done]]
    if bad.size:
        shown = ", ".join(map(str, bad[:10].tolist())) + (" ..." if bad.size > 10 else "")
        raise ResultsDamagedError(f"{path}: checksum mismatch in {bad.size} finished row(s) ({shown}): they changed "
                                  "after they were written (damaged on disk or edited)", path=path)
