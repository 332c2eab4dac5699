"""``pycolfrag subset``: subset simulation of a rare response within one scenario (docs/rare_events.md,
"Subset simulation", "Command line and MPI").

    pycolfrag subset --mw 6.25 --dist 10 --levels 0.35 collapse --solver monolithic=true --out p.json
    mpirun -n 4 python -m mpi4py -m pycolfrag subset --mw 6.0 --dist 10 --levels collapse --out p.json

One estimate of P(EDP >= the highest level) (``collapse``: the column collapses) under the records of
one scenario (Mw, R, a pulse shape or none, a column), the lower levels from the same runs
(:meth:`pycolfrag.rare.subset.SubsetResult.at`); the result, its CoV and interval, every level of the
algorithm and the settings are written to a JSON file. Under MPI rank 0 runs the algorithm and every
batch of runs is shared by the ranks (:class:`pycolfrag.rare.subset_mpi.MPIEvaluator`): the file's
numbers are bitwise those of one process. Every batch's rows are kept, synced, in a journal
(``<out>.journal``, or ``--journal``) before the next batch starts: a run stopped (killed, Ctrl-C, a
machine's end) is resumed by the same command, its finished batches read back instead of run (the
estimate is a pure function of the seed and the rows, so the file is bitwise an uninterrupted run's); a
journal of another estimate (the problem, the algorithm's settings, the code) is refused by name. Exit
codes: 0 done, 2 bad input (the value named; a journal of another estimate), 3 the levels stopped rising
(every run at the same score, or failed), 4 the output cannot be written, 5 the journal is held by a
running estimate.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import ParameterError, RareEventError
from pycolfrag.core.help import HelpFormatter
from pycolfrag.core.version import __version__
from pycolfrag.grid.signing import code_digest
from pycolfrag.ground_motion import registry
from pycolfrag.rare import subset as sus
from pycolfrag.rare.subset_mpi import MPIEvaluator
from pycolfrag.risk import sequences_journal as journals
from pycolfrag.risk.simulate import solver_options_of
from pycolfrag.structure.column import Column

__all__ = ["build_parser", "main", "KIND", "EXIT_OK", "EXIT_ARGS", "EXIT_STOPPED", "EXIT_OS_ERROR", "EXIT_LOCKED",
           "journal_identity", "JournaledEvaluator"]

#: ``kind`` of the output file.
KIND = "pycolfrag-subset-simulation"
EXIT_OK, EXIT_ARGS, EXIT_STOPPED, EXIT_OS_ERROR = 0, 2, 3, 4
EXIT_LOCKED = journals.EXIT_LOCKED   # the grid's code: the journal is held by a running estimate


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="pycolfrag subset", formatter_class=HelpFormatter,
        description="Subset simulation (Au & Beck 2001, aCS) of P(EDP >= level | scenario): the record-to-record "
                    "tail of one scenario, where crude sampling cannot reach. Under MPI: mpirun -n N python -m "
                    "mpi4py -m pycolfrag subset ... (the same numbers, bit for bit). docs/rare_events.md")
    s = p.add_argument_group("scenario and column")
    s.add_argument("--mw", type=float, required=True, help="moment magnitude")
    s.add_argument("--dist", type=float, required=True, metavar="KM", help="distance, km")
    s.add_argument("--pulse", default=registry.DEFAULT_PULSE_SHAPE,
                   help=f"pulse shape ({', '.join(sorted(registry.PULSE_SHAPES))}), or {registry.NO_PULSE}: the "
                        "stochastic record alone")
    s.add_argument("--vp-scale", type=float, default=1.0, help="factor on the pulse model's mean Vp")
    s.add_argument("--record-dt", type=float, default=0.005, help="time step of the records, s")
    s.add_argument("--column", default=None, metavar="FILE",
                   help="column file (.json/.toml, docs/column_format.md); default: Column.parthenon()")
    s.add_argument("--solver", action="append", default=None, metavar="KEY=VALUE",
                   help="a solver option (SolverOptions; e.g. monolithic=true), VALUE read as JSON when it parses "
                        "(repeatable)")
    lv = p.add_argument_group("levels")
    lv.add_argument("--edp", choices=("u_top", "u_d"), default="u_top", help="the response the levels are of")
    lv.add_argument("--levels", nargs="+", required=True, metavar="LEVEL",
                    help="EDP levels, > 0, or 'collapse': the highest is simulated, the others come from the same runs")
    a = p.add_argument_group("algorithm")
    a.add_argument("--n", type=int, default=sus.N_PER_LEVEL, help="runs per level (N)")
    a.add_argument("--p0", type=float, default=sus.P0, help="conditional probability of the intermediate levels")
    a.add_argument("--seed", type=int, default=1, help="the estimate is a pure function of it, 0 <= seed < 2**63")
    a.add_argument("--max-levels", type=int, default=sus.MAX_LEVELS, help="the most levels")
    a.add_argument("--confidence", type=float, default=0.90, help="of the stated log-normal interval")
    o = p.add_argument_group("output and run")
    o.add_argument("--out", required=True, metavar="FILE.json", help="the result (JSON)")
    o.add_argument("--rows", default=None, metavar="FILE.jsonl",
                   help="also every run's row (level, chain, step, score, IMs, EDPs, collapse, status), one JSON "
                        "line each, in the order run (default: not written)")
    o.add_argument("--journal", default=None, metavar="FILE",
                   help="where every finished batch's rows are kept (default: OUT.journal); the same command "
                        "resumes from it, a journal of another estimate is refused; delete it to start afresh")
    o.add_argument("--processes", type=int, default=1, help="processes on this machine (without MPI)")
    o.add_argument("--mpi", choices=("auto", "yes", "no"), default="auto",
                   help="use MPI: auto = when started by mpirun/srun or 'python -m mpi4py'")
    return p


def _level(text: str) -> float:
    if text.strip().lower() in ("collapse", "inf"):
        return math.inf
    try:
        v = float(text)
    except ValueError:
        raise ParameterError(f"--levels: {text!r} is not a number or 'collapse'") from None
    if not (v > 0 and math.isfinite(v)):
        raise ParameterError(f"--levels: {text!r} must be > 0 (or 'collapse')")
    return v



def problem_from_args(args) -> tuple[sus.SubsetProblem, list[float]]:
    """The problem (its threshold the highest level) and the levels, lowest first; ParameterError naming
    a bad value (the scenario's ranges, the pulse shape, a level, a solver option, the output path)."""
    levels = sorted(_level(t) for t in args.levels)
    if len(set(levels)) != len(levels):
        raise ParameterError(f"--levels: a level is repeated in {args.levels}")
    out = Path(args.out)
    paths = (("--out", out), ("--rows", None if args.rows is None else Path(args.rows)),
             ("--journal", Path(args.journal) if args.journal is not None else Path(args.out + ".journal")))
    for opt, path in paths:
        if path is not None and path.is_dir():
            raise ParameterError(f"{opt} {path} is a folder: give a file's path")
        if path is not None and not path.parent.is_dir():
            raise ParameterError(f"{opt} {path}: its folder {str(path.parent)!r} does not exist")
    named = [(opt, path.resolve()) for opt, path in paths if path is not None]
    for i, (opt, path) in enumerate(named):
        for other, p2 in named[:i]:
            if path == p2:
                raise ParameterError(f"{other} and {opt} are the same file {str(path)!r}: give each its own")
    if args.processes < 1:
        raise ParameterError(f"--processes must be >= 1, got {args.processes}")
    col = Column.from_file(args.column) if args.column else Column.parthenon()
    prob = sus.SubsetProblem(col, args.mw, args.dist, edp=args.edp, threshold=levels[-1], shape=args.pulse,
                             dt_s=args.record_dt, vp_scale=args.vp_scale, solver_options=solver_options_of(args.solver))
    sus._settings(args.n, args.p0, args.max_levels, args.seed, args.confidence)   # refused here, before any run
    if args.vp_scale <= 0 or not math.isfinite(args.vp_scale):
        raise ParameterError(f"--vp-scale must be > 0, got {args.vp_scale}")
    return prob, levels


def _plain(x):
    """JSON without Infinity/NaN: non-finite floats as strings."""
    if isinstance(x, float) and not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    return x


def result_document(res: sus.SubsetResult, levels, problem, command: str, runs_by_rank: list, wall_s: float) -> dict:
    """The output file's content: the estimate at every level asked, the algorithm's levels, the settings,
    and the runs each rank computed."""
    at = []
    for t in levels:
        p, cov = (res.probability, res.cov) if t == levels[-1] else res.at(t)
        at.append({"level": "collapse" if t == math.inf else t, "probability": p, "cov": cov,
                   "interval": list(sus.lognormal_interval(p, cov, res.confidence))})
    algo = [{"index": lv.index, "condition": lv.threshold, "next_threshold": lv.next_threshold, "p_next": lv.p_next,
             "gamma": lv.gamma, "cov": lv.cov, "acceptance": lv.acceptance, "scale": lv.scale, "runs": lv.runs}
            for lv in res.levels]
    settings = {k: v for k, v in res.settings.items() if k != "problem"}
    return _plain({"kind": KIND, "version": 1, "pycolfrag": __version__, "command": command,
                   "problem": problem.describe(), "edp": problem.edp, "levels": at,
                   "probability": res.probability, "cov": res.cov, "cov_uncorrelated": res.cov_uncorrelated,
                   "cov_bound": res.cov_bound, "interval": list(res.interval), "confidence": res.confidence,
                   "runs": res.runs, "failed": res.failed, "converged": res.converged, "subset_levels": algo,
                   "settings": settings, "summary": res.summary(), "ranks": len(runs_by_rank),
                   "runs_by_rank": list(runs_by_rank), "wall_s": round(wall_s, 3)})


def _write(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _row(r: dict) -> dict:
    return _plain({k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in r.items()})


def journal_identity(prob: sus.SubsetProblem, args) -> dict:
    """What a journal's runs are of: the problem (column, scenario, EDP, its highest level, solver options),
    the settings the runs depend on (seed, N, p0, the most levels), and the code (the grid's digest of the
    package's sources, the C library and the solver options). The lower levels and the confidence are
    read off the runs afterwards: changing them resumes."""
    return json.loads(report_json.dumps({
        "problem": prob.describe(), "seed": args.seed, "n": args.n, "p0": args.p0, "max_levels": args.max_levels,
        "version": __version__, "code_digest": code_digest(prob.solver_options)}))


def _batch_key(batch) -> str:
    """A batch's runs as one digest: each run's identity (level, chain, step) and its normals' bits."""
    h = hashlib.sha256()
    for inp in batch:
        h.update(f"{inp['level']},{inp['chain']},{inp['step']};".encode())
        h.update(inp["normals"].astype("<f8").tobytes())
    return h.hexdigest()


class JournaledEvaluator:
    """``evaluate(batch) -> rows`` that keeps every batch: the k-th batch the journal holds is read back (its
    runs' key checked: a journal whose batches are other runs is refused), the next ones run by ``evaluate``
    and appended, synced, before they are returned. Either way the rows are the journal's JSON (floats
    round-trip exactly, NaN included), so a resumed estimate is bitwise an uninterrupted one."""

    def __init__(self, evaluate, entries: list, journal, path):
        self.evaluate, self.entries, self.journal, self.path = evaluate, entries, journal, path
        self.batches = 0
        self.read_back = 0      # runs read from the journal instead of run

    def __call__(self, batch):
        key, k = _batch_key(batch), self.batches
        if k < len(self.entries):
            entry = self.entries[k]
            if entry.get("key") != key or len(entry.get("rows", ())) != len(batch):
                raise ParameterError(f"{self.path}: its batch {k} holds other runs than this estimate's: delete it "
                                     "or give another --journal")
            rows = entry["rows"]
            self.read_back += len(rows)
        else:
            rows = json.loads(json.dumps([{k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in r.items()}
                                          for r in self.evaluate(batch)]))
            self.journal.add({"batch": k, "key": key, "rows": rows})
        self.batches += 1
        return rows


def _run_root(args, prob, levels, ev, ranks: int, argv) -> int:
    jpath = Path(args.journal) if args.journal is not None else Path(args.out + ".journal")
    lock, entries, journal, error = journals.open_journal(jpath, journal_identity(prob, args), _log, name="subset",
                                                          remedy="delete it or give another --journal")
    if error is not None:
        print(f"pycolfrag subset: {error[1]}", file=sys.stderr)
        return error[0]
    if entries:
        print(f"pycolfrag subset: resuming from {jpath}: {len(entries)} batches done", file=sys.stderr, flush=True)
    try:
        return _estimate(args, prob, levels, JournaledEvaluator(ev, entries, journal, jpath), ranks, argv)
    finally:
        journal.close()
        lock.release()


def _log(msg: str) -> None:
    """The journal's and its lock's messages (each names what it is of), on stderr."""
    print(msg, file=sys.stderr, flush=True)


def _estimate(args, prob, levels, ev, ranks: int, argv) -> int:
    def progress(lv):
        print(f"level {lv.index}: {lv.runs} runs, next threshold {lv.next_threshold:.4g}, fraction {lv.p_next:.3g}"
              + (f", acceptance {lv.acceptance:.2f}" if lv.index else ""), file=sys.stderr, flush=True)

    t0 = time.time()
    try:
        res = sus.subset_simulation(prob, ev, seed=args.seed, n=args.n, p0=args.p0, max_levels=args.max_levels,
                                    confidence=args.confidence, progress=progress)
    except RareEventError as exc:
        print(f"pycolfrag subset: {exc}", file=sys.stderr)
        return EXIT_STOPPED
    except ParameterError as exc:     # a journal whose batches are another estimate's
        print(f"pycolfrag subset: error: {exc}", file=sys.stderr)
        return EXIT_ARGS
    command = " ".join(["pycolfrag subset", *argv])
    try:
        if args.rows is not None:
            _write(Path(args.rows), "".join(json.dumps(_row(r)) + "\n" for r in res.rows))
        by_rank = ev.evaluate.runs_by_rank if isinstance(ev.evaluate, MPIEvaluator) else [res.runs - ev.read_back]
        doc = result_document(res, levels, prob, command, by_rank, time.time() - t0)
        doc["runs_read_back"] = ev.read_back
        _write(Path(args.out), report_json.dumps(doc, indent=1) + "\n")
    except OSError as exc:
        print(f"pycolfrag subset: cannot write {args.out}: {exc}", file=sys.stderr)
        return EXIT_OS_ERROR
    print(res.summary())
    if not res.converged:
        print(f"pycolfrag subset: not converged in {args.max_levels} levels (raise --max-levels)", file=sys.stderr)
    return EXIT_OK


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    try:
        prob, levels = problem_from_args(args)
    except (ParameterError, OSError) as exc:       # OSError: a column file missing or unreadable
        print(f"pycolfrag subset: error: {exc}", file=sys.stderr)
        return EXIT_ARGS
    from pycolfrag.grid import get_comm  # here: MPI starts only when asked for
    comm = get_comm(args.mpi)
    ranks = comm.Get_size() if comm is not None else 1
    if ranks > 1 and args.processes > 1:
        print("pycolfrag subset: error: --processes and MPI ranks: give one", file=sys.stderr)
        return EXIT_ARGS
    ev = MPIEvaluator(comm) if ranks > 1 else sus.PoolEvaluator(args.processes) if args.processes > 1 else None
    if isinstance(ev, MPIEvaluator) and not ev.is_root:
        ev.serve()
        return EXIT_OK
    try:
        return _run_root(args, prob, levels, ev if ev is not None else sus.run_batch, ranks, argv)
    finally:
        if ev is not None:
            ev.close()


if __name__ == "__main__":
    sys.exit(main())
