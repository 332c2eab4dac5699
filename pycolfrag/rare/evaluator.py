"""Running batches of runs with explicit inputs through the grid's scheduler: the interface an algorithm
above the grid -- the stratified site simulation here -- asks for its runs through (subset simulation
does not: its runs take the record's noise as explicit normals, which the event rows do not carry; it
shares its batches over MPI ranks through :mod:`pycolfrag.rare.subset_mpi`).

    ev = GridEvaluator(outdir, record_settings, comm)
    if not ev.is_root:
        ev.serve()                 # ranks > 0: compute what rank 0 asks for, until it closes
    else:
        rows = ev.evaluate("batch_000", inputs, purpose)   # every rank computes, rank 0 gets the rows
        ...
        ev.close()

``evaluate(name, inputs, purpose, limit=None)`` is one batch: the inputs of every run (the
:class:`pycolfrag.grid.EventBatchSpec`'s: Mw, R, noise seed, pulse parameters, tags) and what the
algorithm declares about them. Before anything runs, rank 0 writes them to ``<name>.plan.json`` beside
the results file ``<name>.h5`` (atomically, with their SHA-256; the batch file's signature holds the
same digest), so a batch's plan is on disk before its first run, and a resume reads it back instead of
asking the algorithm again. The batch then runs through :func:`pycolfrag.grid.run_grid` on every rank
-- the grid's scheduler, journal, lock, checksums and code signature -- and rank 0 gets its rows back
as columns (every row of the batch, those not computed yet with status -1). A finished batch is read,
not reopened: its stored signature is compared with the one asked for (other code is refused unless
allowed, as the grid refuses it; any other difference -- another site, other settings -- is refused).

**SIGTERM** (a job's time limit; docs/rare_events.md): inside a batch the grid's scheduler drains it
(the runs in flight come back, the batch file is written, :mod:`pycolfrag.grid.serve`); between batches
rank 0 only notes it (:meth:`GridEvaluator.sigterm_stops`). Either way ``evaluate`` then raises
:class:`BatchStopped` -- it never returns a batch with runs missing below its limit, so no algorithm
plans from a part of a batch -- and the next ``evaluate`` after a drain that left no run raises it before
its batch starts. The other ranks ignore SIGTERM while they serve: rank 0 decides.
"""
from __future__ import annotations

import hashlib
import json
import os
import signal
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ResultsFileError, StaleBuildError
from pycolfrag.grid import EventBatchSpec, run_grid
from pycolfrag.grid.serve import sigterm_handler as _sigterm_handler
from pycolfrag.grid.signing import CODE_KEYS
from pycolfrag.grid.spec import RunSettings, resolve_solver_options
from pycolfrag.ground_motion.registry import DEFAULT_PULSE_SHAPE, vp_model_key

__all__ = ["RecordSettings", "PLAN_KIND", "plan_path", "write_plan", "read_plan", "read_columns", "GridEvaluator",
           "BatchStopped"]

#: ``kind`` of a plan file.
PLAN_KIND = "pycolfrag-event-plan"


@dataclass(frozen=True)
class RecordSettings(RunSettings):
    """How every run of a batch is computed besides its inputs: column, solver, records, IMs
    (:class:`~pycolfrag.grid.spec.RunSettings`: ``tp_model`` and ``vp_model`` the pulse-period and pulse-amplitude
    relations of :class:`~pycolfrag.rare.plans.PulseMap`), and the pulse shape of the rows with a pulse."""

    pulse_shape: str = DEFAULT_PULSE_SHAPE

    def __post_init__(self):
        object.__setattr__(self, "solver_options", resolve_solver_options(self.solver_options))
        object.__setattr__(self, "vp_model", vp_model_key(self.vp_model))   # refused by name before any run

    def spec(self, inputs, purpose, limit=None) -> EventBatchSpec:
        return EventBatchSpec(inputs=tuple(inputs), purpose=purpose, limit=limit, pulse_shape=self.pulse_shape,
                              **self.run_settings())


class BatchStopped(Exception):
    """A SIGTERM stopped the simulation at batch ``name`` with ``runs_left`` of its runs (up to its limit)
    not computed: in the batch (``began``: it drained) or before it began (all of them); every finished
    run is in the batch files, and rerunning the same command resumes."""

    def __init__(self, name: str, runs_left: int, began: bool):
        self.name, self.runs_left, self.began = name, int(runs_left), began
        where = (f"{name} drained with {self.runs_left} run(s) left" if began else
                 f"stopped before {name} (its plan is on disk, {self.runs_left} run(s))")
        super().__init__(f"SIGTERM: {where}")


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def plan_path(outdir, name: str) -> Path:
    return Path(outdir) / f"{name}.plan.json"


def write_plan(path: Path, purpose: dict, inputs) -> None:
    """Write a batch's plan atomically (a temporary file, fsync, rename, fsync of the folder)."""
    body = {"purpose": purpose, "inputs": list(inputs)}
    text = _canonical({"kind": PLAN_KIND, "version": 1, "sha256": hashlib.sha256(_canonical(body).encode()).hexdigest(),
                       **body})
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def read_plan(path: Path):
    """(purpose, inputs) of a plan file, None when there is none; ResultsFileError when it is damaged."""
    if not path.exists():
        return None
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
        body = {"purpose": d["purpose"], "inputs": d["inputs"]}
        ok = d.get("kind") == PLAN_KIND and d["sha256"] == hashlib.sha256(_canonical(body).encode()).hexdigest()
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ResultsFileError(f"{path}: the plan of a batch cannot be read ({type(exc).__name__}: {exc})") from None
    if not ok:
        raise ResultsFileError(f"{path}: the plan of a batch fails its checksum (changed after it was written); its "
                               "batch cannot be resumed: move the folder's files away, or start in another folder")
    return body["purpose"], body["inputs"]


def read_columns(path: Path):
    """(columns of every row, root attributes, whether a journal is there) of a batch file: the HDF5
    file checked against its checksums, with its journal's rows laid over it when the journal is its own."""
    raw = _results.read_h5_bounded(path)
    jp = _results.journal_path(path)
    header, jrows = None, {}
    if jp.exists():
        try:
            header, jrows = _results.read_journal(jp)
        except _results.JournalHeaderError:
            header, jrows = None, {}
        if header is not None and _results.journal_mismatch(header, raw["attrs"]):
            header, jrows = None, {}
    samples, _, _, attrs = _results.merged_columns(raw, header, jrows)
    return samples, attrs, jp.exists()


def _refuse_stored(path: Path, stored: dict, asked: dict, allow_code_change: bool) -> None:
    diffs = _results.signature_mismatch(stored, asked)
    code = [d for d in diffs if d.split(":", 1)[0] in CODE_KEYS]
    other = [d for d in diffs if d not in code]
    if other:
        raise ResultsFileError(
            f"{path} holds a batch of another simulation; it cannot be resumed with these inputs:\n  - "
            + "\n  - ".join(other) + "\nRerun with the site file and settings it began with, or use another folder.")
    if code and not allow_code_change:
        raise ResultsFileError(
            f"{path} holds a batch computed by another build of pycolfrag (the code changed since it began):\n  - "
            + "\n  - ".join(code) + "\nResuming would mix runs of two versions in one estimate. Rerun with "
            "--allow-code-change to go on anyway (each batch file records its code), or use another folder.")


class GridEvaluator:
    """Batches of explicit inputs through :func:`pycolfrag.grid.run_grid` (module docstring).

    ``run_options``: keywords of :func:`~pycolfrag.grid.run_grid` (``progress``, ``chunk_max``,
    ``flush_s``, ``rank0_works``, ``log``, ``command``); ``allow_code_change`` applies to every batch.
    """

    def __init__(self, outdir, record: RecordSettings, comm=None, *, allow_code_change: bool = False, **run_options):
        self.outdir, self.record, self.comm = Path(outdir), record, comm
        self.allow_code_change = allow_code_change
        self.run_options = run_options
        self.rank = comm.Get_rank() if comm is not None else 0
        self.size = comm.Get_size() if comm is not None else 1
        self.stop_asked = False     # rank 0: a SIGTERM came (the next batch is not begun)

    @property
    def is_root(self) -> bool:
        return self.rank == 0

    def path(self, name: str) -> Path:
        return self.outdir / f"{name}.h5"

    def stored(self, name: str):
        """(purpose, inputs) of a batch planned before (rank 0), or None."""
        return read_plan(plan_path(self.outdir, name))

    def evaluate(self, name: str, inputs, purpose: dict, limit: int | None = None) -> dict:
        """Rank 0: compute (or resume, or read) batch ``name``; returns its rows as columns."""
        purpose = json.loads(_canonical(purpose))
        spec = self.record.spec(inputs, purpose, limit)   # checks the inputs before anything is written
        inputs = [dict(x) for x in spec.inputs]
        pp = plan_path(self.outdir, name)
        old = read_plan(pp)
        if old is None:
            self.outdir.mkdir(parents=True, exist_ok=True)
            write_plan(pp, purpose, inputs)
        elif _canonical(old[0]) != _canonical(purpose) or _canonical(old[1]) != _canonical(inputs):
            raise ResultsFileError(f"{pp}: batch {name!r} was planned with other inputs or purpose; a batch's plan "
                                   "cannot change once written (use another name or folder)")
        done = self._finished(name, spec)
        if done is not None:
            return done
        stop = spec.n_rows if spec.limit is None else min(spec.limit, spec.n_rows)
        if self.stop_asked:
            raise BatchStopped(name, stop, began=False)
        summary = self._command({"op": "run", "name": name, "inputs": inputs, "purpose": purpose, "limit": limit})
        self.stop_asked = self.stop_asked or bool(getattr(summary, "drained", False))
        cols = read_columns(self.path(name))[0]
        left = int(np.sum(np.asarray(cols["status"])[:stop] == _results.STATUS_PENDING))
        if left:   # drained (or stopped in any other way): a part of a batch is never handed on as the batch
            raise BatchStopped(name, left, began=True)
        return cols

    def _finished(self, name: str, spec: EventBatchSpec):
        """The columns of a batch that needs no run (its file whole, no journal, every row up to the limit
        done), after its stored signature is checked; None when it must run (or be resumed)."""
        path = self.path(name)
        if not path.exists() or _results.journal_path(path).exists():
            return None
        try:
            cols, attrs, _ = read_columns(path)
        except (ResultsFileError, OSError):
            return None          # damaged: the run path rebuilds it from its journal, or refuses with a hint
        stop = spec.n_rows if spec.limit is None else min(spec.limit, spec.n_rows)
        if np.any(np.asarray(cols["status"])[:stop] == _results.STATUS_PENDING):
            return None
        _refuse_stored(path, json.loads(attrs["grid_signature"]), spec.signature(), self.allow_code_change)
        return cols

    def _command(self, msg: dict):
        if self.size > 1:
            self.comm.bcast(msg, root=0)
        return self._run(msg)

    def _run(self, msg: dict):
        spec = self.record.spec(msg["inputs"], msg["purpose"], msg["limit"])
        return run_grid(spec, self.path(msg["name"]), comm=self.comm, allow_code_change=self.allow_code_change,
                        **self.run_options)

    @contextmanager
    def sigterm_stops(self):
        """Rank 0, around a whole simulation: a SIGTERM between batches sets :attr:`stop_asked` (the
        grid's drain replaces this handler while a batch runs); the handler before is restored after."""
        def note(signum, frame):
            self.stop_asked = note.pcf_sigterm_pending = True   # pending: a batch starting now drains at once

        note.pcf_sigterm_pending = False      # type: ignore[attr-defined]
        with _sigterm_handler(note):
            yield self

    def serve(self) -> None:
        """Ranks > 0: compute every batch rank 0 asks for, until it closes; SIGTERM is ignored (rank 0
        drains the batch and then says stop)."""
        with _sigterm_handler(signal.SIG_IGN):
            while True:
                msg = self.comm.bcast(None, root=0)
                if msg["op"] == "stop":
                    return
                try:
                    self._run(msg)
                except StaleBuildError:
                    # refused on every rank before any row (rank 0 read the sources): rank 0 says why, then
                    # stops us
                    continue

    def close(self) -> None:
        """Rank 0: the other ranks stop serving."""
        if self.size > 1 and self.is_root:
            self.comm.bcast({"op": "stop"}, root=0)
