"""The replay's engine (:mod:`pycolfrag.grid.replay`): processor sharing of a job's cores among its
ranks, messages, and the ranks as generators that follow :mod:`pycolfrag.grid.serve` step by step.

A rank's generator yields the actions that take time:

* ``("cpu", s)`` -- s seconds of CPU work, shared with the other runnable ranks (:class:`Sim`);
* ``("wall", s)`` -- s seconds that use no CPU (a sleep, the disk, the file's child);
* ``("send", dest, tag, data)`` -- an ``isend``: arrives after the machine's latency;
* ``("recv", src, tag)`` -- a blocking receive (the rank polls: weight ``Machine.spin``); the value sent
  back is ``(src, tag, data)``;
* ``("probe", twice)`` -- Open MPI's ``Iprobe`` (see :func:`pycolfrag.grid.serve._waiting`): true only
  for a message an earlier MPI call moved into the queue of unexpected messages, else it moves what
  has arrived and says false; ``twice``: a second probe right after;
* ``("now",)`` -- the time; ``("mark", name, ...)`` -- a mark in the rank's record.
"""
from __future__ import annotations

import heapq
from collections import OrderedDict

from pycolfrag.grid.chunks import rank0_chunk_max

__all__ = ["Sim", "run_ranks", "batch_width_rule"]

_TAG_REQUEST, _TAG_DONE, _TAG_WORK, _TAG_SIG, _TAG_GO = 11, 12, 13, 21, 22
_ANY = -1


def batch_width_rule(n: int, lanes: int) -> int:
    """The batch width the C library takes for ``n`` runs on a CPU of ``lanes`` lanes
    (``cf_solver_batch_width``: 8 from 5 runs on, 4 from 3 on, else one run after the other;
    ``tests/test_scheduling.py`` holds it to :func:`pycolfrag.solver.run.batch_width`)."""
    if lanes >= 8 and n >= 5:
        return 8
    if lanes >= 4 and n >= 3:
        return 4
    return 1


class _Proc:
    __slots__ = ("rank", "gen", "state", "want", "result", "t_end", "marks")

    def __init__(self, rank):
        self.rank, self.gen, self.state, self.want, self.result, self.t_end = rank, None, "ready", None, None, None
        self.marks: list = []


class Sim:
    """Uniform processor sharing: every rank in a CPU action runs at ``min(1, cores / n)``, ``n`` the
    ranks in CPU actions plus ``spin`` times the ranks polling in blocking receives. The service a CPU
    rank has received is the shared virtual clock ``V`` (dV = rate dt)."""

    def __init__(self, machine):
        self.m = machine
        self.t = self.V = 0.0
        self.procs: list[_Proc] = []
        self.cpu_heap, self.wall_heap, self.msg_heap = [], [], []
        self.mail, self.unexpected = {}, {}   # arrived / moved into the queue of unexpected messages
        self.seq = self.n_cpu = self.n_spin = 0

    def add(self, gen_fn, rank: int) -> None:
        p = _Proc(rank)
        p.gen = gen_fn(p)
        self.procs.append(p)
        self.mail[rank], self.unexpected[rank] = [], []

    def _rate(self) -> float:
        n = self.n_cpu + self.m.spin * self.n_spin
        return 1.0 if n <= 0 else min(1.0, self.m.cores / n)

    def _push(self, heap, key, *item) -> None:
        self.seq += 1
        heapq.heappush(heap, (key, self.seq, *item))

    def _step(self, p: _Proc, value=None) -> None:
        """Run ``p`` until it blocks on an action that takes time."""
        while True:
            try:
                act = p.gen.send(value)
            except StopIteration:
                p.state, p.t_end = "done", self.t
                return
            value, kind = None, act[0]
            if kind == "cpu" and act[1] > 0:
                p.state = "cpu"
                self.n_cpu += 1
                self._push(self.cpu_heap, self.V + float(act[1]), p.rank)
                return
            if kind == "wall" and act[1] > 0:
                p.state = "wall"
                self._push(self.wall_heap, self.t + float(act[1]), p.rank)
                return
            if kind == "send":
                self._push(self.msg_heap, self.t + self.m.latency, act[1], p.rank, act[2], act[3])
            elif kind == "probe":
                value = bool(self.unexpected[p.rank])
                if not value:
                    self._progress(p.rank)
                    if act[1]:
                        value = bool(self.unexpected[p.rank])
            elif kind == "now":
                value = self.t
            elif kind == "mark":
                p.marks.append((self.t, *act[1:]))
            elif kind == "recv":
                got = self._take(p.rank, act[1], act[2])
                if got is not None:
                    value = got
                    continue
                p.state, p.want = "recv", (act[1], act[2])
                self.n_spin += 1
                return

    def _progress(self, rank: int) -> None:
        self.unexpected[rank].extend(self.mail[rank])
        self.mail[rank].clear()

    def _take(self, rank: int, src: int, tag: int):
        self._progress(rank)   # a blocking receive polls until its message is there
        box = self.unexpected[rank]
        for i, (s, tg, data) in enumerate(box):
            if (src == _ANY or s == src) and (tag == _ANY or tg == tag):
                box.pop(i)
                return s, tg, data
        return None

    def run(self, t_limit: float = 1e7) -> "Sim":
        for p in self.procs:
            self._step(p)
        while self.cpu_heap or self.wall_heap or self.msg_heap:
            r = self._rate()
            cands = [h[0][0] for h in (self.wall_heap, self.msg_heap) if h]
            if self.cpu_heap:
                cands.append(self.t + (self.cpu_heap[0][0] - self.V) / r)
            t_next = max(self.t, min(cands))
            if t_next > t_limit:
                raise RuntimeError("the replay did not end (a rank waits for a message nobody sends)")
            if self.n_cpu:
                self.V += (t_next - self.t) * r
            self.t, woken = t_next, []
            while self.cpu_heap and self.cpu_heap[0][0] <= self.V + 1e-12:
                woken.append(heapq.heappop(self.cpu_heap)[2])
                self.n_cpu -= 1
            while self.wall_heap and self.wall_heap[0][0] <= self.t + 1e-12:
                woken.append(heapq.heappop(self.wall_heap)[2])
            while self.msg_heap and self.msg_heap[0][0] <= self.t + 1e-12:
                _, _, dest, src, tag, data = heapq.heappop(self.msg_heap)
                self.mail[dest].append((src, tag, data))
                q = self.procs[dest]
                if q.state == "recv":
                    got = self._take(dest, *q.want)
                    if got is not None:
                        q.state, q.result = "ready", got
                        self.n_spin -= 1
                        woken.append(dest)
            for rk in woken:
                p = self.procs[rk]
                value, p.result = p.result, None
                p.state = "ready"
                self._step(p, value)
        return self


class _Ranks:
    """The ranks of one replayed run as generators (:class:`Sim`): rank 0 (:meth:`rank0`) and the workers
    (:meth:`worker`), step for step :mod:`pycolfrag.grid.serve`."""

    def __init__(self, rows, size, policy, costs, machine, queue, chunk_cost):
        self.rows, self.size, self.policy, self.costs, self.machine = rows, size, policy, costs, machine
        self.queue, self.chunk_cost = queue, chunk_cost
        self.works = size == 1 or size <= policy.rank0_works_up_to
        self.chunks, self.marks = [], {}
        self.last_flush, self.created = 0.0, None

    def start_up(self, p):
        c = self.costs
        yield ("cpu", c.interp + c.imports)
        if self.size > 1:
            yield ("cpu", c.mpi_init)
            yield ("wall", c.mpi_init_wall)
        yield ("cpu", c.checks)
        yield ("mark", "session")      # run_grid's clock starts (its "computed in")
        yield ("cpu", c.identity)

    def compute(self, p, idx, cache):
        cost = self.chunk_cost(idx, cache)
        self.chunks.append((p.rank, len(idx), cost))
        yield ("mark", "chunk", len(idx))
        yield ("cpu", cost)
        yield ("mark", "chunk_end")

    def worker(self, p):
        yield from self.start_up(p)
        yield ("send", 0, _TAG_SIG, None)
        yield ("recv", 0, _TAG_GO)                  # rank 0 has opened the file
        cache = OrderedDict()
        yield ("send", 0, _TAG_REQUEST, 0)
        _, _, chunk = yield ("recv", 0, _TAG_WORK)
        done = 0
        while chunk:
            yield ("send", 0, _TAG_REQUEST, done)   # prefetch, with the last chunk's rows
            yield from self.compute(p, chunk, cache)
            done = len(chunk)
            _, _, chunk = yield ("recv", 0, _TAG_WORK)
        yield ("send", 0, _TAG_DONE, done)
        yield ("recv", 0, _TAG_GO)                  # MPI_Finalize waits for rank 0
        yield ("cpu", self.costs.exit_s)

    def rank0(self, p):
        c = self.costs
        yield from self.start_up(p)
        for _ in range(self.size - 1):
            yield ("recv", _ANY, _TAG_SIG)
        yield ("cpu", c.open_cpu)
        yield ("wall", c.open_wall)
        create = c.create_fixed + c.create_per_row * self.rows.n
        t = yield ("now",)
        self.created = t + create if self.policy.open_overlap else None
        if self.created is None:
            yield ("cpu", create)   # rank 0 waits for the child writing the new file
        self.marks["open"] = self.last_flush = yield ("now",)
        for r in range(1, self.size):
            yield ("send", r, _TAG_GO, None)
        yield from (self.alone if self.size == 1 else self.serving)(p)
        t = yield ("now",)
        if self.created is not None and t < self.created:
            yield ("wall", self.created - t)
        yield ("cpu", c.finish_cpu)
        yield ("wall", c.finish_wall)
        self.marks["end"] = yield ("now",)
        for r in range(1, self.size):
            yield ("send", r, _TAG_GO, None)
        yield ("cpu", c.summary + c.exit_s)

    def accept(self, n_rows):
        """Rows journalled; an HDF5 write every flush_s (not before the file exists)."""
        c = self.costs
        if n_rows:
            yield ("cpu", c.journal_per_row * n_rows)
        now = yield ("now",)
        if n_rows and now - self.last_flush >= self.policy.flush_s and (self.created is None or now >= self.created):
            yield ("cpu", c.flush_cpu)
            yield ("wall", c.flush_wall)
            self.last_flush = yield ("now",)

    def alone(self, p):
        cache = OrderedDict()
        while True:
            idx = self.queue.take(self.policy.chunk_max)
            if not idx:
                return
            yield from self.compute(p, idx, cache)
            yield from self.accept(len(idx))

    def serving(self, p):
        cache, active, heard = OrderedDict(), self.size - 1, set()
        own_max = rank0_chunk_max(self.policy.chunk_max, self.queue.lanes)
        while active > 0 or (self.works and len(self.queue)):
            served = False
            while active > 0:
                if len(heard) < self.size - 1:
                    msg = yield ("recv", _ANY, _ANY)    # the blocking Probe, then its receive
                else:
                    if not (yield ("probe", self.policy.probe_twice)):
                        break
                    msg = yield ("recv", _ANY, _ANY)
                src, tag, n_rows = msg
                heard.add(src)
                yield ("cpu", self.costs.msg_s)
                if tag == _TAG_REQUEST:
                    yield ("send", src, _TAG_WORK, self.queue.take(self.policy.chunk_max))
                elif tag == _TAG_DONE:
                    active -= 1
                yield from self.accept(n_rows)
                served = True
            if self.works and len(self.queue):
                idx = self.queue.take(own_max)
                yield from self.compute(p, idx, cache)
                yield from self.accept(len(idx))
            elif not served:
                yield ("wall", 0.001 + self.machine.sleep_extra)


def run_ranks(rows, size: int, policy, costs, machine, queue, chunk_cost, keep: bool = False) -> dict:
    """Replay one run: rank 0 and ``size - 1`` workers (:mod:`pycolfrag.grid.serve`), the chunks cut by
    ``queue`` (the scheduler's :class:`~pycolfrag.grid.chunks.ChunkQueue`) and costed by
    ``chunk_cost(rows, lhs_cache)``. See :func:`pycolfrag.grid.replay.simulate`."""
    ranks = _Ranks(rows, size, policy, costs, machine, queue, chunk_cost)
    sim = Sim(machine)
    sim.add(ranks.rank0, 0)
    for r in range(1, size):
        sim.add(ranks.worker, r)
    sim.run()
    t_job = max(p.t_end for p in sim.procs)
    session0 = next(m[0] for m in sim.procs[0].marks if m[1] == "session")
    marks, chunks = ranks.marks, ranks.chunks
    out = {"size": size, "rows": rows.n, "policy": policy.name, "t_job": t_job, "t_final": marks["end"],
           "t_session": marks["end"] - session0, "t_startup": session0, "n_chunks": len(chunks),
           "chunk_cpu": float(sum(c for _, _, c in chunks)),
           "small_chunks": sum(1 for _, n, _ in chunks if batch_width_rule(n, costs.lanes) < costs.lanes)}
    if keep:
        out["procs"] = [{"rank": p.rank, "marks": p.marks, "t_end": p.t_end} for p in sim.procs]
        out["marks"] = marks
    return out
