"""The command ``pycolfrag risk SITE.toml --simulate OUTDIR --logic-tree TREE.toml`` (docs/logic_tree.md, "On the
rare-event route"): every distinct run setting of the tree's end branches simulated on the same events
(:func:`pycolfrag.rare.paired.simulate_paired`) into ``OUTDIR/runs_NN``, the site choices re-weighted, the
tree's statistics and outputs (:mod:`pycolfrag.risk.tree_rare`, :mod:`pycolfrag.risk.tree_rare_report`).

Everything before the first run is checked on every rank (the tree, every branch against the models, every
branch site's reach by re-weighting, the folder's record of the tree on rank 0): a refusal exits 2 with
nothing run. The target CoV is the tree's weighted mean's, and each production batch is run by the run settings
whose share of the mean's error asks for it (:class:`pycolfrag.risk.tree_rare.TreeShare`). Exit codes as a single
simulation's (:mod:`pycolfrag.risk.simulate`): 75 on SIGTERM (rerun the same command: the outputs equal an
uninterrupted run's), 6 when the budget ran out before the tree's mean met its target, 7 when failed runs leave a
requested level unresolved in any run setting (or every pilot run of one failed).
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from pycolfrag.core.errors import ParameterError, PycolfragError
from pycolfrag.grid import get_comm
from pycolfrag.rare.paired import GroupEvaluator, serve_groups
from pycolfrag.risk import simulate as _sim
from pycolfrag.site.models import PulseOnly

__all__ = ["prepare", "run"]


def _overridden(site, a):
    """An end branch's site with the command line's overrides (as the single simulation's site has them)."""
    if getattr(a, "pulse_only", False):
        site = replace(site, sources=tuple(replace(s, pulse=PulseOnly()) for s in site.sources))
    if getattr(a, "outside", None):
        site = replace(site, outside=a.outside)
    return site


def prepare(a) -> dict:
    """Everything of the command before any run (every rank; nothing written): the site, settings, stopping rule
    and record of the command line, the tree checked, its run groups and every end branch's site."""
    from pycolfrag.risk.tree_apply import ModelSettings, check_tree
    from pycolfrag.risk.tree_grid import _tree_of, site_dict_of
    from pycolfrag.risk.tree_rare import check_reweighting, run_groups
    if a.results is not None or a.no_pulse is not None:
        raise ParameterError("--logic-tree with --simulate takes no grid files beside it (the grid route's tree is "
                             "`risk SITE PULSE.h5 OUTDIR --logic-tree TREE`)")
    site, settings, stop, record = _sim.settings_from_args(a)
    site_dict = site_dict_of(a.site)
    tree = _tree_of(a.site, site_dict, a.logic_tree)
    pulse_sets = [s.name for s in tree.branch_sets if s.choice.name == "pulse_model"]
    if pulse_sets and (a.pulse_model is not None or a.pulse_only):
        raise ParameterError(f"--pulse-model / --pulse-only would override the tree's pulse_model set(s) {pulse_sets} "
                             "in every branch: drop one of the two")
    if a.pulse_model is not None:
        raise ParameterError("--pulse-model with --logic-tree: give the pulse model in the site file, or as the tree's "
                             "pulse_model set")
    base = ModelSettings(vp_scale=record.vp_scale, tp_model=record.tp_model, vp_model=record.vp_model,
                         solver_options=_sim.solver_options_of(a.solver), column=record.column)
    checked = check_tree(tree, site_dict, str(a.site), base, probe=True, record_dt_s=record.record_dt_s)
    sites = [_overridden(s, a) for s in checked.sites]
    for end, s in zip(checked.ends, sites):
        check_reweighting(site, s, end.path, settings.mw_step, settings.r_edges_km)
    return {"site": site, "settings": settings, "stop": stop, "tree": tree, "ends": checked.ends, "sites": sites,
            "groups": run_groups(checked, record)}


def _simulate(a, p, comm, size, log, argv):
    """(exit code, runs or None) of the paired simulation, rank 0 (the other ranks serve, then return)."""
    from pycolfrag.risk.grid_route import QUANTITIES
    command = " ".join([sys.argv[0]] + list(sys.argv[1:] if argv is None else argv))
    evs = [GroupEvaluator(g, Path(a.simulate) / grp.folder, grp.record, comm, allow_code_change=a.allow_code_change,
                          progress=a.progress, chunk_max=a.chunk_max, log=log, command=command)
           for g, grp in enumerate(p["groups"])]
    if not evs[0].is_root:
        serve_groups(evs)
        return _sim.EXIT_OK, None
    code, runs = _sim.run_paired(p, evs, QUANTITIES, comm, size, log, "risk --simulate --logic-tree", a.simulate,
                                 [g.folder for g in p["groups"]], share=tree_share(p, a.simulate))
    if code is not None:
        return code, None
    return tree_exit_code(runs, [g.folder for g in p["groups"]], log), runs


def tree_share(p: dict, outdir):
    """Where the tree's runs go (:class:`~pycolfrag.risk.tree_rare.TreeShare`): the stop rule's target CoV is the
    tree's weighted mean's, steered by the weights the folder began with."""
    from pycolfrag.risk.tree_rare import TreeShare, groups_of_ends, steering_weights
    group_of = groups_of_ends(p["groups"], len(p["ends"]))
    return TreeShare(tuple(steering_weights(outdir, p["tree"], p["ends"])), tuple(group_of), tuple(p["sites"]),
                     p["stop"].target_cov, p["settings"].batch)


def tree_exit_code(runs, names, log) -> int:
    """7 when failed runs leave a requested level of a run setting unresolved (said, as a single simulation's);
    else 6 when the budget ran out before the tree's mean met its target (:class:`TreeShare`); else 0."""
    codes = [_sim._exit_code(r, lambda s, n=n: log(f"[{n}] {s}")) for r, n in zip(runs, names)]
    if _sim.EXIT_UNRESOLVED in codes:
        return _sim.EXIT_UNRESOLVED
    if any(r.stopped == "failures" for r in runs):
        log("risk --simulate --logic-tree: the tree's mean met its target, but failed runs leave a branch's level "
            "unresolved (its run setting's rows re-weighted to its site: logic_tree.md's branch table marks it)")
        return _sim.EXIT_UNRESOLVED
    return _sim.EXIT_OK if all(r.stopped == "target" for r in runs) else _sim.EXIT_NOT_CONVERGED


def run(argv) -> int:
    """The command on every rank; the exit code (module docstring)."""
    from pycolfrag.risk import rare_route, tree_rare_report
    from pycolfrag.risk.tree_rare import check_folder, tree_of_runs
    ap = rare_route.build_parser()
    ap.add_argument("--logic-tree", metavar="TREE", required=True,
                    help="a logic tree (its own TOML file, or the site file with a [logic_tree] table): every distinct "
                         "run setting simulated on the same events into OUTDIR/runs_NN (docs/logic_tree.md)")
    a = ap.parse_args(argv)
    comm = get_comm(a.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    notes: list = []
    try:
        p = prepare(a)
        _sim._on_rank0(lambda: notes.append(check_folder(a.simulate, p["tree"], p["groups"])), comm)
    except (PycolfragError, OSError) as exc:
        log(f"risk --simulate --logic-tree: {exc}")
        return _sim.EXIT_ARGS
    note = "".join(notes)
    if note:
        log(f"logic tree: {note}")
    log(f"logic tree: {len(p['ends'])} end branches, {len(p['groups'])} run setting(s) on the same events: "
        + "; ".join(f"{g.folder} = {g.name}" for g in p["groups"]))
    code, runs = _simulate(a, p, comm, size, log, argv)
    if runs is None:
        return code
    try:
        years = sorted({50.0, 100.0, 475.0, *p["site"].years, *a.years})
        tr = tree_of_runs(p["tree"], p["ends"], p["sites"], p["groups"], runs, years, note)
        paths = tree_rare_report.write_tree_outputs(tr, a.simulate, figures=not a.no_figures)
    except PycolfragError as exc:
        print(f"{ap.prog}: error: {exc}", file=sys.stderr)
        return _sim.EXIT_ARGS
    tree_rare_report.print_tree_summary(tr, 50.0)
    print(paths["markdown"])
    return code
