"""What a kind of row declares about its results file: :class:`RowKind` (data, no behaviour).

A results file's ``/samples`` row is a kind's own fields around the fields every run shares:
``identity`` (what names the row in the kind that wrote it), the status fields, ``inputs`` (what the
run was given beyond its identity), then the record's IMs, the response's EDPs and the solver's
report. The shared parts are :mod:`pycolfrag.results.layout`'s; a kind declares only its two parts,
which of its fields name a row (``named_by``), and the value of the root attribute ``layout`` its files
carry (``name``; None: the attribute absent, the synthetic grid).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["RowKind", "declared_fields"]


@dataclass(frozen=True)
class RowKind:
    """A kind of row: its name in the file, its own fields, and what names one of its rows.

    ``identity`` and ``inputs``: ``{field: (numpy dtype code, fill value of a row not computed yet,
    "description, unit")}`` in file order. ``named_by``: fields of ``identity`` of which a written row
    carries at least one (an integer >= 0, a text not blank; checked in that order, the first one
    present decides whether the check applies): a row marked done without a name is read as never
    written (:func:`pycolfrag.results.layout.false_done`). ``aliases``: other values of the ``layout``
    attribute that mean this kind. ``owner``: the code that writes and reads the kind's own fields (said
    in errors and docs, never imported).
    """

    name: str | None
    identity: dict
    inputs: dict
    named_by: tuple
    owner: str
    aliases: tuple = field(default=())

    @property
    def names(self) -> tuple:
        """Every value of the root attribute ``layout`` that means this kind."""
        return (self.name, *self.aliases)


def declared_fields(parameters) -> dict:
    """The row fields of declared model parameters (:class:`pycolfrag.ground_motion.registry.Parameter`
    with a ``row_field``): f8, NaN until written, their declared description."""
    return {p.row_field: ("f8", math.nan, p.field_description) for p in parameters if p.row_field}
