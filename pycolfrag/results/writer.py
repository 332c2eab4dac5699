"""Creating, resuming and writing a results file: :func:`create`, :func:`open_for_run`, :class:`ResultsWriter`."""
from __future__ import annotations

import json
import os
import re
import uuid
import warnings
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from pycolfrag.core.errors import ResultsFileError
from pycolfrag.results.bounded import ChildLost, read_h5_bounded, start_child
from pycolfrag.results.checksums import ResultsDamagedError, row_checksums, store_checksums
from pycolfrag.results.journal import (
    Journal,
    JournalHeaderError,
    journal_mismatch,
    journal_path,
    journal_run_id,
    read_journal,
    set_aside,
    signature_mismatch,
    write_journal_header,
)
from pycolfrag.results.layout import (
    FORMAT_VERSION,
    ROW_CRC,
    SPECTRA_FIELDS,
    STATUS_OK,
    STATUS_PENDING,
    dtype_of,
    empty_columns,
    false_done,
    fields_of,
    h5open,
    kind_of,
    merged_columns,
    put_row,
    rows_of,
)
from pycolfrag.results.lock import RunLock
from pycolfrag.results.timeline import append_timeline, next_session

# ---------------------------------------------------------------------------------------
# creating
# ---------------------------------------------------------------------------------------


def _attr_value(v):
    if isinstance(v, (list, tuple)):
        return np.asarray(v, dtype=float)
    if v is None:
        return "null"
    return v


def _create_h5(path: Path, n_rows: int, periods_s: Sequence[float], attrs: Mapping) -> None:
    """Write the new file as ``<path>.tmp`` in a forked child, which renames it into place.

    In a child because the HDF5 library, when a write fails (a full disk), raises RuntimeErrors from
    its clean-up and can crash the process at exit; the parent gets the error back as the OSError
    it is (:func:`_os_error_of`), or the child's exception (e.g. a TypeError for a value HDF5 cannot
    store), and removes the partial ``.tmp``."""
    _start_create_h5(path, n_rows, periods_s, attrs).wait()


class _Creation:
    """A new file being written by a child (:func:`_start_create_h5`), which renames it into place as soon as
    it is complete (a run killed before it waits still leaves the file); :meth:`wait` reaps the child."""

    def __init__(self, path: Path, tmp: Path, child):
        self.path, self.tmp, self.child = path, tmp, child

    def wait(self) -> None:
        """Wait for the child; on failure remove the partial ``.tmp`` and raise the OSError it is."""
        try:
            try:
                self.child.result()
            except ChildLost as lost:
                raise OSError(f"creating the results file crashed the writing process (status {lost.status})") from None
        except BaseException as exc:
            try:
                self.tmp.unlink(missing_ok=True)
            except OSError:
                pass
            err = _os_error_of(exc, self.tmp)
            if err is exc:
                raise
            raise err from None


def _start_create_h5(path: Path, n_rows: int, periods_s: Sequence[float], attrs: Mapping) -> _Creation:
    tmp = path.with_name(path.name + ".tmp")
    return _Creation(path, tmp, start_child(_write_new_h5, tmp, n_rows, periods_s, attrs, path, quiet=True))


def _write_new_h5(tmp: Path, n_rows: int, periods_s: Sequence[float], attrs: Mapping, path: Path) -> None:
    """The new file written as ``tmp``, then renamed to ``path``: it appears complete or not at all."""
    with h5open(tmp, "w") as f:
        g = f.create_group("samples")
        for name, (code, fill, desc) in fields_of(attrs.get("layout")).items():
            dt = dtype_of(code)
            ds = g.create_dataset(name, shape=(n_rows,), dtype=dt, fillvalue=np.array(fill, dtype=dt))
            # allocate and fill now: later writes are then plain in-place data writes
            ds[...] = np.full(n_rows, fill, dtype=dt)
            ds.attrs["description"] = desc
        s = f.create_group("spectra")
        s.attrs["periods_s"] = np.asarray(periods_s, dtype=float)
        for name, desc in SPECTRA_FIELDS.items():
            ds = s.create_dataset(name, shape=(n_rows, len(periods_s)), dtype="f8", fillvalue=np.nan)
            ds[...] = np.nan
            ds.attrs["description"] = desc
            ds.attrs["periods_s"] = np.asarray(periods_s, dtype=float)
        crc = f.create_dataset(ROW_CRC, shape=(n_rows,), dtype="u4", fillvalue=0)
        crc[...] = 0
        crc.attrs["description"] = ROW_CRC_DESCRIPTION
        for k, v in attrs.items():
            f.attrs[k] = _attr_value(v)
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["complete"] = False
        f.attrs["n_done"] = 0
        store_checksums(f, datasets=False)
    os.replace(tmp, path)


#: ``/row_crc32``'s description attribute.
ROW_CRC_DESCRIPTION = ("CRC-32 of the row's bytes in every /samples field and /spectra row (name order), written "
                       "with the row before its status; 0: not written")


def create(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float]) -> str:
    """Create a new results file and its journal (replacing both if present); returns its ``run_id``.

    ``signature`` holds everything that fixes the results (grid, seed, column, solver options,
    periods...): it is stored as the root attribute ``grid_signature`` (JSON) and compared on resume.
    ``attrs`` are further root attributes (lists become float arrays). A fresh ``run_id`` (random)
    names this file's lineage: its journal carries the same id, and a writer refuses to write a
    file or delete a journal with another id. The caller holds the :class:`RunLock`.
    If creating fails (full disk, values HDF5 cannot store) nothing is left behind.
    """
    run_id, creation = _begin_create(path, signature, attrs, n_rows, periods_s)
    try:
        creation.wait()
    except BaseException:
        _unlink_quietly(journal_path(Path(path)))
        raise
    return run_id


def _begin_create(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float]):
    """:func:`create` up to the HDF5 file, which a child is writing when this returns: ``(run_id, creation)``
    (:meth:`_Creation.wait` puts the file in place). The journal exists already, so rows can be journalled
    while the file is made."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    jp = journal_path(path)
    tmp = path.with_name(path.name + ".tmp")
    for p in (jp, path, tmp):
        if p.exists():
            p.unlink()
    all_attrs = dict(attrs)
    all_attrs["grid_signature"] = json.dumps(signature, sort_keys=True)
    all_attrs["run_id"] = uuid.uuid4().hex
    try:
        write_journal_header(jp, n_rows, periods_s, signature, all_attrs)
        creation = _start_create_h5(path, n_rows, periods_s, all_attrs)
    except BaseException:
        for p in (jp, tmp):
            _unlink_quietly(p)
        raise
    return all_attrs["run_id"], creation


def _unlink_quietly(p: Path) -> None:
    try:
        p.unlink(missing_ok=True)
    except OSError:
        pass


# ---------------------------------------------------------------------------------------
# resuming
# ---------------------------------------------------------------------------------------

def open_for_run(path, signature: Mapping, attrs: Mapping, n_rows: int, periods_s: Sequence[float],
                 overwrite: bool = False, log=None, timeout_s=None, command: str | None = None,
                 background: bool = False) -> "ResultsWriter":
    """Lock ``path`` (:class:`RunLock`), then create it or resume it: returns a :class:`ResultsWriter`
    (which holds the lock until :meth:`ResultsWriter.finish`/``close``) whose ``done`` mask says
    which rows are already computed.

    On resume the stored ``grid_signature`` must equal ``signature``, else
    :class:`~pycolfrag.core.errors.ResultsFileError` (unless ``overwrite``). The journal must belong to
    the file (same signature and ``run_id``): a journal of another run, or one whose header is bad,
    is set aside (renamed ``<journal>.set-aside-<time>``, with a message through ``log``) and none
    of its rows is used. A damaged HDF5 file (an error, a checksum mismatch -- of an attribute, a
    dataset or a finished row --, missing checksums, or no answer within ``timeout_s``) is set aside
    and rebuilt from its journal, or, without a journal, refused with :class:`ResultsDamagedError`
    (which says how to salvage it): a resume keeps only rows it has verified. Journalled rows missing
    from the HDF5 file are written into it. ``log`` (default: :func:`warnings.warn`) receives those
    messages. ``path`` is resolved to its real path first (symlinks followed), and the lock covers the
    file's inode too: the lock, journal and file are those of the file itself, whatever name reaches it.

    ``background``: a new file is written by a child while this returns at once (its journal exists, so
    rows can be added); the writer's first HDF5 write waits for it and raises what creating it raised
    (the rows added meanwhile stay in the journal). A resumed or rebuilt file is always read first: its
    rows done decide what to compute.
    """
    log = log or (lambda s: warnings.warn(s, stacklevel=3))
    # the lock, the journal and the file are those of the real path: a symlink to a results file
    # (or a path through a linked folder) must meet the lock of the run writing it
    path = Path(os.path.realpath(path))
    lock = RunLock.acquire(path, log, command)
    try:
        writer = _open_locked(path, signature, attrs, n_rows, periods_s, overwrite, log, timeout_s, background)
        try:
            lock.hold_file(path)  # the file this run created or rebuilt is a new inode: a hard link to it meets the lock
        except BaseException:
            writer.close()
            raise
    except BaseException:
        lock.release()
        raise
    writer._lock = lock
    return writer


def _open_locked(path: Path, signature, attrs, n_rows, periods_s, overwrite, log, timeout_s,
                 background=False) -> "ResultsWriter":
    jp = journal_path(path)
    if overwrite or (not path.exists() and not jp.exists()):
        return _created(path, signature, attrs, n_rows, periods_s, background)
    header, jrows = _read_own_journal(jp, log)
    h5, damage = None, None
    if path.exists():
        try:
            h5 = read_h5_bounded(path, timeout_s)
        except ResultsDamagedError as exc:
            if header is None:
                raise  # nothing to rebuild it from: the error says how to salvage its rows
            damage = exc
    if h5 is not None and header is not None:
        diffs = journal_mismatch(header, h5["attrs"])
        if diffs:
            set_aside(jp, "it belongs to another run (" + "; ".join(diffs) + "); none of its rows is used", log)
            header, jrows = None, {}
    if h5 is None and header is None:  # only a journal with a bad header was there (set aside): nothing to resume
        return _created(path, signature, attrs, n_rows, periods_s, background)
    _refuse_another_run(path, json.loads(h5["attrs"]["grid_signature"]) if h5 is not None else header["signature"],
                        signature)
    if h5 is None:  # rebuild from the journal header, then replay every row below
        if damage is not None:
            set_aside(path, f"{damage.reason}; rebuilding it from {jp.name}", log)
        hattrs = dict(header["attrs"])
        hattrs["rebuilt_from_journal"] = True
        _create_h5(path, int(header["n_rows"]), header["periods_s"], hattrs)
        run_id = hattrs.get("run_id")
    else:
        run_id = h5["attrs"].get("run_id")
        if header is None:
            _journal_the_file(path, h5, n_rows, periods_s, signature)
        _add_row_checksums(path, h5)
    if jrows:  # idempotent replay: rows the HDF5 file may have missed when the run was killed
        _write_rows_h5(path, list(jrows.values()), n_rows, len(periods_s), run_id=run_id)
    writer = ResultsWriter(path, n_rows, len(periods_s), resumed=True, run_id=run_id)
    if writer.false_done:
        log(f"{path}: {writer.false_done} row(s) marked done carry no identity or an unknown status (damaged "
            "status bytes): they are recomputed")
    return writer


def _created(path: Path, signature, attrs, n_rows, periods_s, background=False) -> "ResultsWriter":
    if background:
        run_id, creation = _begin_create(path, signature, attrs, n_rows, periods_s)
        return ResultsWriter(path, n_rows, len(periods_s), resumed=False, run_id=run_id, creating=creation)
    run_id = create(path, signature, attrs, n_rows, periods_s)
    return ResultsWriter(path, n_rows, len(periods_s), resumed=False, run_id=run_id)


def _read_own_journal(jp: Path, log):
    """The journal's header and rows (``(None, {})`` when there is none); one with a bad header is set aside."""
    if jp.exists():
        try:
            return read_journal(jp, truncate=True, report=log)
        except JournalHeaderError as exc:
            set_aside(jp, f"{exc}; its rows cannot be trusted", log)
    return None, {}


def _refuse_another_run(path: Path, old_sig: Mapping, signature: Mapping) -> None:
    """:class:`ResultsFileError` when the file holds a run of another signature than this run's."""
    diffs = signature_mismatch(old_sig, signature)
    if not diffs:
        return
    why = ""
    if any(d.startswith(("build:", "solver:")) for d in diffs):
        why = ("\nIts rows were computed by another build of pycolfrag or with other solver options (the code or "
               "a default changed since): resuming would mix rows of two versions in one file.")
    raise ResultsFileError(
        f"{path} holds a different run; it cannot be resumed with these arguments:\n  - "
        + "\n  - ".join(diffs) + why
        + "\nUse --overwrite to replace it (every row is recomputed), or --out for another file.")


def _journal_the_file(path: Path, h5: Mapping, n_rows: int, periods_s, signature) -> None:
    """A journal-less file (finished run, or journal deleted): start a new journal for this session that
    also holds the file's finished rows -- verified by the read -- so that a kill during this session's
    HDF5 writes can rebuild the file from the journal without losing them."""
    samples, spectra, _, old_attrs = merged_columns(h5)
    old_attrs = {k: v for k, v in old_attrs.items() if k != "checksums"}
    jp = journal_path(path)
    write_journal_header(jp, n_rows, periods_s, signature, old_attrs)
    journal = Journal(jp)
    journal.append(rows_of(samples, spectra, np.flatnonzero(samples["status"] != STATUS_PENDING)))
    journal.sync()
    journal.close()


def _add_row_checksums(path: Path, h5: Mapping) -> None:
    """A complete file of format 1 (before ``/row_crc32``), verified by its dataset checksums, gets the
    checksums of its finished rows before rows are written into it, so that it stays verifiable while
    it is incomplete."""
    with h5open(path, "r+") as f:
        if ROW_CRC in f:
            return
        samples, spectra = h5["samples"], h5["spectra"]
        crc = np.zeros(len(samples["status"]), dtype=np.uint32)
        done = np.flatnonzero(np.asarray(samples["status"]) != STATUS_PENDING)
        crc[done] = row_checksums(samples, spectra, done)
        ds = f.create_dataset(ROW_CRC, data=crc)
        ds.attrs["description"] = ROW_CRC_DESCRIPTION
        f.attrs["format_version"] = FORMAT_VERSION
        store_checksums(f, datasets=bool(np.all(f.attrs.get("complete", False))))
        f.flush()


# ---------------------------------------------------------------------------------------
# writing rows
# ---------------------------------------------------------------------------------------

def _os_error_of(exc: BaseException, path) -> BaseException:
    """An HDF5 write error as the OSError it is: h5py raises RuntimeError (or OSError without an errno)
    for a failed write, with the system's ``errno = N`` in its text (a full disk: 28)."""
    seen = 0
    e: BaseException | None = exc
    while e is not None and seen < 8:  # closing after a failed write raises again: look down the chain
        if isinstance(e, OSError) and e.errno:
            return e if e.filename else OSError(e.errno, os.strerror(e.errno), os.fspath(path))
        m = re.search(r"errno = (\d+)", str(e))
        if m and int(m.group(1)) > 0:
            n = int(m.group(1))
            return OSError(n, os.strerror(n), os.fspath(path))
        e, seen = e.__context__, seen + 1
    return exc


def _write_rows_h5(path: Path, rows: list, n_rows: int, n_periods: int, attrs: Mapping | None = None,
                   run_id: str | None = None, checksums: bool = False, timeline=None) -> None:
    try:
        _write_rows_h5_unguarded(path, rows, n_rows, n_periods, attrs, run_id, checksums, timeline)
    except (RuntimeError, OSError) as exc:
        err = _os_error_of(exc, path)
        if err is exc:
            raise
        raise err from None


def _write_rows_h5_unguarded(path: Path, rows: list, n_rows: int, n_periods: int, attrs: Mapping | None = None,
                             run_id: str | None = None, checksums: bool = False, timeline=None) -> None:
    """Open, write rows (by their ``row`` index) and root attributes, flush, close.

    With ``run_id``, the file must carry that ``run_id`` (else :class:`ResultsFileError`: another
    run replaced the file, and nothing is written into it). Every write stores the attributes'
    checksums afresh; ``checksums=True`` the datasets' too (complete files). ``timeline``:
    ``(session, attrs, rows)`` appended to ``/timeline`` (:mod:`.timeline`; outside the checksums).
    """
    with h5open(path, "r+") as f:
        found = f.attrs.get("run_id")
        found = found.decode() if isinstance(found, bytes) else found
        if run_id is not None and found != run_id:
            raise ResultsFileError(f"{path} was replaced by another run (run_id {found}, this run wrote "
                                   f"{run_id}): nothing more is written into it")
        if rows:
            _write_rows(f, rows, n_rows, n_periods)
        if attrs:
            for k, v in attrs.items():
                f.attrs[k] = _attr_value(v)
        if timeline is not None:
            try:
                append_timeline(f, *timeline)
            except (ValueError, TypeError, OSError, RuntimeError) as exc:  # diagnostic data: never fails the rows
                warnings.warn(f"{path}: this write's timeline could not be stored ({type(exc).__name__}: {exc}); "
                              "the rows are written", stacklevel=2)
        store_checksums(f, datasets=checksums)  # every attribute always; the datasets when complete
        f.flush()


def _write_rows(f, rows: list, n_rows: int, n_periods: int) -> None:
    """Rows into an open file: every field, then each row's checksum, flushed, and ``status`` last."""
    rows = sorted(rows, key=lambda r: int(r["row"]))
    idx = np.array([int(r["row"]) for r in rows])
    if idx.min() < 0 or idx.max() >= n_rows:
        raise ResultsFileError(f"row index out of range 0..{n_rows - 1} in results batch")
    keep = np.r_[idx[1:] != idx[:-1], True]  # duplicates (a replayed row): keep the last
    rows = [r for r, k in zip(rows, keep) if k]
    idx = idx[keep]
    layout = f.attrs.get("layout")
    cols, spec = empty_columns(len(rows), n_periods, layout)
    for j, r in enumerate(rows):
        put_row(cols, spec, j, r, layout)
    g = f["samples"]
    # status last: a kill part-way through this batch leaves its rows pending (status -1) in the
    # HDF5 file, never marked done with half their fields, and a pending row's checksum is not read
    for name in SPECTRA_FIELDS:
        f["spectra"][name][idx, :] = spec[name]
    for name in fields_of(layout):
        if name != "status":
            g[name][idx] = cols[name]
    f[ROW_CRC][idx] = row_checksums(cols, spec, np.arange(len(rows)))
    f.flush()
    g["status"][idx] = cols["status"]
    f.attrs["n_done"] = int(np.count_nonzero(g["status"][...] != STATUS_PENDING))


class ResultsWriter:
    """Rank 0's writer: journal every row at once, HDF5 in batches (open, write, flush, close).

    ``creating``: the file is still being written by a child (:func:`open_for_run` with ``background``):
    rows are journalled meanwhile, and the first HDF5 write waits for it."""

    def __init__(self, path, n_rows: int, n_periods: int, resumed: bool, run_id: str | None = None,
                 creating: _Creation | None = None):
        self.path = Path(path)
        self.n_rows = int(n_rows)
        self.n_periods = int(n_periods)
        self.resumed = resumed
        self.run_id = run_id
        self._lock: RunLock | None = None
        self._pending: list[Mapping] = []
        self._creating = creating
        self._timeline: dict = {"attrs": None, "session": None, "rows": []}
        self._journal = Journal(journal_path(self.path))
        #: rows the HDF5 file marks done that cannot be (damaged status bytes): recomputed
        self.false_done = 0
        if creating is not None:  # a new file: every row pending
            self.status = np.full(self.n_rows, STATUS_PENDING, dtype=np.int32)
            return
        with h5open(self.path, "r") as f:
            g = f["samples"]
            self.status = g["status"][...]
            layout = f.attrs.get("layout")
            ident = {k: g[k][...] for k in kind_of(layout).named_by if k in g}   # what names a row of its kind
        bad = false_done({"status": self.status, **ident}, layout)
        self.false_done = int(bad.sum())
        self.status[bad] = STATUS_PENDING

    @property
    def done(self) -> np.ndarray:
        """Rows finished (ok or failed): ``status != STATUS_PENDING``."""
        return self.status != STATUS_PENDING

    def add(self, rows: Iterable[Mapping]) -> None:
        """Journal finished rows now; they reach the HDF5 file at the next :meth:`flush`."""
        rows = list(rows)
        if not rows:
            return
        self._journal.append(rows)
        for r in rows:
            self.status[int(r["row"])] = int(r.get("status", STATUS_OK))
        self._pending.extend(rows)

    def start_timeline(self, attrs: Mapping) -> None:
        """This session's timeline (:mod:`.timeline`): its attributes; intervals come with
        :meth:`add_timeline` and reach the file with the rows."""
        self._timeline["attrs"] = dict(attrs)

    def add_timeline(self, rows: np.ndarray) -> None:
        """Intervals (:data:`.timeline.DTYPE`) for the next HDF5 write."""
        if len(rows):
            self._timeline["rows"].append(rows)

    def update_timeline_hosts(self, hosts: Mapping) -> None:
        """The hosts of ranks learnt as the session goes (``{rank: host}``) into its ``hosts`` attribute."""
        attrs = self._timeline["attrs"]
        if attrs is None or not hosts:
            return
        listed = list(attrs.get("hosts", []))
        for rank, host in hosts.items():
            if 0 <= rank < len(listed):
                listed[rank] = host
        attrs["hosts"] = listed

    def flush(self, attrs: Mapping | None = None) -> None:
        """Write the journalled rows not yet in the HDF5 file (and optional root attributes)."""
        if self._pending or attrs:
            self._journal.sync()
            self._write_h5(self._pending, attrs)
            self._pending = []

    def _ready(self) -> None:
        """Wait for the child creating the file (once); if it failed, a journal that holds no row goes too
        (nothing is left behind), and the error is raised."""
        creation, self._creating = self._creating, None
        if creation is None:
            return
        try:
            creation.wait()
        except BaseException:
            if not self._pending and not self.done.any():
                self._journal.close()
                _unlink_quietly(journal_path(self.path))
            raise
        if self._lock is not None:
            self._lock.hold_file(self.path)  # the new inode: a hard link to it meets the lock

    def _write_h5(self, rows: list, attrs: Mapping | None = None, checksums: bool = False) -> None:
        self._ready()
        tl, timeline = self._timeline, None
        if tl["attrs"] is not None and tl["rows"]:
            if tl["session"] is None:
                tl["session"] = next_session(self.path)
            timeline = (tl["session"], tl["attrs"], np.concatenate(tl["rows"]))
        _write_rows_h5(self.path, rows, self.n_rows, self.n_periods, attrs, run_id=self.run_id, checksums=checksums,
                       timeline=timeline)
        tl["rows"] = []

    def finish(self, attrs: Mapping | None = None) -> None:
        """Final flush; when every row is done mark the file complete, store its checksums and
        delete the journal -- only if the journal at the path is this run's (same ``run_id``)."""
        try:
            self.flush()
            complete = bool(self.done.all())
            a = dict(attrs or {})
            a["complete"] = complete
            self._write_h5([], a, checksums=complete)
            self._journal.close()
            if complete:
                with open(self.path, "rb+") as fh:
                    os.fsync(fh.fileno())
                jp = journal_path(self.path)
                if jp.exists():
                    other = journal_run_id(jp)
                    if self.run_id is None or other == self.run_id:
                        jp.unlink(missing_ok=True)
                    else:
                        warnings.warn(f"{jp} belongs to another run (run_id {other}); left in place", stacklevel=2)
        finally:
            self.close()

    def close(self) -> None:
        """Close the journal and release the lock (rows not flushed stay in the journal); a file still
        being created is waited for first (its error, if any, was or will be reported by the run)."""
        try:
            if self._creating is not None:
                try:
                    self._ready()
                except BaseException:  # noqa: BLE001 -- closing after a failure: that failure is reported
                    pass
            self._journal.close()
        finally:
            if self._lock is not None:
                self._lock.release()
                self._lock = None
