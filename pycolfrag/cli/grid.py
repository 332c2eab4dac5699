"""The grid command (``pycolfrag grid``, ``scripts/run_grid.py``): run a grid (:mod:`pycolfrag.grid`), then
analyse it.

The driver computes and writes rows; what a person wants after a run -- the summary table, the
failed rows by message, the figures and the report -- is this layer's, so that the driver imports
nothing of :mod:`pycolfrag.analysis`. Options: the run's (:func:`pycolfrag.grid.build_parser`)
plus the analysis options below.
"""
from __future__ import annotations

import argparse
import traceback
from pathlib import Path

from pycolfrag import grid
from pycolfrag.core import progress

# The analysis (pycolfrag.analysis: scipy, h5py readers, matplotlib) is imported inside the functions
# below, on rank 0 after its run: every rank of a grid imports this module, and the start-up of a
# rank is what a many-rank run pays once per rank.

__all__ = ["build_parser", "make_outputs", "synthetic_outputs", "record_outputs", "main"]

#: Exit code when the figures or the report failed (the results are complete).
EXIT_OUTPUTS = grid.EXIT_OUTPUTS


def build_parser() -> argparse.ArgumentParser:
    """The run's options (:func:`pycolfrag.grid.build_parser`) and what to draw and write after it."""
    p = grid.build_parser()
    o = p.add_argument_group("analysis after the run")
    o.add_argument("--figures", action=argparse.BooleanOptionalAction, default=True,
                   help="make figures and report at the end (pycolfrag.analysis.figures / pycolfrag.analysis.report)")
    o.add_argument("--figures-dir", default=None, help="figure folder (default: <out folder>/figures; with "
                   "--records <out folder>/<out name>_analysis)")
    o.add_argument("--report", default=None, help="report path (default: <out folder>/report.md; with --records "
                   "report.md in the figure folder)")
    o.add_argument("--synthetic", default=None, metavar="H5",
                   help="synthetic grid file for the Fig. 10 line of the record report (default: "
                        "results/grid.h5 when it exists)")
    return p


def make_outputs(out: Path, figures_dir: Path, report_path: Path, log, synthetic=None, layout="read") -> bool:
    """Figures, then the report that links them, from the results file; a failure is reported, never raised.
    What is made is the file's kind of grid's (its spec's ``after_run``: :func:`synthetic_outputs`, or
    :func:`record_outputs` for a record suite). ``layout``: the file's layout when the caller knows it
    (None = synthetic, "records"); "read" reads it from the file."""
    if layout == "read":
        layout = _layout_of(out)
    try:
        hook = grid.spec_kind(layout).after_run
    except Exception:   # a layout no kind of grid writes: the synthetic outputs, as before the kinds declared theirs
        hook = grid.GridSpec.after_run
    return _after_run(hook)(out, figures_dir, report_path, log, synthetic=synthetic)


def _after_run(name: str):
    """The function a spec's ``after_run`` names (``module:function``), imported now."""
    import importlib
    module, _, fn = name.partition(":")
    return getattr(importlib.import_module(module), fn)


def record_outputs(out: Path, figures_dir, report_path, log, synthetic=None) -> bool:
    """A record suite's analysis after its run (:attr:`pycolfrag.grid.RecordGridSpec.after_run`):
    :func:`pycolfrag.analysis.record_report.write_record_report` (stripes, cloud, MSA with several scales,
    Fig. 10 against ``synthetic``). Defaults: figures in ``<out folder>/<out name>_analysis``, the
    report ``report.md`` there; ``synthetic`` results/grid.h5 when it exists."""
    from pycolfrag.analysis import record_report  # here: after the run, on rank 0 (top of the module)
    out = Path(out)
    figures_dir = Path(figures_dir) if figures_dir else out.parent / f"{out.stem}_analysis"
    report_path = Path(report_path) if report_path else figures_dir / "report.md"
    if synthetic is None and Path("results/grid.h5").exists():
        synthetic = "results/grid.h5"
    name = "pycolfrag.analysis.record_report.write_record_report"
    try:
        record_report.write_record_report(str(out), str(figures_dir), report_path=str(report_path),
                                          synthetic=synthetic)
        log(f"{name} -> {report_path} and {figures_dir}")
        return True
    except Exception:
        log(f"WARNING: {name} failed (the results in {out} are complete and safe):\n" + traceback.format_exc())
        return False


def synthetic_outputs(out: Path, figures_dir, report_path, log, synthetic=None) -> bool:
    """A synthetic grid's analysis after its run (:attr:`pycolfrag.grid.GridSpec.after_run`): the paper's
    figures (:func:`pycolfrag.analysis.figures.make_all`), then the report that links them
    (:func:`pycolfrag.analysis.report.write_report`). Defaults: ``<out folder>/figures`` and
    ``<out folder>/report.md``; ``synthetic`` is not used."""
    from pycolfrag.analysis import (
        figures,
        report,  # here: after the run, on rank 0 (top of the module)
    )
    out = Path(out)
    figures_dir = Path(figures_dir) if figures_dir else out.parent / "figures"
    report_path = Path(report_path) if report_path else out.parent / "report.md"

    def draw():
        figures.make_all(str(out), str(figures_dir))

    def write():  # the report links the PNGs found in figures_dir, so it must be told where they are
        report.write_report(str(out), str(report_path), figures_dir=str(figures_dir))

    ok = True
    for name, step, target in (("pycolfrag.analysis.figures.make_all", draw, figures_dir),
                               ("pycolfrag.analysis.report.write_report", write, report_path)):
        try:
            step()
            log(f"{name} -> {target}")
        except Exception:
            ok = False
            log(f"WARNING: {name} failed (the results in {out} are complete and safe):\n"
                + traceback.format_exc())
    return ok


def _layout_of(path):
    from pycolfrag.analysis import data  # here: after the run (top of the module)
    try:
        return data.load(path).attrs.get("layout")
    except Exception:
        return None


def main(argv=None) -> int:
    """The grid command (``pycolfrag grid``, ``scripts/run_grid.py``). Exit codes: 0 ok; 2 bad arguments, a
    results file of another run or a damaged one; 3 figures/report failed (results are complete);
    4 an operating-system error on the output (read-only folder, full disk: one line with the path);
    5 the results file is being written by another run (its lock is held); 75 a SIGTERM stopped the run
    with rows left (rerun the same command to resume it)."""
    args = build_parser().parse_args(argv)
    if not args.progress:   # no bar of the grid's, nor of its figures' and report's (pycolfrag.core.progress)
        progress.enable(False)
    code, summary, spec = grid.run_command(args, argv)
    if summary is None:  # a refusal (said already), or a worker rank
        return code

    def log(s):
        print(s, flush=True)

    from pycolfrag.analysis import data  # here: after the run, on rank 0 (top of the module)
    from pycolfrag.analysis.summary import failure_lines, format_table, summary_table
    try:   # the file is complete and safe: a failure to read it back for the summary is only reported
        res = data.load(summary.path)   # read once for the table and the failure lines
        table = summary_table(res)
        log(format_table(table))
        if summary.failed or any(t["failed"] for t in table):
            log("failed rows (status > 0; the message is stored in each row):\n"
                + "\n".join(failure_lines(res)))
    except Exception:
        log(f"WARNING: the summary table of {summary.path} could not be read (the results are complete and "
            "safe):\n" + traceback.format_exc())
        code = code or EXIT_OUTPUTS
    log(f"{summary.computed} runs computed in {summary.wall_s:.1f} s on {summary.n_ranks} rank(s)"
        + (f" ({summary.wall_s / summary.computed * summary.n_ranks:.3f} rank-s per run)" if summary.computed else "")
        + f"; {summary.failed} failed; results: {summary.path}")
    if summary.rows_left:
        log(f"stopped by SIGTERM with {summary.rows_left} row(s) left (exit {grid.EXIT_DRAINED}): rerun the same "
            "command to compute them; figures and report come with the complete file")
        return grid.EXIT_DRAINED
    if args.figures:   # the kind's analysis (its spec's after_run), in the kind's default places unless given
        if not _after_run(spec.after_run)(Path(args.out), args.figures_dir, args.report, log, synthetic=args.synthetic):
            return EXIT_OUTPUTS
    return code
