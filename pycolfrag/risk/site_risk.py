"""The command ``pycolfrag risk`` (:func:`main`): site risk by the grid route (:mod:`.grid_route`, which
computes it; its names are re-exported here), a logic tree over the site's choices (``--logic-tree``,
:mod:`.tree_grid`), or the site's events simulated (``--simulate OUTDIR``, :mod:`pycolfrag.rare`, report
:mod:`.rare_route`), beside the grid route when RESULTS.h5 is given.

    pycolfrag risk SITE.toml RESULTS.h5 OUTDIR [--no-pulse NOPULSE.h5]
"""
from __future__ import annotations

import argparse
import sys
import textwrap

from pycolfrag.core.errors import PycolfragError
from pycolfrag.risk.fit import EQ4_FIT_ALPHA, MISFIT_CHOICES
from pycolfrag.risk.grid_route import (  # noqa: F401 (the computation's names, re-exported)
    _PRINTED_YEARS,
    CURVE_X,
    DEFAULT_ESTIMATOR,
    ESTIMATORS,
    MAX_DRAW_BYTES,
    QUANTITIES,
    RiskQuantity,
    declared_pulse,
    interpolate,
    node_weights,
    report_section,
    site_risk,
)
from pycolfrag.risk.report import SiteRisk, print_summary, write_outputs  # noqa: F401
from pycolfrag.risk.uncertainty import DEFAULT_UNCERTAINTY, UNCERTAINTY_METHODS
from pycolfrag.site.sources import OUTSIDE_CHOICES

__all__ = ["RiskQuantity", "QUANTITIES", "ESTIMATORS", "DEFAULT_ESTIMATOR", "MAX_DRAW_BYTES", "node_weights",
           "interpolate", "declared_pulse", "SiteRisk", "site_risk", "report_section", "write_outputs", "main"]


class _Parser(argparse.ArgumentParser):
    """The grid route's parser; its help ends with the other form's options (``--simulate``, read from its
    own parser when help is asked for: the grid route does not import the simulation)."""

    def format_help(self) -> str:
        from pycolfrag.risk import rare_route as risk_rare
        other = risk_rare.build_parser(self.prog)
        fmt = other._get_formatter()
        for group in other._action_groups:
            if any("--simulate" in a.option_strings for a in group._group_actions):
                fmt.start_section(group.title)
                fmt.add_arguments(group._group_actions)
                fmt.end_section()
        shared = sorted({o for a in self._actions for o in a.option_strings} & _SIMULATE_SHARED)
        self.epilog = (textwrap.fill(f"The event-based simulation instead of the grid route: {self.prog} SITE "
                                     f"[RESULTS] --simulate OUTDIR [options] (docs/rare_events.md); it takes "
                                     f"{', '.join(shared)} as above, and:", 79)
                       + "\n\n" + fmt.format_help().rstrip())
        return super().format_help()


#: Options of the grid route that the ``--simulate`` form takes too.
_SIMULATE_SHARED = {"--no-pulse", "--pulse-only", "--pulse-model", "--outside", "--years", "--draws", "--no-figures"}


def _parser():
    ap = _Parser(prog="pycolfrag risk", formatter_class=argparse.RawDescriptionHelpFormatter,
                 description="Annual rates and T-year probabilities of the column's damage "
                             "levels at a site (docs/risk.md).")
    ap.add_argument("site", help="site file (TOML)")
    ap.add_argument("results", help="results of the grid with pulses (HDF5)")
    ap.add_argument("outdir", help="folder for risk.md, risk.json and the figures")
    ap.add_argument("--no-pulse", metavar="H5", help="results of the same grid made with pycolfrag grid ... --pulse none")
    ap.add_argument("--pulse-only", action="store_true",
                    help="use the pulse branch alone (p_pulse = 1); overstates the risk, said in every output")
    ap.add_argument("--estimator", choices=ESTIMATORS, default=DEFAULT_ESTIMATOR,
                    help="a cell's probability: the share of its runs that exceeded, or Eq. (4)")
    ap.add_argument("--uncertainty", choices=tuple(UNCERTAINTY_METHODS), default=DEFAULT_UNCERTAINTY,
                    help="; ".join(f"{m.name}: {m.description}" for m in UNCERTAINTY_METHODS.values()))
    ap.add_argument("--eq4-misfit", choices=MISFIT_CHOICES, default="fallback",
                    help=f"under Eq. (4), a cell whose fit test fails at {EQ4_FIT_ALPHA:g} takes the empirical "
                         "ratio (fallback) or keeps Eq. (4) with a mark (warn)")
    ap.add_argument("--pulse-model", metavar="TABLE",
                    help="pulse-occurrence model of every source instead of the site file's, as a TOML inline "
                         "table, e.g. '{model = \"shahi_baker_earlier\", mechanism = \"non-strike-slip\", "
                         "s_km = 5.0, angle_deg = 30.0}'")
    ap.add_argument("--outside", choices=OUTSIDE_CHOICES, help="override the site file's choice")
    ap.add_argument("--years", type=float, nargs="*", default=[], help="more horizons (50, 100, 475 always)")
    ap.add_argument("--draws", type=int, default=2000, help="draws per grid cell for the intervals")
    ap.add_argument("--seed", type=int, default=0, help="seed of the draws (>= 0)")
    ap.add_argument("--allow-incomplete", action="store_true",
                    help="compute from a results file that lacks rows (refused otherwise); every output says so")
    ap.add_argument("--no-figures", action="store_true")
    ap.add_argument("--logic-tree", metavar="TREE", help="a logic tree over the site's choices (its own TOML file, or "
                    "the site file with a [logic_tree] table): every end branch, their mean and quantiles "
                    "(docs/logic_tree.md)")
    return ap


def _simulate_main(argv) -> int:
    """``--simulate OUTDIR``: the event-based simulation (:mod:`pycolfrag.rare`, on every rank), then on rank 0
    the grid route beside it when its results are given, and the report (:mod:`.rare_route`)."""
    from pycolfrag.risk import rare_route as risk_rare  # here: only this form of the command needs it
    from pycolfrag.risk.simulate import EXIT_ARGS, run_simulation
    ap = risk_rare.build_parser()
    a = ap.parse_args(argv)
    beside = {}                       # the grid route, read and checked on every rank before any run

    def before(site, settings, record):
        beside.update(risk_rare.grid_route(a, site, settings, site_risk, record))

    code, run = run_simulation(a, QUANTITIES, argv, before=before)
    if run is None:
        return code
    try:
        cmp = risk_rare.compare_with_grid(run, beside["zero"], beside["clamp"]) if beside else None
        kept = risk_rare.larger_estimate(run, a.simulate)    # a subset never replaces a larger estimate
        paths = None if kept else risk_rare.write_outputs(run, a.simulate, cmp, figures=not a.no_figures)
    except PycolfragError as exc:   # the grid's files, the output folder: every run stays in OUTDIR
        print(f"{ap.prog}: error: {exc}", file=sys.stderr)
        return EXIT_ARGS
    risk_rare.print_summary(run, cmp)
    if paths is None:
        print(f"{ap.prog}: {a.simulate} holds the estimate of {kept} runs (risk.md, risk.json, figures): not "
              f"overwritten with this estimate of {run.runs} runs (the first {run.runs} of the folder's runs, printed "
              f"above; --max-runs {a.max_runs}). Rerun with --max-runs {kept} or more "
              f"to rewrite the report; for a report of this estimate, copy the folder without its risk.json and rerun "
              f"this command on the copy")
    else:
        print(paths["markdown"])
    return code


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if any(x == "--simulate" or x.startswith("--simulate=") for x in argv):
        if any(x == "--logic-tree" or x.startswith("--logic-tree=") for x in argv):
            from pycolfrag.risk.tree_rare_run import run as run_tree_simulation  # the tree on the rare-event route
            return run_tree_simulation(argv)
        return _simulate_main(argv)
    ap = _parser()
    a = ap.parse_args(argv)
    if a.logic_tree is not None:        # the tree's branches, each a site_risk (pycolfrag/risk/tree_grid.py)
        from pycolfrag.risk.tree_grid import run_tree
        return run_tree(a, ap.prog)
    try:
        from pycolfrag.risk.report import check_outdir
        check_outdir(a.outdir)
        risk = site_risk(a.site, a.results, a.no_pulse, pulse_only=a.pulse_only, estimator=a.estimator,
                         uncertainty=a.uncertainty, eq4_misfit=a.eq4_misfit, pulse_model=a.pulse_model,
                         outside=a.outside, years=a.years,
                         n_draws=a.draws, rng=a.seed, allow_incomplete=a.allow_incomplete)
        paths = write_outputs(risk, a.outdir, figures=not a.no_figures)
    except PycolfragError as exc:       # a bad site file, results file or folder: its message, not a traceback
        print(f"{ap.prog}: error: {exc}", file=sys.stderr)
        return 2
    print_summary(risk, _PRINTED_YEARS)
    print(paths["markdown"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
