"""The kinds of row a results file holds, declared as data: one module per kind, each the declaration of
the code that writes it (its docstring names the owner).

* :mod:`~pycolfrag.layouts.kind` -- :class:`RowKind`: a kind's own fields (identity, inputs), what names
  one of its rows, its value of the root attribute ``layout``;
* :mod:`~pycolfrag.layouts.synthetic` -- the synthetic grid (:class:`pycolfrag.grid.GridSpec`);
* :mod:`~pycolfrag.layouts.records` -- a record suite (:class:`pycolfrag.grid.RecordGridSpec`);
* :mod:`~pycolfrag.layouts.events` -- the rare route's runs (owned by :mod:`pycolfrag.rare`).

Why here: a results file is written by a kind of grid (:mod:`pycolfrag.grid`, or the rare route through
it) and read by code that must not import either (:mod:`pycolfrag.analysis`, and the resume and reader
of :mod:`pycolfrag.results`). The declarations are data in this package on the models' layer, which
imports only the ground-motion models' field declarations, so both sides see them;
:mod:`pycolfrag.results.layout` keeps the registry (:func:`~pycolfrag.results.layout.register_layout`),
fills it from :data:`KINDS` and adds the fields every run shares. :mod:`pycolfrag.results` itself names no
kind's fields. A new kind of row: its module here and its line in :data:`KINDS` (or, for a kind outside
the package, :func:`~pycolfrag.results.layout.register_layout` at its import).
"""
from __future__ import annotations

from pycolfrag.layouts import events, records, synthetic
from pycolfrag.layouts.kind import RowKind

__all__ = ["RowKind", "KINDS"]

#: Every kind of row the package writes, in the order the registry lists them.
KINDS = (synthetic.KIND, records.KIND, events.KIND)
