"""The command line: ``export`` (NRML and the other registered formats) and ``damage``."""
from __future__ import annotations

import argparse
import sys
import warnings

from pycolfrag.analysis.completeness import ALLOW_INCOMPLETE_HELP
from pycolfrag.analysis.fragility import U_D_LEVELS, U_TOP_LEVELS
from pycolfrag.analysis.openquake.damage import DiscretisationWarning, classical_damage
from pycolfrag.analysis.openquake.export import (
    RANGE_CEILING_POE,
    RANGE_FLOOR_POE,
    fragility_from_results,
    steps_per_interval_warning,
)
from pycolfrag.analysis.openquake.hazard import _IMT, im_of_imt, read_hazard_curves
from pycolfrag.analysis.openquake.nrml import read_nrml
from pycolfrag.analysis.outputs import WRITERS, write_fragility
from pycolfrag.core.errors import ParameterError, PycolfragError


def _parser():
    p = argparse.ArgumentParser(prog="pycolfrag openquake",
                                description="OpenQuake interchange: export IM-based fragility as NRML 0.5, or "
                                            "convolve OpenQuake hazard curves with a fragility model "
                                            "(OpenQuake's classical damage). docs/risk.md")
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export", help="fit IM-based fragility curves to a results file and write NRML 0.5")
    e.add_argument("results", help="results file (pycolfrag grid)")
    e.add_argument("out", help="file to write (" + ", ".join(f"{w.name}: {w.suffix}" for w in WRITERS.values()) + ")")
    e.add_argument("--to", choices=sorted(WRITERS), default="nrml",
                   help="output format: " + "; ".join(f"{w.name}: {w.description}" for w in WRITERS.values()))
    d = sub.add_parser("damage", help="damage-state probabilities from a hazard-curve CSV and a fragility model")
    d.add_argument("hazard", help="OpenQuake hazard-curve CSV")
    d.add_argument("fragility", help="NRML fragility model (.xml) or a results file (.h5, fitted as by export)")
    d.add_argument("--risk-time", type=float, default=None, help="risk investigation time, years "
                   "(default: the hazard's investigation time)")
    d.add_argument("--steps-per-interval", type=int, default=1, help="OpenQuake's steps_per_interval (default 1)")
    d.add_argument("--continuous-fragility-discretization", type=int, default=20, metavar="N",
                   help="OpenQuake's continuous_fragility_discretization: levels from minIML to maxIML of a "
                        "continuous model when --steps-per-interval > 1 (default 20, OpenQuake's)")
    d.add_argument("--taxonomy", default=None, help="fragilityFunction id to use (default: the only one)")
    for a in (e, d):
        a.add_argument("--im", default=None, choices=sorted(_IMT),
                       help="IM of the fitted curves (export: default pga_g; damage with a results file: the "
                            "hazard's IMT)")
        a.add_argument("--period", type=float, default=None, help="period of sa_g, s")
        a.add_argument("--levels", choices=("u_top", "u_d"), default="u_top",
                       help="performance levels: Table III (u_top) or Table IV (u_d)")
        a.add_argument("--no-collapse", action="store_true", help="leave out the collapse limit state")
        a.add_argument("--format", choices=("continuous", "discrete"), default="continuous")
        a.add_argument("--iml-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                       help="minIML/maxIML (continuous) or range of the levels (discrete); default where the fits "
                            f"reach {RANGE_FLOOR_POE:g} and {RANGE_CEILING_POE:g} (docs/risk.md)")
        a.add_argument("--n-imls", type=int, default=20, help="levels of a discrete model")
        a.add_argument("--no-damage-limit", type=float, default=None, help="OpenQuake noDamageLimit")
        a.add_argument("--allow-degenerate", action="store_true",
                       help="write fits that are not estimates (too few runs, separable outcomes, a parameter on "
                            "the optimiser's bound) instead of refusing them; they are marked DEGENERATE")
        a.add_argument("--allow-incomplete", action="store_true", help=ALLOW_INCOMPLETE_HELP)
    return p


def _model_from_args(results, args, im, period):
    return fragility_from_results(results, im, period_s=period,
                                  levels=U_TOP_LEVELS if args.levels == "u_top" else U_D_LEVELS,
                                  collapse=not args.no_collapse, fmt=args.format, n_imls=args.n_imls,
                                  iml_range=args.iml_range, no_damage_limit=args.no_damage_limit,
                                  allow_degenerate=args.allow_degenerate, allow_incomplete=args.allow_incomplete)


def _print_model(model) -> None:
    """The fitted limit states, with the joint fits and what the model's notes say (degenerate fits, an
    incomplete file)."""
    joint = {ls: g for g in model.joint for ls in g}
    for ls, fit in zip(model.limit_states, model.fits):
        with_ = [o for o in joint.get(ls, ()) if o != ls]
        print(f"  {ls:24s} median {fit.median:.4g}  beta {fit.beta:.3f}  ({fit.n_exceed} of {fit.n} runs)"
              + (f"  common beta with {', '.join(with_)}" if with_ else "")
              + ("  DEGENERATE" if fit.degenerate else ""))
    lo, hi = model.domain
    print(f"  IML range {lo:.4g} to {hi:.4g}")
    for note in model.notes:
        print(f"  {note}")


def _export(args) -> None:
    model = _model_from_args(args.results, args, args.im or "pga_g", args.period)
    write_fragility(model, args.out, args.to)
    print(f"{args.out}: {model.format} fragility on {model.imt}, limit states {', '.join(model.limit_states)}")
    _print_model(model)
    note = steps_per_interval_warning(model)
    if note:
        warnings.warn(note, DiscretisationWarning, stacklevel=2)


def _fragility_model(args, hc):
    if str(args.fragility).endswith((".h5", ".hdf5")):
        im, period = im_of_imt(hc.imt)
        model = _model_from_args(args.fragility, args, im, period)
        print(f"fragility fitted to {args.fragility}:")
        _print_model(model)
        return model
    models = read_nrml(args.fragility)
    if args.taxonomy is None and len(models) > 1:
        raise ParameterError(f"{args.fragility} holds {sorted(models)}: choose one with --taxonomy")
    if args.taxonomy is not None and args.taxonomy not in models:
        raise ParameterError(f"--taxonomy {args.taxonomy!r} is not in {args.fragility} (it holds {sorted(models)})")
    return models[args.taxonomy] if args.taxonomy else next(iter(models.values()))


def _damage(args) -> None:
    hc = read_hazard_curves(args.hazard)
    model = _fragility_model(args, hc)
    if model.imt != hc.imt:
        raise ParameterError(f"the fragility is on {model.imt}, the hazard curves on {hc.imt}")
    tr = hc.investigation_time if args.risk_time is None else args.risk_time
    res = classical_damage(model, hc.imls, hc.poes, hc.investigation_time, tr,
                           steps_per_interval=args.steps_per_interval,
                           continuous_fragility_discretization=args.continuous_fragility_discretization)
    print(f"hazard {hc.path}: {hc.imt}, {len(hc.lon)} site(s), investigation time {hc.investigation_time:g} yr; "
          f"risk investigation time {tr:g} yr")
    for i in range(len(hc.lon)):
        print(f"site lon {hc.lon[i]:g} lat {hc.lat[i]:g}")
        for j, ls in enumerate(model.limit_states):
            print(f"  {ls:24s} rate {res['rates'][i, j]:.4e} /yr   P({tr:g} yr) {res['poes'][i, j]:.4e}")
        states = ("no_damage",) + model.limit_states
        print("  damage states: " + ", ".join(f"{s} {p:.4e}" for s, p in zip(states, res["damage"][i])))
    for note in model.notes:
        print(note)


def main(argv=None) -> int:
    """Command-line entry point; exit code 0, or 2 with one line naming the bad input. Warnings (degenerate
    fits, once per cause; hazard levels outside the fragility's range) are printed as lines of their own."""
    args = _parser().parse_args(argv)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        try:
            _export(args) if args.cmd == "export" else _damage(args)
            code = 0
        except (PycolfragError, OSError) as exc:
            print(f"pycolfrag openquake: {exc}", file=sys.stderr)
            code = 2
    for w in seen:
        print(f"pycolfrag openquake: warning: {w.message}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
