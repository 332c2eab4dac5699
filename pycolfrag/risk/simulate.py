"""The command line of the site simulation (``pycolfrag risk SITE.toml --simulate OUTDIR``): its options
(:func:`add_arguments`), the settings they make, and the run on every rank (:func:`run_simulation`: the
evaluator, the simulation on rank 0, the exit code of a failure). What follows a run -- the report beside
the grid route -- is :mod:`pycolfrag.risk.rare_route`'s, so this module imports nothing of the analysis.

Under MPI (``mpirun -n N python -m mpi4py -m pycolfrag risk ... --simulate OUT``) rank 0 runs the
simulation and the other ranks compute the batches it asks for (:class:`~pycolfrag.rare.evaluator.GridEvaluator`).
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
from dataclasses import replace
from pathlib import Path

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError, PycolfragError, ResultsFileError
from pycolfrag.grid import get_comm
from pycolfrag.grid.command import EXIT_ARGS, EXIT_LOCKED, EXIT_OK, EXIT_OS_ERROR  # the grid's codes
from pycolfrag.grid.probes import check_record_dt, check_solver_options
from pycolfrag.grid.serve import EXIT_DRAINED
from pycolfrag.grid.spec import DEFAULT_RECORD_DT_S
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, DEFAULT_VP_MODEL, TP_MODELS, VP_MODELS
from pycolfrag.rare.driver import DEFAULT_SEED, SiteSettings, StopRule, failures, simulate_site
from pycolfrag.rare.estimate import UNRESOLVED, WeightError
from pycolfrag.rare.evaluator import BatchStopped, GridEvaluator, RecordSettings
from pycolfrag.rare.paired import sigterm_stops_all, simulate_paired
from pycolfrag.rare.strata import DEFAULT_MW_STEP, DEFAULT_R_EDGES_KM
from pycolfrag.results import lock as _lock
from pycolfrag.site.models import PulseOnly, Table
from pycolfrag.site.sources import OUTSIDE_CHOICES, load_site, read_pulse_model
from pycolfrag.structure.column import Column

__all__ = ["EXIT_OK", "EXIT_ARGS", "EXIT_OS_ERROR", "EXIT_LOCKED", "EXIT_NOT_CONVERGED", "EXIT_UNRESOLVED",
           "EXIT_DRAINED", "add_arguments", "settings_from_args", "run_simulation", "run_paired", "paired_exit_code",
           "solver_options_of"]

#: Exit codes: those of the grid (0 ok, 2 bad arguments or a folder of another simulation, 4 an
#: operating-system error, 5 a batch file written by another run, 75 stopped by SIGTERM: the batch
#: drained, rerun the same command), 6: the run budget was spent before every requested level
#: converged (the report is written, those levels marked), and 7: failed runs leave a requested level
#: unresolved (they could move it by more than its CoV; the report is written, those levels marked;
#: :mod:`pycolfrag.rare.estimate`).
EXIT_NOT_CONVERGED, EXIT_UNRESOLVED = 6, 7


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The simulation's options (the report's are the caller's)."""
    s = p.add_argument_group("event-based simulation (--simulate; docs/rare_events.md)")
    s.add_argument("--simulate", metavar="OUTDIR", required=True,
                   help="simulate the site's events into OUTDIR (batch files, then risk.md, risk.json, figures); "
                        "rerunning the same command resumes")
    s.add_argument("--target-cov", type=float, default=0.2, help="stop when every requested level's CoV is at most this")
    s.add_argument("--max-runs", type=int, default=20000, help="run budget (the pilot at least)")
    s.add_argument("--seed", type=int, default=DEFAULT_SEED, help="root seed of every run's stream")
    s.add_argument("--batch", type=int, default=2000, help="runs per production batch")
    s.add_argument("--pilot", type=int, default=None,
                   help="pilot runs per stratum (default: sized per site, 5 or more where the strata are few)")
    s.add_argument("--defensive", type=float, default=0.3,
                   help="alpha_0, the nominal share of the pulse quantiles' mixture (weights are at most 1/alpha_0)")
    s.add_argument("--levels", nargs="+", default=[], metavar="LABEL",
                   help="the levels the stopping rule serves, by label (default: every Table III/IV level and collapse)")
    s.add_argument("--mw-step", type=float, default=DEFAULT_MW_STEP, help="width of the strata's magnitude bins")
    s.add_argument("--r-edges", type=float, nargs="+", default=list(DEFAULT_R_EDGES_KM), metavar="KM",
                   help="the strata's distance bin edges, km")
    s.add_argument("--column", default=None, metavar="FILE", help="column file (default: Column.parthenon())")
    s.add_argument("--solver", action="append", default=[], metavar="KEY=VALUE", help="any simulate() keyword")
    s.add_argument("--record-dt", type=float, default=DEFAULT_RECORD_DT_S, help="time step of the records, s")
    s.add_argument("--max-record-s", type=float, default=None,
                   help="cut every record to this many seconds (tests and quick looks: changes the results)")
    s.add_argument("--vp-scale", type=float, default=1.0, help="scale of the pulse amplitude's mean")
    s.add_argument("--tp-model", default=DEFAULT_TP_MODEL, choices=sorted(TP_MODELS), help="pulse-period relation")
    s.add_argument("--vp-model", default="", choices=sorted(VP_MODELS),
                   help=f"pulse-amplitude relation of the median Vp (default: {DEFAULT_VP_MODEL}, the paper's Eq. (6))")
    s.add_argument("--mpi", choices=("auto", "yes", "no"), default="auto", help="use MPI (auto: under mpirun)")
    s.add_argument("--allow-code-change", action="store_true",
                   help="resume a folder whose batches were computed by other code (each batch file records its code)")
    s.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="progress bar of each batch")
    s.add_argument("--chunk-max", type=int, default=32, help="largest chunk of runs handed to a rank")


def solver_options_of(items) -> dict:
    """``--solver KEY=VALUE`` items as simulate keywords (a value read as JSON where it parses, else the text)."""
    opts: dict = {}
    for kv in items or ():
        k, sep, v = kv.partition("=")
        if not sep or not k.strip():
            raise ParameterError(f"--solver expects KEY=VALUE, got {kv!r}")
        try:
            opts[k.strip().replace("-", "_")] = json.loads(v.strip())
        except ValueError:
            opts[k.strip().replace("-", "_")] = v.strip()
    return opts


def site_of(args):
    """The site file with the command line's overrides (``--pulse-model``, ``--pulse-only``, ``--outside``)."""
    site = load_site(args.site)
    if getattr(args, "pulse_model", None):
        import tomllib  # here: only this override reads an inline table
        try:
            table = tomllib.loads(f"pulse = {args.pulse_model}")["pulse"]
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(f"--pulse-model must be a TOML inline table, got {args.pulse_model!r} ({exc})") from None
        model = read_pulse_model(Table(table, "--pulse-model", "pulse"))
        site = replace(site, sources=tuple(s.with_pulse(model) for s in site.sources))
    if getattr(args, "pulse_only", False):
        site = replace(site, sources=tuple(s.with_pulse(PulseOnly()) for s in site.sources))
    if getattr(args, "outside", None):
        if args.outside not in OUTSIDE_CHOICES:
            raise ParameterError(f"--outside must be one of {OUTSIDE_CHOICES}, got {args.outside!r}")
        site = replace(site, outside=args.outside)
    return site


def settings_from_args(args):
    """(site, SiteSettings, StopRule, RecordSettings) of parsed arguments; ParameterError naming a bad value."""
    if not str(args.simulate):
        raise ParameterError(f"--simulate {args.simulate!r} is an empty path (it would write into the current "
                             "directory): give the folder for the batches and the report")
    site = site_of(args)
    settings = SiteSettings(seed=args.seed, pilot_per_stratum=args.pilot, batch=args.batch, defensive=args.defensive,
                            mw_step=args.mw_step, r_edges_km=tuple(args.r_edges), levels=tuple(args.levels))
    stop = StopRule(target_cov=args.target_cov, max_runs=args.max_runs)
    col = Column.from_file(args.column) if args.column else Column.parthenon()
    record = RecordSettings(column=col.to_dict(), solver_options=solver_options_of(args.solver), vp_scale=args.vp_scale,
                            record_dt_s=args.record_dt, max_record_s=args.max_record_s, tp_model=args.tp_model,
                            vp_model=args.vp_model)
    if args.chunk_max < 1:
        raise ParameterError(f"--chunk-max must be >= 1, got {args.chunk_max}")
    check_record_dt(record.record_dt_s)            # the grid's check: every record would fail
    check_solver_options(col, record.solver_options, record.record_dt_s)
    if Path(args.simulate).exists() and not Path(args.simulate).is_dir():
        raise ParameterError(f"--simulate {args.simulate} is a file: give a folder")
    return site, settings, stop, record


def abort_on_interrupt(exc, comm, size: int, log, what: str, folder) -> None:
    """A run interrupted during its batches under MPI (``exc.pcf_during_run``) aborts every rank with its exit
    code, said in the log (every finished run is on disk); the caller re-raises otherwise."""
    if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
        code = exc.code if isinstance(exc, SystemExit) and isinstance(exc.code, int) else 128 + signal.SIGINT
        log(f"{what}: interrupted (exit {code}); every finished run is in {folder}")
        comm.Abort(code)


def _failed(exc, comm, size: int, log) -> int:
    """The exit code of a failure on rank 0, said in one line; the other ranks, if they are inside a
    batch (the failure came in the middle of one), are ended."""
    text = str(exc)
    if isinstance(exc, _results.ResultsLockedError):
        code = EXIT_LOCKED
        # the lock's advice names the grid's --out, which risk lacks: its files live in the --simulate folder
        text = text.replace(_lock.OTHER_FILE, "give --simulate another folder")
    elif isinstance(exc, (ResultsFileError, ParameterError, WeightError)):
        code = EXIT_ARGS
    else:
        code = EXIT_OS_ERROR
    log(f"risk --simulate: {text}")
    if comm is not None and size > 1 and getattr(exc, "pcf_during_run", False):
        comm.Abort(code)
    return code


def run_simulation(args, quantities, argv=None, before=None):
    """Run (or resume) the simulation of parsed arguments on every rank: ``(exit code, SiteRun or None)``;
    the run is given on rank 0 only, when the simulation ended (at its target or its budget).

    ``before(site, settings, record)``: a check of the caller's before any run (the grid's files beside the
    simulation), run by rank 0 alone (:func:`_on_rank0`); a :class:`~pycolfrag.core.errors.PycolfragError` or
    OSError it raises is a refusal on every rank (exit 2)."""
    comm = get_comm(args.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    try:
        site, settings, stop, record = settings_from_args(args)
        if before is not None:
            _on_rank0(before, comm, site, settings, record)
    except (PycolfragError, OSError) as exc:
        log(f"risk --simulate: {exc}")
        return EXIT_ARGS, None
    ev = GridEvaluator(args.simulate, record, comm, allow_code_change=args.allow_code_change, progress=args.progress,
                       chunk_max=args.chunk_max, log=log,
                       command=" ".join([sys.argv[0]] + list(sys.argv[1:] if argv is None else argv)))
    if not ev.is_root:
        ev.serve()
        return EXIT_OK, None
    try:
        with ev.sigterm_stops():
            run = simulate_site(site, settings, stop, ev, quantities, log=log)
    except BatchStopped as exc:      # SIGTERM: the batch drained (or the next one was not begun)
        log(f"risk --simulate: {exc}; every finished run is in {args.simulate}, no estimate or report is made from "
            f"a part of a batch: rerun the same command to compute the rest (exit {EXIT_DRAINED})")
        ev.close()
        return EXIT_DRAINED, None
    except (ResultsFileError, ParameterError, WeightError, OSError) as exc:
        code = _failed(exc, comm, size, log)
        ev.close()
        return code, None
    except (SystemExit, KeyboardInterrupt) as exc:
        abort_on_interrupt(exc, comm, size, log, "risk --simulate", args.simulate)
        raise
    ev.close()
    return _exit_code(run, log), run


def run_paired(p: dict, evs, quantities, comm, size: int, log, what: str, folder, names, share=None):
    """The paired simulation of several run settings on rank 0 (``p``: its ``site``, ``settings``, ``stop``;
    ``evs`` the settings' evaluators), with the signals and failures every run has: ``(None, runs)``, or
    ``(exit code, None)`` when SIGTERM drained a batch (75), a run failed (:func:`_failed`), or an interrupt
    aborts every rank (:func:`abort_on_interrupt`, re-raised). ``share``: where the runs go
    (:func:`pycolfrag.rare.paired.simulate_paired`; None: every setting every batch)."""
    try:
        with sigterm_stops_all(evs):
            runs = simulate_paired(p["site"], p["settings"], p["stop"], evs, quantities, log=log, names=names,
                                   share=share)
    except BatchStopped as exc:
        log(f"{what}: {exc}; every finished run is in {folder}, no estimate or report is made from a part of a batch: "
            f"rerun the same command to compute the rest (exit {EXIT_DRAINED})")
        evs[0].close()
        return EXIT_DRAINED, None
    except (ResultsFileError, ParameterError, WeightError, OSError) as exc:
        code = _failed(exc, comm, size, log)
        evs[0].close()
        return code, None
    except (SystemExit, KeyboardInterrupt) as exc:
        abort_on_interrupt(exc, comm, size, log, what, folder)
        raise
    evs[0].close()
    return None, runs


def _on_rank0(check, comm, *args) -> None:
    """``check(*args)`` on rank 0 alone (the grid route beside a simulation reads and computes two site risks:
    once, not once a rank), its refusal then raised on every rank, so that no rank waits for batches that
    will never come."""
    if comm is None or comm.Get_size() == 1:
        check(*args)
        return
    error = None
    if comm.Get_rank() == 0:
        try:
            check(*args)
        except (PycolfragError, OSError) as exc:
            error = exc
    refused = comm.bcast(None if error is None else str(error), root=0)
    if error is not None:
        raise error
    if refused is not None:
        raise ParameterError(refused)


def paired_exit_code(runs, names, log) -> int:
    """The exit code of several runs on the same events (the tree's run settings, the restoration's
    alternatives): 7 when one is unresolved, else 6 when one did not converge, else 0; each run's say logged
    under its name."""
    codes = [_exit_code(r, lambda s, n=n: log(f"[{n}] {s}")) for r, n in zip(runs, names)]
    return next((c for c in (EXIT_UNRESOLVED, EXIT_NOT_CONVERGED) if c in codes), EXIT_OK)


def _exit_code(run, log) -> int:
    """0 when every requested level converged; 7 (said with the failures) when failed runs leave one
    unresolved; 6 when the budget ran out first."""
    levels = [run.estimate.levels[q.label] for q in run.requested]
    unresolved = [e.label for e in levels if e.status == UNRESOLVED]
    if unresolved:
        failed, done, text = failures(run.cols)
        log(f"risk --simulate: {failed} of {done} runs failed (most common: {text}); level(s) {', '.join(unresolved)} "
            "unresolved: counting the failed runs as exceedances or as none moves them by more than their CoV, and more "
            "runs do not shrink what the failed runs hide. Make the runs succeed (the column, --solver, --vp-scale, "
            "--record-dt) and rerun in another folder; risk.md lists the failures by stratum.")
        return EXIT_UNRESOLVED
    return EXIT_OK if all(e.status == "converged" for e in levels) else EXIT_NOT_CONVERGED
