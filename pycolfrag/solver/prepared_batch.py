"""A structure's C solver set up once, for many batches of runs (the grid's chunks: docs/architecture.md,
"A row of the synthetic grid").

:func:`pycolfrag.solver.run.simulate_batch` sets the structure up in C for each call (the options'
``to_c``, the scene set-up of the column, its joints); a grid calls it once per chunk with the same
column and options. :class:`PreparedBatch` does that set-up once and runs batch after batch on it: each
run is bitwise the ``simulate_batch`` run of its record (a run starts from the set-up state: the batch
already refills a lane from it for each record), each Response the same but for its ``options``, the
options' dict made once and copied.
"""
from __future__ import annotations

from pycolfrag.core.ffi import lib
from pycolfrag.solver import run as _run
from pycolfrag.solver.options import SolverOptions

__all__ = ["PreparedBatch"]


class PreparedBatch:
    """The C solver of ``col`` set up with ``options`` (a :class:`SolverOptions`), for :meth:`run`.

    Made as ``simulate_batch(col, ..., options=options)`` sets it up, with its checks, messages and
    warnings (a StepWarning of an explicit ``dt_solver`` above the stability limit is given here, once).
    One batch at a time (a grid's rank runs its chunks one after the other): its runs share the C solver.
    """

    def __init__(self, col, options: SolverOptions):
        self.column = col
        self.solver, self.options, self.parts = _run._setup(col, options, {}, "simulate_batch")
        self.widest = int(lib.cf_solver_batch_max_width(self.solver))
        self._options_dict = self.options.to_dict()

    def run(self, records) -> list:
        """The runs of ``records`` (Records: their arrays as they are, checked when made; the solver's
        range of accelerations checked per run) side by side, without history: a Response or the
        exception of each, in order, as ``simulate_batch(col, records, options=options, errors="return")``
        gives them."""
        out: list = [None] * len(records)
        jobs = []
        for i, rec in enumerate(records):
            try:
                jobs.append((i, _run._Job(self.solver, self.column, self.options, _run._batch_entry(i, rec), False,
                                          "simulate_batch", self.parts)))
            except Exception as exc:   # a bad record is that run's error, as simulate would raise it
                out[i] = exc
        if jobs and self.parts is not None and self.widest == 1:   # no lanes: one run after the other
            _run._run_one_by_one(self.solver, self._options_dict, jobs, out)
        elif jobs:
            _run._run_batch(self.solver, self._options_dict, 0, jobs, out)
        return out
