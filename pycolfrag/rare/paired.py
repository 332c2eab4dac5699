"""Several run settings simulated on the same events (common random numbers): the site simulation of
:mod:`pycolfrag.rare.driver` run in lockstep over *groups* -- one folder and one
:class:`~pycolfrag.rare.evaluator.RecordSettings` each (another pulse amplitude, pulse-period relation, contact
model, joints, connectors: the run-changing branches of a logic tree, docs/logic_tree.md).

Every group's runs are the same events: a run's inputs are the function of (seed, stage, stratum, index) of
:mod:`pycolfrag.rare.plans`, so with one seed, one site (its strata), one design and the same per-stratum
counts in every batch, every group draws the same Mw, R, pulse occurrence, pulse normals (z_vp, z_fp, z_nu,
z_gamma: mapped to the pulse's parameters by each group's own vp_scale and period relation) and record noise
seed. What makes that so:

* the pilot (``batch_000``) is the same plan in every group (it depends on the seed and the strata alone);
* the production mixture's shifts come from the pilot of the *lead* group (the first one that has a successful
  pilot run: the caller puts the tree's first alternatives first), stored in every group's ``batch_001`` plan;
* every production batch's counts are one allocation for all groups: the minimax-CoV Neyman rule of
  :mod:`pycolfrag.rare.allocation` over every (group, level) pair, the batch split on its own (a piece of every
  group's estimate, :func:`pycolfrag.rare.allocation.piece_allocation`), each group's steering model predicting its
  own levels (a level whose prediction equals the same level's in an earlier group -- groups whose runs came
  out the same -- counts once, so one group, or any number of identical ones, is allocated exactly as the
  single simulation is);
* the simulation stops when every group's requested levels have converged (or are unresolved at the target
  CoV), or when the budget -- ``max_runs`` per group -- is spent;
* or, given a ``share`` rule (a logic tree's :class:`pycolfrag.risk.tree_rare.TreeShare`), when *that* rule says
  its target is met: before each production batch after the first (which every live group takes: the lead's rows
  of it place the second cross-entropy step) it names the groups that take the batch (the others sit it out: they
  run nothing in it), so that the runs go where the rule's estimate needs them. A group that sits out a batch has
  no file of it; the groups that take it run the same counts of the same events, and their plans name them
  (``takers``). A stage planned in any group is resumed as planned -- its takers from the plan, no rule asked, no
  stop -- so a resume reads every batch on disk whatever the stopping rule is now.

A group whose every pilot run failed is *dead*: it gets no further runs (they would fail too), is said, and
its estimate marks every level unresolved. Resume: every group's plans are on disk before their runs; a batch
plan written in one group before an interruption fixes the counts of that stage in the others. SIGTERM stops
as a single simulation does (:class:`~pycolfrag.rare.evaluator.BatchStopped`): one handler for every group.
Under MPI the other ranks serve every group's batches (:func:`serve_groups`).
"""
from __future__ import annotations

import signal
from contextlib import contextmanager

import numpy as np

from pycolfrag.core.errors import StaleBuildError
from pycolfrag.grid.serve import sigterm_handler as _sigterm_handler
from pycolfrag.rare import allocation as _alloc
from pycolfrag.rare import driver as _driver
from pycolfrag.rare.driver import (
    SiteRun,
    _cat,
    _check_same_run,
    _Run,
    _stop_reason,
    batch_name,
    cross_entropy_design,
    failures,
)
from pycolfrag.rare.evaluator import GridEvaluator
from pycolfrag.rare.proposal import PILOT_MIXTURE, Design

__all__ = ["GroupEvaluator", "serve_groups", "sigterm_stops_all", "simulate_paired", "joint_counts"]


class GroupEvaluator(GridEvaluator):
    """A :class:`GridEvaluator` of one group: its messages to the other ranks name the group."""

    def __init__(self, group: int, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.group = int(group)

    def _command(self, msg: dict):
        return super()._command({**msg, "group": self.group})


def serve_groups(evaluators) -> None:
    """Ranks > 0: compute every batch rank 0 asks for, with the group's own settings, until it closes."""
    comm = evaluators[0].comm
    with _sigterm_handler(signal.SIG_IGN):
        while True:
            msg = comm.bcast(None, root=0)
            if msg["op"] == "stop":
                return
            try:
                evaluators[msg["group"]]._run(msg)
            except StaleBuildError:
                continue      # refused on every rank before any row; rank 0 says why, then stops us


@contextmanager
def sigterm_stops_all(evaluators):
    """Rank 0: a SIGTERM between batches stops every group before its next batch (as
    :meth:`GridEvaluator.sigterm_stops` does for one)."""
    def note(signum, frame):
        for ev in evaluators:
            ev.stop_asked = True
        note.pcf_sigterm_pending = True

    note.pcf_sigterm_pending = False
    with _sigterm_handler(note):
        yield evaluators


def joint_counts(parts_by_group, strata, design, settings, requested, stage: int, used: int, events,
                 size: int, floors=None) -> dict:
    """The ``size`` runs of production batch ``stage`` per stratum, one allocation for every group (module
    docstring); with one group the driver's allocation, bit for bit. ``floors``: each group's variance floor of
    the requested levels (the estimate's; None: none)."""
    W = strata.rates
    var_cols: list = []
    lam_cols: list = []
    kept: list = []
    means: list = []
    for g, parts in enumerate(parts_by_group):
        mean, var = _driver.batch_moments(_cat(parts), strata, design, settings, requested, stage, events,
                                          None if floors is None else floors[g])
        means.append(mean)
        lam = W @ mean
        for j in range(var.shape[1]):
            col = np.append(var[:, j], lam[j])
            if any(k == j and np.array_equal(col, c) for k, c in kept):
                continue                  # the same level predicted alike by an earlier group
            kept.append((j, col))
            var_cols.append(var[:, j])
            lam_cols.append(lam[j])
    new = _alloc.piece_allocation(W, np.column_stack(var_cols), np.array(lam_cols), np.column_stack(means), used,
                                  size)
    return {int(h): int(k) for h, k in enumerate(new) if k > 0}


def _pilot_dead(cols) -> bool:
    failed, done, _ = failures(cols)
    return bool(done) and failed == done


def _design(runs, live, settings):
    """The production design: stored in a group's batch_001 plan, else the lead group's cross-entropy step."""
    for g in live:
        stored = runs[g].ev.stored(batch_name(1))
        if stored is not None:
            _check_same_run(batch_name(1), stored[0], runs[g].fp)
            return Design.from_dict(stored[0]["design"])
    lead = runs[live[0]]
    return cross_entropy_design(lead.parts[0], lead.strata, settings, lead.requested)


def _stored_design(runs, live, stage: int) -> None:
    """Every group's design read back from the first stored plan of batch ``stage`` (a second step's, on resume)."""
    for g in live:
        stored = runs[g].ev.stored(batch_name(stage))
        if stored is not None and stored[0].get("design"):
            design = Design.from_dict(stored[0]["design"])
            for r in runs:
                r.design = design
            return


def _stored_counts(runs, live, stage: int):
    """The counts of batch ``stage`` when any group has planned it (an interrupted stage), else None."""
    stored = _stored_purpose(runs, live, stage)
    return None if stored is None else {int(h): int(n) for h, n in stored["counts"]}


def _stored_purpose(runs, live, stage: int):
    """The purpose of the first stored plan of batch ``stage`` among the groups ``live``, else None."""
    for g in live:
        stored = runs[g].ev.stored(batch_name(stage))
        if stored is not None:
            _check_same_run(batch_name(stage), stored[0], runs[g].fp)
            return stored[0]
    return None


def _view(r: "_Run", est) -> SiteRun:
    """A group's state between batches as a :class:`SiteRun` (what a ``share`` rule reads; not stopped yet)."""
    return SiteRun(r.site, r.strata, r.design, r.settings, r.stop, r.quantities, r.requested, _cat(r.parts), est,
                   "budget", r.batches, r.history, record=r.ev.record, floor=r.last_floor)


def _used(r: "_Run") -> int:
    return sum(b["runs"] for b in r.batches)


def _joint_stop(ests, runs, live, stop) -> str:
    reasons = [_stop_reason(ests[g], runs[g].requested, stop) for g in live]
    if all(r == "target" for r in reasons):
        return "target"
    return "budget" if "budget" in reasons else "failures"


def simulate_paired(site, settings, stop, evaluators, quantities, log=print, names=None, share=None) -> list:
    """Run (or resume, or read) the simulation of ``site`` for every group (one evaluator each, its own folder
    and record settings) on the same events; rank 0 only. Returns one :class:`SiteRun` per group (a dead
    group's holds its pilot). ``names``: the groups' names in what is said (default: group 0, 1, ...).
    ``share``: None (every group takes every batch until every group's levels converged), or a callable
    ``share(stage, views) -> (reason, takers)`` of the live groups' :class:`SiteRun` so far (``views``, a dict
    by group), ``reason`` "target", "failures" (stop) or "budget" (go on with the groups ``takers``)."""
    names = list(names or [f"group {g}" for g in range(len(evaluators))])
    runs = [_Run(site, settings, stop, ev, quantities, (lambda s, n=n: log(f"[{n}] {s}"))) for ev, n in
            zip(evaluators, names)]
    pilot = {h: runs[0].pilot_per_stratum for h in range(len(runs[0].strata))}
    for r in runs:
        r.run_batch(0, *r.planned(0, pilot, PILOT_MIXTURE))
    live = [g for g, r in enumerate(runs) if not _pilot_dead(r.parts[0])]
    for g in sorted(set(range(len(runs))) - set(live)):
        failed, done, text = failures(runs[g].parts[0])
        log(f"[{names[g]}] every one of the pilot's {done} runs failed, e.g. {text}: this run setting gets no more "
            "runs; its levels are unresolved in every output")
    stage, stopped = 1, "budget"
    if live:
        design = _design(runs, live, settings)
        for r in runs:
            r.design = design
        for note in design.notes:
            log(f"cross-entropy step ({names[live[0]]}'s pilot): {note}")
        thin = _driver.thin_of(runs[live[0]].parts[0], runs[live[0]].strata, settings, runs[live[0]].requested)
    took, ests = list(live), {}
    while live:
        for g in took:                                 # a group that sat out the last batch keeps its estimate
            ests[g] = runs[g].estimate()
            runs[g].report(stage - 1, ests[g])
        lead = runs[live[0]]
        if any(runs[g].batches[-1]["limit"] < runs[g].batches[-1]["planned"] for g in took):
            break                                      # the budget cut this batch
        used = {g: _used(runs[g]) for g in live}
        planned = _stored_purpose(runs, live, stage) if share is not None else None
        if share is None:
            takers, reason = list(live), _joint_stop(ests, runs, live, stop)
        elif planned is not None:          # a stage planned before an interruption: as planned
            takers, reason = [g for g in live if g in planned.get("takers", live)], "budget"
        elif stage == 1:                   # every live group's first production batch
            takers, reason = [g for g in live if stop.max_runs - used[g] >= lead.least_batch], "budget"
        else:
            reason, wanted = share(stage, {g: _view(runs[g], ests[g]) for g in live})
            takers = [g for g in live if g in set(wanted) and stop.max_runs - used[g] >= lead.least_batch]
            for g in (g for g in wanted if g not in takers and reason == "budget"):
                log(f"[{names[g]}] site simulation: {_alloc.runs_left_unused(stop.max_runs - used[g], len(lead.strata))}")
        counts = _stored_counts(runs, takers if planned is None else live, stage)
        if counts is None:
            stopped = reason
            room = min((stop.max_runs - used[g] for g in takers), default=0)
            if stopped != "budget" or room < lead.least_batch:
                if stopped == "budget" and 0 < room:
                    log(f"site simulation: {_alloc.runs_left_unused(room, len(lead.strata))}")
                break                     # converged, or the runs left cannot visit every stratum twice
            if stage == 2 and thin:       # the driver's second cross-entropy step, on the lead group's rows
                design = _driver.second_design(_cat(lead.parts), lead.strata, lead.design, settings, lead.requested, thin)
                for r in runs:
                    r.design = design
            idx = [lead.quantities.index(q) for q in lead.requested]
            counts = joint_counts([runs[g].parts for g in takers], lead.strata, lead.design, settings, lead.requested,
                                  stage, min(used[g] for g in takers), lead.steering_events(),
                                  min(settings.batch, room),
                                  [None if runs[g].last_floor is None else runs[g].last_floor[:, idx] for g in takers])
        else:
            _stored_design(runs, live, stage)
        extra = None if share is None else {"takers": list(takers)}
        for g in takers:
            runs[g].run_batch(stage, *runs[g].planned(stage, counts, runs[g].design.latest, extra))
        took = takers
        stage += 1
    out = []
    for g, r in enumerate(runs):
        est = r.estimate()
        out.append(SiteRun(site, r.strata, r.design, settings, stop, r.quantities, r.requested, _cat(r.parts), est,
                           stopped if g in live else "failures", r.batches, r.history, record=r.ev.record,
                           floor=r.last_floor))
    return out
