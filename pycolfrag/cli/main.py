"""The ``pycolfrag`` command: one entry point over every command line of the project.

    pycolfrag grid --mw 6.5 7.5 --dist 5 20 --samples 6      # = python scripts/run_grid.py ...
    pycolfrag risk examples/site_athens.toml pulse.h5 out/    # = python -m pycolfrag.risk.site_risk ...
    pycolfrag --help                                          # the commands, one line each

Each command is the ``main(argv)`` of the module that owns it, imported only when that command runs
(:data:`COMMANDS`), so ``pycolfrag --help`` loads none of the analysis; the other ways in
(``scripts/run_grid.py``, ``python -m pycolfrag.risk.site_risk``, ...) do the same. The ``python -m`` entries
of the modules that moved when the package was laid out by layer (2026-12-06: ``pycolfrag.analysis.risk``,
``pycolfrag.analysis.openquake``, ...) moved with them (docs/architecture.md, "Where the modules went"). Every command
lives in the package, so an installed wheel (no checkout, no ``scripts/``) has all of them; the scripts of
a checkout are thin wrappers over :func:`main`. Every command runs here with one BLAS thread, or the user's
``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS`` (:mod:`pycolfrag.core.threads`: numpy is loaded before any command,
so the variables alone would come too late), and its long loops draw a progress bar on stderr
(:mod:`pycolfrag.core.progress`); the older ``python -m`` commands do neither. The commands' help style,
:class:`~pycolfrag.core.help.HelpFormatter`, lives in the bottom layer so that any command line takes it
without importing this one.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from dataclasses import dataclass
from typing import Callable, Sequence

from pycolfrag.core.errors import MissingDependencyError
from pycolfrag.core.help import HelpFormatter
from pycolfrag.core.version import __version__

__all__ = ["HelpFormatter", "Command", "COMMANDS", "DEVELOPER_SCRIPTS", "build_parser", "main"]

class _ListingFormatter(HelpFormatter, argparse.RawDescriptionHelpFormatter):
    """:class:`HelpFormatter` keeping the top level's list of commands as written."""


@dataclass(frozen=True)
class Command:
    """One command: its name, the ``main(argv)`` it runs (``module:function``), what it does, and the older
    command that does the same."""

    name: str
    target: str
    summary: str
    old: str

    def load(self) -> Callable[[Sequence[str]], int | None]:
        """The command's ``main``, imported now (and only now)."""
        where, _, func = self.target.partition(":")
        return getattr(importlib.import_module(where), func)


#: Command lines of the repository that are not users' commands: the developers' own tools, run by
#: ``.ci/run`` or the Makefile (script -> why it is not a ``pycolfrag`` command).
DEVELOPER_SCRIPTS = {
    "scripts/check_c_calls.py": "a CI check of the C library's call graph (.ci/run)",
    "scripts/risk_example.py": "writes the example block of docs/risk.md (make risk-docs)",
    "scripts/restoration_study.py": "runs the restoration study's grids and writes the block of docs/restoration.md "
                                    "(make restoration)",
}

#: Every command, in the order ``pycolfrag --help`` lists them.
COMMANDS = {c.name: c for c in (
    Command("grid", "pycolfrag.cli.grid:main",
            "run (or resume) the Monte Carlo grid, or a record suite (--records), then its summary, figures "
            "and report (docs/grid.md)", "python scripts/run_grid.py"),
    Command("report", "pycolfrag.analysis.report:main", "markdown report of a results file",
            "python -m pycolfrag.analysis.report"),
    Command("timeline", "pycolfrag.analysis.timeline:main",
            "where the ranks' time went in a grid run: utilisation, idle by cause, Gantt chart (docs/grid.md)",
            "python -m pycolfrag.analysis.timeline"),
    Command("replay", "pycolfrag.grid.replay:main",
            "predict a grid's time and efficiency on N ranks from a results file's measured costs "
            "(docs/performance.md)", "python -m pycolfrag.grid.replay"),
    Command("compare", "pycolfrag.analysis.compare:main",
            "compare two results files row by row (bitwise), else by scenario statistics",
            "python -m pycolfrag.analysis.compare"),
    Command("risk", "pycolfrag.risk.site_risk:main",
            "annual rates and T-year probabilities of the damage levels at a site (docs/risk.md)",
            "python -m pycolfrag.risk.site_risk"),
    Command("subset", "pycolfrag.cli.subset:main",
            "subset simulation of P(EDP >= level) in one scenario, the record-to-record tail; MPI "
            "(docs/rare_events.md)", "python -m pycolfrag.cli.subset"),
    Command("restoration", "pycolfrag.risk.restoration_rare:main",
            "restoration alternatives (dowels, a portal) on the same events by the rare-event route: each one's "
            "rates and paired differences (docs/restoration.md)", "python -m pycolfrag.risk.restoration_rare"),
    Command("sequences", "pycolfrag.risk.sequences_run:main",
            "earthquake sequences at a site over T years, with and without accumulated damage (docs/sequences.md)",
            "python -m pycolfrag.risk.sequences_run"),
    Command("openquake", "pycolfrag.cli.openquake:main",
            "OpenQuake interchange: export fragility as NRML, classical damage from hazard curves",
            "python -m pycolfrag.cli.openquake"),
    Command("record-report", "pycolfrag.analysis.record_report:main",
            "analyse a record-suite results file: stripes, cloud, MSA, Fig. 10, report (docs/records.md)",
            "python -m pycolfrag.analysis.record_report"),
    Command("figures", "pycolfrag.cli.figures:main", "the paper's figures from a results file",
            "python scripts/make_figures.py"),
    Command("validation", "pycolfrag.cli.validation:main",
            "docs/validation.md: the paper's quantitative statements against a results file",
            "python scripts/make_validation.py"),
    Command("record-checks", "pycolfrag.cli.record_checks:main",
            "the natural-record checks: fig10, table2, demo-suite, analyse (docs/records.md)",
            "python scripts/record_checks.py"),
)}


def build_parser() -> argparse.ArgumentParser:
    """The top level: the command's name, then its own arguments (``pycolfrag COMMAND --help``)."""
    width = max(len(n) for n in COMMANDS)
    listing = "\n".join(f"  {c.name:<{width}}  {c.summary}" for c in COMMANDS.values())
    same = "\n".join(f"  pycolfrag {c.name:<{width}} = {c.old}" for c in COMMANDS.values())
    p = argparse.ArgumentParser(
        prog="pycolfrag", formatter_class=_ListingFormatter,
        description="Seismic fragility of multidrum classical columns. Under MPI: "
                    "mpirun -n N python -m mpi4py -m pycolfrag grid ...",
        epilog=f"commands:\n{listing}\n\nthe same, by the script or module behind each:\n{same}\n\n"
               "'pycolfrag COMMAND --help' gives a command's options.")
    p.add_argument("--version", action="version", version=f"pycolfrag {__version__}")
    p.add_argument("command", choices=list(COMMANDS), metavar="COMMAND", help="the command to run (below)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="its arguments")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``pycolfrag COMMAND ARGS...``: the command's ``main(ARGS)``; returns its exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0].startswith("-"):
        parser.parse_args(argv)       # --help, or a usage error
        parser.print_usage(sys.stderr)
        return 2
    args = parser.parse_args(argv[:1])  # the name alone: the rest belongs to the command
    command = COMMANDS[args.command]
    from pycolfrag.core import (
        progress,
        threads,  # light: they import nothing of pycolfrag either
    )
    threads.limit_blas_threads()   # one BLAS thread (or the user's count) for every command: pycolfrag.core.threads
    run = command.load()
    prog, bars = sys.argv[0], progress.enabled()
    sys.argv[0] = f"pycolfrag {command.name}"   # a command's usage line and recorded command name it as run
    progress.enable()              # the long loops of every command draw a bar on stderr: pycolfrag.core.progress
    try:
        code = run(argv[1:])
    except MissingDependencyError as exc:
        # an optional dependency the asked feature needs (mpi4py for MPI ranks): one line with the install
        # command, not a traceback
        print(f"pycolfrag {command.name}: {exc}", file=sys.stderr)
        return 2
    finally:   # a caller in this process gets argv and the bars back as they were; the BLAS limit stays
        sys.argv[0] = prog
        progress.enable(bars)
    return 0 if code is None else int(code)
