"""Outputs of an incomplete results file: refused unless asked for, marked wherever a number appears.

A grid or record suite that was interrupted (or is still running) leaves a results file with rows not
computed yet: its finished rows read like a smaller complete file, but a fragility fit, a report, a
site risk or an OpenQuake export made from them changes when the rest is computed -- an interrupted
pulse grid of 33 of 36 rows gave a collapse rate half as large again as the complete one.

The one judge is the count of rows not computed yet (``n_missing`` of
:class:`~pycolfrag.analysis.data.Results` and :class:`~pycolfrag.analysis.data.ResultsData`, kept in a
suite table by :func:`~pycolfrag.analysis.data.read_table`): a run killed after its last row left every
row computed, and its outputs are those of the full run. :func:`check_complete` refuses an incomplete
file unless the caller allows it (``--allow-incomplete`` on every command line that analyses results:
the report, the figures, the validation document, the record-suite report, the site risk, the
OpenQuake export and damage); allowed, it returns :func:`incomplete_note`, the sentence each output
then carries (the reports' first lines, every figure's title, the NRML description, the risk's files,
the command's printout).
"""
from __future__ import annotations

import os

from pycolfrag.core.errors import ResultsFileError

__all__ = ["IncompleteResultsError", "incomplete_note", "check_complete", "ALLOW_INCOMPLETE_HELP", "MARK"]

#: The words that open the mark of an incomplete file's outputs (a reader of such an output finds them).
MARK = "INCOMPLETE RESULTS"

#: The ``--allow-incomplete`` help of every command that analyses a results file.
ALLOW_INCOMPLETE_HELP = ("analyse a results file whose run has not finished (interrupted or still running); "
                         "every output is then marked INCOMPLETE")


class IncompleteResultsError(ResultsFileError):
    """A results file with rows not computed yet, given to an output that needs every row."""


def _counts(source) -> tuple[int, int, str]:
    """(rows of the file, rows not computed yet, its path or "") of a ResultsData, a Results or a suite
    table; a table built by other code without the counts is taken as complete."""
    if isinstance(source, dict):
        n_rows = int(source.get("n_rows", len(source.get("status", ()))))
        return n_rows, int(source.get("n_missing", 0)), ""
    return int(source.n_expected), int(source.n_missing), str(getattr(source, "path", "") or "")


def incomplete_note(source, path=None) -> str:
    """``""`` for a complete file; else the sentence every output of it carries ("INCOMPLETE RESULTS: ...").

    ``source``: :class:`~pycolfrag.analysis.data.ResultsData`, :class:`~pycolfrag.analysis.data.Results`
    or a suite table (:func:`~pycolfrag.analysis.data.read_table`); ``path``: the file's path when the
    source does not carry it (it is then named)."""
    n_rows, n_missing, own = _counts(source)
    if n_missing <= 0:
        return ""
    path = os.fspath(path) if path is not None else own
    where = f"{path} holds" if path else "the results hold"
    return (f"{MARK}: {where} {n_rows - n_missing} of the {n_rows} rows (its run was interrupted or is still "
            "going); every number here changes when the remaining rows are computed")


def check_complete(source, allow_incomplete: bool, what: str, path=None) -> str:
    """Refuse an incomplete results file (:class:`IncompleteResultsError` naming ``what`` would be made
    from it) unless ``allow_incomplete``; return :func:`incomplete_note` (``""`` when complete) for the
    output to carry."""
    note = incomplete_note(source, path)
    if note and not allow_incomplete:
        err = IncompleteResultsError(f"{what} refused: {note[len(MARK) + 2:]}. Finish the run (rerun its command "
                                     "to resume) or pass --allow-incomplete (allow_incomplete=True) to get outputs "
                                     "marked INCOMPLETE")
        err.note = note         # for a command whose own advice differs (risk --simulate has no --allow-incomplete)
        raise err
    return note
