"""What the scheduler asks of a kind of grid: the members a spec, its row context and its row function
declare, so that a new kind of grid (the synthetic grid, a record suite, ...) is one class that
satisfies :class:`RunSpec` and nothing in the scheduler, the probes or the command line changes.

``tests/test_grid_protocol.py`` checks that :class:`~pycolfrag.grid.GridSpec`,
:class:`~pycolfrag.grid.RecordGridSpec` and :class:`~pycolfrag.grid.EventBatchSpec` implement every member
with the signatures below.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Protocol, Sequence, runtime_checkable

__all__ = ["RunSpec", "RowContext", "RowFunction", "as_row_function", "DEFAULT_RECORD_DT_S"]

#: The step of a synthetic record, s (a grid's `--record-dt`).
DEFAULT_RECORD_DT_S = 0.005


@runtime_checkable
class RowContext(Protocol):
    """What a rank holds to compute any row of one grid (made once per rank by :meth:`RunSpec.context`)."""

    spec: Any
    column: Any

    def locate(self, row: int) -> tuple:
        """Where a row sits in the grid: (scenario, sample, Mw, R km) or (record, component, scale)."""

    def identity(self, row: int) -> dict:
        """The fields naming a row, kept in a failed row whose row function raised."""


@dataclass(frozen=True)
class RowFunction:
    """How the rows of a grid are computed.

    ``one(ctx, row) -> dict`` computes one row; ``many(ctx, rows) -> list[dict]``, when given, computes
    a chunk of rows with their runs side by side in SIMD lanes and must return bitwise the rows of
    ``one`` (the scheduler uses it for every chunk of two rows or more). Neither raises for a failing
    sample (``status`` > 0 and ``message`` instead); an exception that escapes makes the row (or each
    row of the chunk, redone one by one) a failure of its own. ``--sample-function MODULE:NAME`` takes
    a plain function (``one``) or a ``RowFunction``.
    """

    one: Callable[[Any, int], dict]
    many: Callable[[Any, Sequence[int]], list] | None = None

    def __call__(self, ctx, row: int) -> dict:
        return self.one(ctx, row)


def as_row_function(fn) -> RowFunction:
    """``fn`` as a :class:`RowFunction`: itself, or a plain function of one row."""
    return fn if isinstance(fn, RowFunction) else RowFunction(fn)


@runtime_checkable
class RunSpec(Protocol):
    """Everything that fixes the results of a run, and what the scheduler asks of it.

    Data members: ``column`` (``Column.to_dict()``), ``solver_options`` (a resolved
    :class:`pycolfrag.SolverOptions`), ``periods_s`` (spectral periods, s), ``damping`` (spectral
    damping ratio), ``max_record_s`` (records cut to this length, s, or None), ``sample_function``
    (``module:function`` replacing the default rows, or None), ``layout`` (the results layout:
    None for the synthetic grid, ``"records"``, ``"events"``; :func:`pycolfrag.results.fields_of`),
    ``fields`` (its rows' ``/samples`` fields: the kind's declaration in :mod:`pycolfrag.layouts`),
    ``after_run`` and ``n_rows``.

    What differs between kinds is asked of the spec, never read off its layout's name: its fields, its
    probe and checks before the run (:mod:`pycolfrag.grid.probes` calls :meth:`probe`,
    :meth:`check_inputs`, :meth:`expected_work`), and what the command does after it (``after_run``).
    """

    column: dict
    solver_options: Any
    periods_s: tuple
    damping: float
    max_record_s: float | None
    sample_function: str | None
    layout: str | None
    #: What the grid command runs after the run: ``"module:function"`` with the signature of
    #: :func:`pycolfrag.cli.grid.synthetic_outputs` (the analysis sits above the driver, so the spec names
    #: it and the command imports it when it runs).
    after_run: str

    @property
    def n_rows(self) -> int:
        """Rows of the results file."""

    @property
    def fields(self) -> dict:
        """The ``/samples`` fields of its rows (:func:`pycolfrag.results.fields_of` of its layout)."""

    def probe(self) -> tuple:
        """(acceleration, dt, label, durations, option) of a representative record made with the run's
        options, checked before any file is made (:func:`pycolfrag.grid.probes.probe_rows`): ``durations``
        the (label, s) of its longest records, ``option`` the one that scales the record (named when it is
        too strong); ``(None, None, None, durations, None)`` when there is nothing to probe."""

    def check_inputs(self) -> None:
        """Refuse (ParameterError), before any file is made, inputs that would fail every row."""

    def expected_work(self, durations, timing, log) -> float:
        """The run's expected CPU seconds from its longest records' ``durations`` and the measured
        ``timing`` (:class:`pycolfrag.grid.probes.RowTiming`); refuses (ParameterError) rows the kind
        will not run, and says through ``log`` what the user should know."""

    def signature(self) -> dict:
        """What a resume must match (stored as ``grid_signature``): every input of the rows, and the code."""

    def order(self, rows: Sequence[int]) -> list:
        """The rows to compute of ``rows`` (those not done), longest expected first (a balanced end on many
        ranks). A kind that computes its rows in stages may leave some out (:class:`pycolfrag.grid.EventBatchSpec`
        computes a prefix within a run budget): they stay pending for a later run."""

    def expected_cost(self, rows: Sequence[int]) -> Any:
        """Each row's expected cost before it runs (an array of floats >= 0, any unit: only ratios
        matter): the scheduler sizes its chunks by it (:mod:`pycolfrag.grid.chunks`)."""

    def context(self) -> RowContext:
        """What a rank needs to compute any row (:class:`RowContext`)."""

    def default_function(self) -> RowFunction:
        """The rows' :class:`RowFunction` when ``sample_function`` is None."""

    def file_attrs(self) -> dict:
        """Root attributes of the results file that describe this kind of grid."""

    def shortest_record_dt(self) -> float:
        """The shortest record time step of the run, s (the solver step must not be longer)."""

    def describe(self) -> str:
        """One line saying what runs ("2 Mw x 2 R x 6 samples = 24 runs")."""

    def input_notes(self) -> list:
        """Lines to say before the run about inputs that will fail rows (e.g. unreadable records)."""
