"""The layout of a results file: its fields and their dtypes, status codes, and rows <-> columns.

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

from pycolfrag.core import names as _names
from pycolfrag.core.errors import ResultsFileError
from pycolfrag.ground_motion import record as _gm_record
from pycolfrag.ground_motion import registry as _gm_registry

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
    # intensity measures of the record, then the response (EDPs): from pycolfrag.core.names
    **_quantity_fields(_names.IMS),
    **_quantity_fields(_names.EDPS),
    **_RESPONSE_FIELDS,
}

#: Longest stored ``record_id``, ``event``, ``station``, ``mechanism`` (bytes of UTF-8; longer is cut).
LABEL_BYTES = 96

#: ``/samples`` of a record-suite grid (root attribute ``layout = "records"``,
#: ``scripts/run_grid.py --records``): one row per record x component x scale
#: (:func:`pycolfrag.solver.sample.record_jobs`).
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

#: ``/samples`` of a batch of events with explicit inputs (root attribute ``layout = "events"``,
#: :class:`pycolfrag.grid.EventBatchSpec`): one row per event, each with the inputs it was given --
#: what the stratified site simulation of :mod:`pycolfrag.rare` draws -- then the synthetic row's fields.
EVENT_SAMPLE_FIELDS: dict[str, tuple[str, object, str]] = {
    # identity of the run in the algorithm that asked for it
    "stage": ("i4", -1, "stage of the algorithm that asked for the run (site simulation: 0 the pilot, "
                        "1, 2, ... the production batches)"),
    "stratum": ("i4", -1, "stratum of the site's events (source x Mw bin x R bin x pulse occurrence)"),
    "index": ("i4", -1, "index of the run within its stage and stratum"),
    "source": ("i4", -1, "index of the site source (order of the site file)"),
    "pulse": ("u1", 0, "1: the motion carries a velocity pulse; 0: the stochastic record alone"),
    "component": ("i4", -1, "component of the pulse-parameter mixture that drew the run (0 the site's own "
                            "density, c >= 1 a shifted one; -1 no pulse)"),
    "hf_seed": ("u8", 0, "seed of the high-frequency noise of the record"),
    # the standard normals the event was drawn from (Phi of each is a CDF fraction)
    "z_mw": ("f8", math.nan, "standard normal whose Phi places Mw in its bin (NaN: one magnitude)"),
    "z_dist": ("f8", math.nan, "standard normal whose Phi places R in its bin (NaN: one distance)"),
    "z_vp": ("f8", math.nan, "standard normal quantile of the pulse amplitude Vp (NaN: no pulse)"),
    "z_fp": ("f8", math.nan, "standard normal quantile of the pulse frequency fp (NaN: no pulse)"),
    "z_nu": ("f8", math.nan, "standard normal whose Phi places the pulse phase nu (NaN: no pulse)"),
    "z_gamma": ("f8", math.nan, "standard normal whose Phi places the pulse's gamma (NaN: no pulse)"),
    # what the run stands for
    "weight": ("f8", math.nan, "sampling weight under the proposal that drew the run: the site's density of "
                               "its pulse normals over the proposal's, times its pulse-occurrence weight, -"),
    "occurrence_weight": ("f8", math.nan, "pulse-occurrence weight: p(R) / the bin's mean p (pulse), (1 - p(R)) "
                                          "/ (1 - mean p) (no pulse), -"),
    "stratum_rate_per_yr": ("f8", math.nan, "annual rate of the run's stratum, 1/yr"),
    **_declared_fields(_gm_record.PARAMETERS),        # mw, dist_km
    **_STATUS_FIELDS,
    **_declared_fields(_gm_registry.PULSE_FIELDS),
    "record_s": ("f8", math.nan, "record duration used (len(acc) * dt), s"),
    **_quantity_fields(_names.IMS),
    **_quantity_fields(_names.EDPS),
    **_RESPONSE_FIELDS,
}

#: Values of the root attribute ``layout``: None (absent) = synthetic grid.
LAYOUTS = {None: SAMPLE_FIELDS, "synthetic": SAMPLE_FIELDS, "records": RECORD_SAMPLE_FIELDS,
           "events": EVENT_SAMPLE_FIELDS}


def fields_of(layout) -> dict:
    """The ``/samples`` fields of a layout (``None``/``"synthetic"`` or ``"records"``)."""
    if isinstance(layout, bytes):
        layout = layout.decode()
    try:
        return LAYOUTS[layout]
    except (KeyError, TypeError):
        raise ResultsFileError(f"unknown results layout {layout!r} (known: synthetic, records, events)") from None


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


def false_done(samples: Mapping, layout) -> np.ndarray:
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
    elif fields_of(layout) is EVENT_SAMPLE_FIELDS:
        if "stage" in samples:  # an event row is named by its stage (and stratum, index) in its algorithm
            bad |= done & (np.asarray(samples["stage"]) < 0)
    elif "scenario" in samples:
        bad |= done & (np.asarray(samples["scenario"]) < 0)
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
