"""A record-suite grid's row (:class:`pycolfrag.grid.RecordGridSpec`, ``run_grid.py --records``): one row
per record x component x scale (:func:`pycolfrag.solver.sample.record_jobs`), named by the record's index
or its id; its inputs are the record's metadata as the suite gives it."""
from __future__ import annotations

import math

from pycolfrag.layouts.kind import RowKind

__all__ = ["KIND", "LABEL_BYTES"]

#: Longest stored ``record_id``, ``event``, ``station``, ``mechanism`` (bytes of UTF-8; longer is cut).
LABEL_BYTES = 96

KIND = RowKind(
    name="records",
    identity={
        "record": ("i4", -1, "index of the record in the suite (order of the suite table)"),
        "record_id": (f"S{LABEL_BYTES}", b"", "record identifier (PEER: RSN; UTF-8)"),
        "event": (f"S{LABEL_BYTES}", b"", "earthquake name (UTF-8)"),
        "station": (f"S{LABEL_BYTES}", b"", "recording station (UTF-8)"),
        "component": ("S8", b"", "component run: h1, h2 or both (H1 along x, H2 along y)"),
        "scale": ("f8", math.nan, "amplitude factor applied to every component, -"),
        "mw": ("f8", math.nan, "moment magnitude"),
        "rrup_km": ("f8", math.nan, "closest distance to the rupture plane Rrup, km"),
        "dist_km": ("f8", math.nan, "= rrup_km (the synthetic grid's distance definition), km"),
    },
    inputs={  # further record metadata (NaN / empty when the source does not give it)
        "rjb_km": ("f8", math.nan, "Joyner-Boore distance, km"),
        "vs30_m_s": ("f8", math.nan, "Vs30 of the station, m/s"),
        "tp_s": ("f8", math.nan, "pulse period given by the source (PEER), s"),
        "year": ("f8", math.nan, "year of the earthquake"),
        "mechanism": (f"S{LABEL_BYTES}", b"", "fault mechanism (UTF-8)"),
        "rotation_deg": ("f8", math.nan, "rotation of the pair before the run, degrees (NaN: as recorded)"),
        "dt_s": ("f8", math.nan, "time step of the record, s"),
        "record_s": ("f8", math.nan, "record duration used (samples * dt), s"),
    },
    named_by=("record", "record_id"),          # a row is named by its index or its id (files by other code)
    owner="pycolfrag.grid.RecordGridSpec",
)
