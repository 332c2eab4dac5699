"""Outputs of an incomplete results file: refused unless asked for, marked wherever a number appears.

A grid or record suite that was interrupted (or is still running) leaves a results file whose
``complete`` attribute is false: its finished rows read like a smaller complete file, but a fragility
fit, a report or an OpenQuake export made from them changes when the rest is computed -- an
interrupted pulse grid of 33 of 36 rows gave a collapse rate half as large again as the complete one.
:func:`check_complete` refuses such a file unless the caller allows it (``--allow-incomplete`` on
every command line that analyses results: the report, the figures, the validation document, the
record-suite report, the OpenQuake export and damage); allowed, it returns :func:`incomplete_note`,
the sentence each output then carries (the report's and the validation's first lines, every figure's
title, the NRML description, the command's printout).

A file without a ``complete`` attribute (written by other code in the documented layout, which has no
notion of rows still to compute) is taken as it is.
"""
from __future__ import annotations

import os

from ..errors import PycolfragError, ResultsFileError

__all__ = ["incomplete_note", "check_complete", "ALLOW_INCOMPLETE_HELP", "MARK"]

#: The words that open the mark of an incomplete file's outputs (a reader of such an output finds them).
MARK = "INCOMPLETE RESULTS"

#: The ``--allow-incomplete`` help of every command that analyses a results file.
ALLOW_INCOMPLETE_HELP = ("analyse a results file whose run has not finished (interrupted or still running); "
                         "every output is then marked INCOMPLETE")


def _facts(source) -> tuple[dict, int, str]:
    """(root attributes, finished rows, path or "") of a ResultsData, a Results or a suite table."""
    if isinstance(source, dict):
        return dict(source.get("attrs", {})), len(source.get("status", ())), ""
    if hasattr(source, "n_total"):                      # analysis.data.ResultsData
        return dict(source.attrs), int(source.n_total), str(source.path)
    return dict(source.attrs), len(source), ""          # analysis.data.Results


def _rows_in_file(path: str) -> int | None:
    """Rows the file was made for (finished or not), or None when it cannot be told."""
    if not path:
        return None
    from .data import load  # here: only an incomplete file needs the second read
    try:
        return len(load(path, pending=True, any_layout=True))
    except (PycolfragError, OSError):   # the count only enriches the message; the file was read a moment ago
        return None


def incomplete_note(source, path=None) -> str:
    """``""`` for a complete file; else the sentence every output of it carries ("INCOMPLETE RESULTS: ...").

    ``source``: :class:`~pycolfrag.analysis.data.ResultsData`, :class:`~pycolfrag.analysis.data.Results`
    or a suite table (:func:`~pycolfrag.analysis.data.read_table`); ``path``: the file's path when the
    source does not carry it (it is then named, and its rows counted)."""
    attrs, n_finished, own = _facts(source)
    path = os.fspath(path) if path is not None else own
    if "complete" not in attrs or bool(attrs["complete"]):
        return ""
    total = _rows_in_file(path)
    of = f" of the {total}" if total else ""
    where = f"{path} holds" if path else "the results hold"
    return (f"{MARK}: {where} {n_finished}{of} rows (its run was interrupted or is still going); "
            "every number here changes when the remaining rows are computed")


def check_complete(source, allow_incomplete: bool, what: str, path=None) -> str:
    """Refuse an incomplete results file (:class:`~pycolfrag.errors.ResultsFileError` naming ``what``
    would be made from it) unless ``allow_incomplete``; return :func:`incomplete_note` (``""`` when
    complete) for the output to carry."""
    note = incomplete_note(source, path)
    if note and not allow_incomplete:
        raise ResultsFileError(f"{what} refused: {note[len(MARK) + 2:]}. Finish the run (rerun its "
                               "command to resume) or pass --allow-incomplete (allow_incomplete=True) to get "
                               "outputs marked INCOMPLETE")
    return note
