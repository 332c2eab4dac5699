"""The layout of a results file: its fields and their dtypes, status codes, and rows <-> columns.

The registry of layouts (:data:`LAYOUTS`, :func:`register_layout`, :func:`fields_of`): each kind of row
declares its own fields as data (:mod:`pycolfrag.layouts`: the synthetic grid, a record suite, the rare
route's events), and this module adds the fields every run shares (status, IMs, EDPs, the solver's
report); it names no kind's fields, so it knows neither the grid's specs nor the rare algorithm, while
every reader of a results file finds every layout here without importing the code that wrote it.

What a finished row is (:func:`merged_columns`, :func:`false_done`) is said here once, for the writer's
resume and for the reader (:mod:`pycolfrag.analysis.data`) alike. The layout is documented in
``docs/results_format.md`` and readable with h5py alone.
"""
from __future__ import annotations

import json
import math
import warnings
from typing import Mapping

import numpy as np

from pycolfrag import layouts as _layouts
from pycolfrag.core import names as _names
from pycolfrag.core.errors import ResultsFileError

#: Version of the file layout (root attribute ``format_version``): 2 added ``/row_crc32``, each finished
#: row's checksum, so that the rows of an interrupted file can be verified before a resume keeps them.
FORMAT_VERSION = 2

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
# The IM and EDP fields are not spelled here: they come from the one registry (pycolfrag.core.names),
# "<description>, <unit>"; nor are a kind's own fields (its identity and inputs): each kind of row
# declares them as data (pycolfrag.layouts), and this module composes them with the fields every run shares.


def _quantity_fields(table) -> dict:
    out = {}
    for name, q in table.items():
        if not q.spectral:
            desc = f"{q.description}, {q.unit}"
            out[name] = ("f8", math.nan, desc)
    return out


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


def row_fields(kind) -> dict[str, tuple[str, object, str]]:
    """The ``/samples`` fields of a kind of row (:class:`pycolfrag.layouts.RowKind`), in file order: its
    identity, the status, its inputs, the IMs of the record and the EDPs of the response (from
    :mod:`pycolfrag.core.names`), the solver's report."""
    return {**kind.identity, **_STATUS_FIELDS, **kind.inputs, **_quantity_fields(_names.IMS),
            **_quantity_fields(_names.EDPS), **_RESPONSE_FIELDS}


#: The registry of layouts: value of the root attribute ``layout`` (None: absent) -> its ``/samples``
#: fields. Filled from the kinds of row the package declares (:data:`pycolfrag.layouts.KINDS`) and by
#: :func:`register_layout`.
LAYOUTS: dict = {}
#: value of the root attribute ``layout`` -> its :class:`~pycolfrag.layouts.RowKind`.
_KINDS: dict = {}


def register_layout(kind) -> dict:
    """Register a kind of row (:class:`pycolfrag.layouts.RowKind`) under each of its names; returns its
    fields. A name taken by another kind raises ValueError (a file would be read as the wrong kind)."""
    taken = [n for n in kind.names if n in _KINDS and _KINDS[n] != kind]
    if taken:
        raise ValueError(f"results layout {taken[0]!r} is registered already (by {_KINDS[taken[0]].owner})")
    fields = row_fields(kind)
    for n in kind.names:
        LAYOUTS[n], _KINDS[n] = fields, kind
    return fields


for _kind in _layouts.KINDS:
    register_layout(_kind)

#: The registered layouts under the names this module gave them before the registry (kept for their callers):
#: ``/samples`` of a synthetic grid (root attribute ``layout`` absent), of a record suite
#: (``layout = "records"``) and of a batch of events (``layout = "events"``, the rare route's runs).
SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = LAYOUTS[None]
RECORD_SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = LAYOUTS["records"]
EVENT_SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = LAYOUTS["events"]
#: Longest stored label of a record row (bytes of UTF-8): :data:`pycolfrag.layouts.records.LABEL_BYTES`.
LABEL_BYTES = _layouts.records.LABEL_BYTES


def kind_of(layout):
    """The :class:`~pycolfrag.layouts.RowKind` of a value of the root attribute ``layout`` (None, a
    registered name, or its bytes), or ResultsFileError naming the known ones."""
    if isinstance(layout, bytes):
        layout = layout.decode()
    try:
        return _KINDS[layout]
    except (KeyError, TypeError):
        known = ", ".join(n for n in _KINDS if n is not None)
        raise ResultsFileError(f"unknown results layout {layout!r} (known: {known})") from None


def fields_of(layout) -> dict:
    """The ``/samples`` fields of a layout (None/``"synthetic"``, ``"records"``, ``"events"``: any
    registered value of the root attribute ``layout``)."""
    return LAYOUTS[kind_of(layout).name]


#: Fields whose values depend on the machine/ranks rather than the inputs.
TIMING_FIELDS = ("wall_s",)

#: ``/spectra`` datasets (rows x periods): the spectral IMs of :mod:`pycolfrag.core.names`.
SPECTRA_FIELDS = {name: f"{q.description}, {q.unit}" for name, q in _names.IMS.items() if q.spectral}


def _h5py():
    import h5py  # imported lazily: reading the field table must not need h5py
    return h5py


def h5open(path, mode: str = "r"):
    """``h5py.File(path, mode)`` without HDF5's file locks. With them (the library's default) a reader
    holding the file open -- h5py, HDFView, the reader polling -- makes the grid's next write fail
    ("unable to lock file", exit 4), and a writer between batches locks readers out. Only one process
    writes a results file (the run lock, :mod:`.lock`), it writes in short batches with ``status``
    last, and readers that want every finished row take the journal too (:func:`pycolfrag.analysis.data.load`)."""
    return _h5py().File(path, mode, locking=False)


#: The dataset of each row's CRC-32 (``uint32``, 0 until the row is written): see :mod:`.checksums`.
ROW_CRC = "row_crc32"


def row_bytes(n_periods: int, layout=None) -> int:
    """Bytes one row takes in the HDF5 file: its ``/samples`` fields, its ``/spectra`` rows, its checksum."""
    return (sum(dtype_of(code).itemsize for code, _, _ in fields_of(layout).values())
            + 8 * len(SPECTRA_FIELDS) * n_periods + 4)


def dtype_of(code: str):
    if code == "S":
        return np.dtype(f"S{MESSAGE_BYTES}")
    return np.dtype(code)


def encode_text(msg, limit: int = MESSAGE_BYTES) -> bytes:
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
        dt = dtype_of(code)
        samples[name] = np.full(n_rows, fill, dtype=dt)
    spectra = {name: np.full((n_rows, n_periods), np.nan) for name in SPECTRA_FIELDS}
    return samples, spectra


def put_row(samples: dict, spectra: dict, i: int, row: Mapping, layout=None) -> None:
    for name, (code, fill, _) in fields_of(layout).items():
        if name not in samples:  # a file in the documented layout written by other code may lack fields
            continue
        v = row.get(name, fill)
        if code.startswith("S"):
            samples[name][i] = encode_text(v, samples[name].dtype.itemsize)
        elif v is None:
            samples[name][i] = fill
        else:
            samples[name][i] = v
    for name in SPECTRA_FIELDS:
        v = row.get(name)
        if v is not None and name in spectra:
            spectra[name][i, :] = np.asarray(v, dtype=float)


def row_to_json(row: Mapping) -> str:
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


def rows_of(samples: Mapping, spectra: Mapping, rows) -> list[dict]:
    """Rows ``rows`` of a file's columns as row dicts (the inverse of :func:`put_row`)."""
    out = []
    for i in rows:
        row = {name: v[i] for name, v in samples.items()}
        row.update({name: spectra[name][i] for name in SPECTRA_FIELDS if name in spectra})
        row["row"] = int(i)
        out.append(row)
    return out


#: ``status`` values a written row can hold.
_KNOWN_STATUS = (STATUS_OK, STATUS_RECORD_FAILED, STATUS_IM_FAILED, STATUS_SOLVER_FAILED, STATUS_OTHER_FAILED)


def _unnamed(values) -> np.ndarray:
    """Which values of a naming field name nothing: a negative index, a blank text."""
    v = np.asarray(values)
    if v.dtype.kind in "SUO":
        return np.array([not (x.strip() if isinstance(x, (bytes, str)) else x) for x in v], dtype=bool)
    return v < 0


def false_done(samples: Mapping, layout) -> np.ndarray:
    """Rows whose ``status`` says done but which cannot be: an unknown status code, or no identity
    (the kind's naming fields, :attr:`pycolfrag.layouts.RowKind.named_by`, still -1 or blank, the value of
    a row never written -- every row the grid writes, failed ones too, carries it). Damaged status bytes
    (e.g. zeroed by a crash of the file system) would otherwise read as successful rows of NaN that are never recomputed."""
    status = np.asarray(samples["status"])
    done = status != STATUS_PENDING
    bad = done & ~np.isin(status, _KNOWN_STATUS)
    named_by = [f for f in kind_of(layout).named_by if f in samples]
    if named_by and named_by[0] == kind_of(layout).named_by[0]:
        nameless = _unnamed(samples[named_by[0]])
        for f in named_by[1:]:
            nameless &= _unnamed(samples[f])
        bad |= done & nameless
    return bad


def merged_columns(raw: Mapping | None, header: Mapping | None = None, jrows: Mapping | None = None):
    """The columns of a file as :func:`read_h5_bounded` read them (or, when ``raw`` is None, the pending
    columns of a journal header), with the journalled rows ``jrows`` laid over them (the journal is
    authoritative for every row it holds) and rows marked done that cannot be (:func:`false_done`)
    read as not computed, with a warning. Returns ``(samples, spectra, periods_s, attrs)``, copies.

    The one text of what a finished row is: the resume path takes its rows from here, and so does the
    reader (:func:`pycolfrag.analysis.data.load`)."""
    if raw is not None:
        samples = {k: v.copy() for k, v in raw["samples"].items()}
        spectra = {k: v.copy() for k, v in raw["spectra"].items()}
        periods, attrs = raw["periods"], dict(raw["attrs"])
    else:
        assert header is not None, "merged_columns: without raw, the journal header's columns"
        periods = np.asarray(header["periods_s"], dtype=float)
        attrs = dict(header["attrs"])
        samples, spectra = empty_columns(int(header["n_rows"]), len(periods), attrs.get("layout"))
    bad = false_done(samples, attrs.get("layout"))
    if bad.any():
        warnings.warn(f"{int(bad.sum())} row(s) of the results file are marked done but carry no identity or an "
                      f"unknown status (damaged status bytes; rows {np.flatnonzero(bad)[:10].tolist()}...): they "
                      "are read as not computed (a rerun of the grid recomputes them)", stacklevel=4)
        samples["status"][bad] = STATUS_PENDING
    if jrows:
        for i, r in jrows.items():
            put_row(samples, spectra, i, r, attrs.get("layout"))
    if jrows or bad.any():
        attrs["n_done"] = int(np.count_nonzero(samples["status"] != STATUS_PENDING))
    return samples, spectra, periods, attrs
