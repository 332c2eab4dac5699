"""Subset simulation's runs over the ranks of an MPI job (docs/rare_events.md, "Subset simulation",
"Command line and MPI").

    ev = MPIEvaluator(comm)
    if not ev.is_root:
        ev.serve()                                   # ranks > 0: compute what rank 0 sends, until it closes
    else:
        try:
            res = subset_simulation(problem, ev, seed=1)
        finally:
            ev.close()

Rank 0 runs the algorithm; each batch it asks for (level 0's N runs, then one step of every chain: N
p0 runs) is cut into one contiguous part per rank, scattered, computed by
:func:`pycolfrag.rare.subset.run_batch` on every rank (rank 0 its own part too) and gathered in rank
order. A run's inputs are explicit (its normals travel with it) and its row depends only on them, so
the rows, and the whole estimate, are bitwise those of a serial run whatever the number of ranks. This
is not :class:`pycolfrag.rare.evaluator.GridEvaluator`: the grid's event rows take a record's noise as
a seed, and a chain's state is a vector of normals that no seed gives. A rank whose part raises sends
the error back instead of rows, and rank 0 raises it (no rank is left waiting).
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from pycolfrag.core.errors import RareEventError
from pycolfrag.rare.subset import run_batch

__all__ = ["MPIEvaluator"]

_ERROR = "__subset_mpi_error__"


def _compute(worker, part) -> list:
    try:
        return worker(part)
    except Exception as exc:  # sent back to rank 0, which raises it: no rank left waiting
        return [{_ERROR: f"{type(exc).__name__}: {exc}"}]


class MPIEvaluator:
    """``evaluate(batch) -> rows`` over the ranks of ``comm`` (module docstring); ``worker`` computes a
    part (:func:`~pycolfrag.rare.subset.run_batch`; tests pass their own). ``comm`` None: serial."""

    def __init__(self, comm, worker: Callable[[Sequence[dict]], list] = run_batch):
        self.comm, self.worker = comm, worker
        self.rank = comm.Get_rank() if comm is not None else 0
        self.size = comm.Get_size() if comm is not None else 1
        self.batches = 0
        self.runs_by_rank = [0] * self.size      # rank 0: the runs each rank computed

    @property
    def is_root(self) -> bool:
        return self.rank == 0

    def __call__(self, batch: Sequence[dict]) -> list[dict]:
        """Rank 0: the rows of ``batch``, in order."""
        self.batches += 1
        if self.size == 1:
            self.runs_by_rank[0] += len(batch)
            return self.worker(list(batch))
        parts = [[batch[i] for i in p] for p in np.array_split(np.arange(len(batch)), self.size)]
        for rank, part in enumerate(parts):
            self.runs_by_rank[rank] += len(part)
        mine = self.comm.scatter(parts, root=0)
        done = self.comm.gather(_compute(self.worker, mine), root=0)
        rows = []
        for rank, part in enumerate(done):
            if part and _ERROR in part[0]:
                raise RareEventError(f"rank {rank} failed on its part of batch {self.batches}: {part[0][_ERROR]}")
            rows.extend(part)
        return rows

    def serve(self) -> None:
        """Ranks > 0: compute the part of every batch rank 0 scatters, until :meth:`close`."""
        while True:
            part = self.comm.scatter(None, root=0)
            if part is None:
                return
            self.comm.gather(_compute(self.worker, part), root=0)

    def close(self) -> None:
        """Rank 0: the other ranks stop serving."""
        if self.size > 1 and self.is_root:
            self.comm.scatter([None] * self.size, root=0)
