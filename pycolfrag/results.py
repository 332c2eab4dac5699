"""HDF5 results of the Monte Carlo grid (``scripts/run_grid.py``): layout, crash-safe writing, resume.

Reading a file for analysis (``load``, ``Results``) is :mod:`pycolfrag.analysis.data`; the names
``pycolfrag.results.load`` and ``pycolfrag.results.Results`` still work (see :func:`__getattr__`).

The layout is documented in ``docs/results_format.md`` and readable with h5py alone:

* group ``/samples``: one 1-D dataset per field of :data:`SAMPLE_FIELDS`, all of length
  ``n_scenarios * n_samples``, one row per run, ordered by (scenario, sample). The rows are
  allocated when the file is created; a row not computed yet has ``status == -1``
  (:data:`STATUS_PENDING`) and NaN/zero values.
* group ``/spectra``: ``sa_g`` (g) and ``sv_cm_s`` (cm/s), shape (rows, periods), attribute ``periods_s``.
* root attributes: ``seed``, ``n_ranks``, ``version``, ``git_revision``, ``column`` (JSON),
  ``solver`` (JSON), ``created`` and the grid arguments (see :func:`create`).

Crash safety
------------
HDF5 files are not safe against a kill in the middle of a write. Rank 0 therefore keeps an
append-only *journal* next to the file (``<file>.journal``, JSON lines): a header line with
the grid signature and root attributes, then one line per finished row, appended and flushed
to the operating system as soon as a row reaches rank 0 -- before the HDF5 file is touched.
The HDF5 file is opened, written, flushed and closed in short batches (:class:`ResultsWriter`).
A kill (SIGTERM or SIGKILL) can therefore at worst lose the HDF5 batch being written, never a
journalled row: :func:`open_for_run` (the resume path) recreates the HDF5 file from the journal
header when it cannot be opened and replays every journalled row into it (row writes are
idempotent), and :func:`load` overlays journalled rows in memory, so readers see every finished
sample even right after a kill. A truncated last journal line (killed mid-append) is ignored
and cut off before appending again. When a run completes, the HDF5 file is final (with CRC-32
``checksums`` of its datasets) and the journal is deleted; reopening such a file starts a journal
that holds its finished rows.

Faults from outside a run
-------------------------
* Two runs on one path: the writer holds :class:`RunLock` (``<file>.lock``, ``flock`` + holder's
  pid/host/start time); a second writer gets :class:`ResultsLockedError` naming the holder; a lock
  whose holder died is taken over.
* Rows of another run: the file and its journal carry the same ``run_id``; a journal is merged
  only if its signature and ``run_id`` match the file's (:func:`journal_mismatch`), else it is
  ignored (:func:`load`) or set aside (:func:`open_for_run`); every HDF5 write checks the file's
  ``run_id``, and :meth:`ResultsWriter.finish` deletes only its own journal.
* A damaged file: read in a forked child with a deadline and checked against its checksums
  (:func:`read_h5_bounded`), so a damaged file is reported (:class:`ResultsDamagedError`) instead
  of hanging the HDF5 library, and rebuilt from the journal when there is one.
* A journal whose header was cut (full disk) raises :class:`JournalHeaderError` in
  :func:`read_journal`; callers set it aside or ignore it, never crash.
"""
from __future__ import annotations

import fcntl
import json
import math
import os
import pickle
import re
import select
import signal
import socket
import time
import uuid
import warnings
import zlib
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from . import names as _names
from .errors import ResultsFileError
from .ground_motion import record as _gm_record
from .ground_motion import registry as _gm_registry

__all__ = [
    "FORMAT_VERSION", "SAMPLE_FIELDS", "STATUS_PENDING", "STATUS_OK", "STATUS_RECORD_FAILED",
    "STATUS_IM_FAILED", "STATUS_SOLVER_FAILED", "STATUS_OTHER_FAILED", "MESSAGE_BYTES",
    "ResultsWriter", "create", "merged_columns", "read_h5_bounded", "lock_held", "open_for_run",
    "journal_path", "read_journal",
    "signature_mismatch", "lock_path", "RunLock", "ResultsLockedError", "ResultsDamagedError",
    "OPEN_TIMEOUT_S", "JournalHeaderError", "journal_mismatch", "h5open",
]

FORMAT_VERSION = 1

#: ``status`` values (0 = ok; positive = failed in that phase; -1 = not computed yet).
STATUS_PENDING = -1
STATUS_OK = 0
STATUS_RECORD_FAILED = 1    # ground-motion synthesis raised
STATUS_IM_FAILED = 2        # intensity measures raised
STATUS_SOLVER_FAILED = 3    # simulate raised
STATUS_OTHER_FAILED = 9     # anything else (EDP extraction, a user sample function, ...)

#: Longest ``message`` stored in HDF5, bytes of UTF-8 (the journal keeps the full text).
MESSAGE_BYTES = 256

# name: (numpy dtype, fill value for rows not computed yet, unit/description)
# The IM and EDP fields are not spelled here: they come from the one registry (pycolfrag.names),
# "<description>, <unit>"; nor are the scenario and pulse fields of a synthetic row: they come from
# the ground-motion models' declarations (pycolfrag.ground_motion.registry).


def _quantity_fields(table) -> dict:
    out = {}
    for name, q in table.items():
        if not q.spectral:
            desc = f"{q.description}, {q.unit}"
            out[name] = ("f8", math.nan, desc)
    return out


def _declared_fields(parameters) -> dict:
    return {p.row_field: ("f8", math.nan, p.field_description) for p in parameters if p.row_field}


_STATUS_FIELDS = {
    "status": ("i4", STATUS_PENDING, "0 ok, 1 record, 2 IMs, 3 solver, 9 other failure, -1 not computed"),
    "message": ("S", b"", "error message of a failed run (UTF-8, truncated to MESSAGE_BYTES)"),
}
_RESPONSE_FIELDS = {
    "collapsed": ("u1", 0, "1 if the column collapsed, else 0"),
    "collapse_block": ("i4", -1, "lowest block that fell (-1: no collapse)"),
    "collapse_time_s": ("f8", math.nan, "time of collapse, s (NaN: no collapse)"),
    "n_steps": ("i8", 0, "solver time steps"),
    "t_end_s": ("f8", math.nan, "simulated time, s"),
    "energy_error": ("f8", math.nan, "relative energy balance error of the solver, -"),
    "energy_warning": ("u1", 0, "1 if energy_error exceeded the solver's tolerance"),
    "collapse_reason": ("S32", b"", "solver's collapse criterion (Response.collapse_reason), empty: none"),
    "solver_dt_s": ("f8", math.nan, "solver time step used, s"),
    # timing (the only fields that differ between runs with different rank counts)
    "wall_s": ("f8", math.nan, "wall time of the whole sample (record, IMs, solver), s"),
}

#: ``/samples`` of a synthetic grid (the default layout; root attribute ``layout`` absent).
SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = {
    # identity of the run
    "scenario": ("i4", -1, "scenario index in the grid (row-major over mw, then dist_km)"),
    "sample": ("i4", -1, "sample index within the scenario (row of the scenario's LHS)"),
    **_declared_fields(_gm_record.PARAMETERS),        # mw, dist_km
    **_STATUS_FIELDS,
    # sampled pulse parameters and record metadata (from Record.meta)
    **_declared_fields(_gm_registry.PULSE_FIELDS),
    "record_s": ("f8", math.nan, "record duration used (len(acc) * dt), s"),
    # intensity measures of the record, then the response (EDPs): from pycolfrag.names
    **_quantity_fields(_names.IMS),
    **_quantity_fields(_names.EDPS),
    **_RESPONSE_FIELDS,
}

#: Longest stored ``record_id``, ``event``, ``station``, ``mechanism`` (bytes of UTF-8; longer is cut).
LABEL_BYTES = 96

#: ``/samples`` of a record-suite grid (root attribute ``layout = "records"``,
#: ``scripts/run_grid.py --records``): one row per record x component x scale
#: (:func:`pycolfrag.sample.record_jobs`).
RECORD_SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = {
    # identity of the run
    "record": ("i4", -1, "index of the record in the suite (order of the suite table)"),
    "record_id": (f"S{LABEL_BYTES}", b"", "record identifier (PEER: RSN; UTF-8)"),
    "event": (f"S{LABEL_BYTES}", b"", "earthquake name (UTF-8)"),
    "station": (f"S{LABEL_BYTES}", b"", "recording station (UTF-8)"),
    "component": ("S8", b"", "component run: h1, h2 or both (H1 along x, H2 along y)"),
    "scale": ("f8", math.nan, "amplitude factor applied to every component, -"),
    "mw": ("f8", math.nan, "moment magnitude"),
    "rrup_km": ("f8", math.nan, "closest distance to the rupture plane Rrup, km"),
    "dist_km": ("f8", math.nan, "= rrup_km (the synthetic grid's distance definition), km"),
    **_STATUS_FIELDS,
    # further record metadata (NaN / empty when the source does not give it)
    "rjb_km": ("f8", math.nan, "Joyner-Boore distance, km"),
    "vs30_m_s": ("f8", math.nan, "Vs30 of the station, m/s"),
    "tp_s": ("f8", math.nan, "pulse period given by the source (PEER), s"),
    "year": ("f8", math.nan, "year of the earthquake"),
    "mechanism": (f"S{LABEL_BYTES}", b"", "fault mechanism (UTF-8)"),
    "rotation_deg": ("f8", math.nan, "rotation of the pair before the run, degrees (NaN: as recorded)"),
    "dt_s": ("f8", math.nan, "time step of the record, s"),
    "record_s": ("f8", math.nan, "record duration used (samples * dt), s"),
    **_quantity_fields(_names.IMS),
    **_quantity_fields(_names.EDPS),
    **_RESPONSE_FIELDS,
}

#: Values of the root attribute ``layout``: None (absent) = synthetic grid.
LAYOUTS = {None: SAMPLE_FIELDS, "synthetic": SAMPLE_FIELDS, "records": RECORD_SAMPLE_FIELDS}


def fields_of(layout) -> dict:
    """The ``/samples`` fields of a layout (``None``/``"synthetic"`` or ``"records"``)."""
    if isinstance(layout, bytes):
        layout = layout.decode()
    try:
        return LAYOUTS[layout]
    except (KeyError, TypeError):
        raise ResultsFileError(f"unknown results layout {layout!r} (known: synthetic, records)") from None


#: Fields whose values depend on the machine/ranks rather than the inputs.
TIMING_FIELDS = ("wall_s",)

#: Seconds a results file may take to open and read fully before it is called damaged (a damaged
#: HDF5 file can make the HDF5 library loop forever; the read runs in a forked child that is killed
#: at the deadline). Environment variable ``PYCOLFRAG_OPEN_TIMEOUT_S`` overrides it; 1 s is added
#: per 50 MB of file.
OPEN_TIMEOUT_S = 30.0


class ResultsLockedError(ResultsFileError):
    """The results file is being written by another running grid (its lock is held)."""


class ResultsDamagedError(ResultsFileError):
    """The HDF5 file cannot be read (error, checksum mismatch or no answer within the time limit).
    ``data_intact``: every dataset passed its checksum (only attributes are damaged)."""

    def __init__(self, message="", data_intact: bool = False):
        super().__init__(message)
        self.data_intact = data_intact

    def __reduce__(self):  # crosses the pipe of the reading child intact
        return (type(self), (str(self), self.data_intact))


#: ``/spectra`` datasets (rows x periods): the spectral IMs of :mod:`pycolfrag.names`.
SPECTRA_FIELDS = {name: f"{q.description}, {q.unit}" for name, q in _names.IMS.items() if q.spectral}


def _h5py():
    import h5py  # imported lazily: reading the field table must not need h5py
    return h5py


def h5open(path, mode: str = "r"):
    """``h5py.File(path, mode)`` without HDF5's file locks. With them (the library's default) a reader
    holding the file open -- h5py, HDFView, :func:`load` polling -- makes the grid's next write fail
    ("unable to lock file", exit 4), and a writer between batches locks readers out. Only one process
    writes a results file (the run lock, :class:`RunLock`), it writes in short batches with ``status``
    last, and readers that want every finished row take the journal too (:func:`load`)."""
    return _h5py().File(path, mode, locking=False)


def journal_path(path) -> Path:
    """The journal sidecar of a results file: ``<path>.journal``."""
    return Path(os.fspath(path) + ".journal")


def row_bytes(n_periods: int, layout=None) -> int:
    """Bytes one row takes in the HDF5 file: its ``/samples`` fields and its ``/spectra`` rows."""
    return sum(_dtype(code).itemsize for code, _, _ in fields_of(layout).values()) + 8 * len(SPECTRA_FIELDS) * n_periods


def _dtype(code: str):
    if code == "S":
        return np.dtype(f"S{MESSAGE_BYTES}")
    return np.dtype(code)


def _encode_message(msg, limit: int = MESSAGE_BYTES) -> bytes:
    b = str(msg or "").encode("utf-8")
    if len(b) <= limit:
        return b
    return b[:limit].decode("utf-8", errors="ignore").encode("utf-8")  # cut on a character boundary


# ---------------------------------------------------------------------------------------
# rows <-> columns
# ---------------------------------------------------------------------------------------

def empty_columns(n_rows: int, n_periods: int, layout=None) -> tuple[dict, dict]:
    """Columns of ``n_rows`` pending rows of a layout (:func:`fields_of`): (samples dict, spectra dict)."""
    samples = {}
    for name, (code, fill, _) in fields_of(layout).items():
        dt = _dtype(code)
        samples[name] = np.full(n_rows, fill, dtype=dt)
    spectra = {name: np.full((n_rows, n_periods), np.nan) for name in SPECTRA_FIELDS}
    return samples, spectra


def _put_row(samples: dict, spectra: dict, i: int, row: Mapping, layout=None) -> None:
    for name, (code, fill, _) in fields_of(layout).items():
        if name not in samples:  # a file in the documented layout written by other code may lack fields
            continue
        v = row.get(name, fill)
        if code.startswith("S"):
            samples[name][i] = _encode_message(v, samples[name].dtype.itemsize)
        elif v is None:
            samples[name][i] = fill
        else:
            samples[name][i] = v
    for name in SPECTRA_FIELDS:
        v = row.get(name)
        if v is not None and name in spectra:
            spectra[name][i, :] = np.asarray(v, dtype=float)


def _row_to_json(row: Mapping) -> str:
    """One journal line. Python floats round-trip exactly through JSON (shortest repr);
    NaN and inf use JSON's common extension, which :func:`json.loads` reads back."""
    out = {}
    for k, v in row.items():
        if isinstance(v, np.ndarray):
            v = [float(x) for x in v]
        elif isinstance(v, (np.floating,)):
            v = float(v)
        elif isinstance(v, (np.integer, np.bool_)):
            v = int(v)
        elif isinstance(v, bool):
            v = int(v)
        elif isinstance(v, bytes):
            v = v.decode("utf-8", errors="replace")
        out[k] = v
    return json.dumps(out, separators=(",", ":"))


def _rows_of(samples: Mapping, spectra: Mapping, rows) -> list[dict]:
    """Rows ``rows`` of a file's columns as row dicts (the inverse of :func:`_put_row`)."""
    out = []
    for i in rows:
        row = {name: v[i] for name, v in samples.items()}
        row.update({name: spectra[name][i] for name in SPECTRA_FIELDS if name in spectra})
        row["row"] = int(i)
        out.append(row)
    return out


# ---------------------------------------------------------------------------------------
# journal
# ---------------------------------------------------------------------------------------

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
    callers set such a journal aside (:func:`open_for_run`) or ignore it with a warning (:func:`load`).

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


def _journal_run_id(jp: Path):
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


def _set_aside(p: Path, reason: str, log) -> Path:
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


class _Journal:
    def __init__(self, path: Path):
        self.path = path
        self.fh = open(path, "a", encoding="utf-8")

    def append(self, rows: Iterable[Mapping]) -> None:
        self.fh.write("".join(_journal_line(_row_to_json(r)) for r in rows))
        self.fh.flush()  # in the OS page cache: survives a kill of this process

    def sync(self) -> None:
        self.fh.flush()
        os.fsync(self.fh.fileno())  # survives a machine crash too

    def close(self) -> None:
        if not self.fh.closed:
            self.fh.close()


# ---------------------------------------------------------------------------------------
# the run lock
# ---------------------------------------------------------------------------------------

def lock_path(path) -> Path:
    """The lock sidecar of a results file: ``<path>.lock``."""
    return Path(os.fspath(path) + ".lock")


def _holder_text(info: Mapping) -> str:
    return (f"pid {info.get('pid', '?')} on host {info.get('host', '?')}, started {info.get('started', '?')}"
            + (f" ({info['command']})" if info.get("command") else ""))


def _read_holder(fd: int) -> dict:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        data = os.read(fd, 1 << 16)
        return json.loads(data.decode("utf-8")) if data.strip() else {}
    except (OSError, ValueError, UnicodeDecodeError):
        return {}


def lock_held(results_path) -> bool:
    """Whether a run holds the lock of ``results_path`` now (its :class:`RunLock`)."""
    try:
        fd = os.open(lock_path(results_path), os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except OSError:
        return True
    finally:
        os.close(fd)


def _pid_alive(pid) -> bool:
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except (PermissionError, TypeError, ValueError, OverflowError):
        return True
    return True


class RunLock:
    """Exclusive lock on a results path, held by the one process that writes it (rank 0).

    ``<path>.lock`` is locked with ``flock(LOCK_EX | LOCK_NB)`` and holds JSON with the holder's
    pid, host and start time. The kernel drops an flock when its process dies (also by SIGKILL),
    so a lock file that can be locked is stale: its former holder is gone, and the new run takes
    it over (and says so, with whether that pid still exists when it was on this host). A second
    run while the holder lives is refused with :class:`ResultsLockedError` naming the holder.
    flock does not protect across hosts on file systems without lock support (some NFS set-ups):
    there the pid/host in the file is still shown, but only the kernel's lock is enforced.
    """

    def __init__(self, path: Path, fd: int, info: dict, stale: dict | None):
        self.path, self._fd, self.info, self.stale = path, fd, info, stale

    @classmethod
    def acquire(cls, results_path, log=None, command: str | None = None) -> "RunLock":
        log = log or (lambda s: warnings.warn(s, stacklevel=3))
        lp = lock_path(results_path)
        lp.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(10):
            fd = os.open(lp, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _read_holder(fd)
                os.close(fd)
                raise ResultsLockedError(
                    f"{results_path} is being written by another run: {_holder_text(holder)}; lock file {lp}. "
                    "Wait for that run to end, or use --out for another file.") from None
            except BaseException:
                os.close(fd)
                raise
            try:  # a run that releases unlinks the file: make sure we locked the one at the path
                same = os.stat(lp).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            old = _read_holder(fd)
            info = {"pid": os.getpid(), "host": socket.gethostname(),
                    "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
            if command:
                info["command"] = command[:300]
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, (json.dumps(info) + "\n").encode("utf-8"))
            os.fsync(fd)
            stale = old or None
            if stale:
                same_host = stale.get("host") == info["host"]
                state = ("no longer running" if not _pid_alive(stale.get("pid")) else "pid exists but does not hold "
                         "the lock") if same_host else "on another host; its lock was released"
                log(f"took over a stale lock on {results_path} left by {_holder_text(stale)}: {state}")
            return cls(lp, fd, info, stale)
        raise ResultsLockedError(f"could not take the lock {lp}: it keeps being replaced by other runs")

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # unlinked while still locked: no one can lock this inode after
        except OSError:
            pass
        finally:
            os.close(self._fd)
            self._fd = None


# ---------------------------------------------------------------------------------------
# time-bounded, checksummed reading of the HDF5 file
# ---------------------------------------------------------------------------------------

def _checksums(groups) -> dict:
    """CRC-32 of every dataset's bytes (stored in the root attribute ``checksums`` when complete).
    ``groups``: an open file, or {"samples": {name: array}, "spectra": {...}} already read from one."""
    out = {}
    for grp in ("samples", "spectra"):
        for name in (groups[grp] if grp in groups else ()):
            out[f"{grp}/{name}"] = zlib.crc32(np.ascontiguousarray(groups[grp][name][...]).tobytes())
    return out


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


def _all_attrs(f) -> dict:
    """Every attribute of a results file (root, groups, datasets) as {object path: {name: value}}."""
    out = {"/": dict(f.attrs)}
    for grp in ("samples", "spectra"):
        if grp in f:
            out[grp] = dict(f[grp].attrs)
            for name in f[grp]:
                out[f"{grp}/{name}"] = dict(f[grp][name].attrs)
    return out


def _store_checksums(f, datasets: bool) -> None:
    """Store the root attribute ``checksums``: every attribute's CRC always, every dataset's when
    ``datasets`` (a complete file; the datasets of a file being written change at every batch)."""
    f.flush()
    sums = _attr_checksums(_all_attrs(f))
    if datasets:
        sums.update(_checksums(f))
    f.attrs["checksums"] = json.dumps(sums, sort_keys=True)


def _verify_checksums(path, stored_json, samples, spectra, attrs_by_object) -> None:
    """Raise :class:`ResultsDamagedError` naming what fails its stored checksum: every attribute, and
    every dataset when the file stored dataset checksums (complete files)."""
    try:
        stored = json.loads(stored_json)
        if not isinstance(stored, dict):
            raise ValueError
    except (TypeError, ValueError):
        raise ResultsDamagedError(f"{path}: its checksums attribute is damaged") from None
    now = _attr_checksums(attrs_by_object)
    if any(not k.startswith("attr:") for k in stored):
        now.update(_checksums({"samples": samples, "spectra": spectra}))
    else:  # a file being written: only its attributes are covered
        stored = {k: v for k, v in stored.items() if k.startswith("attr:")}
    bad = sorted(k for k in set(stored) | set(now) if stored.get(k) != now.get(k))
    if bad:
        what = [f"attribute {k[5:].lstrip('/')}" if k.startswith("attr:") else k for k in bad]
        has_data = any(not k.startswith("attr:") for k in stored)
        raise ResultsDamagedError(f"{path}: checksum mismatch in {', '.join(what)} (the file changed after its "
                                  "checksums were written: damaged on disk, edited, or a run stopped in the middle of a "
                                  "write)", data_intact=has_data and all(k.startswith("attr:") for k in bad))


def _read_h5(path: Path, any_layout: bool = False, verify: bool = True) -> dict:
    """Read every dataset and attribute; verify the stored checksums. Raises on any damage.

    ``any_layout``: also read a file in the documented layout that ``run_grid.py`` did not write
    (a ``/samples`` group, no ``grid_signature``; ``/spectra`` optional)."""
    with h5open(path, "r") as f:
        if "samples" not in f or ("grid_signature" not in f.attrs and not any_layout):
            raise ResultsFileError(f"{path} is not a pycolfrag grid results file (no grid_signature attribute); "
                                   "use --overwrite to replace it or --out for another file")
        samples = {name: f["samples"][name][...] for name in f["samples"]}
        spectra = {name: f["spectra"][name][...] for name in f["spectra"]} if "spectra" in f else {}
        periods = (np.asarray(f["spectra"].attrs["periods_s"], dtype=float)
                   if "spectra" in f and "periods_s" in f["spectra"].attrs else np.zeros(0))
        every = _all_attrs(f)
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in every["/"].items()}
        if "checksums" in attrs and verify:
            _verify_checksums(path, attrs["checksums"], samples, spectra, every)
    return {"samples": samples, "spectra": spectra, "periods": periods, "attrs": attrs}


def _open_timeout(path: Path, timeout_s) -> float:
    if timeout_s is None:
        timeout_s = float(os.environ.get("PYCOLFRAG_OPEN_TIMEOUT_S", OPEN_TIMEOUT_S))
        try:
            timeout_s += os.path.getsize(path) / 50e6
        except OSError:
            pass
    return float(timeout_s)


def read_h5_bounded(path: Path, timeout_s=None, any_layout: bool = False, verify: bool = True) -> dict:
    """:func:`_read_h5` in a forked child (:func:`_in_child`), killed after ``timeout_s`` s.

    Some damage (e.g. zeroed bytes in an HDF5 B-tree) makes the HDF5 library loop forever while
    holding the GIL: neither a thread nor a signal can stop it in this process, but a child can be
    killed. Raises :class:`ResultsDamagedError` for a file that errors, fails its checksums or does
    not answer in time; ``FileNotFoundError`` if absent; other :class:`ResultsFileError` as is.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"results file not found: {path}")
    timeout_s = _open_timeout(path, timeout_s)
    try:
        return _in_child(_read_h5, path, any_layout, verify, timeout_s=timeout_s)
    except _ChildLost as lost:
        if lost.timed_out:
            raise ResultsDamagedError(f"{path} did not open within {timeout_s:.0f} s (the HDF5 library stalled on "
                                      "it: the file is damaged)") from None
        raise ResultsDamagedError(f"{path}: reading it crashed the reading process (the file is damaged)") from None
    except ResultsFileError:
        raise
    except Exception as exc:  # noqa: BLE001 -- whatever the HDF5 library raised: the file cannot be read
        raise ResultsDamagedError(f"{path} cannot be read ({type(exc).__name__}: {exc}): the file is "
                                  "damaged") from None


class _ChildLost(Exception):
    """The child of :func:`_in_child` sent no answer: it died (``status``) or ran out of time."""

    def __init__(self, status=None, timed_out: bool = False):
        super().__init__(f"child ended without an answer (status {status}, timed out {timed_out})")
        self.status, self.timed_out = status, timed_out


def _in_child(fn, *args, timeout_s: float | None = None, quiet: bool = False):
    """``fn(*args)`` in a forked child; return what it returned, or raise what it raised (both pickled
    back through a pipe). :class:`_ChildLost` when the child died without a word (a crash of the
    HDF5 library) or, with ``timeout_s``, did not answer in time (it is killed then).

    The HDF5 library can hang on a damaged file holding the GIL, or crash the process when a write
    fails (a full disk); in a child, this process survives both. ``quiet``: the child's stderr goes
    to /dev/null (the HDF5 library's clean-up noise after a failed write)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: run, send the result (or the error) back, exit without clean-up handlers
        code = 0
        try:
            os.close(r)
            if quiet:
                os.dup2(os.open(os.devnull, os.O_WRONLY), 2)
            try:
                out = ("ok", fn(*args))
            except BaseException as exc:  # noqa: BLE001 -- every failure goes to the parent
                try:
                    pickle.dumps(exc)
                    out = ("err", exc)
                except Exception:
                    out = ("err", RuntimeError(f"{type(exc).__name__}: {exc}"))
            view = memoryview(pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL))
            while view:
                view = view[os.write(w, view):]
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    chunks, timed_out = [], False
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    try:
        while True:
            left = 1.0 if deadline is None else deadline - time.monotonic()
            if left <= 0:
                timed_out = True
                break
            ready, _, _ = select.select([r], [], [], min(left, 1.0))
            if ready:
                b = os.read(r, 1 << 20)
                if not b:
                    break
                chunks.append(b)
    finally:
        os.close(r)
        if timed_out:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        _, status = os.waitpid(pid, 0)
    if timed_out:
        raise _ChildLost(status, timed_out=True)
    try:
        kind, val = pickle.loads(b"".join(chunks))
    except Exception:
        raise _ChildLost(status) from None
    if kind == "err":
        raise val
    return val


# ---------------------------------------------------------------------------------------
# creating / resuming
# ---------------------------------------------------------------------------------------

def _attr_value(v):
    if isinstance(v, (list, tuple)):
        return np.asarray(v, dtype=float)
    if v is None:
        return "null"
    return v


def _create_h5(path: Path, n_rows: int, periods_s: Sequence[float], attrs: Mapping) -> None:
    """Write the new file as ``<path>.tmp`` in a forked child, then rename it into place.

    In a child because the HDF5 library, when a write fails (a full disk), raises RuntimeErrors from
    its clean-up and can crash the process at exit; the parent gets the error back as the OSError
    it is (:func:`_os_error_of`), or the child's exception (e.g. a TypeError for a value HDF5 cannot
    store), and removes the partial ``.tmp``."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        try:
            _in_child(_write_new_h5, tmp, n_rows, periods_s, attrs, quiet=True)
        except _ChildLost as lost:
            raise OSError(f"creating the results file crashed the writing process (status {lost.status})") from None
    except BaseException as exc:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        err = _os_error_of(exc, tmp)
        if err is exc:
            raise
        raise err from None
    os.replace(tmp, path)  # the file appears complete or not at all


def _write_new_h5(tmp: Path, n_rows: int, periods_s: Sequence[float], attrs: Mapping) -> None:
    with h5open(tmp, "w") as f:
        g = f.create_group("samples")
        for name, (code, fill, desc) in fields_of(attrs.get("layout")).items():
            dt = _dtype(code)
            ds = g.create_dataset(name, shape=(n_rows,), dtype=dt, fillvalue=np.array(fill, dtype=dt))
            # allocate and fill now: later writes are then plain in-place data writes
            ds[...] = np.full(n_rows, fill, dtype=dt)
            ds.attrs["description"] = desc
        s = f.create_group("spectra")
        s.attrs["periods_s"] = np.asarray(periods_s, dtype=float)
        for name, desc in SPECTRA_FIELDS.items():
            ds = s.create_dataset(name, shape=(n_rows, len(periods_s)), dtype="f8", fillvalue=np.nan)
            ds[...] = np.nan
            ds.attrs["description"] = desc
            ds.attrs["periods_s"] = np.asarray(periods_s, dtype=float)
        for k, v in attrs.items():
            f.attrs[k] = _attr_value(v)
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["complete"] = False
        f.attrs["n_done"] = 0
        _store_checksums(f, datasets=False)


def signature_mismatch(old: Mapping, new: Mapping, names=("file has", "this run asks for")) -> list[str]:
    """Human-readable differences between two grid signatures (empty when they agree)."""
    def short(v):
        return v if len(v) <= 120 else v[:117] + "..."

    diffs = []
    for k in sorted(set(old) | set(new)):
        sa, sb = (json.dumps(d.get(k, "<absent>"), sort_keys=True) for d in (old, new))
        if sa != sb:
            diffs.append(f"{k}: {names[0]} {short(sa)}, {names[1]} {short(sb)}")
    return diffs


def create(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float]) -> str:
    """Create a new results file and its journal (replacing both if present); returns its ``run_id``.

    ``signature`` holds everything that fixes the results (grid, seed, column, solver options,
    periods...): it is stored as the root attribute ``grid_signature`` (JSON) and compared on resume.
    ``attrs`` are further root attributes (lists become float arrays). A fresh ``run_id`` (random)
    names this file's lineage: its journal carries the same id, and a writer refuses to write a
    file or delete a journal with another id. The caller holds the :class:`RunLock`.
    If creating fails (full disk, values HDF5 cannot store) nothing is left behind.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    jp = journal_path(path)
    tmp = path.with_name(path.name + ".tmp")
    for p in (jp, path, tmp):
        if p.exists():
            p.unlink()
    all_attrs = dict(attrs)
    all_attrs["grid_signature"] = json.dumps(signature, sort_keys=True)
    all_attrs["run_id"] = uuid.uuid4().hex
    try:
        _write_journal_header(jp, n_rows, periods_s, signature, all_attrs)
        _create_h5(path, n_rows, periods_s, all_attrs)
    except BaseException:
        for p in (jp, tmp):
            try:
                p.unlink(missing_ok=True)
            except OSError:
                pass
        raise
    return all_attrs["run_id"]


def open_for_run(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float],
                 overwrite: bool = False, log=None, timeout_s=None, command: str | None = None) -> "ResultsWriter":
    """Lock ``path`` (:class:`RunLock`), then create it or resume it: returns a :class:`ResultsWriter`
    (which holds the lock until :meth:`ResultsWriter.finish`/``close``) whose ``done`` mask says
    which rows are already computed.

    On resume the stored ``grid_signature`` must equal ``signature``, else
    :class:`~pycolfrag.errors.ResultsFileError` (unless ``overwrite``). The journal must belong to
    the file (same signature and ``run_id``): a journal of another run, or one whose header is bad,
    is set aside (renamed ``<journal>.set-aside-<time>``, with a message through ``log``) and none
    of its rows is used. A damaged HDF5 file (an error, a checksum mismatch, or no answer within
    ``timeout_s``) is set aside and rebuilt from its journal; journalled rows missing from the HDF5
    file are written into it. ``log`` (default: :func:`warnings.warn`) receives those messages.
    ``path`` is resolved to its real path first (symlinks followed): the lock, journal and file
    are those of the file itself, whatever name reaches it.
    """
    log = log or (lambda s: warnings.warn(s, stacklevel=3))
    # the lock, the journal and the file are those of the real path: a symlink to a results file
    # (or a path through a linked folder) must meet the lock of the run writing it
    path = Path(os.path.realpath(path))
    lock = RunLock.acquire(path, log, command)
    try:
        writer = _open_locked(path, signature, attrs, n_rows, periods_s, overwrite, log, timeout_s)
    except BaseException:
        lock.release()
        raise
    writer._lock = lock
    return writer


def _open_locked(path: Path, signature, attrs, n_rows, periods_s, overwrite, log, timeout_s) -> "ResultsWriter":
    jp = journal_path(path)
    if overwrite or (not path.exists() and not jp.exists()):
        run_id = create(path, signature, attrs, n_rows, periods_s)
        return ResultsWriter(path, n_rows, len(periods_s), resumed=False, run_id=run_id)

    header, jrows = None, {}
    if jp.exists():
        try:
            header, jrows = read_journal(jp, truncate=True, report=log)
        except JournalHeaderError as exc:
            _set_aside(jp, f"{exc}; its rows cannot be trusted", log)
    h5, damage = None, None
    if path.exists():
        try:
            h5 = read_h5_bounded(path, timeout_s)
        except ResultsDamagedError as exc:
            if header is None:
                raise ResultsDamagedError(_salvage_text(path, exc), data_intact=exc.data_intact) from None
            damage = exc
    if h5 is not None and header is not None:
        diffs = journal_mismatch(header, h5["attrs"])
        if diffs:
            _set_aside(jp, "it belongs to another run (" + "; ".join(diffs) + "); none of its rows is used", log)
            header, jrows = None, {}
    if h5 is not None:
        old_sig = json.loads(h5["attrs"]["grid_signature"])
    elif header is not None:
        old_sig = header["signature"]
    else:  # only a journal with a bad header was there (set aside above): nothing to resume
        run_id = create(path, signature, attrs, n_rows, periods_s)
        return ResultsWriter(path, n_rows, len(periods_s), resumed=False, run_id=run_id)
    diffs = signature_mismatch(old_sig, signature)
    if diffs:
        why = ""
        if any(d.startswith(("build:", "solver:")) for d in diffs):
            why = ("\nIts rows were computed by another build of pycolfrag or with other solver options (the code or "
                   "a default changed since): resuming would mix rows of two versions in one file.")
        raise ResultsFileError(
            f"{path} holds a different run; it cannot be resumed with these arguments:\n  - "
            + "\n  - ".join(diffs) + why
            + "\nUse --overwrite to replace it (every row is recomputed), or --out for another file.")
    if h5 is None:  # rebuild from the journal header, then replay every row below
        if damage is not None:
            _set_aside(path, f"{damage}; rebuilding it from {jp.name}", log)
        hattrs = dict(header["attrs"])
        hattrs["rebuilt_from_journal"] = True
        _create_h5(path, int(header["n_rows"]), header["periods_s"], hattrs)
        run_id = hattrs.get("run_id")
    else:
        run_id = h5["attrs"].get("run_id")
    if header is None:
        # a journal-less file (finished run, or journal deleted): start a new journal for this
        # session that also holds the file's finished rows, so that a kill during this session's
        # HDF5 writes can rebuild the file from the journal without losing them
        samples, spectra, _, old_attrs = merged_columns(h5)
        old_attrs = {k: v for k, v in old_attrs.items() if k != "checksums"}
        _write_journal_header(jp, n_rows, periods_s, signature, old_attrs)
        journal = _Journal(jp)
        journal.append(_rows_of(samples, spectra, np.flatnonzero(samples["status"] != STATUS_PENDING)))
        journal.sync()
        journal.close()
    if jrows:  # idempotent replay: rows the HDF5 file may have missed when the run was killed
        _write_rows_h5(path, list(jrows.values()), n_rows, len(periods_s), run_id=run_id)
    writer = ResultsWriter(path, n_rows, len(periods_s), resumed=True, run_id=run_id)
    if writer.false_done:
        log(f"{path}: {writer.false_done} row(s) marked done carry no identity or an unknown status (damaged "
            "status bytes): they are recomputed")
    return writer


def _salvage_text(path: Path, exc: "ResultsDamagedError") -> str:
    """What to do with a damaged results file that has no journal: it is left as it is (never
    deleted); its rows may still be worth keeping."""
    if exc.data_intact:
        rows = ("every dataset passes its checksum, so its rows are intact: read them with "
                f"pycolfrag.results.load('{path}', verify=False) and check the attributes by hand")
    else:
        rows = (f"the rows that can still be read come from pycolfrag.results.load('{path}', verify=False) "
                "(check them: part of the file is damaged)")
    return (f"{exc}. The file is left as it is and there is no journal to rebuild it from; {rows}. To "
            f"recompute, move it aside first (mv {path} {path}.damaged) and rerun the same command, or write "
            "elsewhere with --out (--overwrite would delete it)")


def _write_journal_header(jp: Path, n_rows: int, periods_s, signature: Mapping, attrs: Mapping) -> None:
    """Start a journal: its first line holds what rebuilding the HDF5 file needs (fsynced)."""
    def plain(v):  # list/array attributes are float arrays in the HDF5 file (_attr_value)
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


def _os_error_of(exc: BaseException, path) -> BaseException:
    """An HDF5 write error as the OSError it is: h5py raises RuntimeError (or OSError without an errno)
    for a failed write, with the system's ``errno = N`` in its text (a full disk: 28)."""
    seen, e = 0, exc
    while e is not None and seen < 8:  # closing after a failed write raises again: look down the chain
        if isinstance(e, OSError) and e.errno:
            return e if e.filename else OSError(e.errno, os.strerror(e.errno), os.fspath(path))
        m = re.search(r"errno = (\d+)", str(e))
        if m and int(m.group(1)) > 0:
            n = int(m.group(1))
            return OSError(n, os.strerror(n), os.fspath(path))
        e, seen = e.__context__, seen + 1
    return exc


def _write_rows_h5(path: Path, rows: list, n_rows: int, n_periods: int, attrs: Mapping | None = None,
                   run_id: str | None = None, checksums: bool = False) -> None:
    try:
        _write_rows_h5_unguarded(path, rows, n_rows, n_periods, attrs, run_id, checksums)
    except (RuntimeError, OSError) as exc:
        err = _os_error_of(exc, path)
        if err is exc:
            raise
        raise err from None


def _write_rows_h5_unguarded(path: Path, rows: list, n_rows: int, n_periods: int, attrs: Mapping | None = None,
                             run_id: str | None = None, checksums: bool = False) -> None:
    """Open, write rows (by their ``row`` index) and root attributes, flush, close.

    With ``run_id``, the file must carry that ``run_id`` (else :class:`ResultsFileError`: another
    run replaced the file, and nothing is written into it). Writing rows removes the stored
    ``checksums``; ``checksums=True`` stores them afresh after the write (complete files).
    """
    with h5open(path, "r+") as f:
        found = f.attrs.get("run_id")
        found = found.decode() if isinstance(found, bytes) else found
        if run_id is not None and found != run_id:
            raise ResultsFileError(f"{path} was replaced by another run (run_id {found}, this run wrote "
                                   f"{run_id}): nothing more is written into it")
        if rows:
            rows = sorted(rows, key=lambda r: int(r["row"]))
            idx = np.array([int(r["row"]) for r in rows])
            if idx.min() < 0 or idx.max() >= n_rows:
                raise ResultsFileError(f"row index out of range 0..{n_rows - 1} in results batch")
            keep = np.r_[idx[1:] != idx[:-1], True]  # duplicates (a replayed row): keep the last
            rows = [r for r, k in zip(rows, keep) if k]
            idx = idx[keep]
            layout = f.attrs.get("layout")
            cols, spec = empty_columns(len(rows), n_periods, layout)
            for j, r in enumerate(rows):
                _put_row(cols, spec, j, r, layout)
            g = f["samples"]
            # status last: a kill part-way through this batch leaves its rows pending (status -1)
            # in the HDF5 file, never marked done with half their fields
            for name in SPECTRA_FIELDS:
                f["spectra"][name][idx, :] = spec[name]
            for name in fields_of(layout):
                if name != "status":
                    g[name][idx] = cols[name]
            f.flush()
            g["status"][idx] = cols["status"]
            f.attrs["n_done"] = int(np.count_nonzero(g["status"][...] != STATUS_PENDING))
        if attrs:
            for k, v in attrs.items():
                f.attrs[k] = _attr_value(v)
        _store_checksums(f, datasets=checksums)  # every attribute always; the datasets when complete
        f.flush()


#: ``status`` values a written row can hold.
_KNOWN_STATUS = (STATUS_OK, STATUS_RECORD_FAILED, STATUS_IM_FAILED, STATUS_SOLVER_FAILED, STATUS_OTHER_FAILED)


def _false_done(samples: Mapping, layout) -> np.ndarray:
    """Rows whose ``status`` says done but which cannot be: an unknown status code, or no identity
    (``scenario``/``record`` still -1, the value of a row never written -- every row the grid writes,
    failed ones too, carries it). Damaged status bytes (e.g. zeroed by a crash of the file system)
    would otherwise read as successful rows of NaN that are never recomputed."""
    status = np.asarray(samples["status"])
    done = status != STATUS_PENDING
    bad = done & ~np.isin(status, _KNOWN_STATUS)
    if fields_of(layout) is RECORD_SAMPLE_FIELDS:
        # a record row is named by its index or its id (files written by other code may give only the id)
        if "record" in samples:
            nameless = np.asarray(samples["record"]) < 0
            if "record_id" in samples:
                nameless &= np.array([not (x.strip() if isinstance(x, (bytes, str)) else x)
                                      for x in samples["record_id"]], dtype=bool)
            bad |= done & nameless
    elif "scenario" in samples:
        bad |= done & (np.asarray(samples["scenario"]) < 0)
    return bad


def merged_columns(raw: Mapping | None, header: Mapping | None = None, jrows: Mapping | None = None):
    """The columns of a file as :func:`read_h5_bounded` read them (or, when ``raw`` is None, the pending
    columns of a journal header), with the journalled rows ``jrows`` laid over them (the journal is
    authoritative for every row it holds) and rows marked done that cannot be (:func:`_false_done`)
    read as not computed, with a warning. Returns ``(samples, spectra, periods_s, attrs)``, copies.

    The one text of what a finished row is: the resume path takes its rows from here, and so does the
    reader (:func:`pycolfrag.analysis.data.load`)."""
    if raw is not None:
        samples = {k: v.copy() for k, v in raw["samples"].items()}
        spectra = {k: v.copy() for k, v in raw["spectra"].items()}
        periods, attrs = raw["periods"], dict(raw["attrs"])
    else:
        periods = np.asarray(header["periods_s"], dtype=float)
        attrs = dict(header["attrs"])
        samples, spectra = empty_columns(int(header["n_rows"]), len(periods), attrs.get("layout"))
    bad = _false_done(samples, attrs.get("layout"))
    if bad.any():
        warnings.warn(f"{int(bad.sum())} row(s) of the results file are marked done but carry no identity or an "
                      f"unknown status (damaged status bytes; rows {np.flatnonzero(bad)[:10].tolist()}...): they "
                      "are read as not computed (a rerun of the grid recomputes them)", stacklevel=4)
        samples["status"][bad] = STATUS_PENDING
    if jrows:
        for i, r in jrows.items():
            _put_row(samples, spectra, i, r, attrs.get("layout"))
    if jrows or bad.any():
        attrs["n_done"] = int(np.count_nonzero(samples["status"] != STATUS_PENDING))
    return samples, spectra, periods, attrs


class ResultsWriter:
    """Rank 0's writer: journal every row at once, HDF5 in batches (open, write, flush, close)."""

    def __init__(self, path, n_rows: int, n_periods: int, resumed: bool, run_id: str | None = None):
        self.path = Path(path)
        self.n_rows = int(n_rows)
        self.n_periods = int(n_periods)
        self.resumed = resumed
        self.run_id = run_id
        self._lock: RunLock | None = None
        self._pending: list[dict] = []
        self._journal = _Journal(journal_path(self.path))
        with h5open(self.path, "r") as f:
            g = f["samples"]
            self.status = g["status"][...]
            ident = {k: g[k][...] for k in ("scenario", "record", "record_id") if k in g}
            layout = f.attrs.get("layout")
        bad = _false_done({"status": self.status, **ident}, layout)
        #: rows the HDF5 file marks done that cannot be (damaged status bytes): recomputed
        self.false_done = int(bad.sum())
        self.status[bad] = STATUS_PENDING

    @property
    def done(self) -> np.ndarray:
        """Rows finished (ok or failed): ``status != STATUS_PENDING``."""
        return self.status != STATUS_PENDING

    def add(self, rows: Iterable[Mapping]) -> None:
        """Journal finished rows now; they reach the HDF5 file at the next :meth:`flush`."""
        rows = list(rows)
        if not rows:
            return
        self._journal.append(rows)
        for r in rows:
            self.status[int(r["row"])] = int(r.get("status", STATUS_OK))
        self._pending.extend(rows)

    def flush(self, attrs: Mapping | None = None) -> None:
        """Write the journalled rows not yet in the HDF5 file (and optional root attributes)."""
        if self._pending or attrs:
            self._journal.sync()
            self._write_h5(self._pending, attrs)
            self._pending = []

    def _write_h5(self, rows: list, attrs: Mapping | None = None, checksums: bool = False) -> None:
        _write_rows_h5(self.path, rows, self.n_rows, self.n_periods, attrs, run_id=self.run_id, checksums=checksums)

    def finish(self, attrs: Mapping | None = None) -> None:
        """Final flush; when every row is done mark the file complete, store its checksums and
        delete the journal -- only if the journal at the path is this run's (same ``run_id``)."""
        try:
            self.flush()
            complete = bool(self.done.all())
            a = dict(attrs or {})
            a["complete"] = complete
            self._write_h5([], a, checksums=complete)
            self._journal.close()
            if complete:
                with open(self.path, "rb+") as fh:
                    os.fsync(fh.fileno())
                jp = journal_path(self.path)
                if jp.exists():
                    other = _journal_run_id(jp)
                    if self.run_id is None or other == self.run_id:
                        jp.unlink(missing_ok=True)
                    else:
                        warnings.warn(f"{jp} belongs to another run (run_id {other}); left in place", stacklevel=2)
        finally:
            self.close()

    def close(self) -> None:
        """Close the journal and release the lock (rows not flushed stay in the journal)."""
        try:
            self._journal.close()
        finally:
            if self._lock is not None:
                self._lock.release()
                self._lock = None


def __getattr__(name):
    """``pycolfrag.results.load`` and ``pycolfrag.results.Results``, public names from before the reading
    side moved to :mod:`pycolfrag.analysis.data`, keep working. Imported on first use, not at the top:
    the reader imports this module (layout, journal, the bounded read), so a top-level import here
    would be an import circle, and the driver, which writes through this module, must not load the
    analysis package."""
    if name in ("load", "Results"):
        from .analysis import data  # here: the reader imports this module (a circle at the top)
        return getattr(data, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
