"""The synthetic grid's row (:class:`pycolfrag.grid.GridSpec`: Mw x R scenarios x Latin-hypercube samples):
named by its scenario and sample; its inputs are the sampled pulse parameters and the record's length.
The magnitude, distance and pulse fields are the ground-motion models' declarations
(:mod:`pycolfrag.ground_motion.registry`), not spelled here. Files of this kind carry no ``layout``
attribute (``"synthetic"`` is read as the same)."""
from __future__ import annotations

import math

from pycolfrag.ground_motion import record as _gm_record
from pycolfrag.ground_motion import registry as _gm_registry
from pycolfrag.layouts.kind import RowKind, declared_fields

__all__ = ["KIND", "INPUTS"]

#: What a synthetic run is given besides its identity: the sampled pulse parameters and record metadata
#: (from ``Record.meta``), and the record's length. The event rows of :mod:`.events` share it.
INPUTS = {
    **declared_fields(_gm_registry.PULSE_FIELDS),
    "record_s": ("f8", math.nan, "record duration used (len(acc) * dt), s"),
}

KIND = RowKind(
    name=None,
    identity={
        "scenario": ("i4", -1, "scenario index in the grid (row-major over mw, then dist_km)"),
        "sample": ("i4", -1, "sample index within the scenario (row of the scenario's LHS)"),
        **declared_fields(_gm_record.PARAMETERS),        # mw, dist_km
    },
    inputs=INPUTS,
    named_by=("scenario",),
    owner="pycolfrag.grid.GridSpec",
    aliases=("synthetic",),
)
