"""Every reader of a results file: the one place that turns an HDF5 results file into data to analyse.

* :func:`load` -> :class:`Results`: every finished row (ok or failed) of a file, the journal of a
  killed or running grid laid over it, damage reported instead of hanging (the bounded read and
  the journal are the writing side's, :mod:`pycolfrag.results`);
* :func:`read_results` -> :class:`ResultsData`: the successful rows of a synthetic grid, ready for
  the paper's figures, the report, the validation and the site risk;
* :func:`read_table`: a file as one table of fields (a record suite's analysis, the OpenQuake
  fragility fits);
* :func:`as_results`, :func:`as_data`: the same, passing through what was read already.

Both say whether the file is complete: ``n_missing`` rows not computed yet (an interrupted or running
grid) and ``complete`` (none missing); a table of :func:`read_table` keeps both counts. What an output
does with an incomplete file (refuse, or carry a mark) is :mod:`pycolfrag.analysis.completeness`.

This module imports no C binding and nothing of the grid driver: only the results layout and its
crash-safe reading (:mod:`pycolfrag.results`).
"""
from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results import STATUS_OK, STATUS_PENDING

__all__ = ["Results", "load", "as_results", "ResultsData", "read_results", "as_data", "read_table",
           ]


def _rows_asked(attrs) -> int:
    """Rows a synthetic grid's attributes ask for (``mw`` x ``dist_km`` x ``samples``), 0 when they do not say."""
    try:
        return int(np.size(attrs["mw"]) * np.size(attrs["dist_km"]) * int(attrs["samples"]))
    except (KeyError, TypeError, ValueError):
        return 0


class _Completeness:
    """``n_missing`` and ``complete`` from ``n_rows`` and the finished rows."""

    @property
    def n_missing(self) -> int:
        """Rows not computed yet: those of the file still pending (``status == -1``), or, in a file written
        by other code with fewer rows than its grid's ``mw`` x ``dist_km`` x ``samples`` attributes ask
        for, the rows it lacks; 0 for a complete file."""
        return int(self.n_expected - self.n_finished)

    @property
    def n_expected(self) -> int:
        """Rows the run asked for: the file's rows, or more when its grid's attributes ask for more."""
        return int(max(self.n_rows, _rows_asked(self.attrs)))

    @property
    def complete(self) -> bool:
        """Every row of the file is computed (ok or failed). The run's own seal is ``attrs["complete"]``:
        it stays False in a file whose run was killed after its last row, whose rows are all here."""
        return self.n_missing == 0


@dataclass
class Results(_Completeness):
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
    n_rows : int
        Rows the file holds, computed or not (``n_missing``: those not computed yet).
    """

    samples: dict
    spectra: dict
    periods_s: np.ndarray
    attrs: dict
    rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    n_rows: int = -1

    def __post_init__(self):
        if self.n_rows < 0:
            self.n_rows = len(self)

    def __len__(self) -> int:
        return len(self.samples["status"])

    @property
    def n_finished(self) -> int:
        """Rows computed (ok or failed)."""
        return int(np.count_nonzero(np.asarray(self.samples["status"]) != STATUS_PENDING))

    @property
    def ok(self) -> np.ndarray:
        """Mask of successful runs (``status == 0``)."""
        return self.samples["status"] == STATUS_OK

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


def _results_from_raw(raw, pending: bool, header: Mapping | None = None, jrows: Mapping | None = None) -> Results:
    """Build :class:`Results` from :func:`~pycolfrag.results.read_h5_bounded`'s dict (or from a journal
    header alone when ``raw`` is None), overlaying journalled rows (:func:`pycolfrag.results.merged_columns`)."""
    samples, spectra, periods, attrs = _results.merged_columns(raw, header, jrows)
    for name in list(samples):  # string datasets (fixed-length UTF-8) -> str
        if samples[name].dtype.kind == "S":
            samples[name] = np.array([m.decode("utf-8", errors="replace") if isinstance(m, bytes) else str(m)
                                      for m in samples[name]], dtype=object)
    if "collapsed" in samples:
        samples["collapsed"] = samples["collapsed"].astype(bool)
    rows = np.arange(len(samples["status"]))
    n_rows = rows.size
    if not pending:
        keep = samples["status"] != STATUS_PENDING
        samples = {k: v[keep] for k, v in samples.items()}
        spectra = {k: v[keep] for k, v in spectra.items()}
        rows = rows[keep]
    return Results(samples=samples, spectra=spectra, periods_s=periods, attrs=attrs, rows=rows, n_rows=n_rows)


def _refuse_non_hdf5(path: Path) -> None:
    """A path that cannot hold results at all (a folder, a file of another kind) gets an error saying
    what it is, instead of the reader's "damaged"."""
    if path.is_dir():
        raise ResultsFileError(f"{path} is a folder, not a results file")
    if path.is_file() and not _has_hdf5_signature(path):
        raise ResultsFileError(f"{path} is not an HDF5 file (no HDF5 signature at its start): not a results "
                               "file, or one whose first bytes were overwritten")


def _has_hdf5_signature(path: Path) -> bool:
    """The HDF5 format signature at offset 0, 512, 1024, 2048, ... (after a user block); read directly,
    since the HDF5 library's own probe opens the file, which a damaged file can make hang."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        off = 0
        while off + 8 <= size:
            fh.seek(off)
            if fh.read(8) == b"\x89HDF\r\n\x1a\n":
                return True
            off = 512 if off == 0 else 2 * off
    return False


def load(path, pending: bool = False, journal: bool = True, timeout_s: float | None = None,
         any_layout: bool = False, verify: bool = True) -> Results:
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
        yet (present only while a run is going on or after a kill). Nothing is written. The journal
        is used only if it belongs to the file (same signature and ``run_id``); a journal of another
        run or with a bad header is ignored with a warning. If the HDF5 file cannot be read (killed
        mid-write, damaged) the data come from the journal alone, with a warning.
    timeout_s : float or None
        Time allowed to open and read the file (in a child process) before it is called damaged;
        default :data:`OPEN_TIMEOUT_S` (env ``PYCOLFRAG_OPEN_TIMEOUT_S``) plus 1 s per 50 MB.
    any_layout : bool
        Also read a file in the documented ``/samples`` layout written by other code (no
        ``grid_signature``; fields or ``/spectra`` may be missing). Default False: such a file is
        refused (:class:`~pycolfrag.core.errors.ResultsFileError`).
    verify : bool
        Check the stored checksums (every attribute; every dataset of a complete file, each finished row of
        another; a file of the grid without them is damaged: docs/results_format.md, "Integrity"). Default
        True; False reads a damaged file as it is (salvage: check what you take from it).

    Returns
    -------
    Results
        ``samples`` (dict of 1-D arrays), ``spectra`` (dict of 2-D arrays), ``periods_s``, ``attrs``,
        ``rows`` (row indices kept), ``n_rows``, ``n_missing``, ``complete`` (how many rows the file
        still lacks). ``collapsed`` is returned as bool.

    Raises
    ------
    pycolfrag.results.ResultsDamagedError
        The file is damaged (read error, checksum mismatch, missing checksums, no answer in time) and no
        journal of it exists; its text says how to salvage the rows.
    ResultsFileError
        Not a pycolfrag results file.
    """
    path = Path(os.path.realpath(path))  # the journal is beside the real file (a symlink has none)
    jp = _results.journal_path(path)
    header, jrows = None, {}
    if journal and jp.exists():
        try:
            header, jrows = _results.read_journal(jp)
        except _results.JournalHeaderError as exc:
            warnings.warn(f"{exc}; the journal is ignored", stacklevel=2)
    if header is None:
        _refuse_non_hdf5(path)
    try:
        raw = _read_while_written(path, timeout_s, any_layout, verify)
    except (_results.ResultsDamagedError, FileNotFoundError) as exc:
        if header is None:
            if isinstance(exc, _results.ResultsDamagedError):
                raise  # its text says how to salvage the rows
            raise ResultsFileError(f"cannot read results file {path}: {exc}") from None
        reason = exc.reason if isinstance(exc, _results.ResultsDamagedError) else str(exc)
        warnings.warn(f"{reason}; the rows come from the journal {jp} alone", stacklevel=2)
        return _results_from_raw(None, pending, header, jrows)
    if header is not None:
        diffs = _results.journal_mismatch(header, raw["attrs"])
        if diffs:
            warnings.warn(f"{jp} belongs to another run ({'; '.join(diffs)}): none of its rows is used",
                          stacklevel=2)
            jrows = {}
    return _results_from_raw(raw, pending, header, jrows)


def _read_while_written(path: Path, timeout_s, any_layout: bool, verify: bool) -> dict:
    """:func:`pycolfrag.results.read_h5_bounded`, read again while a run holds the file's lock: a read that
    met a batch half-written by the run writing it now is not damage."""
    attempt = 0
    while True:
        try:
            return _results.read_h5_bounded(path, timeout_s, any_layout, verify)
        except _results.ResultsDamagedError:
            if attempt == 3 or (attempt > 0 and not _results.lock_held(path)):
                raise  # read twice (the run may have just finished its last batch), more while it runs
            attempt += 1
            time.sleep(0.2)


@dataclass
class ResultsData(_Completeness):
    """Successful samples of a results file, ready for the fragility analysis.

    Attributes
    ----------
    samples : dict of str -> ndarray
        ``/samples`` fields restricted to rows with ``status == 0`` (``collapsed`` as bool).
    sa_g, sv_cm_s : ndarray (n_ok, n_periods) or None
    periods_s : ndarray or None
    attrs : dict
        Root attributes of the file.
    n_total, n_failed : int
        Finished rows in the file, and rows with ``status != 0`` (excluded here).
    failures : dict of int -> int
        Failed rows by status code.
    path : str
    n_rows : int
        Rows the file holds, computed or not; ``n_missing = n_rows - n_total`` are not computed yet.
    """

    samples: dict
    sa_g: np.ndarray | None
    sv_cm_s: np.ndarray | None
    periods_s: np.ndarray | None
    attrs: dict
    n_total: int
    n_failed: int
    failures: dict = field(default_factory=dict)
    path: str = ""
    n_rows: int = -1

    def __post_init__(self):
        if self.n_rows < 0:
            self.n_rows = self.n_total

    @property
    def n_finished(self) -> int:
        return self.n_total

    @property
    def n(self) -> int:
        return int(self.samples["mw"].size)

    def __getitem__(self, name):
        try:
            return self.samples[name]
        except KeyError:
            raise ResultsFileError(f"{self.path}: /samples has no field {name!r}, which this output needs "
                                   f"(fields: {', '.join(sorted(self.samples))})") from None

    def scenario_index(self) -> np.ndarray:
        """Integer stratum of each sample: its (Mw, R) scenario (for stratified bootstraps)."""
        keys = np.round(self.samples["mw"], 6) * 1e4 + np.round(self.samples["dist_km"], 6)
        return np.unique(keys, return_inverse=True)[1].ravel()

    def failed_note(self) -> str:
        return f"; {self.n_failed} failed runs excluded" if self.n_failed else ""


def read_results(path) -> ResultsData:
    """Read a synthetic grid's results file through :func:`load` (journal overlay of
    a killed run; ``any_layout=True`` also reads a file in the documented layout that ``run_grid.py``
    did not write, without ``grid_signature``).

    Rows not computed yet (status -1) are dropped; failed rows (status > 0) are counted and excluded.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ResultsFileError(f"results file {path} does not exist")
    r = load(path, any_layout=True)
    samples, spectra, attrs = r.samples, r.spectra, r.attrs
    if attrs.get("layout") == "records":
        # a suite's rows are records x components x scales, not (Mw, R) scenarios of one distribution:
        # pooling them as scenarios would mix scale factors into one probability
        raise ResultsFileError(f"{path} is a record-suite results file (pycolfrag grid --records), not a synthetic "
                               f"grid: analyse it with pycolfrag record-report {path} OUT_DIR")
    periods = r.periods_s if len(r.periods_s) else None
    missing = [k for k in ("mw", "dist_km", "u_top", "u_d", "collapsed", "status") if k not in samples]
    if missing:
        raise ResultsFileError(f"{path}: /samples lacks {', '.join(missing)}")
    status = np.asarray(samples["status"])
    done = status >= 0
    ok = status == 0
    n_total = int(done.sum())
    failures = {int(s): int(np.sum(status == s)) for s in np.unique(status[done & ~ok])}
    s = {k: np.asarray(v)[ok] for k, v in samples.items() if np.ndim(v) == 1 and len(v) == status.size}
    s["collapsed"] = s["collapsed"].astype(bool)
    if ok.sum() == 0:
        raise ResultsFileError(f"{path}: no successful runs (status == 0) to analyse")
    sa = np.asarray(spectra["sa_g"])[ok] if "sa_g" in spectra else None
    sv = np.asarray(spectra["sv_cm_s"])[ok] if "sv_cm_s" in spectra else None
    return ResultsData(s, sa, sv, periods, dict(attrs), n_total, int(n_total - ok.sum()), failures, path, r.n_rows)


def as_data(data) -> ResultsData:
    """``data`` itself when it is a :class:`ResultsData`, else :func:`read_results` of the path."""
    return data if isinstance(data, ResultsData) else read_results(data)


def as_results(results) -> Results:
    """``results`` itself when it is a :class:`Results`, else :func:`load` of the path."""
    return results if isinstance(results, Results) else load(results)


def read_table(results, layout: str | None = None) -> dict:
    """A results file as one table: the ``/samples`` fields, ``sa_g``/``sv_cm_s`` (rows x periods),
    ``periods_s`` and ``attrs``; finished rows only, failed ones kept with their ``status``.

    ``results``: a path, a :class:`Results`, or a table already built (returned as it is).
    ``layout="records"``: refuse anything but a record suite's file with rows in it."""
    if isinstance(results, dict):
        return results
    r = as_results(results)
    if layout == "records":
        if r.attrs.get("layout") != "records":
            raise ResultsFileError(f"{results} is not a record-suite results file (pycolfrag grid --records); "
                                   "for a synthetic grid use pycolfrag report")
        if len(r) == 0:
            raise ResultsFileError(f"{results} holds no finished rows yet")
    t = dict(r.samples)
    t.update(r.spectra)
    t["periods_s"] = np.asarray(r.periods_s, dtype=float)
    t["attrs"] = dict(r.attrs)
    t["n_rows"], t["n_missing"] = r.n_expected, r.n_missing   # what analysis.completeness judges a table by
    return t
