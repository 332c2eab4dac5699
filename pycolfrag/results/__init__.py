"""HDF5 results of the Monte Carlo grid (``scripts/run_grid.py``): layout, crash-safe writing, resume.

Reading a file for analysis (``load`` -> ``Results``, ``read_results`` -> ``ResultsData``) is
:mod:`pycolfrag.analysis.data`; this package is the writing side and what both sides share.

* :mod:`~pycolfrag.results.layout` -- the registry of layouts (each kind of row declares its own fields in
  :mod:`pycolfrag.layouts`), the fields every row shares, their dtypes, status codes, rows <-> columns, and what a
  finished row is (:func:`merged_columns`);
* :mod:`~pycolfrag.results.journal` -- the journal sidecar that makes a run crash-safe;
* :mod:`~pycolfrag.results.lock` -- one writer per file (:class:`RunLock`, :func:`lock_held`);
* :mod:`~pycolfrag.results.checksums` -- what proves a file intact, and :class:`ResultsDamagedError`
  with its salvage hint;
* :mod:`~pycolfrag.results.bounded` -- the time-bounded, checksummed read in a forked child
  (:func:`read_h5_bounded`);
* :mod:`~pycolfrag.results.writer` -- :func:`create`, :func:`open_for_run` (create or resume) and
  :class:`ResultsWriter`.

The layout is documented in ``docs/results_format.md`` and readable with h5py alone:

* group ``/samples``: one 1-D dataset per field of :data:`SAMPLE_FIELDS`, all of length
  ``n_scenarios * n_samples``, one row per run, ordered by (scenario, sample). The rows are
  allocated when the file is created; a row not computed yet has ``status == -1``
  (:data:`STATUS_PENDING`) and NaN/zero values.
* group ``/spectra``: ``sa_g`` (g) and ``sv_cm_s`` (cm/s), shape (rows, periods), attribute ``periods_s``.
* dataset ``/row_crc32``: each finished row's CRC-32, written with the row.
* root attributes: ``seed``, ``n_ranks``, ``version``, ``git_revision``, ``column`` (JSON),
  ``solver`` (JSON), ``created``, ``checksums`` and the grid arguments (see :func:`create`).

Crash safety
------------
HDF5 files are not safe against a kill in the middle of a write. Rank 0 therefore keeps an
append-only *journal* next to the file (``<file>.journal``, JSON lines): a header line with
the grid signature and root attributes, then one line per finished row, appended and flushed
to the operating system as soon as a row reaches rank 0 -- before the HDF5 file is touched.
The HDF5 file is opened, written, flushed and closed in short batches (:class:`ResultsWriter`).
A kill (SIGTERM or SIGKILL) can therefore at worst lose the HDF5 batch being written, never a
journalled row: :func:`open_for_run` (the resume path) recreates the HDF5 file from the journal
header when it cannot be opened and replays every journalled row into it (row writes are
idempotent), and the reader overlays journalled rows in memory, so it sees every finished
sample even right after a kill. A truncated last journal line (killed mid-append) is ignored
and cut off before appending again. When a run completes, the HDF5 file is final (with CRC-32
``checksums`` of its datasets) and the journal is deleted; reopening such a file starts a journal
that holds its finished rows.

Faults from outside a run
-------------------------
* Two runs on one file: the writer holds :class:`RunLock` (``<file>.lock``, ``flock`` + holder's
  pid/host/start time, and a lock on the file's inode, so a hard link meets it too); a second
  writer gets :class:`ResultsLockedError`; a lock whose holder died is taken over.
* Rows of another run: the file and its journal carry the same ``run_id``; a journal is merged
  only if its signature and ``run_id`` match the file's (:func:`journal_mismatch`), else it is
  ignored (the reader) or set aside (:func:`open_for_run`); every HDF5 write checks the file's
  ``run_id``, and :meth:`ResultsWriter.finish` deletes only its own journal.
* A damaged file: read in a forked child with a deadline and checked against its checksums
  (:func:`read_h5_bounded`), so a damaged file is reported (:class:`ResultsDamagedError`, which says
  how to salvage its rows) instead of hanging the HDF5 library, and rebuilt from the journal when
  there is one. Missing checksums are damage.
* A journal whose header was cut (full disk) raises :class:`JournalHeaderError` in
  :func:`read_journal`; callers set it aside or ignore it, never crash.
"""
from pycolfrag.core.errors import ResultsFileError  # the base of this package's errors, importable beside them
from pycolfrag.results.bounded import OPEN_TIMEOUT_S, read_h5_bounded
from pycolfrag.results.checksums import ResultsDamagedError
from pycolfrag.results.journal import (
    JournalHeaderError,
    journal_mismatch,
    journal_path,
    read_journal,
    signature_mismatch,
)
from pycolfrag.results.layout import (
    EVENT_SAMPLE_FIELDS,
    FORMAT_VERSION,
    LABEL_BYTES,
    LAYOUTS,
    MESSAGE_BYTES,
    RECORD_SAMPLE_FIELDS,
    SAMPLE_FIELDS,
    SPECTRA_FIELDS,
    STATUS_IM_FAILED,
    STATUS_OK,
    STATUS_OTHER_FAILED,
    STATUS_PENDING,
    STATUS_RECORD_FAILED,
    STATUS_SOLVER_FAILED,
    TIMING_FIELDS,
    empty_columns,
    fields_of,
    h5open,
    kind_of,
    merged_columns,
    register_layout,
    row_bytes,
)
from pycolfrag.results.lock import ResultsLockedError, RunLock, lock_held, lock_path
from pycolfrag.results.writer import ResultsWriter, create, open_for_run

__all__ = [
    "FORMAT_VERSION", "SAMPLE_FIELDS", "RECORD_SAMPLE_FIELDS", "EVENT_SAMPLE_FIELDS", "SPECTRA_FIELDS", "LAYOUTS", "LABEL_BYTES",
    "TIMING_FIELDS", "STATUS_PENDING", "STATUS_OK", "STATUS_RECORD_FAILED", "STATUS_IM_FAILED",
    "STATUS_SOLVER_FAILED", "STATUS_OTHER_FAILED", "MESSAGE_BYTES", "OPEN_TIMEOUT_S",
    "fields_of", "kind_of", "register_layout", "row_bytes", "empty_columns", "merged_columns", "h5open",
    "journal_path", "read_journal", "journal_mismatch", "signature_mismatch", "JournalHeaderError",
    "lock_path", "lock_held", "RunLock", "ResultsFileError", "ResultsLockedError", "ResultsDamagedError",
    "read_h5_bounded",
    "ResultsWriter", "create", "open_for_run",
]
