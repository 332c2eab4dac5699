"""MPI scheduling: every rank computes, rank 0 hands out the rows and alone writes the results.

Rank 0 holds the queue of rows (longest expected first: Mw 7.5 before 5.5), takes a chunk at a time
for itself, and between its own chunks answers the other ranks' requests (non-blocking probes). The
other ranks ask for their next chunk *before* computing the current one (prefetch), so a request is
answered while they work and they do not wait for rank 0 to finish its row; a request also carries
the finished rows of the previous chunk (one message per chunk). Chunks shrink as the queue empties
(guided self-scheduling, at most ``chunk_max`` rows); a chunk's runs go side by side in SIMD lanes
(the row function's ``many``; the same rows). With many ranks rank 0 only serves
(``rank0_works="auto"``: it computes when there are at most 16 ranks). Rank 0 alone writes the results
(:mod:`pycolfrag.results`: journal at once, HDF5 in batches). mpi4py is imported only when the run
is launched under MPI.
"""
from __future__ import annotations

import json
import os
import signal
import sys
import time
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .. import __version__
from .. import results as _results
from ..errors import ParameterError
from .protocol import RunSpec, as_row_function
from .rows import guarded_rows, load_function
from .signing import code_digest, code_entry, git_revision, now, resume_signature, share_code_digest

__all__ = ["get_comm", "run_grid", "RunSummary"]

# tags of the rank-0 <-> worker protocol
_TAG_REQUEST = 11   # worker -> 0: "next chunk please" + rows finished since the last request
_TAG_DONE = 12      # worker -> 0: last rows; the worker stops
_TAG_WORK = 13      # 0 -> worker: a list of row indices (empty: no more work)
#: Rank 0 computes rows between serving the others up to this many ranks (``rank0_works="auto"``).
RANK0_WORKS_UP_TO = 16

_LAUNCHER_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS", "HYDRA_CONTROL_FD")


def get_comm(mode: str = "auto"):
    """``MPI.COMM_WORLD`` or None (serial).

    ``auto``: use MPI when started by a launcher (mpirun/srun environment) or when ``mpi4py.MPI``
    is already imported (``python -m mpi4py``); otherwise do not import it at all. ``yes``: always
    (an error when mpi4py is missing); ``no``: never.
    """
    if mode == "no":
        return None
    if mode == "auto" and "mpi4py.MPI" not in sys.modules and not any(v in os.environ for v in _LAUNCHER_VARS):
        return None
    try:
        from mpi4py import MPI  # here: importing it starts MPI, wanted only under a launcher
    except ImportError:
        if mode == "yes":
            raise
        return None
    return MPI.COMM_WORLD


@dataclass
class RunSummary:
    """What :func:`run_grid` returns on rank 0."""

    path: Path
    n_rows: int
    computed: int
    failed: int
    wall_s: float
    n_ranks: int


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


def run_grid(spec: RunSpec, out, *, overwrite: bool = False, retry_failed: bool = False,
             sample_fn: Callable | None = None, comm=None, progress: bool = True, rank0_works: str = "auto",
             chunk_max: int = 32, flush_s: float = 2.0, command: str | None = None,
             log: Callable[[str], None] | None = None, allow_code_change: bool = False) -> RunSummary | None:
    """Run (or resume) a grid; every rank calls this. Returns a :class:`RunSummary` on rank 0, None elsewhere.

    ``sample_fn``: a function of one row or a :class:`~pycolfrag.grid.protocol.RowFunction` replacing
    the spec's rows. ``allow_code_change``: resume a file whose rows were computed by other code (its
    ``code_digest`` or result hash differ), recording this code in its ``code_digests``.
    Raises :class:`~pycolfrag.errors.ResultsFileError` on rank 0 when ``out`` holds another run
    (other ranks then return None).
    """
    log = log or (lambda s: print(s, flush=True))
    fn = as_row_function(sample_fn) if sample_fn is not None else load_function(spec.sample_function,
                                                                                  spec.default_function())
    run = _Run(overwrite, retry_failed, allow_code_change, progress, rank0_works, chunk_max, flush_s,
               command or " ".join(sys.argv))
    ctx = spec.context()
    out = Path(out)
    t_start, started = time.perf_counter(), now()
    share_code_digest(comm)   # before any signature: rank 0 reads the code, the others take its digest
    opened = _open(spec, out, comm, started, run, log)
    if comm is not None and comm.Get_rank() != 0:
        if opened:
            _worker(comm, ctx, fn)
        return None
    writer, todo = opened
    size = comm.Get_size() if comm is not None else 1
    intake = _Intake(writer, _progress(len(todo), progress, under_mpi=comm is not None), flush_s)
    failure = None
    with _sigterm_as_exit():
        try:
            if size == 1:
                queue = deque(todo)
                while queue:
                    intake(guarded_rows(fn, ctx, _chunk(queue, 1, chunk_max)))
            else:
                works = rank0_works == "yes" or (rank0_works == "auto" and size <= RANK0_WORKS_UP_TO)
                _serve(comm, ctx, fn, deque(todo), works, chunk_max, intake)
        except BaseException as exc:
            failure = exc
            exc.pcf_during_run = True  # main() must abort the other ranks, which still wait for rank 0
            raise
        finally:
            intake.close()
            wall = time.perf_counter() - t_start
            session = {"started": started, "n_ranks": size, "rows_computed": intake.computed,
                       "wall_s": round(wall, 3), "code_digest": code_digest(spec.solver_options)}
            _finish(writer, out, session, wall, failure)
    return RunSummary(path=out, n_rows=spec.n_rows, computed=intake.computed, failed=intake.failed, wall_s=wall,
                      n_ranks=size)


def _open(spec: RunSpec, out: Path, comm, started: str, run: _Run, log):
    """Every rank: rank 0 compares the ranks' signatures and opens the results file. Returns
    ``(writer, rows to compute)`` on rank 0 (or raises why not), and on the other ranks whether
    the run goes on."""
    size = comm.Get_size() if comm is not None else 1
    rank = comm.Get_rank() if comm is not None else 0
    # every rank read the column and the record files itself: they must have read the same inputs
    # (a suite folder changed while the job started would otherwise mix two suites in one file)
    sigs = None
    if size > 1:
        sigs = comm.gather(json.dumps(spec.signature(), sort_keys=True, default=str), root=0)
    opened, err = None, None
    if rank == 0:
        try:
            if sigs is not None and len(set(sigs)) > 1:
                bad = [i for i, x in enumerate(sigs) if x != sigs[0]]
                raise ParameterError(f"ranks {bad} read other inputs than rank 0 (the column or record files "
                                     "changed while the job started, or the ranks run different builds of "
                                     "pycolfrag); nothing was run")
            opened = _open_file(spec, out, size, started, run, log)
        except Exception as exc:
            err = exc
    if size > 1:
        ok = comm.bcast(err is None, root=0)
        if rank != 0:
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
    writer = _results.open_for_run(out, opened_sig, attrs, spec.n_rows, spec.periods_s, overwrite=run.overwrite,
                                   log=log, command=run.command)
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
    """Rank 0's intake of finished rows: journal them at once, count them, move the progress bar,
    and write the HDF5 file every ``flush_s`` seconds."""

    def __init__(self, writer, pbar, flush_s: float):
        self.writer, self.pbar, self.flush_s = writer, pbar, flush_s
        self.computed = self.failed = self.collapses = 0
        self.last_flush = time.perf_counter()

    def __call__(self, rows) -> None:
        if not rows:
            return
        self.writer.add(rows)
        self.computed += len(rows)
        self.failed += sum(1 for r in rows if r.get("status", 0) != 0)
        self.collapses += sum(1 for r in rows if r.get("collapsed"))
        if self.pbar is not None:
            self.pbar.update(len(rows))
            self.pbar.set_postfix(collapsed=self.collapses, failed=self.failed, refresh=False)
        if time.perf_counter() - self.last_flush >= self.flush_s:
            self.writer.flush()
            self.last_flush = time.perf_counter()

    def close(self) -> None:
        if self.pbar is not None:
            self.pbar.close()


@contextmanager
def _sigterm_as_exit():
    """SIGTERM raises SystemExit while the run goes on (so the final write happens); the handlers of
    SIGTERM and SIGINT in place before are restored after it."""
    prev_sigterm = signal.getsignal(signal.SIGTERM)
    prev_sigint = signal.getsignal(signal.SIGINT)

    def _on_sigterm(signum, frame):
        raise SystemExit(128 + signum)

    try:
        signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        try:
            signal.signal(signal.SIGTERM, prev_sigterm)
            signal.signal(signal.SIGINT, prev_sigint)
        except ValueError:
            pass


def _finish(writer, out: Path, session: dict, wall: float, failure) -> None:
    """The final write (rows, the session's line in ``sessions``, ``complete``) with SIGTERM and SIGINT
    ignored, so a second signal does not cut it short. An error here is raised unless the run failed
    already (then it is that failure's consequence, e.g. the same full disk, and the first is reported)."""
    try:
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
    try:
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


def _chunk(queue: deque, size: int, chunk_max: int) -> list[int]:
    """Guided self-scheduling: a quarter of an equal share, between 1 and ``chunk_max`` rows."""
    n = len(queue)
    k = max(1, min(chunk_max, n // (4 * size)))
    return [queue.popleft() for _ in range(min(k, n))]


def _serve(comm, ctx, fn, queue: deque, works: bool, chunk_max: int, accept) -> None:
    """Rank 0: answer requests between its own rows until every worker has stopped."""
    from mpi4py import MPI  # here: only under MPI (importing it starts MPI)
    size = comm.Get_size()
    status = MPI.Status()
    active = size - 1
    sends = []
    heard: set = set()   # workers whose first request has come
    while active > 0 or (works and queue):
        served = False
        # A worker asks for work as soon as it starts, but a test of the queue (Iprobe) right after
        # start-up can miss that request: wait for each worker's first one before rank 0 takes rows
        # of its own, or the worker idles through rank 0's first batches (measured: two of them).
        while active > 0 and (len(heard) < size - 1
                              or comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)):
            if len(heard) < size - 1:
                comm.Probe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)
            src, tag = status.Get_source(), status.Get_tag()
            heard.add(src)
            rows = comm.recv(source=src, tag=tag)
            if tag == _TAG_REQUEST:
                sends.append(comm.isend(_chunk(queue, size, chunk_max), dest=src, tag=_TAG_WORK))
            elif tag == _TAG_DONE:
                active -= 1
            accept(rows)
            served = True
        if works and queue:   # a quarter of a worker's chunk: the workers' next requests wait less
            accept(guarded_rows(fn, ctx, _chunk(queue, size, max(1, chunk_max // 4))))
        elif not served:
            time.sleep(0.001)  # nothing to do but wait: do not spin on a shared core
        if len(sends) > 64:
            sends = [r for r in sends if not r.Test()]
    for r in sends:
        r.Wait()


def _worker(comm, ctx, fn) -> None:
    """Ranks > 0: ask for the next chunk before computing the current one; hand in rows per chunk."""
    pending = [comm.isend([], dest=0, tag=_TAG_REQUEST)]
    chunk = comm.recv(source=0, tag=_TAG_WORK)
    done: list = []
    while chunk:
        pending.append(comm.isend(done, dest=0, tag=_TAG_REQUEST))  # prefetch + last chunk's rows
        done = guarded_rows(fn, ctx, chunk)
        chunk = comm.recv(source=0, tag=_TAG_WORK)
        pending = [r for r in pending if not r.Test()]
    pending.append(comm.isend(done, dest=0, tag=_TAG_DONE))
    for r in pending:
        r.Wait()
