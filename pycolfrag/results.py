"""HDF5 results of the Monte Carlo grid (``scripts/run_grid.py``): layout, crash-safe writing, reading.

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
and cut off before appending again. When a run completes, the HDF5 file is final and the
journal is deleted; reopening such a file starts a journal that holds its finished rows.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from .errors import ResultsFileError

__all__ = [
    "FORMAT_VERSION", "SAMPLE_FIELDS", "STATUS_PENDING", "STATUS_OK", "STATUS_RECORD_FAILED",
    "STATUS_IM_FAILED", "STATUS_SOLVER_FAILED", "STATUS_OTHER_FAILED", "MESSAGE_BYTES",
    "Results", "ResultsWriter", "load", "create", "open_for_run", "journal_path", "read_journal",
    "signature_mismatch",
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
SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = {
    # identity of the run
    "scenario": ("i4", -1, "scenario index in the grid (row-major over mw, then dist_km)"),
    "sample": ("i4", -1, "sample index within the scenario (row of the scenario's LHS)"),
    "mw": ("f8", math.nan, "moment magnitude"),
    "dist_km": ("f8", math.nan, "closest distance to the rupture, km"),
    "status": ("i4", STATUS_PENDING, "0 ok, 1 record, 2 IMs, 3 solver, 9 other failure, -1 not computed"),
    "message": ("S", b"", "error message of a failed run (UTF-8, truncated to MESSAGE_BYTES)"),
    # sampled pulse parameters and record metadata (from Record.meta)
    "vp_cm_s": ("f8", math.nan, "pulse amplitude Vp, cm/s"),
    "fp_hz": ("f8", math.nan, "pulse frequency fp, Hz"),
    "nu_rad": ("f8", math.nan, "pulse phase nu, rad"),
    "gamma": ("f8", math.nan, "pulse oscillatory character gamma, -"),
    "t0_s": ("f8", math.nan, "time of the pulse peak, s"),
    "tp_s": ("f8", math.nan, "pulse period Tp = 1/fp, s"),
    "a_cm_s": ("f8", math.nan, "envelope amplitude A of the pulse model, cm/s"),
    "ap_g": ("f8", math.nan, "peak acceleration of the pulse alone, g"),
    "record_s": ("f8", math.nan, "record duration used (len(acc) * dt), s"),
    # intensity measures of the record
    "pga_g": ("f8", math.nan, "peak ground acceleration, g"),
    "pgv_cm_s": ("f8", math.nan, "peak ground velocity, cm/s"),
    "pgd_cm": ("f8", math.nan, "peak ground displacement, cm"),
    "arias_m_s": ("f8", math.nan, "Arias intensity, m/s"),
    "d5_95_s": ("f8", math.nan, "significant duration 5-95 % of Arias, s"),
    # response (EDPs)
    "u_top": ("f8", math.nan, "peak top displacement / base diameter, -"),
    "u_d": ("f8", math.nan, "peak joint dislocation / joint diameter, -"),
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

#: Fields whose values depend on the machine/ranks rather than the inputs.
TIMING_FIELDS = ("wall_s",)

SPECTRA_FIELDS = {"sa_g": "pseudo-spectral acceleration, g", "sv_cm_s": "pseudo-spectral velocity, cm/s"}


def _h5py():
    import h5py  # imported lazily: reading the field table must not need h5py
    return h5py


def journal_path(path) -> Path:
    """The journal sidecar of a results file: ``<path>.journal``."""
    return Path(os.fspath(path) + ".journal")


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

def empty_columns(n_rows: int, n_periods: int) -> tuple[dict, dict]:
    """Columns of ``n_rows`` pending rows: (samples dict, spectra dict)."""
    samples = {}
    for name, (code, fill, _) in SAMPLE_FIELDS.items():
        dt = _dtype(code)
        samples[name] = np.full(n_rows, fill, dtype=dt)
    spectra = {name: np.full((n_rows, n_periods), np.nan) for name in SPECTRA_FIELDS}
    return samples, spectra


def _put_row(samples: dict, spectra: dict, i: int, row: Mapping) -> None:
    for name, (code, fill, _) in SAMPLE_FIELDS.items():
        v = row.get(name, fill)
        if code.startswith("S"):
            samples[name][i] = _encode_message(v, samples[name].dtype.itemsize)
        elif v is None:
            samples[name][i] = fill
        else:
            samples[name][i] = v
    for name in SPECTRA_FIELDS:
        v = row.get(name)
        if v is not None:
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


def _rows_of(res: "Results") -> list[dict]:
    """The rows of a loaded file as row dicts (the inverse of :func:`_put_row`)."""
    out = []
    for j, i in enumerate(res.rows):
        row = {name: v[j] for name, v in res.samples.items()}
        row.update({name: res.spectra[name][j] for name in SPECTRA_FIELDS if name in res.spectra})
        row["row"] = int(i)
        out.append(row)
    return out


# ---------------------------------------------------------------------------------------
# journal
# ---------------------------------------------------------------------------------------

def read_journal(path, truncate: bool = False):
    """Read a journal: ``(header dict or None, {row index: row dict})``.

    A last line without its newline (a kill in the middle of an append) or that does not
    parse is ignored; with ``truncate=True`` the file is cut back to the last good line so
    that appending can go on.
    """
    jp = Path(path)
    if not jp.exists():
        return None, {}
    header, rows = None, {}
    good_end = 0
    with open(jp, "rb") as fh:
        data = fh.read()
    pos = 0
    while pos < len(data):
        nl = data.find(b"\n", pos)
        if nl < 0:
            break  # incomplete last line
        line = data[pos:nl]
        try:
            obj = json.loads(line.decode("utf-8"))
        except (ValueError, UnicodeDecodeError):
            break  # damaged line: everything after it is suspect
        if header is None:
            if obj.get("kind") != "pycolfrag-grid-journal":
                raise ResultsFileError(f"{jp} is not a pycolfrag journal (first line has no journal header)")
            header = obj
        else:
            rows[int(obj["row"])] = obj
        pos = good_end = nl + 1
    if truncate and good_end < len(data):
        with open(jp, "r+b") as fh:
            fh.truncate(good_end)
    return header, rows


class _Journal:
    def __init__(self, path: Path):
        self.path = path
        self.fh = open(path, "a", encoding="utf-8")

    def append(self, rows: Iterable[Mapping]) -> None:
        self.fh.write("".join(_row_to_json(r) + "\n" for r in rows))
        self.fh.flush()  # in the OS page cache: survives a kill of this process

    def sync(self) -> None:
        self.fh.flush()
        os.fsync(self.fh.fileno())  # survives a machine crash too

    def close(self) -> None:
        if not self.fh.closed:
            self.fh.close()


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
    h5py = _h5py()
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        g = f.create_group("samples")
        for name, (code, fill, desc) in SAMPLE_FIELDS.items():
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
    os.replace(tmp, path)  # the file appears complete or not at all


def signature_mismatch(old: Mapping, new: Mapping) -> list[str]:
    """Human-readable differences between two grid signatures (empty when they agree)."""
    def short(v):
        return v if len(v) <= 120 else v[:117] + "..."

    diffs = []
    for k in sorted(set(old) | set(new)):
        sa, sb = (json.dumps(d.get(k, "<absent>"), sort_keys=True) for d in (old, new))
        if sa != sb:
            diffs.append(f"{k}: file has {short(sa)}, this run asks for {short(sb)}")
    return diffs


def _read_signature_h5(path: Path):
    h5py = _h5py()
    with h5py.File(path, "r") as f:
        if "grid_signature" not in f.attrs:
            raise ResultsFileError(f"{path} is not a pycolfrag grid results file (no grid_signature attribute); "
                                   "use --overwrite to replace it or --out for another file")
        return json.loads(f.attrs["grid_signature"])


def create(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float]) -> None:
    """Create a new results file and its journal (replacing both if present).

    ``signature`` holds everything that fixes the results (grid, seed, column, solver options,
    periods...): it is stored as the root attribute ``grid_signature`` (JSON) and compared on resume.
    ``attrs`` are further root attributes (lists become float arrays).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    jp = journal_path(path)
    for p in (jp, path):
        if p.exists():
            p.unlink()
    all_attrs = dict(attrs)
    all_attrs["grid_signature"] = json.dumps(signature, sort_keys=True)
    _write_journal_header(jp, n_rows, periods_s, signature, all_attrs)
    _create_h5(path, n_rows, periods_s, all_attrs)


def open_for_run(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float],
                 overwrite: bool = False) -> "ResultsWriter":
    """Create ``path``, or resume it: returns a :class:`ResultsWriter` whose ``done`` mask says
    which rows are already computed.

    On resume the stored ``grid_signature`` must equal ``signature``, else
    :class:`~pycolfrag.errors.ResultsFileError` (unless ``overwrite``). A damaged HDF5 file is
    rebuilt from its journal; journalled rows missing from the HDF5 file are written into it.
    """
    path = Path(path)
    jp = journal_path(path)
    if overwrite or (not path.exists() and not jp.exists()):
        create(path, signature, attrs, n_rows, periods_s)
        return ResultsWriter(path, n_rows, len(periods_s), resumed=False)

    header, jrows = read_journal(jp, truncate=True) if jp.exists() else (None, {})
    h5_ok = False
    if path.exists():
        try:
            old_sig = _read_signature_h5(path)
            h5_ok = True
        except ResultsFileError:
            raise
        except Exception as exc:  # unreadable HDF5 (killed mid-write): the journal decides
            if header is None:
                raise ResultsFileError(f"{path} cannot be opened ({exc}) and has no journal to rebuild it from; "
                                       "use --overwrite to start again") from None
            old_sig = header["signature"]
    else:
        old_sig = header["signature"]
    diffs = signature_mismatch(old_sig, signature)
    if diffs:
        raise ResultsFileError(
            f"{path} holds a different run; it cannot be resumed with these arguments:\n  - "
            + "\n  - ".join(diffs) + "\nUse --overwrite to replace it, or --out for another file.")
    if not h5_ok:  # rebuild from the journal header, then replay every row below
        hattrs = dict(header["attrs"])
        hattrs["rebuilt_from_journal"] = True
        _create_h5(path, int(header["n_rows"]), header["periods_s"], hattrs)
    if header is None:
        # a journal-less file (finished run, or journal deleted): start a new journal for this
        # session that also holds the file's finished rows, so that a kill during this session's
        # HDF5 writes can rebuild the file from the journal without losing them
        old = load(path, journal=False)
        _write_journal_header(jp, n_rows, periods_s, signature, old.attrs)
        journal = _Journal(jp)
        journal.append(_rows_of(old))
        journal.sync()
        journal.close()
    if jrows:  # idempotent replay: rows the HDF5 file may have missed when the run was killed
        _write_rows_h5(path, list(jrows.values()), n_rows, len(periods_s))
    return ResultsWriter(path, n_rows, len(periods_s), resumed=True)


def _write_journal_header(jp: Path, n_rows: int, periods_s, signature: Mapping, attrs: Mapping) -> None:
    """Start a journal: its first line holds what rebuilding the HDF5 file needs (fsynced)."""
    def plain(v):  # list/array attributes are float arrays in the HDF5 file (_attr_value)
        if isinstance(v, (list, tuple, np.ndarray)):
            return [float(x) for x in v]
        return v.item() if isinstance(v, np.generic) else v

    header = {"kind": "pycolfrag-grid-journal", "format_version": FORMAT_VERSION, "n_rows": int(n_rows),
              "periods_s": [float(p) for p in periods_s], "signature": signature,
              "attrs": {k: plain(v) for k, v in attrs.items()}}
    with open(jp, "w", encoding="utf-8") as fh:
        fh.write(json.dumps(header, sort_keys=True, default=str) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def _write_rows_h5(path: Path, rows: list, n_rows: int, n_periods: int, attrs: Mapping | None = None) -> None:
    """Open, write rows (by their ``row`` index) and root attributes, flush, close."""
    h5py = _h5py()
    with h5py.File(path, "r+") as f:
        if rows:
            rows = sorted(rows, key=lambda r: int(r["row"]))
            idx = np.array([int(r["row"]) for r in rows])
            if idx.min() < 0 or idx.max() >= n_rows:
                raise ResultsFileError(f"row index out of range 0..{n_rows - 1} in results batch")
            keep = np.r_[idx[1:] != idx[:-1], True]  # duplicates (a replayed row): keep the last
            rows = [r for r, k in zip(rows, keep) if k]
            idx = idx[keep]
            cols, spec = empty_columns(len(rows), n_periods)
            for j, r in enumerate(rows):
                _put_row(cols, spec, j, r)
            g = f["samples"]
            # status last: a kill part-way through this batch leaves its rows pending (status -1)
            # in the HDF5 file, never marked done with half their fields
            for name in SPECTRA_FIELDS:
                f["spectra"][name][idx, :] = spec[name]
            for name in SAMPLE_FIELDS:
                if name != "status":
                    g[name][idx] = cols[name]
            f.flush()
            g["status"][idx] = cols["status"]
            f.attrs["n_done"] = int(np.count_nonzero(g["status"][...] != STATUS_PENDING))
        if attrs:
            for k, v in attrs.items():
                f.attrs[k] = _attr_value(v)
        f.flush()


class ResultsWriter:
    """Rank 0's writer: journal every row at once, HDF5 in batches (open, write, flush, close)."""

    def __init__(self, path, n_rows: int, n_periods: int, resumed: bool):
        self.path = Path(path)
        self.n_rows = int(n_rows)
        self.n_periods = int(n_periods)
        self.resumed = resumed
        self._pending: list[dict] = []
        self._journal = _Journal(journal_path(self.path))
        h5py = _h5py()
        with h5py.File(self.path, "r") as f:
            self.status = f["samples/status"][...]

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

    def _write_h5(self, rows: list, attrs: Mapping | None = None) -> None:
        _write_rows_h5(self.path, rows, self.n_rows, self.n_periods, attrs)

    def finish(self, attrs: Mapping | None = None) -> None:
        """Final flush; when every row is done mark the file complete and delete the journal."""
        self.flush()
        complete = bool(self.done.all())
        a = dict(attrs or {})
        a["complete"] = complete
        self._write_h5([], a)
        self._journal.close()
        if complete:
            with open(self.path, "rb+") as fh:
                os.fsync(fh.fileno())
            journal_path(self.path).unlink(missing_ok=True)

    def close(self) -> None:
        self._journal.close()


# ---------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------

@dataclass
class Results:
    """A results file in memory (see :func:`load`).

    Attributes
    ----------
    samples : dict of str -> ndarray
        The ``/samples`` fields (``message`` decoded to ``str``), one entry per row.
    spectra : dict of str -> ndarray
        ``sa_g`` (g) and ``sv_cm_s`` (cm/s), shape (rows, periods).
    periods_s : ndarray
        Spectral periods, s.
    attrs : dict
        Root attributes; ``column``, ``solver`` and ``grid_signature`` are JSON strings.
    rows : ndarray of int
        Row index of each entry in the file (all rows for a complete file).
    """

    samples: dict
    spectra: dict
    periods_s: np.ndarray
    attrs: dict
    rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def __len__(self) -> int:
        return len(self.samples["status"])

    @property
    def ok(self) -> np.ndarray:
        """Mask of successful runs (``status == 0``)."""
        return self.samples["status"] == STATUS_OK

    @property
    def complete(self) -> bool:
        return bool(self.attrs.get("complete", False))

    def scenario_table(self) -> list[dict]:
        """One dict per scenario present: mw, dist_km, n, ok, failed, collapses, rows (indices)."""
        out = []
        s = self.samples
        for sc in np.unique(s["scenario"]):
            m = s["scenario"] == sc
            okm = m & self.ok
            out.append({"scenario": int(sc), "mw": float(s["mw"][m][0]), "dist_km": float(s["dist_km"][m][0]),
                        "n": int(m.sum()), "ok": int(okm.sum()), "failed": int((m & ~self.ok).sum()),
                        "collapses": int(s["collapsed"][okm].astype(bool).sum()), "index": np.flatnonzero(m)})
        return out


def load(path, pending: bool = False, journal: bool = True) -> Results:
    """Read a results file written by ``scripts/run_grid.py``.

    Parameters
    ----------
    path : str or path-like
        The HDF5 file (e.g. ``results/grid.h5``).
    pending : bool
        Keep rows not computed yet (``status == -1``). Default False: only finished rows
        (ok or failed), so a partial file from a killed run reads like a smaller complete one.
    journal : bool
        Overlay rows from the journal sidecar (``<path>.journal``) that are not in the HDF5 file
        yet (present only while a run is going on or after a kill). Nothing is written. If the HDF5
        file cannot be opened (killed mid-write) the data come from the journal alone.

    Returns
    -------
    Results
        ``samples`` (dict of 1-D arrays), ``spectra`` (dict of 2-D arrays), ``periods_s``, ``attrs``,
        ``rows`` (row indices kept). ``collapsed`` is returned as bool.
    """
    h5py = _h5py()
    path = Path(path)
    jp = journal_path(path)
    header, jrows = (read_journal(jp) if (journal and jp.exists()) else (None, {}))
    try:
        with h5py.File(path, "r") as f:
            if "samples" not in f or "grid_signature" not in f.attrs:
                raise ResultsFileError(f"{path} is not a pycolfrag grid results file")
            samples = {name: f["samples"][name][...] for name in SAMPLE_FIELDS if name in f["samples"]}
            extra = [name for name in f["samples"] if name not in SAMPLE_FIELDS]
            for name in extra:
                samples[name] = f["samples"][name][...]
            spectra = {name: f["spectra"][name][...] for name in f["spectra"]}
            periods = np.asarray(f["spectra"].attrs["periods_s"], dtype=float)
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    except (OSError, KeyError) as exc:
        if header is None:
            raise ResultsFileError(f"cannot read results file {path}: {exc}") from None
        periods = np.asarray(header["periods_s"], dtype=float)
        samples, spectra = empty_columns(int(header["n_rows"]), len(periods))
        attrs = dict(header["attrs"])
    if jrows:  # the journal is authoritative for every row it holds
        for i, r in jrows.items():
            _put_row(samples, spectra, i, r)
        attrs["n_done"] = int(np.count_nonzero(samples["status"] != STATUS_PENDING))
    for name, (code, _, _) in SAMPLE_FIELDS.items():  # fixed-length UTF-8 -> str
        if code.startswith("S") and name in samples:
            samples[name] = np.array([m.decode("utf-8", errors="replace") if isinstance(m, bytes) else str(m)
                                      for m in samples[name]], dtype=object)
    samples["collapsed"] = samples["collapsed"].astype(bool)
    rows = np.arange(len(samples["status"]))
    if not pending:
        keep = samples["status"] != STATUS_PENDING
        samples = {k: v[keep] for k, v in samples.items()}
        spectra = {k: v[keep] for k, v in spectra.items()}
        rows = rows[keep]
    return Results(samples=samples, spectra=spectra, periods_s=periods, attrs=attrs, rows=rows)
