"""Sequences at a site by importance sampling on the sequence's strongest event (docs/sequences.md, "Rare
sequences").

Crude sequences (:mod:`pycolfrag.risk.sequences`) spend their runs where nothing happens: at the example
site a collapse within 50 years has a probability of about 7e-5, which crude Monte Carlo would need some
350 000 sequences to measure at a CoV of 0.2. Here every sequence is a row of the rare-event route's
strata, on its one strongest event.

**The estimator.** Let the site's mainshocks over [0, T] be a Poisson process Phi of intensity measure
Lambda(dx) = T lambda(dm) dt / T over marks x (time, source, Mw, R, pulse occurrence, the pulse's normals,
the record's noise), A an outcome of the sequence (a collapse within T, a level exceeded), and s(x) a
deterministic score of an event. Exactly one event of a sequence is its strongest, events ranked by
(s, time) (the score ties where the marks are discrete -- a characteristic magnitude at a fixed distance
without a pulse -- and the times, uniform, break those ties with probability one), so
1_A(Phi) = sum over x in Phi of 1{x strongest in Phi} 1_A(Phi), and the
Mecke (Campbell-Little-Mecke) formula of Poisson processes gives

    P(A) = integral of E[ 1{x strongest in Phi + x} 1_A(Phi + x) ] Lambda(dx),

the expectation over Phi, the process itself, independent of x. The integral over x is the rare route's:
its strata h with rates W_h (1/yr), x drawn from the stratum's proposal with weight w(x) = the density
ratio of the natural law to the proposal (occurrence weight times the pulse normals' ratio:
:func:`pycolfrag.rare.plans.event_input`, the same inputs as the rare route's run (stage, h, j)), and
its time uniform on [0, T] (the pilot's rows under the rare route's pilot proposal, the later rows under a
production proposal the cross-entropy steps place, below; each row's weight is that of its own
proposal, so the estimate is unbiased for any). So a row (h, j) draws x, its time, and one natural sequence Phi (its own
streams), and contributes y = T W_h w(x) 1{x strongest} 1_A; P(A) = sum_h E_h[y], estimated by the strata's
means, its variance by the strata's sample variances (a stratum with no row in A: the rare route's floor,
below). A row whose x is not the strongest contributes 0 and costs no run: that sequence is counted
where its strongest event is the row's x. The estimate is unbiased for any score; the score only sets
the variance. Ours ranks events by the pulse's peak velocity Vp when the motion has a pulse, and by
exp(-1) times Eq. (6)'s median Vp of the event's (Mw, R) when it has none (:func:`strength`): a rank,
not a model.

**Aftershocks** (``sequences.aftershocks``; docs/sequences.md, "Aftershocks in the rare sequences"). The process
is then the mainshocks', each carrying its aftershocks as its mark (given the mainshock, a Poisson process: the
marking theorem keeps the whole a Poisson process), and the ranking is over the mainshocks alone (an aftershock,
which may be stronger than its mainshock, is never ranked). A row's natural sequence holds its mainshocks'
aftershocks (the crude sequences' draws on the row's streams), and x's own are drawn given x from the row's streams
(3, :data:`X_AFTERSHOCKS`; its directivity geometry given its branch from 4, :data:`X_GEOMETRY`): the same law under
the proposal and the target, so the weight stays the mainshock's. A site with mainshocks outside the models whose
aftershocks may lie inside is refused (:func:`refuse_outside_aftershocks`): no row could count their sequences.

Each row is run the ways of the crude sequences (accumulated, intact, restored: :func:`pycolfrag.risk.sequences.run_one`,
the same calls; ``ways``, the accumulated one and any of the others), so the paired differences come with it.

**The tail** (``tail_share`` q; docs/sequences.md, "The tail after the strongest event"): a row runs the events after
x with probability q (its own stream :data:`X_TAIL`, drawn before any run), else stops at x; a hit first seen after
x counts 1 / q. The tail's hits only add to those up to x, so the estimate stays unbiased; q = 1 (the default) runs
every tail.

**Allocation** (the rare route's steps, one text each: :mod:`pycolfrag.rare.driver`, :mod:`pycolfrag.rare.allocation`).
A pilot of ``pilot`` rows per stratum under the rare route's pilot proposal; then the production proposal: the
rare route's cross-entropy step on the pilot's rows for the target's family (collapse: the top displacement's;
the elite the rows with a collapse once :data:`CE_MIN_HITS` have one, else the top of the sequences' peak u_top),
and its second step on the rows of the first batch where that elite was thin (rows of stage 2 on); ``mixture``
fixes it instead. Then batches spread by the rare route's minimax Neyman allocation on the target (the
accumulated way's collapse by default): the steering model's predicted standard deviation of w y per stratum
(logistic on the rows' strongest events: Mw, ln R and the pulse normals), each at least the estimate's floor,
a stratum predicted to carry 1 % of the target, or with 1 % of the site's rate, keeping 20 rows -- until the
target's CoV (with the floor) reaches ``target_cov`` or ``max_rows`` rows are used. The floor of a stratum with no
row in A is the rare route's (:func:`pycolfrag.rare.allocation.variance_floor`): the predicted Var[w y] of the
smaller of the steering and demand models' probabilities (the demand model: ln of the row's peak EDP linear in
the same features, collapse read as the largest peak u_top a standing sequence reached), at most the Jeffreys
pseudo-count's (s_h^2 <= (T W_h)^2 (m2 p_J - p_J^2), p_J = 0.5 / (n_h + 1), m2 the mean square weight). The CoV from
the sample variances alone is stated beside (``cov_sample``), with how much of the estimate rests on strata of
fewer than 20 rows. v1 (a fixed shift, the bare pseudo-count and plain Neyman) spread the rows as crude sampling
would where the rare level lies in a few strata (docs/sequences.md). A row whose event is not the strongest is,
to the models, an event that exceeds nothing (its y is 0), with no EDP (the demand model leaves it out).

Runs are spread over MPI ranks (each batch's rows dealt by index, the rows then shared by every rank:
every rank takes the same decisions), and every finished row is a line of ``OUT/rows.jsonl`` (rank 0's),
so a stopped run resumes: the journal's identity is that of :mod:`pycolfrag.risk.sequences_run` plus the
rare settings (:func:`journal_settings`: a row budget that cuts no batch is not part of it, so that a run its
budget stopped goes on under a larger one).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from pycolfrag.core.errors import ParameterError, RareEventError
from pycolfrag.damage import PERFORMANCE_LEVELS
from pycolfrag.ground_motion.rupakhety_2011 import mean_vp_cm_s
from pycolfrag.rare import allocation as _alloc
from pycolfrag.rare.driver import SiteSettings, allocate_batch, cross_entropy_design, second_design, thin_of
from pycolfrag.rare.estimate import jeffreys_run_variance, piece_factors, piece_parts, piece_variance, piece_weights
from pycolfrag.rare.plans import PulseMap, event_input
from pycolfrag.rare.proposal import PILOT_MIXTURE, Design, Mixture
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk.grid_route import QUANTITIES as _RISK_QUANTITIES
from pycolfrag.risk.sequences import (
    WAYS,
    SequenceSettings,
    SiteEvent,
    aftershocks_of,
    check_ways,
    run_one,
    sequence_events,
)

__all__ = ["ALGORITHM", "STREAM_RARE_SEQUENCES", "NO_PULSE_OFFSET", "strength", "RareSequenceSettings", "run_row",
           "refuse_outside_aftershocks", "X_AFTERSHOCKS", "X_GEOMETRY", "X_TAIL", "TAIL_SHARE",
           "estimate", "allocate", "floors", "design_of", "simulate_sequences", "estimate_rows", "QUANTITIES", "LEVELS",
           "settings_dict", "journal_settings", "tails_run", "format_estimate"]

#: What the rows and decisions mean (part of a journal's identity: an older folder is refused by name, not
#: resumed). v2: a row stores its strongest event's features and each way's peak EDPs; the production proposal
#: is the rare route's cross-entropy step on the pilot's rows for the target's family (unless ``mixture`` is
#: given); the variance floor of a stratum without a hit and the batches' allocation are the rare route's
#: (steering and demand models, run floor, minimax Neyman). v1 (no name in its identity): a fixed shift, the
#: bare Jeffreys floor and plain Neyman.
#: v3: every batch allocated on its own (every stratum at least 2 rows) and the strata's means the batches'
#: combined as pieces, as the rare route's v5 (a row stores its ``batch``): the pooled means under the steered
#: allocation were biased low (docs/sequences.md, "The steered allocation's bias").
#: v4: Russian roulette on the tail (the events after x: :data:`TAIL_SHARE`), a row stores which of its hits came
#: after x (``late``) and its ``tail_weight``; the ways run are a setting (``ways``).
ALGORITHM = ("rare sequences on the strongest event: the rare route's cross-entropy shift, demand-model variance "
             "floor and model-steered allocation, batches as pieces, roulette on the tail after x; v4")

#: Stream identifier of a row's own draws (its time, its natural sequence); the crude sequences' is 4.
STREAM_RARE_SEQUENCES = 5
#: The run stages of the rows' strongest events in the rare route's streams: the pilot's, the batches' under the
#: first cross-entropy step's proposal, and those under the second step's (the rare route's stages).
PILOT_STAGE, PRODUCTION_STAGE, SECOND_STAGE = 0, 1, 2
#: The fewest rows exceeding the target in the cross-entropy step's elite (the rare route's ``ce_min_hits``, 20,
#: made for its pilot of single events): below it, the rows above the family's weighted 0.9 quantile -- for collapse,
#: those of u_top > 0.15, a lower level's elite (at the example site its shift, about (+0.95, -0.4), stayed far from
#: the collapses' normals, about (+2.3, -0.6)). A collapse within 50 years is seen a few times in the sequences'
#: first rows; the cross-entropy program's answer on them is the weighted mean of the collapses' own normals, and the
#: defensive share bounds every weight whatever it is.
CE_MIN_HITS = 3
#: The production proposal's defensive share alpha_0 of the natural law (the rare route's). Its shift is the
#: cross-entropy step's on the pilot (:func:`design_of`). A proposal: it sets the variance, never the estimate.
DEFENSIVE = 0.3
#: A motion without a pulse ranks as a pulse of exp(-NO_PULSE_OFFSET) times Eq. (6)'s median Vp.
NO_PULSE_OFFSET = 1.0
#: A row's own streams for its event x's aftershocks and for the directivity geometry they carry pulses with
#: (after ``(STREAM_RARE_SEQUENCES, h, j)``; 0, (1, k) and (2, k) are its natural sequence's, 2 x's time).
X_AFTERSHOCKS, X_GEOMETRY = 3, 4
#: A row's own stream for whether its sequence's tail (the events after x) is run (:data:`TAIL_SHARE`).
X_TAIL = 6
#: The share of rows whose tail -- the events after x, the strongest -- is run (Russian roulette: the others stop
#: at x, and a hit first seen in the tail counts 1 / TAIL_SHARE). 1, the default, runs every tail (v3's rows).
#: Unbiased at any share; where and why a share below 1 may be used, and what it risks: docs/sequences.md, "The tail
#: after the strongest event" (refused with aftershocks).
TAIL_SHARE = 1.0
#: The directivity geometries drawn at a time, and the most batches, for x's pulse probability given its branch.
_GEOMETRY_BATCH, _GEOMETRY_TRIES = 64, 16384
#: The quantities of a row, per way: collapse, then each level of Tables III/IV.
QUANTITIES = ("collapse",) + tuple(lv.label for lv in PERFORMANCE_LEVELS)
#: The rare route's levels (label, edp, threshold) in the order of :data:`QUANTITIES`.
LEVELS = tuple(next(q for q in _RISK_QUANTITIES if q.label == label) for label in QUANTITIES)


def strength(mw: float, r_km: float, pulse) -> float:
    """The score that ranks a sequence's events (see the module's text)."""
    if pulse is not None:
        return math.log(float(pulse["Vp_cm_s"]))
    return math.log(float(mean_vp_cm_s(mw, r_km))) - NO_PULSE_OFFSET


@dataclass(frozen=True)
class RareSequenceSettings:
    """The rows' sequences (``sequences``: its ``n_sequences`` is not used) and the estimator's settings."""

    sequences: SequenceSettings = field(default_factory=SequenceSettings)
    target: str = "collapse"
    target_cov: float = 0.2
    pilot: int = 10
    batch: int = 400
    max_rows: int = 20000
    pilot_mixture: Mixture = PILOT_MIXTURE
    mixture: Mixture | None = None     # None: the cross-entropy step on the pilot's rows (:func:`design_of`)
    ways: tuple = WAYS
    tail_share: float = TAIL_SHARE

    def __post_init__(self):
        if not isinstance(self.sequences, SequenceSettings):
            raise ParameterError(f"sequences must be a SequenceSettings, got {type(self.sequences).__name__}")
        object.__setattr__(self, "ways", check_ways(self.ways))
        q = self.tail_share
        if isinstance(q, bool) or not isinstance(q, (int, float)) or not 0 < q <= 1:   # NaN fails too
            raise ParameterError(f"tail_share must be a number in (0, 1], got {q!r}")
        if q < 1 and self.sequences.aftershocks is not None:
            raise ParameterError(f"tail_share {q!r} with aftershocks: x's own aftershocks are in the tail, whose rare "
                                 "and heavy hits a share below 1 misses, with its error (docs/sequences.md, \"The tail "
                                 "after the strongest event\"): use 1")
        if self.target not in QUANTITIES:
            raise ParameterError(f"target must be one of {', '.join(QUANTITIES)}, got {self.target!r}")
        if not (isinstance(self.target_cov, (int, float)) and 0 < self.target_cov < 1):
            raise ParameterError(f"target_cov must be in (0, 1), got {self.target_cov!r}")
        for name, least in (("pilot", 2), ("batch", 1), ("max_rows", 1)):   # a variance needs two rows
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
                raise ParameterError(f"{name} must be an integer >= {least}, got {v!r}")
        for name in ("pilot_mixture", "mixture"):
            if not isinstance(getattr(self, name), Mixture) and not (name == "mixture" and self.mixture is None):
                raise ParameterError(f"{name} must be a Mixture, got {type(getattr(self, name)).__name__}")


def _row_rng(seed: int, h: int, j: int, part: int = 2) -> np.random.Generator:
    """Row (h, j)'s own stream ``part``: 2 its event's time, :data:`X_AFTERSHOCKS` and :data:`X_GEOMETRY`."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(STREAM_RARE_SEQUENCES, h, j, part)))


def _x_pulse_probability(strata, h: int, r_km: float, rng: np.random.Generator) -> float:
    """The pulse-occurrence probability at the directivity geometry of row event x of stratum ``h`` at ``r_km``, the
    geometry drawn from its source's law given x's branch (docs/sequences.md, "Aftershocks in the rare sequences"):
    drawn as the crude sequences draw an event's (the source's pulse model's ``draw``) and kept with probability p
    (1 - p without a pulse), the first kept of each batch taken. A model that draws no geometry (one value, a given
    p) gives its one p at once. x's aftershocks carry pulses with it, as a crude mainshock's do with its own p."""
    st = strata[h]
    model = strata.sources[st.source].pulse
    r = np.full(_GEOMETRY_BATCH, float(r_km))
    for _ in range(_GEOMETRY_TRIES):
        p = np.asarray(model.draw(r, rng)[0], dtype=float)
        if np.all(p == p[0]):
            return float(p[0])
        kept = np.flatnonzero(rng.uniform(size=p.size) < (p if st.pulse else 1.0 - p))
        if kept.size:
            return float(p[kept[0]])
    raise RareEventError(f"stratum {h} ({st.source_name}, {'pulse' if st.pulse else 'no pulse'}) at R = {r_km:g} km: "
                         f"no directivity geometry of its branch in {_GEOMETRY_BATCH * _GEOMETRY_TRIES} draws (the "
                         "branch's probability there is below 1e-6): its aftershocks' pulse occurrence is not drawn")


def refuse_outside_aftershocks(strata, rs: RareSequenceSettings) -> None:
    """With aftershocks, a site part of whose mainshocks lies outside the models where their aftershocks may lie
    inside (Mw below or above the models, or a pulse beyond the pulse model's distance) is refused by name: the rows'
    events are the strata's, inside the models, so a sequence with no mainshock inside would not be counted, while
    the crude sequences count its aftershocks (docs/sequences.md, "Aftershocks in the rare sequences"). Outside only
    by a distance beyond every model's (no-pulse R beyond its limit): its aftershocks, at its distance, are outside
    too, and nothing is lost."""
    if rs.sequences.aftershocks is None:
        return
    bad = [o for o in strata.outside if o.mw_below > 0 or o.mw_above > 0 or o.pulse > 0]
    if bad:
        raise ParameterError(
            "aftershocks in the rare sequences need every mainshock whose aftershocks may fall where the models apply "
            "to lie there itself (the rows' events are the strata's): outside the models are "
            + "; ".join(o.text() for o in bad)
            + ". Run the crude sequences (without --rare), or change the sources")


def run_row(site, strata, model, rs: RareSequenceSettings, h: int, j: int, pulse_map: PulseMap,
            mixture: Mixture | None = None, stage: int = PRODUCTION_STAGE, batch: int = 0) -> dict:
    """Row (h, j): its strongest event x (the rare route's run (stage, h, j): stage 0 and the pilot's proposal
    for the first ``rs.pilot`` rows of a stratum, ``stage`` (1 or 2) and the production proposal -- ``mixture``,
    else ``rs.mixture`` -- after them), x's time, its natural sequence, and -- when x is the strongest mainshock -- x's
    aftershocks (with ``rs.sequences.aftershocks``) and the sequence run the three ways. Returns the row as a dict
    (its hits and peak EDPs per way, x's features, its weight, its sequence's events, runs and seconds; ``batch``
    the batch it was allocated in, 0 the pilot's: a piece of the estimate)."""
    t0 = time.perf_counter()
    st = rs.sequences
    pilot = j < rs.pilot
    mixture = rs.pilot_mixture if pilot else (mixture or rs.mixture)
    if mixture is None:
        raise ParameterError(f"row ({h}, {j}) is a production row and no production proposal is placed yet")
    x = event_input(strata, st.seed, PILOT_STAGE if pilot else int(stage), h, j, mixture, pulse_map)
    t_x = float(_row_rng(st.seed, h, j).uniform(0.0, st.years))
    phi = sequence_events(site, st.years, st.seed, j, pulse_map, strata.ranges, key=(STREAM_RARE_SEQUENCES, h, j),
                          aftershocks=st.aftershocks)
    rank_x = (strength(x["mw"], x["dist_km"], x["pulse"]), t_x)   # ties of the score broken by the time
    strongest = not any(e.parent == -1 and not e.outside and (strength(e.mw, e.r_km, e.pulse), e.time_yr) >= rank_x
                        for e in phi)   # ranked over the mainshocks alone (an aftershock's parent is its mainshock)
    tags = x["tags"]
    row = {"h": h, "j": j, "stage": int(tags["stage"]), "batch": int(batch), "weight": float(tags["weight"]),
           "strongest": strongest,
           "mw": x["mw"], "dist_km": x["dist_km"], "pulse": x["pulse"] is not None,
           "z_vp": float(tags.get("z_vp", 0.0)), "z_fp": float(tags.get("z_fp", 0.0)),
           "occurrence_weight": float(tags["occurrence_weight"]), "events": len(phi) + 1, "runs": 0, "shared": 0,
           "restorations": 0, "hits": {w: [False] * len(QUANTITIES) for w in rs.ways},
           "late": {w: [False] * len(QUANTITIES) for w in rs.ways}, "tail_weight": 0.0, "tail_events": 0,
           "peak": {w: {"u_top": 0.0, "u_d": 0.0} for w in rs.ways}}
    after: list = []
    if strongest:
        n_main = sum(e.parent == -1 for e in phi)   # x's index: after the natural mainshocks' (its aftershocks' parent)
        ev = SiteEvent(j, n_main, t_x, strata[h].source, x["mw"], x["dist_km"], x["pulse"], x["hf_seed"], False)
        if st.aftershocks is not None:   # given x, from x's own streams: the same law under any proposal
            p_x = _x_pulse_probability(strata, h, x["dist_km"], _row_rng(st.seed, h, j, X_GEOMETRY))
            after = aftershocks_of(ev, p_x, st.years, st.aftershocks, _row_rng(st.seed, h, j, X_AFTERSHOCKS),
                                   pulse_map, strata.ranges)
        evs = sorted(phi + [ev] + after, key=lambda e: e.time_yr)
        row["events"] += len(after)
        tail = rs.tail_share >= 1 or bool(_row_rng(st.seed, h, j, X_TAIL).uniform() < rs.tail_share)
        o = run_one(model, j, evs if tail else [e for e in evs if e.time_yr <= t_x], st, rs.ways)
        row["runs"], row["shared"], row["restorations"] = o.runs, o.shared, o.restorations
        row["hits"] = {w: [bool(o.collapsed[w])] + [bool(math.isfinite(t)) for t in o.first_yr[w]] for w in rs.ways}
        row["late"] = {w: [bool(o.collapsed[w] and o.collapse_yr[w] > t_x)] + [bool(t > t_x) for t in o.first_yr[w]]
                       for w in rs.ways}
        row["tail_weight"] = 1.0 / rs.tail_share if tail else 0.0
        row["tail_events"] = sum(e.time_yr > t_x and not e.outside for e in evs)
        row["peak"] = {w: {k: float(v) for k, v in o.peak[w].items()} for w in rs.ways}
    row["seconds"] = time.perf_counter() - t0
    return row


def _cols(rows: list, way: str) -> dict:
    """The rows as the rare route's columns (its steering, demand and floor models and its cross-entropy step read
    them): x's features, its stage and weights, and the way's outcome -- a row whose x is not the strongest is a
    row where nothing is exceeded (y = 0: its sequence counts at its own strongest event) with EDPs 0, which the
    demand model leaves out (it fits EDP > 0)."""
    def col(key, dtype=float):
        return np.array([r[key] for r in rows], dtype=dtype)
    ran = col("strongest", bool)
    return {"status": np.zeros(len(rows), dtype=int), "stratum": col("h", int), "index": col("j", int),
            "stage": col("stage", int), "mw": col("mw"), "dist_km": col("dist_km"), "pulse": col("pulse", bool),
            "z_vp": col("z_vp"), "z_fp": col("z_fp"), "occurrence_weight": col("occurrence_weight"),
            "collapsed": ran & np.array([r["hits"][way][0] for r in rows], dtype=bool),
            **{k: np.where(ran, [r["peak"][way][k] for r in rows], 0.0) for k in ("u_top", "u_d")}}


def _steer_rng(seed: int, *key) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(_alloc.STREAM_STEER,) + key))


def _steering_events(strata, seed: int) -> list:
    """The rare route's draws of every stratum's events for its models (they only steer)."""
    return _alloc.steering_events(strata, _steer_rng(seed))


def floors(rows: list, strata, design: Design, seed: int, ways=WAYS, labels=QUANTITIES, events=None) -> dict:
    """{(way, quantity): (H,)} per-run variance of T-less w y of every stratum none of whose rows exceeds: the rare
    route's floor (:func:`pycolfrag.rare.allocation.variance_floor`: the steering and demand models' predicted
    Var[w y], at most the Jeffreys pseudo-count's), fitted on the way's outcomes; 0 where a row exceeds."""
    events = _steering_events(strata, seed) if events is None else events
    levels = tuple(LEVELS[QUANTITIES.index(x)] for x in labels)
    out = {}
    for w in ways:
        fl = _alloc.variance_floor(_cols(rows, w), strata, design, levels, _steer_rng(seed, _alloc.STREAM_FLOOR),
                                   events)
        out.update({(w, x): fl[:, k] for k, x in enumerate(labels)})
    return out


def _value(row: dict, way: str, q: int) -> tuple[float, bool]:
    """A row's outcome of quantity ``q`` in ``way`` before its weights, and whether it is a hit first seen after x:
    (0, False) without a hit (or where x is not the strongest), (1, False) for a hit at or before x, (the row's
    ``tail_weight``, True) for a hit first seen after x -- 1 / the settings' ``tail_share`` where its tail was run (Russian
    roulette on the tail: unbiased, as the tail's hits only add)."""
    if not (row["strongest"] and row["hits"][way][q]):
        return 0.0, False
    late = bool(row["late"][way][q])
    return (float(row["tail_weight"]) if late else 1.0), late


def _stratum_stats(rows_h: list, way: str, q: int, years: float, rate: float, floor_h=None, a=None) -> tuple:
    """A stratum's mean of y, its sample variance of the mean, that variance with the floor of a stratum without
    a hit (``floor_h``, the per-run variance of w y :func:`floors` gives, else the bare Jeffreys pseudo-count's),
    its rows and its hits. ``a``: the batches' weights (:func:`pycolfrag.rare.estimate.piece_weights`): the mean
    the batches' means combined as pieces, the variance from each batch's own rows, the floor times their design
    effect (the rare route's estimator)."""
    n = len(rows_h)
    values = [_value(r, way, q) for r in rows_h]
    y = np.array([years * rate * r["weight"] * v for r, (v, _) in zip(rows_h, values)], dtype=float)
    late = np.array([is_late for _, is_late in values], dtype=bool)
    batches = [r["batch"] for r in rows_h]
    f, deff = (None, 1.0) if a is None or not n else piece_factors(batches, np.zeros(n, bool), a)
    hits = int(np.count_nonzero(y))
    mean = (float(y.mean()) if f is None else float(np.mean(f * y))) if n else 0.0
    mean_late = (float(np.mean(np.where(late, y if f is None else f * y, 0.0)))) if n else 0.0
    var = float(y.var(ddof=1)) / n if n > 1 else 0.0
    if f is not None:          # each batch's own sample variance (rare/estimate.py, piece_variance)
        var = piece_variance(y, np.zeros(n, bool), piece_parts(batches, a), float(y.var(ddof=1)))
    m2 = float(np.mean([r["weight"] ** 2 for r in rows_h])) if n else 1.0
    per_run = float(jeffreys_run_variance(m2, n)) if floor_h is None else float(floor_h)
    floor = (years * rate) ** 2 * per_run / max(n, 1) * deff if hits == 0 else 0.0
    return mean, var, max(var, floor), n, hits, int(np.count_nonzero(late)), mean_late


def estimate(rows: list, strata, years: float, floor=None, ways=WAYS, labels=QUANTITIES) -> dict:
    """P(within T) of every way and quantity: ``p``, its standard error and CoV with the floor of the strata
    without a hit (``se``, ``cov``: ``floor[(way, quantity)]`` from :func:`floors`, the rare route's model-steered
    floor; where absent, the bare Jeffreys pseudo-count's, which says what those strata could hold with no model of
    them), the same from the strata's sample variances alone (``se_sample``, ``cov_sample``), the hits, and how much
    of ``p`` rests on strata of fewer than 20 rows. The batches' means are combined as pieces (rows of a v3 run
    store their ``batch``; :func:`_stratum_stats`); rows without it are refused."""
    by_h: dict = {h: [] for h in range(len(strata))}
    for r in rows:
        by_h[r["h"]].append(r)
    if rows and not all("batch" in r for r in rows):
        raise ParameterError("rows without their batch (made before the rare sequences' v3): their means cannot be "
                             "combined as pieces; rerun in a new folder")
    a = piece_weights([r["batch"] for r in rows]) if rows else None
    floor = floor or {}
    out: dict = {}
    for w in ways:
        out[w] = {}
        for name in labels:
            q, fl = QUANTITIES.index(name), floor.get((w, name))
            st = [_stratum_stats(by_h[h], w, q, years, strata[h].rate, None if fl is None else fl[h], a)
                  for h in range(len(strata))]
            p = float(sum(x[0] for x in st))
            se_sample, se = math.sqrt(sum(x[1] for x in st)), math.sqrt(sum(x[2] for x in st))
            out[w][name] = {"p": p, "se": se, "cov": se / p if p > 0 else math.inf, "se_sample": se_sample,
                            "cov_sample": se_sample / p if p > 0 else math.inf, "hits": int(sum(x[4] for x in st)),
                            "p_on_few_rows": float(sum(x[0] for x in st if x[3] < 20)),
                            "late_hits": int(sum(x[5] for x in st)), "p_late": float(sum(x[6] for x in st))}
    return out


def _site_settings(rs: RareSequenceSettings) -> SiteSettings:
    """The rare route's settings its cross-entropy step and allocation read (seed, alpha_0, the elite's rule)."""
    return SiteSettings(seed=int(rs.sequences.seed), defensive=DEFENSIVE, ce_min_hits=CE_MIN_HITS)


def design_of(rows: list, strata, rs: RareSequenceSettings) -> tuple[Design, tuple]:
    """(the proposals, the families whose elite was thin): the pilot's, and the production one -- ``rs.mixture`` when
    given, else the rare route's cross-entropy step (:func:`pycolfrag.rare.driver.cross_entropy_design`) on the
    pilot's ``rows`` for the target's family (collapse: the top displacement's; its elite the rows with a collapse
    once :data:`CE_MIN_HITS` have one, else those at the top of the sequences' peak u_top), with the defensive
    share alpha_0 = 0.3. Where the elite was thin, :func:`simulate_sequences` takes the rare route's second step
    after the first batch."""
    if rs.mixture is not None:
        return Design(rs.pilot_mixture, rs.mixture, ("the production proposal as given",)), ()
    cols, requested = _cols(rows, "accumulated"), (LEVELS[QUANTITIES.index(rs.target)],)
    ce = cross_entropy_design(cols, strata, _site_settings(rs), requested)
    return Design(rs.pilot_mixture, ce.production, ce.notes), thin_of(cols, strata, _site_settings(rs), requested)


def allocate(rows: list, strata, rs: RareSequenceSettings, design: Design, stage: int, n: int, floor=None,
             events=None) -> dict:
    """``n`` new rows over the strata: the rare route's allocation of a batch
    (:func:`pycolfrag.rare.driver.allocate_batch`: the steering model's predicted variances under the production
    proposal, each at least the estimate's ``floor`` of the target, minimax Neyman, a stratum predicted to matter
    keeping 20 rows) on the target of the accumulated way."""
    q = QUANTITIES.index(rs.target)
    fl = None if floor is None else np.asarray(floor[("accumulated", rs.target)], dtype=float)[:, None]
    events = _steering_events(strata, rs.sequences.seed) if events is None else events
    return allocate_batch(_cols(rows, "accumulated"), strata, design, _site_settings(rs), (LEVELS[q],), stage,
                          len(rows), events, n, fl)


def simulate_sequences(site, model, rs: RareSequenceSettings, evaluate=None, done=(), log=None) -> dict:
    """Run rows until the target's CoV (with the floor) or the row budget. ``evaluate(list of (h, j, batch),
    production mixture, stage) -> list of rows`` (None: in this process, in order). A resume gives the rows already finished
    (``done``): they are not run again. Every decision (the production proposal, the batches' allocations, the
    stop) is a function of the rows of the batches before it alone, never of ``done``, so a resumed run makes the
    uninterrupted run's rows and decisions. Returns ``{"rows", "estimate", "strata", "settings", "design", "runs",
    "seconds"}``."""
    strata = build_strata(site)
    refuse_outside_aftershocks(strata, rs)
    least = _alloc.PIECE_MIN_RUNS * len(strata)
    if rs.batch < least:
        raise ParameterError(f"batch {rs.batch} is below {least} rows: every batch gives each of the site's "
                             f"{len(strata)} strata at least {_alloc.PIECE_MIN_RUNS} (its own stratified estimate, a "
                             "piece of the whole)")
    pulse_map = PulseMap(rs.sequences.pulse_shape, rs.sequences.vp_scale, rs.sequences.tp_model)
    if evaluate is None:
        def evaluate(todo, mixture, stage):
            return [run_row(site, strata, model, rs, h, j, pulse_map, mixture, stage, b) for h, j, b in todo]
    finished = {(r["h"], r["j"]): r for r in done}

    def run(todo, mixture, stage) -> list:
        missing = [t for t in todo if t[:2] not in finished]
        for r in evaluate(missing, mixture, stage):
            finished[(r["h"], r["j"])] = r
        return [finished[t[:2]] for t in todo]
    rows = run([(h, j, 0) for h in range(len(strata)) for j in range(rs.pilot)], None, PILOT_STAGE)
    design, thin = design_of(rows, strata, rs)
    if log is not None:
        for note in design.notes:
            log(f"sequences (rare): production proposal: {note}")
    count = {h: rs.pilot for h in range(len(strata))}
    events, years, stage = _steering_events(strata, rs.sequences.seed), rs.sequences.years, 1
    converged = False
    while rs.max_rows - len(rows) >= least:      # rows left that cannot visit every stratum twice are not run
        fl = floors(rows, strata, design, rs.sequences.seed, ("accumulated",), (rs.target,), events)
        est = estimate(rows, strata, years, fl, ("accumulated",), (rs.target,))["accumulated"][rs.target]
        if log is not None:
            log(f"sequences (rare): {len(rows)} rows, P({rs.target}) {est['p']:.4g}, CoV {est['cov']:.3f} "
                f"(sample variances alone {est['cov_sample']:.3f})")
        if est["cov"] <= rs.target_cov:
            converged = True
            break
        if stage == SECOND_STAGE and thin:   # the rare route's second step, on every row so far
            design = second_design(_cols(rows, "accumulated"), strata, design, _site_settings(rs),
                                   (LEVELS[QUANTITIES.index(rs.target)],), thin)
            if log is not None:
                log(f"sequences (rare): production proposal from stage 2: {design.notes[-1]}")
        new = allocate(rows, strata, rs, design, stage, min(rs.batch, rs.max_rows - len(rows)), fl, events)
        todo = [(h, count[h] + t, stage) for h, k in sorted(new.items()) for t in range(k)]
        for h, j, _ in todo:
            count[h] = max(count[h], j + 1)
        rows += run(todo, design.latest, PRODUCTION_STAGE if design.second is None else SECOND_STAGE)
        stage += 1
    if not converged and 0 < rs.max_rows - len(rows) < least and log is not None:
        log(f"sequences (rare): {_alloc.runs_left_unused(rs.max_rows - len(rows), len(strata), 'rows')}")
    fl = floors(rows, strata, design, rs.sequences.seed, rs.ways, events=events)
    return {"rows": rows, "estimate": estimate(rows, strata, years, fl, rs.ways), "strata": strata, "settings": rs,
            "design": design, "runs": int(sum(r["runs"] for r in rows)), "shared": _shared(rows),
            "seconds": float(sum(r["seconds"] for r in rows))}


def _shared(rows: list) -> int:
    """The event runs the rows' ways shared (:func:`pycolfrag.risk.sequences.run_one`; 0 in rows made before)."""
    return int(sum(r.get("shared", 0) for r in rows))


def estimate_rows(site, rs: RareSequenceSettings, rows: list) -> dict:
    """A journal's ``rows`` (those of a stopped run too) as :func:`simulate_sequences` returns them: the design its
    decisions placed (the first cross-entropy step on the pilot's rows, the second on the rows of stages 0 and 1
    where rows of stage 2 exist), the floors and the estimate of every way and quantity."""
    strata = build_strata(site)
    design, thin = design_of([r for r in rows if r["stage"] == PILOT_STAGE], strata, rs)
    if any(r["stage"] == SECOND_STAGE for r in rows):
        design = second_design(_cols([r for r in rows if r["stage"] < SECOND_STAGE], "accumulated"), strata, design,
                               _site_settings(rs), (LEVELS[QUANTITIES.index(rs.target)],), thin)
    fl = floors(rows, strata, design, rs.sequences.seed, rs.ways)
    return {"rows": rows, "estimate": estimate(rows, strata, rs.sequences.years, fl, rs.ways), "strata": strata,
            "settings": rs,
            "design": design, "runs": int(sum(r["runs"] for r in rows)), "shared": _shared(rows),
            "seconds": float(sum(r["seconds"] for r in rows))}


def journal_settings(rs: RareSequenceSettings, n_strata: int) -> dict:
    """The rare settings of a journal's identity: :func:`settings_dict` with the row budget as ``"whole batches"``
    where it cuts no batch -- the pilot done, the rows left after its last whole batch too few for a batch (fewer
    than 2 per stratum: not run) -- so that every budget of that kind makes the same batches as far as it goes, and
    a run stopped by its budget resumes under a larger one. A budget that cuts the pilot or a batch (its last one
    smaller than ``batch``) stays in the identity: another budget would place other rows."""
    d = settings_dict(rs)
    pilot = rs.pilot * n_strata
    if rs.max_rows >= pilot and (rs.max_rows - pilot) % rs.batch < _alloc.PIECE_MIN_RUNS * n_strata:
        d["max_rows"] = "whole batches"
    return d


def settings_dict(rs: RareSequenceSettings) -> dict:
    """The rare settings as plain data (a journal's identity), the algorithm's name included."""
    return {"algorithm": ALGORITHM, "target": rs.target, "target_cov": rs.target_cov, "pilot": rs.pilot,
            "batch": rs.batch, "max_rows": rs.max_rows, "pilot_mixture": rs.pilot_mixture.as_dict(),
            "mixture": None if rs.mixture is None else rs.mixture.as_dict(), "ce_min_hits": CE_MIN_HITS,
            "stream": STREAM_RARE_SEQUENCES,
            "no_pulse_offset": NO_PULSE_OFFSET, "ways": list(rs.ways), "tail_share": rs.tail_share}


def tails_run(rows: list) -> int:
    """The rows whose tail -- the events after x, the strongest -- was run (x the strongest of its sequence and the
    roulette's draw kept its tail: a ``tail_weight`` above 0; every such row at ``tail_share`` 1)."""
    return sum(bool(r["strongest"] and r["tail_weight"] > 0) for r in rows)


def format_estimate(run: dict, title: str = "") -> str:
    """The estimate of :func:`simulate_sequences` as text: P(within T) per quantity and way, with the CoV."""
    st = run["settings"].sequences
    est = run["estimate"]
    rows = run["rows"]
    strongest = sum(r["strongest"] for r in rows)
    ways = run["settings"].ways
    lines = [f"## {title or 'Sequences at a site, importance sampling on the strongest event'}", "",
             f"{len(rows)} rows over {len(run['strata'])} strata ({strongest} with the row's event the strongest of "
             f"its sequence), {run['runs']} event runs ({run['shared']} more shared between the ways), "
             f"{run['seconds']:.1f} s of runs; horizon {st.years:g} years, "
             f"seed {st.seed}, restoration {st.restoration.describe()}; the tail after x run in {tails_run(rows)} of "
             f"{strongest} rows (share {run['settings'].tail_share:g}).", "",
             *(f"Production proposal: {n}." for n in run["design"].notes), "",
             f"| quantity | {' | '.join(f'P(within {st.years:g} yr): {w} [CoV]' for w in ways)} | "
             "hits (accumulated) | of them after x | P from them | CoV of the sample variances alone | "
             "P on strata of < 20 rows |",
             "|---|" + "---|" * (len(ways) + 5)]
    for q in QUANTITIES:
        cells = [f"{est[w][q]['p']:.4g} [{est[w][q]['cov']:.2f}]" for w in ways]
        a = est["accumulated"][q]
        lines.append(f"| {q} | {' | '.join(cells)} | {a['hits']} | {a['late_hits']} | {a['p_late']:.3g} | "
                     f"{a['cov_sample']:.3g} | {a['p_on_few_rows']:.3g} |")
    if run["settings"].tail_share < 1:
        lines += ["", f"A share {run['settings'].tail_share:g} of the tails was run: the stated errors hold only where "
                      "the hits after x are seen often enough (docs/sequences.md, \"The tail after the strongest "
                      "event\"); rerun with --tail-share 1 where the column of hits after x is not small."]
    return "\n".join(lines)
