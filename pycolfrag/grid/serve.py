"""The ranks while rows are computed: rank 0 hands out chunks and journals the rows, the workers compute.

Rank 0 holds the queue (:class:`~pycolfrag.grid.chunks.ChunkQueue`), takes a chunk at a time for itself,
and between its own chunks answers the other ranks' requests. A worker asks for its next chunk *before*
computing the current one (prefetch), so the answer is there when it finishes; a request also carries
the rows of the worker's previous chunk and its timeline since (one message per chunk). With many ranks
rank 0 only serves (``rank0_works="auto"``: it computes when there are at most
:data:`RANK0_WORKS_UP_TO` ranks).

**A stop asked by SIGTERM** (Slurm's ``--signal=TERM@T`` signals every task, as ``scancel`` of an ``srun``
step does; ``mpirun`` does not forward it but aborts the job, SIGTERM a second before SIGKILL: docs/grid.md,
"Signals"): a worker ignores it and finishes its chunk -- rank 0 decides, and the launcher's SIGKILL at
the limit still ends everything -- while rank 0 *drains*: it hands out nothing more (every later request
gets an empty chunk, so each worker sends its last rows and stops), collects the chunks in flight, and
the run ends with its final write; rows left make the command exit :data:`EXIT_DRAINED` (75). Chunks
still out after ``drain_s`` seconds, or a second SIGTERM, stop rank 0 at once (final write, then the
other ranks are ended), as a run stopped before draining existed did.
"""
from __future__ import annotations

import os
import signal
import time
from contextlib import contextmanager

from pycolfrag.grid.chunks import ChunkQueue, rank0_chunk_max
from pycolfrag.grid.rows import guarded_rows

__all__ = ["RANK0_WORKS_UP_TO", "EXIT_DRAINED", "DRAIN_S", "Drain", "serve", "work", "compute_alone"]

#: Rank 0 computes rows between serving the others up to this many ranks (``rank0_works="auto"``).
RANK0_WORKS_UP_TO = 16
#: Exit code of a run that stopped on SIGTERM with rows left (EX_TEMPFAIL of sysexits.h: "try again";
#: rerunning the same command resumes the file).
EXIT_DRAINED = 75
#: Seconds rank 0 waits, after a SIGTERM, for the chunks in flight (``--drain-s``).
DRAIN_S = 60.0

# tags of the rank-0 <-> worker protocol
_TAG_REQUEST = 11   # worker -> 0: "next chunk please" + rows finished since the last request + timeline
_TAG_DONE = 12      # worker -> 0: last rows and timeline; the worker stops
_TAG_WORK = 13      # 0 -> worker: a list of row indices (empty: no more work)


class Drain:
    """Rank 0's answer to SIGTERM (module docstring): the first stops the queue, a second (or
    ``drain_s`` seconds without the last chunk back) stops the run."""

    def __init__(self, queue: ChunkQueue, drain_s: float = DRAIN_S):
        self.queue, self.drain_s = queue, float(drain_s)
        self.t: float | None = None    # when the signal came (time.time())
        self.rows_left = 0
        self._said = False

    def on_sigterm(self, signum, frame) -> None:
        if self.t is None:   # only a flag and a number: safe whatever the loop is doing
            self.t = time.time()
            self.rows_left = self.queue.drain()
            return
        raise SystemExit(128 + signum)

    def check(self, log) -> None:
        """In the loop: say once that the run drains; past ``drain_s`` stop it (SystemExit 143)."""
        if self.t is None:
            return
        if not self._said:
            self._said = True
            log(f"run_grid: SIGTERM: no new chunks; collecting the chunks in flight (at most {self.drain_s:g} s); "
                f"{self.rows_left} row(s) left for the next run of the same command")
        if time.time() - self.t > self.drain_s:
            log(f"run_grid: chunks still in flight {self.drain_s:g} s after SIGTERM; stopping now (their rows "
                "are computed again by the next run)")
            raise SystemExit(128 + signal.SIGTERM)

    @contextmanager
    def installed(self):
        """SIGTERM drains while the run goes on; the handlers of SIGTERM and SIGINT in place before are
        restored after it. A handler before that says it caught a SIGTERM not yet acted on (its attribute
        ``pcf_sigterm_pending`` true: a caller running grid after grid, as the site simulation does)
        makes the run drain from its start."""
        prev = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
        try:
            signal.signal(signal.SIGTERM, self.on_sigterm)
        except ValueError:  # not the main thread
            pass
        if getattr(prev[0], "pcf_sigterm_pending", False):
            self.on_sigterm(signal.SIGTERM, None)
        try:
            yield self
        finally:
            try:
                signal.signal(signal.SIGTERM, prev[0])
                signal.signal(signal.SIGINT, prev[1])
            except ValueError:
                pass


@contextmanager
def sigterm_handler(handler):
    """SIGTERM handled by ``handler`` (a function, or ``signal.SIG_IGN``) inside the block, the handler
    before it restored after; nothing changes off the main thread (signals are the main thread's)."""
    try:
        prev = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        prev = None
    try:
        yield
    finally:
        if prev is not None:
            signal.signal(signal.SIGTERM, prev)


def _sigterm_ignored():
    """A worker leaves SIGTERM to rank 0 (which drains, and then this worker's chunk comes back)."""
    return sigterm_handler(signal.SIG_IGN)


def _compute(fn, ctx, chunk, tl, width) -> list:
    with tl.span("chunk", len(chunk), width(len(chunk)), chunk[0]):
        return guarded_rows(fn, ctx, chunk)


def compute_alone(ctx, fn, queue: ChunkQueue, chunk_max: int, intake, tl, width, drain: Drain, log) -> None:
    """One rank: chunk after chunk until the queue is empty (or drained)."""
    while True:
        drain.check(log)
        chunk = queue.take(chunk_max)
        if not chunk:
            break
        intake(_compute(fn, ctx, chunk, tl, width))
        intake.maybe_flush()


def _waiting(comm, status) -> bool:
    """Whether a request waits. Open MPI's ``Iprobe`` matches only messages an earlier MPI call moved into
    its queue of unexpected messages; finding none, it runs the progress engine (which moves what has
    arrived) and says no. A request that arrived during rank 0's own chunk is so seen by a second probe,
    not the first: with one probe it waited for another of rank 0's chunks (measured: workers waited
    34-48 % of a 2-rank session, 6 % with the second probe)."""
    from mpi4py import MPI  # here: only under MPI (importing it starts MPI)
    return (comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)
            or comm.Iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status))


def serve(comm, ctx, fn, queue: ChunkQueue, works: bool, chunk_max: int, intake, tl, width, drain: Drain,
          log) -> None:
    """Rank 0: answer requests between its own chunks until every worker has stopped."""
    from mpi4py import MPI  # here: only under MPI (importing it starts MPI)
    size = comm.Get_size()
    status = MPI.Status()
    active, sends, heard = size - 1, [], set()   # heard: workers whose first request has come
    own_max = rank0_chunk_max(chunk_max, queue.lanes)
    while active > 0 or (works and len(queue)):
        drain.check(log)
        served, t_loop = False, time.time()
        # A worker asks for work as soon as it starts, but a test of the queue (Iprobe) right after
        # start-up can miss that request: wait for each worker's first one before rank 0 takes rows
        # of its own, or the worker idles through rank 0's first batches (measured: two of them).
        while active > 0 and (len(heard) < size - 1 or _waiting(comm, status)):
            if len(heard) < size - 1:
                t = time.time()
                comm.Probe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status)
                tl.add("idle", t, time.time(), 0.0)
            t, c = time.time(), time.thread_time()
            src, tag = status.Get_source(), status.Get_tag()
            heard.add(src)
            rows, events, hello = comm.recv(source=src, tag=tag)
            if tag == _TAG_REQUEST:
                sends.append(comm.isend(queue.take(chunk_max), dest=src, tag=_TAG_WORK))
            elif tag == _TAG_DONE:
                active -= 1
            intake(rows, src, events, hello)
            tl.add("serve", t, time.time(), time.thread_time() - c, len(rows))
            served = True
        if works and len(queue):   # a short chunk: the workers' next requests wait less
            intake(_compute(fn, ctx, queue.take(own_max), tl, width))
        elif not served:
            time.sleep(0.001)  # nothing to do but wait: do not spin on a shared core
            tl.add("idle", t_loop, time.time(), 0.0)   # the probes included: they found nothing
        intake.maybe_flush()
        if len(sends) > 64:
            sends = [r for r in sends if not r.Test()]
    for r in sends:
        r.Wait()


def work(comm, ctx, fn, tl, width) -> None:
    """Ranks > 0: ask for the next chunk before computing the current one; hand in rows and the
    timeline per chunk (the first request says which host and process this rank is)."""
    with _sigterm_ignored():
        hello = {"host": tl.host, "pid": os.getpid()}
        t, c = time.time(), time.thread_time()
        pending = [comm.isend(([], tl.take(), hello), dest=0, tag=_TAG_REQUEST)]
        chunk = comm.recv(source=0, tag=_TAG_WORK)
        tl.add("wait", t, time.time(), time.thread_time() - c)
        done: list = []
        while chunk:
            pending.append(comm.isend((done, tl.take(), None), dest=0, tag=_TAG_REQUEST))  # prefetch
            done = _compute(fn, ctx, chunk, tl, width)
            t, c = time.time(), time.thread_time()
            chunk = comm.recv(source=0, tag=_TAG_WORK)
            tl.add("wait", t, time.time(), time.thread_time() - c)
            pending = [r for r in pending if not r.Test()]
        pending.append(comm.isend((done, tl.take(), None), dest=0, tag=_TAG_DONE))
        for r in pending:
            r.Wait()
