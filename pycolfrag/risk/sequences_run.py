"""Sequences at a site as a command: ``pycolfrag sequences SITE.toml OUTDIR`` (docs/sequences.md, "Running it").

The sequences of :mod:`pycolfrag.risk.sequences` are independent of one another (each draws from its own
streams), so they spread over MPI ranks by their index (rank ``r`` of ``N`` runs sequences ``s`` with
``s % N == r``) and a run's result cannot depend on the number of ranks. Every finished sequence is a
line of ``OUTDIR/sequences.jsonl`` (the journal), written by rank 0 alone (the other ranks send theirs
to it) and flushed to disk at once, so a run stopped at any moment -- SIGTERM, ``kill -9``, a lost
node -- loses at most the sequences being run; the same command then runs only what the journal lacks.

The journal's first line is its **identity**: the site file's bytes (SHA-256), the structure's table,
every setting but the number of sequences (years, seed, restoration, settling, records, solver options),
the package version and the grid's code digest (Python sources, C library, solver options). A journal of another identity is refused (exit
2, naming what differs), so a resumed run never keeps a sequence another run computed; a larger ``--n``
resumes and adds sequences (sequence ``s`` is the same whatever the count), a smaller one reads the
first ``n``. A torn last line (a write cut by ``kill -9``) is dropped and said; any other damage is
refused. Two runs on one folder at once: the second is refused (the grid's run lock, exit 5).

Exit codes: 0 (every sequence done: ``summary.json``, ``summary.md`` written), 2 (bad arguments, a
journal of another run), 4 (an operating-system error), 5 (the folder is locked by a running run),
75 (stopped by SIGTERM after the running sequences finished: rerun the same command).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import signal
import sys
import time
from pathlib import Path

from pycolfrag.core import report_json
from pycolfrag.core.errors import ParameterError, PycolfragError
from pycolfrag.core.help import HelpFormatter
from pycolfrag.grid import get_comm
from pycolfrag.grid.serve import EXIT_DRAINED
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk.aftershocks import AFTERSHOCK_MODELS, DEFAULT_AFTERSHOCK_MODEL, aftershock_model
from pycolfrag.risk.sequences import (
    DEFAULT_SEED,
    SequenceOutcome,
    SequenceSettings,
    SiteEvent,
    format_summary,
    run_one,
    sequence_events,
    summarize,
)
from pycolfrag.risk.sequences_journal import (
    EXIT_ARGS,
    EXIT_LOCKED,
    EXIT_OK,
    EXIT_OS_ERROR,
    abort_others,
    identity,
    open_journal,
    read_lines,
)
from pycolfrag.site.sources import load_site
from pycolfrag.solver.sequence import Restoration
from pycolfrag.structure.column import Column
from pycolfrag.structure.kinds import scene_from_file

__all__ = ["JOURNAL", "EXIT_OK", "EXIT_ARGS", "EXIT_OS_ERROR", "EXIT_LOCKED", "EXIT_DRAINED", "identity",
           "outcome_to_dict", "outcome_from_dict", "read_journal", "run_folder", "rare_settings", "parse_args", "main"]

#: The journal's name in the output folder.
JOURNAL = "sequences.jsonl"
_TAG_DONE, _TAG_OUTCOME, _TAG_STOP = 11, 12, 13


def outcome_to_dict(o: SequenceOutcome, seconds: float) -> dict:
    """A sequence's line of the journal (``seconds``: its wall time)."""
    d = dataclasses.asdict(o)
    d["seconds"] = seconds
    return d


def outcome_from_dict(d: dict) -> tuple[SequenceOutcome, float]:
    """The inverse of :func:`outcome_to_dict` (JSON keeps every float's bits, NaN and inf included)."""
    d = dict(d)
    seconds = float(d.pop("seconds"))
    d["events"] = [SiteEvent(**e) for e in d["events"]]
    return SequenceOutcome(**d), seconds


def read_journal(path: Path, ident: dict, log) -> dict:
    """The finished sequences of a journal (index -> (outcome, seconds)); see :func:`read_lines`."""
    done = {}
    for i, d in enumerate(read_lines(path, ident, log), start=2):
        try:
            o, sec = outcome_from_dict(d)
        except (KeyError, TypeError) as exc:
            raise ParameterError(f"{path}, line {i}: damaged ({exc}): give another folder") from None
        done[o.sequence] = (o, sec)
    return done


class _Stop:
    """SIGTERM asks for a stop after the running sequence (the handler only sets a flag)."""

    def __init__(self):
        self.asked = False
        self._old = signal.signal(signal.SIGTERM, self._handle)

    def _handle(self, signum, frame):
        self.asked = True

    def restore(self) -> None:
        signal.signal(signal.SIGTERM, self._old)


def _work(site, model, st: SequenceSettings, todo: list, stop: _Stop, deliver) -> None:
    """Run the sequences ``todo`` in order, handing each to ``deliver(outcome, seconds)``, until done or a
    stop is asked."""
    strata = build_strata(site)   # the site simulation's check: refuses sources outside the models but 'zero'
    pulse_map = PulseMap(st.pulse_shape, st.vp_scale, st.tp_model)
    for s in todo:
        if stop.asked:
            return
        t0 = time.perf_counter()
        evs = sequence_events(site, st.years, st.seed, s, pulse_map, strata.ranges, aftershocks=st.aftershocks)
        try:
            o = run_one(model, s, evs, st)
        except Exception as exc:
            exc.add_note(f"in sequence {s} (seed {st.seed}) of {len(evs)} event(s)")
            raise
        deliver(o, time.perf_counter() - t0)


def run_folder(site_path, model, st: SequenceSettings, folder, comm=None, log=print, progress=None):
    """Run (or resume) ``st.n_sequences`` sequences of the site file ``site_path`` on ``model`` into
    ``folder`` on every rank of ``comm`` (None: this process). Returns ``(exit code, run)``: ``run`` (the
    dict :func:`pycolfrag.risk.sequences.summarize` reads; its ``wall_s`` the sum of the sequences' own
    times) on rank 0 when every sequence is done, else None."""
    rank, size = (comm.Get_rank(), comm.Get_size()) if comm is not None else (0, 1)
    folder = Path(folder)
    site = load_site(site_path)
    ident = identity(site_path, model, st)
    lock = journal = error = None
    done: dict = {}
    if rank == 0:
        lock, done, journal, error = open_journal(folder / JOURNAL, ident, log, read=read_journal)
        done = done or {}
    if comm is not None:
        error, finished = comm.bcast((error, sorted(done)), root=0)
    else:
        finished = sorted(done)
    if error is not None:
        log(f"sequences: {error[1]}")
        return error[0], None
    have = set(finished)
    todo = [s for s in range(st.n_sequences) if s not in have and s % size == rank]
    n_done = len([s for s in finished if s < st.n_sequences])
    stop = _Stop()
    try:
        if rank == 0:
            n_done = _run_rank0(site, model, st, todo, stop, journal, done, comm, size, n_done, progress)
        else:
            def send(o, sec):
                comm.send((o, sec), dest=0, tag=_TAG_OUTCOME)
                if comm.iprobe(source=0, tag=_TAG_STOP):   # rank 0 was stopped: stop here too
                    stop.asked = True
            _work(site, model, st, todo, stop, send)
            comm.send(None, dest=0, tag=_TAG_DONE)
    except BaseException as exc:
        abort_others(exc, comm, log)
        raise
    finally:
        stop.restore()
        if journal is not None:
            journal.close()
    if lock is None:   # the other ranks: rank 0's exit code
        return comm.bcast(None, root=0), None
    lock.release()
    code = EXIT_DRAINED if n_done < st.n_sequences else EXIT_OK
    if comm is not None:
        comm.bcast(code, root=0)
    if code == EXIT_DRAINED:
        log(f"sequences: stopped after {n_done} of {st.n_sequences} sequences; every finished one is in "
            f"{folder / JOURNAL}: rerun the same command to run the rest (exit {EXIT_DRAINED})")
        return EXIT_DRAINED, None
    outs = [done[s] for s in range(st.n_sequences)]
    return EXIT_OK, {"settings": st, "outcomes": [o for o, _ in outs], "wall_s": float(sum(sec for _, sec in outs)),
                     "total_rate": float(sum(src.rate for src in site.sources)),
                     "outside_share": {o.source: o.outside for o in build_strata(site).outside}}


def _run_rank0(site, model, st, todo, stop, journal, done, comm, size, n_done, progress) -> int:
    """Rank 0's part: its own sequences, and the other ranks' as they come (written as they arrive); returns
    how many of the first ``st.n_sequences`` are done."""
    count, waiting = [n_done], [size - 1]

    def keep(o, sec):
        journal.add(outcome_to_dict(o, sec))
        done[o.sequence] = (o, sec)
        count[0] += 1
        if progress is not None:
            progress(count[0], st.n_sequences)

    def receive() -> None:
        status = _status()
        msg = comm.recv(source=_mpi().ANY_SOURCE, tag=_mpi().ANY_TAG, status=status)
        if status.Get_tag() == _TAG_DONE:
            waiting[0] -= 1
        else:
            keep(*msg)

    def own(o, sec):
        keep(o, sec)
        while comm is not None and comm.iprobe(source=_mpi().ANY_SOURCE, tag=_TAG_OUTCOME):
            receive()
    _work(site, model, st, todo, stop, own)
    if stop.asked and comm is not None:   # a stop seen here alone: the others stop after their running sequence
        for r in range(1, size):
            comm.send(None, dest=r, tag=_TAG_STOP)
    while waiting[0] > 0:
        receive()
    return count[0]


def _mpi():
    from mpi4py import MPI  # only under MPI (a comm was given)
    return MPI


def _status():
    return _mpi().Status()


#: The options of ``--rare`` that are :class:`pycolfrag.risk.sequences_rare.RareSequenceSettings`' fields of the same
#: name: None in the parser, so that only those given reach the settings and each default has its one text there.
_RARE_FIELDS = ("target", "target_cov", "pilot", "batch", "max_rows", "ways", "tail_share")
#: Every option of the parser's importance-sampling group but ``--rare`` itself: refused without ``--rare`` (the crude
#: sequences read none of them, so a silent pass would look like an effect); None in the parser, so given = not None.
_RARE_ONLY = _RARE_FIELDS + ("shift",)


class _Help(HelpFormatter):
    """The commands' help style, the ``--rare`` options' defaults read from the settings' fields when the help is
    shown (the rare modules are loaded for ``--rare`` and the help alone)."""

    def _get_help_string(self, action):
        if action.dest not in _RARE_FIELDS:
            return super()._get_help_string(action)
        from pycolfrag.risk.sequences_rare import RareSequenceSettings
        default = next(f.default for f in dataclasses.fields(RareSequenceSettings) if f.name == action.dest)
        if isinstance(default, tuple):   # the ways, in --ways' own syntax
            default = ",".join(default)
        return f"{action.help} (default: {default})"


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="pycolfrag sequences", formatter_class=_Help,
                                description=__doc__.split("\n\n")[0] + " Under MPI: mpirun -n N python -m mpi4py -m "
                                "pycolfrag sequences ...; rerunning the same command resumes.")
    p.add_argument("site", help="site file (TOML, docs/risk.md)")
    p.add_argument("out", help="output folder: the journal sequences.jsonl, then summary.json and summary.md")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--column", default=None, help="column file (default: the Parthenon column)")
    what.add_argument("--scene", default=None, help="scene file (a colonnade, a portal: docs/scene_format.md)")
    p.add_argument("--years", type=float, default=50.0, help="the horizon, years")
    p.add_argument("--n", type=int, default=1000, help="sequences")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help="root seed")
    p.add_argument("--restore-u-d", type=float, default=0.005,
                   help="the restored way's policy: reassemble when the accumulated u_d exceeds this")
    p.add_argument("--restore-tilt", type=float, default=math.inf, help="... or the residual tilt exceeds this, rad")
    p.add_argument("--max-record-s", type=float, default=None, help="cut the records (tests and quick looks only)")
    p.add_argument("--aftershocks", nargs="?", const=DEFAULT_AFTERSHOCK_MODEL, default=None, metavar="MODEL",
                   help="each mainshock's aftershocks of Mw >= 5 within a year, by the generic parameters MODEL: "
                        "rj1989 (Reasenberg & Jones 1989, California; the flag alone, also where the word after it "
                        "names no model: --aftershocks site.toml out) or page2016-REGION (Page et al. 2016 by "
                        "tectonic region); one of " + ", ".join(AFTERSHOCK_MODELS) + " (docs/sequences.md, "
                        "\"Aftershocks\"; with --rare: \"Aftershocks in the rare sequences\")")
    rare = p.add_argument_group("importance sampling on the strongest event (--rare; docs/sequences.md, \"Rare sequences\")")
    rare.add_argument("--rare", action="store_true",
                      help="rows of the rare-event strata instead of crude sequences (--n is not used)")
    rare.add_argument("--target", default=None, help="the quantity whose CoV stops the run (accumulated way)")
    rare.add_argument("--target-cov", type=float, default=None, help="stop when the target's CoV reaches this")
    rare.add_argument("--pilot", type=int, default=None, help="rows per stratum before the allocation")
    rare.add_argument("--batch", type=int, default=None, help="rows per batch after the pilot")
    rare.add_argument("--max-rows", type=int, default=None, help="the row budget")
    rare.add_argument("--ways", default=None,
                      help="the ways run, comma-separated: accumulated and any of intact, restored (accumulated alone "
                           "costs the fewest runs)")
    rare.add_argument("--tail-share", type=float, default=None,
                      help="the share of rows whose events after the strongest are run (Russian roulette: fewer "
                           "runs where the tail rarely matters; 1 runs every row's; docs/sequences.md)")
    rare.add_argument("--shift", type=float, nargs=2, default=None, metavar=("Z_VP", "Z_FP"),
                      help="the production proposal's shift of the pulse normals (default: the cross-entropy step on "
                           "the pilot's rows)")
    p.add_argument("--mpi", choices=("auto", "yes", "no"), default="auto", help="use MPI (auto: under a launcher)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="a line per 10 %% done")
    return p


def _aftershocks_bare(argv: list) -> list:
    """``argv`` with every ``--aftershocks`` followed by a word that names no aftershock model made explicit
    (``--aftershocks=`` the model the flag alone means), so that the word is left to the positional arguments."""
    out = list(argv)
    for i, (word, after) in enumerate(zip(argv, argv[1:])):
        if word == "--":
            break
        if word == "--aftershocks" and not after.startswith("-") and after not in AFTERSHOCK_MODELS:
            out[i] = f"--aftershocks={DEFAULT_AFTERSHOCK_MODEL}"
    return out


def parse_args(argv=None) -> argparse.Namespace:
    """The command line, parsed by :func:`parser`, but for the word after ``--aftershocks``: argparse gives an
    optional value any word, so ``--aftershocks site.toml out`` would read the site file as the model (and lack
    ``out``). Here the word is the model where it names one, or where no positional argument could take it
    (``site.toml out --aftershocks page2016-greece``: refused in :func:`main`, naming the known models); any other
    word is the site or the folder, and the flag alone means rj1989."""
    argv = list(sys.argv[1:] if argv is None else argv)
    p, bare = parser(), _aftershocks_bare(argv)
    if bare != argv:
        args, rest = p.parse_known_args(bare)
        if not rest:
            return args
        if any(w.startswith("-") for w in rest):   # an unknown option is the error to report, not a lost positional
            p.error(f"unrecognized arguments: {' '.join(rest)}")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    comm = get_comm(args.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    given = ["--" + k.replace("_", "-") for k in _RARE_ONLY if getattr(args, k) is not None]
    if given and not args.rare:
        log(f"sequences: {', '.join(given)} {'needs' if len(given) == 1 else 'need'} --rare (settings of the rare "
            "sequences; the crude sequences read none of them)")
        return EXIT_ARGS
    try:
        model = (scene_from_file(args.scene) if args.scene else
                 Column.from_file(args.column) if args.column else Column.parthenon())
        st = SequenceSettings(years=args.years, n_sequences=args.n, seed=args.seed,
                              restoration=Restoration(u_d=args.restore_u_d, tilt_rad=args.restore_tilt),
                              max_record_s=args.max_record_s,
                              aftershocks=None if args.aftershocks is None else aftershock_model(args.aftershocks))
        if not Path(args.site).is_file():
            raise ParameterError(f"site file {args.site} does not exist")
    except (PycolfragError, OSError) as exc:
        log(f"sequences: {exc}")
        return EXIT_ARGS

    if args.rare:
        return _main_rare(args, model, st, comm, log)

    def progress(done, total):
        if args.progress and (done == total or done % max(1, total // 10) == 0):
            print(f"  {done}/{total} sequences", file=sys.stderr, flush=True)
    code, run = run_folder(args.site, model, st, args.out, comm, log, progress)
    if run is None:
        return code
    sm = summarize(run)
    text = format_summary(sm, f"{Path(args.site).stem}: {getattr(model, 'name', type(model).__name__)}, "
                              f"{st.n_sequences} sequences of {st.years:g} years")
    out = Path(args.out)
    (out / "summary.json").write_text(report_json.dumps(sm, indent=1, default=str))
    (out / "summary.md").write_text(text + "\n")
    log(text)
    return EXIT_OK


def rare_settings(args, st: SequenceSettings):
    """The :class:`pycolfrag.risk.sequences_rare.RareSequenceSettings` of the parsed ``--rare`` options: those given,
    the others left to the settings' own defaults; ParameterError names a bad one."""
    from pycolfrag.rare.proposal import production_mixture  # the rare route's modules, for --rare only
    from pycolfrag.risk import sequences_rare as rare
    mixture = None if args.shift is None else production_mixture(rare.DEFENSIVE, (tuple(args.shift),))
    given = {k: getattr(args, k) for k in _RARE_FIELDS if getattr(args, k) is not None}
    if "ways" in given:
        given["ways"] = tuple(w.strip() for w in given["ways"].split(","))
    return rare.RareSequenceSettings(sequences=st, mixture=mixture, **given)


def _main_rare(args, model, st: SequenceSettings, comm, log) -> int:
    from pycolfrag.risk import sequences_rare as rare  # the rare route's modules, for --rare only
    from pycolfrag.risk.sequences_rare_run import run_rare_folder
    try:
        rs = rare_settings(args, st)
    except PycolfragError as exc:
        log(f"sequences: {exc}")
        return EXIT_ARGS
    code, run = run_rare_folder(args.site, model, rs, args.out, comm, log)
    if run is None:
        return code
    text = rare.format_estimate(run, f"{Path(args.site).stem}: {getattr(model, 'name', type(model).__name__)}, "
                                     f"importance sampling on the strongest event")
    out = Path(args.out)
    (out / "rare_summary.json").write_text(report_json.dumps(
        {"estimate": run["estimate"], "rows": len(run["rows"]), "runs": run["runs"], "shared": run["shared"],
         "seconds": run["seconds"],
         "strata": len(run["strata"]), "settings": rare.settings_dict(rs), "design": run["design"].as_dict()},
        indent=1))
    (out / "rare_summary.md").write_text(text + "\n")
    log(text)
    reached = run["estimate"]["accumulated"][rs.target]["cov"]
    if reached > rs.target_cov:   # the row budget ran out first: said, and exit 6 as the rare route's
        more = ("rerun with a larger --max-rows to go on: the rows so far are kept" if
                rare.journal_settings(rs, len(run["strata"]))["max_rows"] == "whole batches" else
                "its last batch was cut, so a larger --max-rows would place other rows: rerun in another folder, "
                "with a budget of the pilot plus whole batches to be able to go on")
        log(f"sequences: the row budget ({rs.max_rows}) was spent before {rs.target}'s CoV reached "
            f"{rs.target_cov:g} (it is {reached:.3g}); {more} (exit 6)")
        from pycolfrag.risk.simulate import EXIT_NOT_CONVERGED  # the rare route's code for a spent budget
        return EXIT_NOT_CONVERGED
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
