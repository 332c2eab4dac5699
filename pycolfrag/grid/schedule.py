"""MPI scheduling and rank 0's writes: :func:`run_grid` on every rank.

Every rank computes; rank 0 also hands out the rows and alone writes the results
(:mod:`pycolfrag.results`: journal at once, HDF5 in batches). The order of work: every rank starts
(imports, checks, its signature), rank 0 compares the signatures and opens the results file (a new
file is written by a child while the ranks already compute: rows go to the journal meanwhile), then
the ranks compute chunk after chunk (:mod:`pycolfrag.grid.serve`; chunk sizes:
:mod:`pycolfrag.grid.chunks`), and rank 0 makes the final write. Every rank records its timeline
(:mod:`pycolfrag.grid.timeline`), which rank 0 stores in the file (``/timeline``). mpi4py is imported
only when the run is launched under MPI.
"""
from __future__ import annotations

import json
import os
import signal
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import MissingDependencyError, ParameterError
from pycolfrag.core.version import __version__
from pycolfrag.grid.chunks import ChunkQueue
from pycolfrag.grid.protocol import RunSpec, as_row_function
from pycolfrag.grid.rows import load_function
from pycolfrag.grid.serve import DRAIN_S, RANK0_WORKS_UP_TO, Drain, compute_alone, serve, work
from pycolfrag.grid.signing import code_digest, code_entry, git_revision, now, resume_signature, share_code_digest
from pycolfrag.grid.timeline import Recorder
from pycolfrag.results import timeline as _tl_store
from pycolfrag.solver import run as _solver

__all__ = ["get_comm", "run_grid", "RunSummary", "RANK0_WORKS_UP_TO"]

_LAUNCHER_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS", "HYDRA_CONTROL_FD")


def get_comm(mode: str = "auto"):
    """``MPI.COMM_WORLD`` or None (serial).

    ``auto``: use MPI when started by a launcher (mpirun/srun environment) or when ``mpi4py.MPI``
    is already imported (``python -m mpi4py``); otherwise do not import it at all. ``yes``: always;
    ``no``: never. MPI asked for (``yes``, or ``auto`` under a launcher) without mpi4py installed raises
    :class:`~pycolfrag.core.errors.MissingDependencyError` with the install command: each rank running the
    whole job alone, as if it were the only process, would be a silent change of what was asked.
    """
    if mode == "no":
        return None
    launched = [v for v in _LAUNCHER_VARS if v in os.environ]
    if mode == "auto" and "mpi4py.MPI" not in sys.modules and not launched:
        return None
    try:
        from mpi4py import MPI  # here: importing it starts MPI, wanted only under a launcher
    except ImportError as exc:
        why = "--mpi yes" if mode == "yes" else f"started by an MPI launcher ({launched[0]} is set)"
        raise MissingDependencyError(
            f"MPI was asked for ({why}) but mpi4py is not installed: pip install 'pycolfrag[mpi]' "
            f"(or run one process without mpirun) [{exc}]") from exc
    return MPI.COMM_WORLD


@dataclass
class RunSummary:
    """What :func:`run_grid` returns on rank 0. ``rows_left``: rows not computed because a SIGTERM
    stopped the run (it drained; rerunning the same command resumes it). ``drained``: a SIGTERM came
    during the run (with no row left too: a caller running several grids stops before its next one)."""

    path: Path
    n_rows: int
    computed: int
    failed: int
    wall_s: float
    n_ranks: int
    rows_left: int = 0
    drained: bool = False


@dataclass(frozen=True)
class _Run:
    """How a run goes (not what it computes: that is the spec)."""

    overwrite: bool
    retry_failed: bool
    allow_code_change: bool
    progress: bool
    rank0_works: str
    chunk_max: int
    flush_s: float
    command: str
    drain_s: float


def run_grid(spec: RunSpec, out, *, overwrite: bool = False, retry_failed: bool = False,
             sample_fn: Callable | None = None, comm=None, progress: bool = True, rank0_works: str = "auto",
             chunk_max: int = 32, flush_s: float = 2.0, command: str | None = None,
             log: Callable[[str], None] | None = None, allow_code_change: bool = False,
             drain_s: float = DRAIN_S, timeline: Recorder | None = None) -> RunSummary | None:
    """Run (or resume) a grid; every rank calls this. Returns a :class:`RunSummary` on rank 0, None elsewhere.

    ``sample_fn``: a function of one row or a :class:`~pycolfrag.grid.protocol.RowFunction` replacing
    the spec's rows. ``allow_code_change``: resume a file whose rows were computed by other code (its
    ``code_digest`` or result hash differ), recording this code in its ``code_digests``. ``drain_s``:
    seconds rank 0 waits for the chunks in flight after a SIGTERM (:mod:`pycolfrag.grid.serve`).
    ``timeline``: this rank's :class:`~pycolfrag.grid.timeline.Recorder` with its start-up so far (the
    command's); a new one by default.
    Raises :class:`~pycolfrag.core.errors.ResultsFileError` on rank 0 when ``out`` holds another run
    (other ranks then return None).
    """
    log = log or (lambda s: print(s, flush=True))
    fn = as_row_function(sample_fn) if sample_fn is not None else load_function(spec.sample_function,
                                                                                  spec.default_function())
    run = _Run(overwrite, retry_failed, allow_code_change, progress, rank0_works, chunk_max, flush_s,
               command or " ".join(sys.argv), drain_s)
    tl = timeline or Recorder()
    ctx = spec.context()
    out = Path(out)
    t_start, epoch, started = time.perf_counter(), time.time(), now()
    with tl.span("identity"):
        share_code_digest(comm)   # before any signature: rank 0 reads the code, the others take its digest
        sig = json.dumps(spec.signature(), sort_keys=True, default=str)
    opened = _open(spec, sig, out, comm, started, run, log, tl)
    width = _widths(fn, ctx)
    if comm is not None and comm.Get_rank() != 0:
        if opened:
            work(comm, ctx, fn, tl, width)
        return None
    writer, todo = opened
    size = comm.Get_size() if comm is not None else 1
    queue = ChunkQueue(todo, spec.expected_cost(todo), size, width(None))
    drain = Drain(queue, drain_s)
    works = size == 1 or rank0_works == "yes" or (rank0_works == "auto" and size <= RANK0_WORKS_UP_TO)
    writer.start_timeline(_timeline_attrs(started, epoch, size, queue.lanes, run, works, comm))
    intake = _Intake(writer, _progress(len(todo), progress, under_mpi=comm is not None), flush_s, tl, epoch)
    failure = None
    with drain.installed():
        try:
            if size == 1:
                compute_alone(ctx, fn, queue, chunk_max, intake, tl, width, drain, log)
            else:
                serve(comm, ctx, fn, queue, works, chunk_max, intake, tl, width, drain, log)
        except BaseException as exc:
            failure = exc
            exc.pcf_during_run = True  # main() must abort the other ranks, which still wait for rank 0
            raise
        finally:
            if drain.t is not None:
                tl.add("drain", drain.t, time.time())
            intake.close()
            wall = time.perf_counter() - t_start
            session = {"started": started, "n_ranks": size, "rows_computed": intake.computed,
                       "wall_s": round(wall, 3), "code_digest": code_digest(spec.solver_options)}
            _finish(writer, intake, out, session, wall, failure)
    left = int((~writer.done).sum()) if drain.t is not None else 0
    return RunSummary(path=out, n_rows=spec.n_rows, computed=intake.computed, failed=intake.failed, wall_s=wall,
                      n_ranks=size, rows_left=left, drained=drain.t is not None)


def _widths(fn, ctx):
    """``width(n)``: the SIMD batch width the C library takes for a chunk of ``n`` rows (``width(None)``:
    the widest, the lanes a chunk is sized in); 1 for a row function without batches. Asked of the
    library once per size (a solver set-up, about 0.3 ms)."""
    memo: dict = {}
    column, opts = getattr(ctx, "column", None), getattr(ctx.spec, "solver_options", None)

    def width(n):
        if fn.many is None or column is None or (n is not None and n < 2):
            return 1
        if n not in memo:
            memo[n] = _solver.batch_width(column, opts) if n is None else _solver.batch_width(column, opts, n_runs=n)
        return memo[n]
    return width


def _timeline_attrs(started: str, epoch: float, size: int, lanes: int, run, works: bool, comm) -> dict:
    """The session's timeline attributes (docs/results_format.md): when and where it ran, and how."""
    mpi = ""
    if comm is not None:
        from mpi4py import MPI  # here: only under MPI (loaded already)
        mpi = MPI.Get_library_version().replace("\x00", "").strip().splitlines()[0].split(",")[0]
    launcher = ("srun" if "SLURM_STEP_ID" in os.environ else "mpirun" if "OMPI_COMM_WORLD_SIZE" in os.environ
                else "mpiexec" if "PMI_SIZE" in os.environ or "PMIX_RANK" in os.environ else "")
    return {"started": started, "epoch_unix": epoch, "n_ranks": size, "hosts": [socket.gethostname()] * size,
            "cpu": cpu_model(), "mpi": mpi, "launcher": launcher, "lanes": lanes, "chunk_max": run.chunk_max,
            "rank0_works": bool(works), "flush_s": run.flush_s}


def cpu_model() -> str:
    """The CPU's model name (/proc/cpuinfo), else platform's: what a timing was measured on."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform  # here: only where /proc/cpuinfo is not
    return platform.processor() or platform.machine()


def _open(spec: RunSpec, sig: str, out: Path, comm, started: str, run: _Run, log, tl: Recorder):
    """Every rank: rank 0 compares the ranks' signatures (``sig``: this rank's, JSON) and opens the results
    file. Returns ``(writer, rows to compute)`` on rank 0 (or raises why not), and on the other ranks
    whether the run goes on. Rank 0's go also sets the others' clocks for the timeline."""
    size = comm.Get_size() if comm is not None else 1
    rank = comm.Get_rank() if comm is not None else 0
    # every rank read the column and the record files itself: they must have read the same inputs
    # (a suite folder changed while the job started would otherwise mix two suites in one file)
    sigs = None
    if size > 1:
        with tl.span("gather"):
            sigs = comm.gather(sig, root=0)
    opened, err = None, None
    if rank == 0:
        try:
            if sigs is not None and len(set(sigs)) > 1:
                bad = [i for i, x in enumerate(sigs) if x != sigs[0]]
                raise ParameterError(f"ranks {bad} read other inputs than rank 0 (the column or record files "
                                     "changed while the job started, or the ranks run different builds of "
                                     "pycolfrag); nothing was run")
            with tl.span("open"):
                opened = _open_file(spec, out, size, started, run, log)
        except Exception as exc:
            err = exc
    if size > 1:
        t, c = time.time(), time.thread_time()
        ok, t0, host0 = comm.bcast((err is None, time.time(), tl.host), root=0)
        if rank != 0:
            received = time.time()
            tl.add("release", t, received, time.thread_time() - c)
            tl.set_clock(t0, host0, received)
            return ok
    if err is not None:
        raise err
    return opened


def _file_attrs(spec: RunSpec, signature: dict, size: int, started: str, command: str) -> dict:
    """The root attributes of a new results file: those every file has, then the spec's own."""
    attrs = {
        "version": __version__, "git_revision": git_revision(),
        "column": json.dumps(spec.column, sort_keys=True),
        "solver": json.dumps(spec.solver_options.to_dict(), sort_keys=True),
        "created": started, "n_ranks": size,
        "periods_s": list(spec.periods_s), "damping": float(spec.damping), "command": command,
        "code_digest": signature["code_digest"],
        "code_digests": json.dumps([code_entry(signature, started, 0)]),
    }
    attrs.update(spec.file_attrs())
    return attrs


def _open_file(spec: RunSpec, out: Path, size: int, started: str, run: _Run, log):
    """Rank 0: create or resume ``out`` (:func:`pycolfrag.results.open_for_run`) under the code rule of
    :func:`pycolfrag.grid.signing.resume_signature`; returns ``(writer, rows to compute)``."""
    signature = spec.signature()
    attrs = _file_attrs(spec, signature, size, started, run.command)
    opened_sig, history = signature, None
    if not run.overwrite:
        opened_sig, history = resume_signature(out, signature, run.allow_code_change, log)
    # a new file is written by a child while the ranks compute (its rows go to the journal meanwhile)
    writer = _results.open_for_run(out, opened_sig, attrs, spec.n_rows, spec.periods_s, overwrite=run.overwrite,
                                   log=log, command=run.command, background=True)
    try:
        if history is not None:  # other code resumes (allowed): say so in the file before its first row
            history.append(code_entry(signature, started, int(writer.done.sum())))
            writer.flush({"code_digests": json.dumps(history)})
        need = ~writer.done
        if run.retry_failed:
            need |= writer.status > 0
        todo = spec.order(np.flatnonzero(need).tolist())
    except BaseException:
        writer.close()
        raise
    if writer.resumed:
        log(f"resuming {out}: {int(writer.done.sum())} of {spec.n_rows} rows already done, {len(todo)} to compute")
    return writer, todo


class _Intake:
    """Rank 0's intake of finished rows: journal them at once, count them, move the progress bar, keep
    every rank's timeline, and write the HDF5 file every ``flush_s`` seconds (:meth:`maybe_flush`)."""

    def __init__(self, writer, pbar, flush_s: float, tl: Recorder, epoch: float):
        self.writer, self.pbar, self.flush_s, self.tl, self.epoch = writer, pbar, flush_s, tl, epoch
        self.computed = self.failed = self.collapses = 0
        self.last_flush = time.perf_counter()
        self.hosts: dict = {}
        self._events: list = []     # (rank, intervals) not yet handed to the writer

    def __call__(self, rows, rank: int = 0, events=None, hello=None) -> None:
        """Rows of a chunk (journalled now), with the intervals and, on its first request, the host of the
        rank that computed them."""
        if events:
            self._events.append((rank, events))
        if hello:
            self.hosts[rank] = hello.get("host", "")
        if not rows:
            return
        self.writer.add(rows)
        self.computed += len(rows)
        self.failed += sum(1 for r in rows if r.get("status", 0) != 0)
        self.collapses += sum(1 for r in rows if r.get("collapsed"))
        if self.pbar is not None:
            self.pbar.update(len(rows))
            self.pbar.set_postfix(collapsed=self.collapses, failed=self.failed, refresh=False)

    def maybe_flush(self) -> None:
        """The HDF5 write, when ``flush_s`` seconds have passed since the last."""
        if time.perf_counter() - self.last_flush >= self.flush_s:
            with self.tl.span("flush"):
                self.push_timeline()
                self.writer.flush()
            self.last_flush = time.perf_counter()

    def push_timeline(self) -> None:
        """Every rank's intervals received, and rank 0's own, to the writer for its next write."""
        self._events.append((0, self.tl.take()))
        for rank, events in self._events:
            self.writer.add_timeline(_tl_store.records(rank, events, self.epoch))
        self._events = []
        self.writer.update_timeline_hosts(self.hosts)

    def close(self) -> None:
        if self.pbar is not None:
            self.pbar.close()


def _finish(writer, intake: "_Intake", out: Path, session: dict, wall: float, failure) -> None:
    """The final write (rows, the session's line in ``sessions``, ``complete``) with SIGTERM and SIGINT
    ignored, so a second signal does not cut it short. An error here is raised unless the run failed
    already (then it is that failure's consequence, e.g. the same full disk, and the first is reported)."""
    try:
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
    try:
        t0 = time.time()
        writer.flush()   # the rows; the session's attributes and the timeline up to here in the last write
        intake.tl.add("finish", t0, time.time())
        intake.push_timeline()
        sessions = _previous_sessions(out)
        sessions.append(session)
        writer.finish({"n_ranks": session["n_ranks"], "sessions": json.dumps(sessions), "wall_s_last_session": wall})
    except Exception as exc:
        try:
            writer.close()  # journal closed (its rows stay), lock released
        except OSError:
            pass  # the same full disk again: the error reported is the one raised below or above
        if failure is None:
            exc.pcf_during_run = True
            raise


def _previous_sessions(path) -> list:
    try:
        with _results.h5open(path, "r") as f:
            return json.loads(f.attrs.get("sessions", "[]"))
    except Exception:
        return []


def _progress(total: int, enabled: bool, under_mpi: bool = False):
    if not enabled or total == 0:
        return None
    try:
        from tqdm import tqdm  # here: only rank 0 with a bar loads it; without tqdm, no bar
    except ImportError:
        return None
    # Under mpirun stderr is always a pipe (stdout a pty), so a terminal cannot be told from a log
    # file there: update every second under MPI or on a terminal, every 30 s into a plain file.
    live = sys.stderr.isatty() or under_mpi
    return tqdm(total=total, desc="grid", unit="run", dynamic_ncols=True, smoothing=0.05,
                mininterval=1.0 if live else 30.0)
