"""The Monte Carlo grid driver behind ``pycolfrag grid`` and ``scripts/run_grid.py`` (docs/grid.md).

For every scenario (Mw, R) of the grid and every sample ``k`` of that scenario:

1. pulse parameters = row ``k`` of the scenario's Latin hypercube
   (:func:`pycolfrag.ground_motion.sample_pulse_parameters`, seeded from (seed, Mw, R) only);
2. record = :func:`pycolfrag.ground_motion.synthesize` with those pulse parameters and a
   high-frequency noise seed derived from (seed, Mw, R, k) through :class:`numpy.random.SeedSequence`;
3. intensity measures (:func:`pycolfrag.ground_motion.intensity.measures`);
4. response of the column (:func:`pycolfrag.simulate`): EDPs, collapse, timing.

Nothing random depends on the rank or the order of work, so 1 rank and N ranks write identical
datasets (except ``wall_s`` and the ``n_ranks`` attribute). The scenario enters the streams by its
(Mw, R) values (in thousandths), not its index, so a sub-grid reproduces the full grid's records.
Record suites (``--records SOURCE``, :class:`RecordGridSpec`) run the rows of
:func:`pycolfrag.solver.sample.record_jobs` (record x component x scale) under the same scheduler, journal,
lock, resume and refusals. What a row holds is defined once, in :mod:`pycolfrag.solver.sample`.

The package, by the sections a reader looks for:

* :mod:`~pycolfrag.grid.protocol` -- what a kind of grid declares (:class:`RunSpec`, its row context
  and :class:`RowFunction`);
* :mod:`~pycolfrag.grid.spec` -- the two kinds, :class:`GridSpec` and :class:`RecordGridSpec`;
* :mod:`~pycolfrag.grid.events` -- a third kind, :class:`EventBatchSpec`: events with explicit inputs, the
  runs an algorithm above the grid asks for (the stratified site simulation of :mod:`pycolfrag.rare`);
* :mod:`~pycolfrag.grid.rows` -- seeds, row contexts and the row functions;
* :mod:`~pycolfrag.grid.signing` -- the code that computes the rows, signed into every run;
* :mod:`~pycolfrag.grid.probes` -- checks before a run;
* :mod:`~pycolfrag.grid.schedule` -- a run on every rank and rank 0's writes (:func:`run_grid`);
* :mod:`~pycolfrag.grid.serve` -- the ranks while rows are computed: rank 0 serving, the workers, the
  drain on SIGTERM;
* :mod:`~pycolfrag.grid.chunks` -- the queue of rows and the chunk rule (by expected cost, in whole lanes);
* :mod:`~pycolfrag.grid.timeline` -- every rank's timeline, stored in the results file;
* :mod:`~pycolfrag.grid.replay` -- the replay model: the scheduling policy simulated at N ranks;
* :mod:`~pycolfrag.grid.command` -- the command line's options and run (:func:`run_command`; what
  follows a run is :mod:`pycolfrag.cli.grid`'s).
"""
from __future__ import annotations

from pycolfrag.core.errors import ParameterError  # noqa: F401 (the driver's refusals; callers catch it as grid.ParameterError)
from pycolfrag.grid.command import (
    EXIT_ARGS,
    EXIT_DRAINED,
    EXIT_LOCKED,
    EXIT_OK,
    EXIT_OS_ERROR,
    EXIT_OUTPUTS,
    HelpFormatter,
    build_parser,
    run_command,
    spec_from_args,
)
from pycolfrag.grid.events import EVENT_ROWS, EventBatchSpec, EventContext, run_event, run_events
from pycolfrag.grid.probes import (
    MAX_CHECK_STEPS,
    MAX_ROW_STEPS,
    SAY_WORK_ABOVE_S,
    check_models,
    check_solver_options,
    check_space,
    check_work,
    probe_rows,
)
from pycolfrag.grid.protocol import RowContext, RowFunction, RunSpec
from pycolfrag.grid.rows import (
    RECORD_ROWS,
    SYNTHETIC_ROWS,
    RecordContext,
    SampleContext,
    derive_seed,
    run_record_row,
    run_record_rows,
    run_sample,
    run_samples,
)
from pycolfrag.grid.schedule import RunSummary, get_comm, run_grid
from pycolfrag.grid.signing import build_identity, code_digest
from pycolfrag.grid.spec import (
    DEFAULT_DAMPING,
    DEFAULT_DIST_KM,
    DEFAULT_MW,
    DEFAULT_PERIODS_S,
    DEFAULT_PULSE,
    DEFAULT_RECORD_DT_S,
    DEFAULT_SAMPLES,
    DEFAULT_SEED,
    MAX_ROWS,
    MAX_SAMPLES,
    PULSES,
    SEED_MAX,
    GridSpec,
    RecordGridSpec,
    resolve_solver_options,
    solver_defaults,
)

__all__ = [
    "DEFAULT_MW", "DEFAULT_DIST_KM", "DEFAULT_SAMPLES", "DEFAULT_SEED", "DEFAULT_PERIODS_S", "DEFAULT_DAMPING",
    "DEFAULT_RECORD_DT_S", "PULSES", "DEFAULT_PULSE", "SEED_MAX", "MAX_ROWS", "MAX_SAMPLES",
    "RunSpec", "RowContext", "RowFunction", "GridSpec", "RecordGridSpec", "EventBatchSpec", "EventContext",
    "run_event", "run_events", "EVENT_ROWS", "resolve_solver_options",
    "solver_defaults", "SampleContext", "RecordContext", "run_sample", "run_samples", "run_record_row",
    "run_record_rows", "SYNTHETIC_ROWS", "RECORD_ROWS", "derive_seed", "build_identity", "code_digest",
    "MAX_CHECK_STEPS", "MAX_ROW_STEPS", "SAY_WORK_ABOVE_S", "check_solver_options", "probe_rows", "check_work",
    "check_space", "check_models", "get_comm", "run_grid", "RunSummary", "EXIT_OK", "EXIT_ARGS", "EXIT_OUTPUTS",
    "EXIT_OS_ERROR", "EXIT_LOCKED", "EXIT_DRAINED", "HelpFormatter", "build_parser", "spec_from_args", "run_command",
]

#: The kinds of grid this package runs: a results file's ``layout`` attribute names one of them
#: (:func:`spec_kind`), which says what is done with the file (its ``after_run``).
SPEC_KINDS = (GridSpec, RecordGridSpec, EventBatchSpec)


def spec_kind(layout):
    """The spec class of :data:`SPEC_KINDS` whose files carry the root attribute ``layout`` (None, or its
    name; ``"synthetic"`` and bytes read as the results registry reads them), or ParameterError."""
    from pycolfrag import results as _results
    name = _results.layout.kind_of(layout).name
    for cls in SPEC_KINDS:
        if cls.layout == name:
            return cls
    raise ParameterError(f"no kind of grid writes results layout {layout!r}")


__all__ += ["SPEC_KINDS", "spec_kind"]
