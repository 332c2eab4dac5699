"""Rare-event estimation (docs/rare_events.md). This file is a map; it imports nothing.

* :mod:`~pycolfrag.rare.subset` -- subset simulation of a rare response within one scenario (the
  record-to-record tail), in the space of the standard normals a record is made from.
"""
