"""A rank's timeline while a grid runs: intervals of what it did (start-up phases, waiting, each chunk,
rank 0's serving and writes; the kinds are :data:`pycolfrag.results.timeline.KINDS`).

Every rank records its own intervals in memory (about 3 us each, a few per chunk); a worker hands
them to rank 0 on the requests it sends anyway, and rank 0 writes them into the results file with
the rows (``/timeline``). Times are ``time.time()`` on the rank's clock, moved onto rank 0's: ranks on
rank 0's host share its clock; a rank on another host takes the offset it measures when rank 0
releases the ranks (all of them wait for that message, so the error is the message's latency).
"""
from __future__ import annotations

import math
import os
import socket
import time
from contextlib import contextmanager

from pycolfrag.core.version import IMPORT_STARTED

__all__ = ["Recorder", "process_started", "MERGE_GAP_S"]

#: Serve and idle intervals of rank 0 closer than this (s) are one interval: rank 0 answers a request
#: in a fraction of a millisecond, and a row per answer would be most of the timeline.
MERGE_GAP_S = 2e-3
_MERGED = ("serve", "idle")


def process_started() -> float | None:
    """When this process was started (its exec by the launcher), s since the epoch: ``/proc/self/stat``
    field 22 (clock ticks since boot) on Linux; None elsewhere."""
    try:
        with open("/proc/self/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        boot = time.time() - time.clock_gettime(time.CLOCK_BOOTTIME)
        return boot + int(fields[19]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


class Recorder:
    """One rank's intervals (kind, t0, t1, thread CPU s, rows, batch width, first row), in order.

    Made when the command starts (:meth:`start_up` adds the launch and the imports before it, from the
    process's start and the time ``pycolfrag`` began to load)."""

    def __init__(self):
        self.events: list[tuple] = []
        self.offset = 0.0           # add to this rank's clock to get rank 0's
        self.host = socket.gethostname()

    def start_up(self) -> "Recorder":
        """Add ``launch`` (process start to the package's first line, with the process's CPU time until
        then) and ``imports`` (from there to now)."""
        t_now, c_now = time.time(), time.process_time()
        t_imp, c_imp = IMPORT_STARTED
        t_proc = process_started()
        if t_proc is not None and t_proc <= t_imp:
            self.add("launch", t_proc, t_imp, c_imp)
        self.add("imports", t_imp, t_now, c_now - c_imp)
        return self

    def add(self, kind: str, t0: float, t1: float, cpu: float = math.nan, n_rows: int = 0, width: int = 0,
            first_row: int = -1) -> None:
        """An interval (times on this rank's clock). Serve and idle intervals that follow one of their
        kind within :data:`MERGE_GAP_S` extend it (their rows and CPU added)."""
        if kind in _MERGED and self.events:
            k, a, b, c, n, w, f = self.events[-1]
            if k == kind and t0 - b <= MERGE_GAP_S:
                self.events[-1] = (k, a, t1, c + cpu, n + n_rows, w, f)
                return
        self.events.append((kind, t0, t1, cpu, n_rows, width, first_row))

    @contextmanager
    def span(self, kind: str, n_rows: int = 0, width: int = 0, first_row: int = -1):
        """An interval around a block: its wall time and this thread's CPU time."""
        t0, c0 = time.time(), time.thread_time()
        try:
            yield
        finally:
            self.add(kind, t0, time.time(), time.thread_time() - c0, n_rows, width, first_row)

    def take(self) -> list[tuple]:
        """The intervals recorded since the last take, on rank 0's clock; they are forgotten here."""
        out, self.events = self.events, []
        if self.offset:
            out = [(k, a + self.offset, b + self.offset, c, n, w, f) for k, a, b, c, n, w, f in out]
        return out

    def set_clock(self, rank0_time: float, rank0_host: str, received: float) -> None:
        """Rank 0's clock from its release message (sent at ``rank0_time``, received at ``received`` on
        this clock): the same clock on rank 0's host, else the offset between them."""
        self.offset = 0.0 if rank0_host == self.host else rank0_time - received
