"""The stratified event-based simulation of a site: pilot, one cross-entropy step, batches, stopping rule.

1. *Pilot* (stage 0, ``batch_000``): ``pilot_per_stratum`` runs in every stratum (by default sized per
   site, :meth:`SiteSettings.pilot_for`: 5, or more where the site has few strata, so that the pilot
   holds at least :data:`PILOT_MIN_RUNS` runs and the cross-entropy step more than one run's normals),
   the pulse quantiles drawn from :data:`~pycolfrag.rare.proposal.PILOT_MIXTURE`.
2. *Cross-entropy step*: the production mixture's shifts from the pilot's rows
   (:func:`~pycolfrag.rare.proposal.cross_entropy_means`); stored in the plan of ``batch_001`` (and of
   every later batch) before its first run. Where no level of a family was exceeded by ``ce_min_hits`` pilot runs
   (:func:`~pycolfrag.rare.proposal.thin_families`), a *second step* on every row after ``batch_001`` places
   the proposal of ``batch_002`` on (stored in their plans, read back on resume).
3. *Batches* (stages 1, 2, ...): ``batch`` runs each, every one allocated on its own by the minimax-CoV Neyman
   rule of :mod:`~pycolfrag.rare.allocation` (steered by every row so far; every stratum at least 2 runs), its
   stratified estimate a piece that the estimator combines with the pilot's and the other batches' in
   proportion to their runs (unbiased whatever the steering, at a fixed budget: docs/rare_events.md, "Batches as
   pieces (v5)"), until every requested level reaches the target CoV with at least ``min_neff`` effective
   exceedances and no run carrying more than ``max_share`` of it (a stop on the estimates: a small high bias,
   measured there), or the run budget is spent (runs left that cannot give every stratum 2 are not run). The estimate and CoV of every level
   are said after every batch.

Every batch goes through an evaluator (:class:`~pycolfrag.rare.evaluator.GridEvaluator`: the grid's
scheduler on every rank); its plan is on disk before it runs, so a resume -- after a kill -9 too --
reads the plans back and computes the same runs: the final estimate is the uninterrupted one. A resume
whose site or settings differ from those the folder began with is refused, listing the differences.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
from collections import Counter
from dataclasses import dataclass, field, fields, is_dataclass
from types import ModuleType

import numpy as np

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError, ResultsFileError
from pycolfrag.rare import allocation as _alloc
from pycolfrag.rare import proposal as _proposal
from pycolfrag.rare.estimate import DEFAULT_MAX_SHARE, DEFAULT_MIN_NEFF, UNRESOLVED, estimate, exceedances, row_weights
from pycolfrag.rare.plans import PulseMap, interleave, plan_inputs
from pycolfrag.rare.proposal import PILOT_MIXTURE, Design, cross_entropy_means, families_of, production_mixture, score
from pycolfrag.rare.strata import DEFAULT_MW_STEP, DEFAULT_R_EDGES_KM, build_strata

__all__ = ["DEFAULT_SEED", "SiteSettings", "StopRule", "SiteRun", "site_fingerprint", "simulate_site", "batch_name",
           "ALGORITHM", "failures", "cross_entropy_design", "thin_of", "second_design", "allocate_batch", "batch_moments"]

#: The root seed when none is given (the grid's).
DEFAULT_SEED = 20160601
#: What a batch's purpose names the algorithm (a change of what the plans mean changes it): v2 sizes the
#: last batch by the runs left in the budget (v1 planned whole batches); v3 sizes the pilot per site, floors
#: the allocation's variances and runs (strata with no exceedance, strata that matter) and may take a second
#: cross-entropy step: the same command and seed plan other runs, and an older folder is not resumed; v4
#: estimates every stratum's mean with the weights' known mean as a control variate (rare/estimate.py): other
#: estimates, hence other stopping and allocation, so a v3 folder is not resumed either.
#: v5 allocates every production batch on its own (every stratum at least 2 runs) and combines the batches'
#: stratified estimates as pieces with weights their sizes: the steered allocation left the pooled means biased low
#: (docs/rare_events.md, "Batches as pieces").
ALGORITHM = "stratified site simulation, defensive mixture, cross-entropy steps, batches as pieces; v5"
#: The fewest runs a pilot sized per site holds (5 per stratum where that is more).
PILOT_MIN_RUNS = 60
#: Runs per stratum of a pilot sized per site, where the strata are many.
PILOT_PER_STRATUM = 5


def batch_name(stage: int) -> str:
    return f"batch_{int(stage):03d}"


@dataclass(frozen=True)
class SiteSettings:
    """The settings that fix which runs a site simulation makes (signed: a resume must match them).

    seed -- root seed; pilot_per_stratum -- runs per stratum in the pilot (>= 2: a variance needs two; None:
    sized per site, :meth:`pilot_for`);
    batch -- runs per production batch; defensive -- alpha_0, the nominal share of the production
    mixture (in [0.1, 1]: the weights' bound is 1 / alpha_0); mw_step, r_edges_km -- the strata's bins;
    ce_min_hits, ce_quantile -- the cross-entropy step's elite set; levels -- the labels of the levels the
    stopping rule and the shifts serve (empty: every level).
    """

    seed: int = DEFAULT_SEED
    pilot_per_stratum: int | None = None
    batch: int = 2000
    defensive: float = 0.3
    mw_step: float = DEFAULT_MW_STEP
    r_edges_km: tuple = DEFAULT_R_EDGES_KM
    ce_min_hits: int = 20
    ce_quantile: float = 0.9
    levels: tuple = ()

    def __post_init__(self):
        for name, lo in (("seed", 0), ("pilot_per_stratum", 2), ("batch", 1), ("ce_min_hits", 1)):
            v = getattr(self, name)
            if v is None and name == "pilot_per_stratum":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
        if not (isinstance(self.defensive, (int, float)) and 0.1 <= self.defensive <= 1.0):
            raise ParameterError(f"defensive (alpha_0) must be in [0.1, 1]: below it one run may carry up to "
                                 f"1/alpha_0 of its stratum and the weights degenerate; got {self.defensive!r}")
        if not (isinstance(self.mw_step, (int, float)) and 0.01 <= self.mw_step <= 2.0):
            raise ParameterError(f"mw_step must be in [0.01, 2], got {self.mw_step!r}")
        edges = tuple(float(x) for x in self.r_edges_km)
        if any(not math.isfinite(x) or x <= 0 for x in edges) or list(edges) != sorted(set(edges)):
            raise ParameterError(f"r_edges_km must be increasing positive distances, got {self.r_edges_km!r}")
        if not 0.0 < self.ce_quantile < 1.0:
            raise ParameterError(f"ce_quantile must be in (0, 1), got {self.ce_quantile!r}")
        object.__setattr__(self, "r_edges_km", edges)
        object.__setattr__(self, "levels", tuple(self.levels))

    def as_dict(self) -> dict:
        return {f.name: (list(v) if isinstance(v, tuple) else v) for f in fields(self) for v in [getattr(self, f.name)]}

    def pilot_for(self, n_strata: int) -> int:
        """The pilot's runs per stratum at a site of ``n_strata`` strata: ``pilot_per_stratum`` when given,
        else :data:`PILOT_PER_STRATUM`, or ceil(:data:`PILOT_MIN_RUNS` / n_strata) where that is more (a site of
        few strata: at 2 strata 5 runs each left the cross-entropy shift one run's normals)."""
        if self.pilot_per_stratum is not None:
            return int(self.pilot_per_stratum)
        return max(PILOT_PER_STRATUM, -(-PILOT_MIN_RUNS // max(int(n_strata), 1)))


@dataclass(frozen=True)
class StopRule:
    """When the simulation stops (not signed: a resume may change it)."""

    target_cov: float = 0.2
    max_runs: int = 20000
    min_neff: float = DEFAULT_MIN_NEFF
    max_share: float = DEFAULT_MAX_SHARE
    confidence: float = 0.90

    def __post_init__(self):
        t = self.target_cov
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (0.0 < t < 1.0):
            raise ParameterError(f"the target CoV must be in (0, 1) (a coefficient of variation of 0 needs infinitely "
                                 f"many runs, one of 1 or more says nothing), got {t!r}")
        if isinstance(self.max_runs, bool) or not isinstance(self.max_runs, (int, np.integer)) or self.max_runs < 1:
            raise ParameterError(f"max_runs must be an integer >= 1, got {self.max_runs!r}")


@dataclass
class SiteRun:
    """A site simulation's outcome (rank 0): its strata, design, rows, estimate and history."""

    site: object
    strata: object
    design: Design
    settings: SiteSettings
    stop: StopRule
    quantities: tuple
    requested: tuple
    cols: dict
    estimate: object
    stopped: str                     # "target", "failures" (the rest unresolved at the target CoV) or "budget"
    batches: list = field(default_factory=list)
    history: list = field(default_factory=list)
    record: object = None            # the evaluator's RecordSettings: what every run was computed with
    floor: object = None             # the estimate's variance floor (H, L) (estimate.py), for estimates of parts

    @property
    def runs(self) -> int:
        return int(np.sum(np.asarray(self.cols["status"]) != _results.STATUS_PENDING))


def _described(x):
    """A site part as plain JSON: dataclass fields, a module by its NAME."""
    if isinstance(x, ModuleType):
        return getattr(x, "NAME", x.__name__)
    if is_dataclass(x):
        d = {f.name: _described(getattr(x, f.name)) for f in fields(x)}
        return {"type": getattr(x, "TYPE", type(x).__name__), **d}
    if isinstance(x, (list, tuple)):
        return [_described(v) for v in x]
    return x


def site_fingerprint(site) -> dict:
    """What fixes a site's events (its sources as read, ``outside``), with the SHA-256 of its canonical JSON."""
    d = {"outside": site.outside, "sources": [_described(s) for s in site.sources]}
    return {"sha256": hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest(), **d}


def _fingerprint(site, settings: SiteSettings, quantities) -> dict:
    return {"algorithm": ALGORITHM, "site": site_fingerprint(site), "settings": settings.as_dict(),
            "levels": [[q.label, q.edp, q.threshold] for q in quantities]}


def _check_same_run(name: str, stored_purpose: dict, fp: dict) -> None:
    diffs = _results.signature_mismatch(stored_purpose.get("run", {}), fp)
    if diffs:
        raise ResultsFileError(
            f"the folder's {name} was planned by a simulation of another site or with other settings:\n  - "
            + "\n  - ".join(diffs) + "\nResuming would mix two designs in one estimate: rerun with the site file and "
            "settings it began with, or use another folder.")


def _cat(parts: list) -> dict:
    return {k: np.concatenate([np.asarray(p[k]) for p in parts]) for k in parts[0]}


def _ce_inputs(cols, strata, design, requested):
    """(z, contrib, y, scores) of the successful pulse rows of ``cols`` for the cross-entropy program, each row
    weighted under its own stage's mixture of ``design``; None without a pulse row."""
    ok = np.asarray(cols["status"]) == 0
    sub = {k: np.asarray(v)[ok] for k, v in cols.items()}
    w, _ = row_weights(sub, strata, design)
    h = np.asarray(sub["stratum"])
    n_h = np.bincount(h, minlength=len(strata))
    contrib = strata.rates[h] * w / np.maximum(n_h[h], 1)
    pulse = np.asarray(sub["pulse"], dtype=bool)
    if not pulse.any():
        return None
    z = np.column_stack([sub["z_vp"][pulse], sub["z_fp"][pulse]])
    y = {q.label: exceedances(sub, q)[pulse] for q in requested}
    scores = {f: score(sub, f)[pulse] for f in families_of(requested)}
    return z, contrib[pulse], y, scores


def cross_entropy_design(cols, strata, settings, requested) -> Design:
    """The production mixture from the pilot's rows (every stratum's weights under the pilot's proposal)."""
    got = _ce_inputs(cols, strata, Design(PILOT_MIXTURE), requested)
    if got is None:
        return Design(PILOT_MIXTURE, production_mixture(settings.defensive, ()), ("no stratum with a pulse",))
    means, notes = cross_entropy_means(*got, requested, min_hits=settings.ce_min_hits, quantile=settings.ce_quantile)
    return Design(PILOT_MIXTURE, production_mixture(settings.defensive, means), tuple(notes))


#: The cross-entropy steps (first, whether its elite was thin, second) and the batch allocation as the rare
#: sequences (pycolfrag.risk.sequences_rare) take them too, their rows as this simulation's columns: one text each.

def thin_of(cols, strata, settings, requested) -> tuple:
    """The families whose first step's elite (from the pilot ``cols``) held fewer than ``ce_min_hits`` runs."""
    got = _ce_inputs(cols, strata, Design(PILOT_MIXTURE), requested)
    return () if got is None else _proposal.thin_families(*got, requested, min_hits=settings.ce_min_hits,
                                                             quantile=settings.ce_quantile)


def second_design(cols, strata, design: Design, settings, requested, thin) -> Design:
    """The second cross-entropy step: the same program on every row so far (the pilot's and the first
    production batch's, each under its own stage's mixture), the proposal of the batches from stage 2 on."""
    means, notes = cross_entropy_means(*_ce_inputs(cols, strata, design, requested), requested,
                                       min_hits=settings.ce_min_hits, quantile=settings.ce_quantile)
    why = (f"second step (the first step's elite was thin: no level exceeded by {settings.ce_min_hits} pilot runs, for "
           f"{', '.join(thin)}), ")
    return Design(design.pilot, design.production, design.notes + tuple(why + n for n in notes),
                  production_mixture(settings.defensive, means))


def failures(cols) -> tuple[int, int, str]:
    """(failed runs, finished runs, the most common failure message with its count) of a simulation's rows."""
    status = np.asarray(cols["status"])
    done = status != _results.STATUS_PENDING
    bad = done & (status != _results.STATUS_OK)
    if not bad.any():
        return 0, int(np.sum(done)), ""
    raw = np.asarray(cols["message"])[bad] if "message" in cols else np.full(int(np.sum(bad)), b"")
    texts = [(m.decode("utf-8", "replace") if isinstance(m, bytes) else str(m)) or "(no message)" for m in raw]
    kinds = Counter(re.sub(r"\d[\d.eE+-]*", "#", t) for t in texts)     # the same failure with other numbers
    kind, k = kinds.most_common(1)[0]
    example = next(t for t in texts if re.sub(r"\d[\d.eE+-]*", "#", t) == kind)
    return int(np.sum(bad)), int(np.sum(done)), f"{example!r} ({k} of them alike)"


def _stop_reason(est, requested, stop: StopRule) -> str:
    """"target" when every requested level converged; "failures" when the others are unresolved with their CoV
    at the target already (more runs shrink the CoV, not the range the failed runs leave); else "budget"."""
    levels = [est.levels[q.label] for q in requested]
    if all(e.status == "converged" for e in levels):
        return "target"
    if all(e.status == "converged" or (e.status == UNRESOLVED and e.cov <= stop.target_cov) for e in levels):
        return "failures"
    return "budget"


def _check_pilot(cols) -> None:
    """Refuse to go on when not one run of the pilot succeeded: every later run would fail as well, and a
    failed run says nothing of the levels (ParameterError with the most common failure)."""
    failed, done, text = failures(cols)
    if done and failed == done:
        raise ParameterError(f"every one of the pilot's {done} runs failed, e.g. {text}: the column, solver or record "
                             "settings (--vp-scale, --record-dt, --solver) cannot be run; the failed runs are in the "
                             "folder's batch_000.h5")


def batch_moments(cols, strata, design, settings, requested, stage: int, events, floor=None) -> tuple:
    """``(mean, var)`` (H, L): every stratum's predicted mean and variance of w y of the requested levels under
    the latest proposal, by the steering model fitted on ``cols`` (each variance at least the estimate's ``floor``,
    so that the allocation sees the variance the estimate states)."""
    model = _alloc.SteeringModel(cols, requested)
    rng = np.random.default_rng(np.random.SeedSequence(settings.seed, spawn_key=(_alloc.STREAM_STEER, stage)))
    mean, var = _alloc.predicted_moments(strata, design.latest, model, requested, rng, events)
    return mean, (var if floor is None else np.maximum(var, floor))


def allocate_batch(cols, strata, design, settings, requested, stage: int, used: int, events, size: int,
                   floor=None) -> dict:
    """The ``size`` runs of production batch ``stage`` per stratum: the batch's own minimax-CoV Neyman split,
    steered by every row so far, at least :func:`~pycolfrag.rare.allocation.piece_floor` in every stratum
    (:func:`~pycolfrag.rare.allocation.piece_allocation`): the batch is a stratified sample of counts fixed
    before it runs, its estimate a piece the estimator combines with the others (v5)."""
    mean, var = batch_moments(cols, strata, design, settings, requested, stage, events, floor)
    W = strata.rates
    new = _alloc.piece_allocation(W, var, W @ mean, mean, used, size)
    return {int(h): int(k) for h, k in enumerate(new) if k > 0}


def _progress_lines(stage: int, runs: int, est, requested, stop: StopRule) -> list:
    failed = est.n_failed
    lines = [f"site simulation: batch {stage} done, {runs} runs" + (f", {failed} FAILED" if failed else "")
             + f" (target CoV {stop.target_cov:g}, budget {stop.max_runs})",
             f"  {'level':<16} {'rate /yr':>10} {'CoV':>7} {'n_eff':>7} {'top run':>8}"
             + (f" {'failed runs as none - as exceeding':>35}" if failed else "") + "  status"]
    for q in requested:
        e = est.levels[q.label]
        share = f"{100 * e.max_share:7.1f}%" if math.isfinite(e.max_share) else f"{'-':>8}"
        span = f" {e.failed_low:16.3e} - {e.failed_high:<16.3e}" if failed else ""
        lines.append(f"  {q.label:<16} {e.rate:10.3e} {e.cov:7.3f} {e.n_eff:7.1f} {share}{span}  {e.status}")
    return lines


class _Run:
    """The state of one simulation between its batches (rank 0)."""

    def __init__(self, site, settings, stop, evaluator, quantities, log):
        self.site, self.settings, self.stop, self.ev, self.log = site, settings, stop, evaluator, log
        self.quantities = tuple(quantities)
        labels = {q.label for q in self.quantities}
        unknown = [x for x in settings.levels if x not in labels]
        if unknown:
            raise ParameterError(f"unknown level(s) {unknown}; known: {sorted(labels)}")
        self.requested = tuple(q for q in self.quantities if not settings.levels or q.label in settings.levels)
        self.strata = build_strata(site, settings.mw_step, settings.r_edges_km)
        self.pilot_per_stratum = settings.pilot_for(len(self.strata))
        pilot = self.pilot_per_stratum * len(self.strata)
        if stop.max_runs < pilot:
            raise ParameterError(f"--max-runs {stop.max_runs} is below one pilot: {pilot} runs ({self.pilot_per_stratum} "
                                 f"in each of the site's {len(self.strata)} strata)")
        least = _alloc.PIECE_MIN_RUNS * len(self.strata)
        if settings.batch < least:
            raise ParameterError(f"--batch {settings.batch} is below {least} runs: every batch gives each of the site's "
                                 f"{len(self.strata)} strata at least {_alloc.PIECE_MIN_RUNS} (its own stratified "
                                 "estimate, a piece of the whole)")
        self.least_batch = least
        rec = evaluator.record
        self.pulse_map = PulseMap(rec.pulse_shape, rec.vp_scale, rec.tp_model, rec.vp_model)
        self.fp = _fingerprint(site, settings, self.quantities)
        self.parts, self.batches, self.history = [], [], []
        self.design = Design(PILOT_MIXTURE)
        self._events = None
        self.last_floor = None

    def planned(self, stage: int, counts: dict, mixture, extra=None):
        """(inputs, purpose) of batch ``stage``: the stored plan, or a new one from ``counts`` (``extra``: more of
        the purpose, e.g. the run settings that take the batch)."""
        name = batch_name(stage)
        stored = self.ev.stored(name)
        if stored is not None:
            _check_same_run(name, stored[0], self.fp)
            return stored[1], stored[0]
        runs = interleave(counts, {})
        purpose = {"run": self.fp, "stage": stage, "counts": sorted([h, n] for h, n in counts.items()),
                   "design": self.design.as_dict() if stage > 0 else None, **(extra or {})}
        return plan_inputs(self.strata, self.settings.seed, stage, runs, mixture, self.pulse_map), purpose

    def run_batch(self, stage: int, inputs, purpose) -> int:
        used = sum(b["runs"] for b in self.batches)
        limit = max(0, min(len(inputs), self.stop.max_runs - used))   # a smaller budget on resume: nothing more
        cols = self.ev.evaluate(batch_name(stage), inputs, purpose, limit)
        if limit < len(inputs):   # a batch finished by a larger budget, read under this one: its prefix alone
            status = np.array(cols["status"])
            status[limit:] = _results.STATUS_PENDING
            cols = {**cols, "status": status}
        runs = int(np.sum(np.asarray(cols["status"]) != _results.STATUS_PENDING))
        self.parts.append(cols)
        self.batches.append({"name": batch_name(stage), "stage": stage, "planned": len(inputs), "runs": runs,
                             "limit": limit})
        return limit

    def steering_events(self) -> list:
        """The allocation's draws of every stratum's events (once per simulation; they only steer)."""
        if self._events is None:
            rng = np.random.default_rng(np.random.SeedSequence(self.settings.seed, spawn_key=(_alloc.STREAM_STEER,)))
            self._events = _alloc.steering_events(self.strata, rng)
        return self._events

    def floor(self, cols):
        """The estimate's variance floor of the strata none of whose runs exceed a level (the steering model's)."""
        rng = np.random.default_rng(np.random.SeedSequence(self.settings.seed,
                                                           spawn_key=(_alloc.STREAM_STEER, _alloc.STREAM_FLOOR)))
        return _alloc.variance_floor(cols, self.strata, self.design, self.quantities, rng, self.steering_events())

    def estimate(self):
        cols = _cat(self.parts)
        self.last_floor = self.floor(cols)
        return estimate(cols, self.strata, self.design, self.quantities, confidence=self.stop.confidence,
                        min_neff=self.stop.min_neff, max_share=self.stop.max_share, target_cov=self.stop.target_cov,
                        floor=self.last_floor, pieces=True)

    def report(self, stage: int, est) -> None:
        runs = sum(b["runs"] for b in self.batches)
        self.history.append({"stage": stage, "runs": runs, "levels": {q.label: [est.levels[q.label].rate,
                             est.levels[q.label].cov, est.levels[q.label].n_eff] for q in self.requested}})
        for line in _progress_lines(stage, runs, est, self.requested, self.stop):
            self.log(line)


def simulate_site(site, settings: SiteSettings, stop: StopRule, evaluator, quantities, log=print) -> SiteRun:
    """Run (or resume, or read) the simulation of ``site`` in the evaluator's folder; rank 0 only (the
    evaluator's other ranks serve). Returns the :class:`SiteRun`.

    ``quantities``: the levels (``label``, ``edp``, ``threshold``; collapse with ``edp`` None), e.g.
    :data:`pycolfrag.risk.site_risk.QUANTITIES`."""
    run = _Run(site, settings, stop, evaluator, quantities, log)
    pilot = {h: run.pilot_per_stratum for h in range(len(run.strata))}
    run.run_batch(0, *run.planned(0, pilot, PILOT_MIXTURE))
    _check_pilot(run.parts[0])
    stored = evaluator.stored(batch_name(1))
    if stored is not None:
        _check_same_run(batch_name(1), stored[0], run.fp)
        run.design = Design.from_dict(stored[0]["design"])
    else:
        run.design = cross_entropy_design(run.parts[0], run.strata, settings, run.requested)
    for note in run.design.notes:
        log(f"cross-entropy step: {note}")
    thin = thin_of(run.parts[0], run.strata, settings, run.requested)
    stage, stopped = 1, "budget"
    while True:
        est = run.estimate()
        run.report(stage - 1, est)
        used = sum(b["runs"] for b in run.batches)
        if run.batches[-1]["limit"] < run.batches[-1]["planned"]:
            break                                      # the budget cut this batch
        if evaluator.stored(batch_name(stage)) is None:
            stopped = _stop_reason(est, run.requested, stop)
            if stopped != "budget":
                break
            if stop.max_runs - used < run.least_batch:
                if used < stop.max_runs:
                    log(f"site simulation: {_alloc.runs_left_unused(stop.max_runs - used, len(run.strata))}")
                break
            if stage == 2 and thin:
                first = len(run.design.notes)      # the second step's notes follow the first's
                run.design = second_design(_cat(run.parts), run.strata, run.design, settings, run.requested, thin)
                for note in run.design.notes[first:]:
                    log(f"cross-entropy step: {note}")
            idx = [run.quantities.index(q) for q in run.requested]
            counts = allocate_batch(_cat(run.parts), run.strata, run.design, settings, run.requested, stage, used,
                               run.steering_events(), min(settings.batch, stop.max_runs - used),
                               None if run.last_floor is None else run.last_floor[:, idx])
        else:
            counts = {}
            run.design = Design.from_dict(evaluator.stored(batch_name(stage))[0]["design"])
        run.run_batch(stage, *run.planned(stage, counts, run.design.latest))
        stage += 1
    return SiteRun(site, run.strata, run.design, settings, stop, run.quantities, run.requested, _cat(run.parts), est,
                   stopped, run.batches, run.history, record=evaluator.record, floor=run.last_floor)
