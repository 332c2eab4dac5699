"""Earthquake sequences at a site by crude Monte Carlo (docs/sequences.md, "Sequences at a site").

A sequence is the site's mainshocks over ``years``: a Poisson process of the site's total rate (the sum
of its sources' rates), the count and the times drawn first, then each event's source (in proportion to
its rate), its (Mw, R) and pulse geometry (:meth:`SiteSource.sample <pycolfrag.site.sources.SiteSource.sample>`),
whether its motion has a pulse (its pulse-occurrence probability), the pulse's parameters (the pulse
shape's map of four standard normals, as the site simulation's runs, :class:`pycolfrag.rare.plans.PulseMap`)
and the record's noise seed. Everything random about sequence ``s`` comes from its own streams,
``SeedSequence(seed, spawn_key=(STREAM_SEQUENCES, s, 0))`` for its count and times and
``(STREAM_SEQUENCES, s, 1, k)`` for its event ``k``: a sequence's events do not depend on which others
are run, nor in what order. A sequence without an event costs no run. Events where the ground-motion
models do not apply are dropped as the site file's ``outside = "zero"`` says (the site simulation's
check, :func:`pycolfrag.rare.strata.build_strata`, refuses any other site) and counted.

Every sequence is run three ways on the same events (paired), through
:func:`pycolfrag.solver.sequence.run_sequence`:

* **accumulated**: each event on the state the previous one left (at rest), until a collapse;
* **intact**: each event on the intact column (from rest), as the single-event risk assumes;
* **restored**: as accumulated, with a restoration policy (reassemble when the accumulated ``u_d`` or
  tilt exceeds its thresholds; the count of restorations is its cost).

:func:`summarize` gives P(collapse within the horizon) of each way with its binomial standard error
and the paired difference's, the distribution of the accumulated ``u_d`` and tilt at the horizon, the
probability of exceeding each level of Tables III/IV within the horizon and the time to the first
exceedance, and the restorations.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from pycolfrag import ground_motion
from pycolfrag.core.errors import ParameterError
from pycolfrag.damage import PERFORMANCE_LEVELS
from pycolfrag.ground_motion.registry import DEFAULT_PULSE_SHAPE, DEFAULT_TP_MODEL
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import build_strata
from pycolfrag.risk.aftershocks import DAYS_PER_YEAR, Aftershocks
from pycolfrag.solver.sequence import NO_RESTORATION, Restoration, Settle, run_sequence

__all__ = ["STREAM_SEQUENCES", "DEFAULT_SEED", "SequenceSettings", "SiteEvent", "sequence_events", "SequenceOutcome",
           "run_site_sequences", "summarize", "format_summary", "WAYS", "check_ways"]

#: Stream identifier of the sequences' draws (the grid's streams are 1 and 2, the site simulation's 3).
STREAM_SEQUENCES = 4
DEFAULT_SEED = 20261206
#: The three ways every sequence is run.
WAYS = ("accumulated", "intact", "restored")


@dataclass(frozen=True)
class SequenceSettings:
    """What a site's sequences are: ``years`` (the horizon), ``n_sequences``, the root ``seed``, the
    restoration policy of the ``restored`` way, the settling of every event's tail, the records
    (``record_dt_s``, ``vp_scale``, ``tp_model``, ``pulse_shape``; ``max_record_s`` cuts them: tests
    and quick looks only) and the solver options (a dict of :func:`pycolfrag.simulate` keywords)."""

    years: float = 50.0
    n_sequences: int = 200
    seed: int = DEFAULT_SEED
    restoration: Restoration = Restoration(u_d=0.005)
    settle: Settle = Settle()
    record_dt_s: float = 0.005
    vp_scale: float = 1.0
    tp_model: str = DEFAULT_TP_MODEL
    pulse_shape: str = DEFAULT_PULSE_SHAPE
    max_record_s: float | None = None
    solver_options: dict = field(default_factory=dict)
    aftershocks: Aftershocks | None = None

    def __post_init__(self):
        if isinstance(self.years, bool) or not isinstance(self.years, (int, float)) or not 0 < self.years < math.inf:
            raise ParameterError(f"years must be a finite number > 0, got {self.years!r}")
        if isinstance(self.n_sequences, bool) or not isinstance(self.n_sequences, (int, np.integer)) \
                or self.n_sequences < 1:
            raise ParameterError(f"n_sequences must be an integer >= 1, got {self.n_sequences!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        if not isinstance(self.restoration, Restoration) or not self.restoration.active:
            raise ParameterError(f"restoration must be a Restoration with a finite threshold, got {self.restoration!r}")
        if not isinstance(self.settle, Settle):
            raise ParameterError(f"settle must be a Settle, got {type(self.settle).__name__}")
        if self.max_record_s is not None and not (isinstance(self.max_record_s, (int, float)) and self.max_record_s > 0):
            raise ParameterError(f"max_record_s must be None or a number > 0, got {self.max_record_s!r}")
        if not isinstance(self.solver_options, dict):
            raise ParameterError(f"solver_options must be a dict, got {type(self.solver_options).__name__}")
        if self.aftershocks is not None and not isinstance(self.aftershocks, Aftershocks):
            raise ParameterError(f"aftershocks must be None or an Aftershocks, got {type(self.aftershocks).__name__}")


@dataclass(frozen=True)
class SiteEvent:
    """One event of a sequence: its time (years from the sequence's start), source, (Mw, R), the pulse's
    parameters (None: no pulse) and the record's noise seed; ``outside``: where the models do not apply
    (dropped, no run); ``parent``: the index of its mainshock for an aftershock, -1 for a mainshock."""

    sequence: int
    index: int
    time_yr: float
    source: int
    mw: float
    r_km: float
    pulse: dict | None
    hf_seed: int
    outside: bool
    parent: int = -1


def _rng(seed: int, *key) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=key))


def _event(s, k, t, j, mw, r, p_pulse, rng, pulse_map, ranges, parent=-1) -> SiteEvent:
    """An event of source ``j`` at (Mw, R): whether it has a pulse, the pulse's normals and the noise seed from
    ``rng``, in that order."""
    has_pulse = bool(rng.uniform() < p_pulse)
    z4 = rng.standard_normal(4)
    hf_seed = int(rng.integers(0, 2 ** 63 - 1, dtype=np.int64))
    rg = ranges[has_pulse]
    outside = not (rg.mw[0] <= mw <= rg.mw[1] and r <= rg.r_max_km)
    pulse = pulse_map(mw, r, tuple(float(z) for z in z4)) if has_pulse and not outside else None
    return SiteEvent(s, k, float(t), j, mw, r, pulse, hf_seed, outside, parent)


def aftershocks_of(main: SiteEvent, p_pulse: float, years: float, model: Aftershocks, rng, pulse_map: PulseMap,
                   ranges: dict) -> list:
    """The aftershocks of ``main`` within the horizon (:mod:`pycolfrag.risk.aftershocks`): at its distance and
    source (the rupture's zone), each with a pulse as its mainshock's geometry gives (``p_pulse``)."""
    t_days, mags = model.sample(main.mw, rng)
    out = []
    for t, mw in zip(t_days, mags):
        when = main.time_yr + float(t) / DAYS_PER_YEAR
        ev = _event(main.sequence, main.index, when, main.source, float(mw), main.r_km, p_pulse, rng, pulse_map,
                    ranges, parent=main.index)
        if when < years:
            out.append(ev)
    return out


def sequence_events(site, years: float, seed: int, s: int, pulse_map: PulseMap, ranges: dict, key=None,
                    aftershocks: Aftershocks | None = None) -> list:
    """The events of sequence ``s`` (see the module's text), in time order. ``ranges``: the models' ranges
    by branch (:func:`pycolfrag.rare.strata.model_ranges`). ``key``: the streams' spawn key before the
    (0,) of the count and times and the (1, k) of event k (default ``(STREAM_SEQUENCES, s)``); with
    ``aftershocks``, mainshock k's from the stream (2, k) (none: the mainshocks alone, the same bits)."""
    key = (STREAM_SEQUENCES, s) if key is None else tuple(key)
    rates = np.array([src.rate for src in site.sources], dtype=float)
    total = float(rates.sum())
    head = _rng(seed, *key, 0)
    n = int(head.poisson(total * years))
    times = np.sort(head.uniform(0.0, years, n))
    cum = np.cumsum(rates) / total
    out = []
    for k in range(n):
        rng = _rng(seed, *key, 1, k)
        j = min(int(np.searchsorted(cum, rng.uniform(), side="right")), len(rates) - 1)
        ev = site.sources[j].sample(1, rng)
        mw, r = float(ev.mw[0]), float(ev.r_km[0])
        main = _event(s, k, times[k], j, mw, r, float(ev.p_pulse[0]), rng, pulse_map, ranges)
        out.append(main)
        if aftershocks is not None:
            out += aftershocks_of(main, float(ev.p_pulse[0]), years, aftershocks, _rng(seed, *key, 2, k), pulse_map,
                                  ranges)
    return sorted(out, key=lambda e: e.time_yr) if aftershocks is not None else out


def _motion(ev: SiteEvent, st: SequenceSettings):
    """The record of an event (the grid's synthetic row's: :func:`pycolfrag.ground_motion.synthesize`
    with the pulse, :func:`pycolfrag.ground_motion.stochastic` without), its first horizontal component."""
    if ev.pulse is not None:
        rec = ground_motion.synthesize(ev.mw, ev.r_km, ev.hf_seed, dt=st.record_dt_s, vp_scale=st.vp_scale,
                                       pulse=ev.pulse, shape=st.pulse_shape)
    else:
        rec = ground_motion.stochastic(ev.mw, ev.r_km, ev.hf_seed, dt=st.record_dt_s)
    cut = None if st.max_record_s is None else int(round(st.max_record_s / rec.dt)) + 1
    return rec.motion("h1", max_samples=cut)


@dataclass
class SequenceOutcome:
    """One sequence run three ways: its events, and per way (:data:`WAYS`) ``collapsed``, the collapse's
    time (years; NaN), the accumulated ``u_d`` and tilt at the horizon (NaN after a collapse; the intact
    way's: NaN, nothing accumulates), the time of the first exceedance of each level of
    :data:`pycolfrag.damage.PERFORMANCE_LEVELS` (years; NaN: not within the horizon), the restorations,
    the runs it took (event runs made, settling runs not counted), and per way ``peak``: the largest of each EDP
    the levels read over its events (``u_top``, the sequence's peak; ``u_d``, the accumulated u_d at rest;
    0 without an event), which the rare sequences' demand model reads; ``shared``: the event runs a way took
    from another instead of making them (the same computation: ``runs + shared`` is what the three ways run
    apart would make)."""

    sequence: int
    events: list
    collapsed: dict
    collapse_yr: dict
    u_d_end: dict
    tilt_end: dict
    first_yr: dict
    restorations: int
    runs: int
    peak: dict = field(default_factory=dict)
    shared: int = 0


def _first_times(times: list, results: list) -> list:
    """The first exceedance time of each level: ``results`` (EventResult per run event, in order) at
    ``times``; a collapse exceeds every level; u_top levels read the sequence's peak, u_d levels the
    accumulated u_d at rest."""
    out = []
    for lv in PERFORMANCE_LEVELS:
        t = math.nan
        for when, e in zip(times, results):
            value = e.u_top if lv.edp == "u_top" else e.u_d_rest
            if e.collapsed or value >= lv.threshold:
                t = when
                break
        out.append(t)
    return out


def _peak(results: list) -> dict:
    """The largest u_top (the sequence's peak) and accumulated u_d at rest over ``results`` (NaN ignored)."""
    return {k: float(max([0.0] + [v for e in results for v in [getattr(e, a)] if v == v]))
            for k, a in (("u_top", "u_top"), ("u_d", "u_d_rest"))}


def _accumulating(model, motions, times, restoration, st: SequenceSettings, known=None):
    seq = run_sequence(model, motions, restoration=restoration, settle=st.settle, known=known, **st.solver_options)
    c = seq.collapsed
    return seq, {"collapsed": c, "collapse_yr": times[len(seq.events) - 1] if c else math.nan,
                 "u_d_end": seq.accumulated_u_d, "tilt_end": seq.tilt_rad,
                 "first_yr": _first_times(times, seq.events), "peak": _peak(seq.events)}


def _intact(model, motions, times, first, st: SequenceSettings):
    """Every event on the intact column; the first event's run is the accumulated way's (bitwise the same
    call), reused (``first``; None: run it too)."""
    given = [] if first is None else [first]
    results = given + [run_sequence(model, [m], settle=st.settle, **st.solver_options).events[0]
                       for m in motions[len(given):]]
    hit = [t for t, e in zip(times, results) if e.collapsed]
    return results, {"collapsed": bool(hit), "collapse_yr": hit[0] if hit else math.nan, "u_d_end": math.nan,
                     "tilt_end": math.nan, "first_yr": _first_times(times, results), "peak": _peak(results)}


#: Share the runs that are the same computation between the ways (docs/sequences.md, "Runs shared between the
#: ways"). False runs every way's every event (the tests compare the two, bit for bit): internal, not a setting.
_SHARE = True


def _known(accumulated: list, intact: list):
    """The restored way's runs already made (``run_sequence``'s ``known``): before its policy first acts it is the
    accumulated way call for call (the same state in, the same run), and an event right after a restoration
    meets the intact column at rest, the intact way's run of that event (``intact`` empty where that way is not
    run: the restored way makes those runs itself)."""
    def known(k: int, restorations: int, fresh: bool):
        if restorations == 0:
            return accumulated[k]   # the accumulated way reached k: it stops only where this way would
        return intact[k] if fresh and k < len(intact) else None
    return known


def check_ways(ways) -> tuple:
    """``ways`` as a tuple of :data:`WAYS` in their order: the accumulated way and any of the others (the intact
    way's first run and the restored way's runs before its policy acts are the accumulated way's), refused by
    name otherwise."""
    if isinstance(ways, str) or not all(isinstance(w, str) for w in ways):
        raise ParameterError(f"ways must be a sequence of names out of {', '.join(WAYS)}, got {ways!r}")
    bad = [w for w in ways if w not in WAYS]
    if bad or "accumulated" not in ways or len(set(ways)) != len(tuple(ways)):
        raise ParameterError(f"ways must hold 'accumulated' and any of 'intact', 'restored', each once; got "
                             f"{', '.join(map(repr, ways)) or 'none'}")
    return tuple(w for w in WAYS if w in ways)


def run_one(model, s: int, site_events: list, st: SequenceSettings, ways=WAYS) -> SequenceOutcome:
    """Run sequence ``s``'s events (:func:`sequence_events`) the ``ways`` (:func:`check_ways`; default the
    three), each run that two ways share made once (:data:`_SHARE`): ``runs`` counts the runs made, ``shared``
    those a way took from another. The outcome holds the ways asked for alone."""
    ways = check_ways(ways)
    out: dict = {w: {"collapsed": False, "collapse_yr": math.nan, "u_d_end": 0.0, "tilt_end": 0.0,
                     "first_yr": [math.nan] * len(PERFORMANCE_LEVELS), "peak": _peak([])} for w in WAYS}
    out["intact"].update(u_d_end=math.nan, tilt_end=math.nan)
    todo = [e for e in site_events if not e.outside]
    runs, restorations, asked = 0, 0, 0
    if todo:
        motions, times = [_motion(e, st) for e in todo], [e.time_yr for e in todo]
        acc, out["accumulated"] = _accumulating(model, motions, times, NO_RESTORATION, st)
        runs += len(acc.events)
        asked += len(acc.events)
        intact: list = []
        if "intact" in ways:
            intact, out["intact"] = _intact(model, motions, times, acc.events[0] if _SHARE else None, st)
            runs += len(intact) - (1 if _SHARE else 0)
            asked += len(intact)
        if "restored" in ways:
            acts = any(not e.collapsed and st.restoration.due(e.u_d_rest, e.tilt_rad) for e in acc.events)
            if acts or not _SHARE:
                res, out["restored"] = _accumulating(model, motions, times, st.restoration, st,
                                                     _known(acc.events, intact) if _SHARE else None)
                runs += len(res.events) - res.reused
                asked += len(res.events)
                restorations = res.restorations
            else:   # the policy never acts: the restored way is the accumulated one, call for call
                out["restored"] = dict(out["accumulated"])
                asked += len(acc.events)
    return SequenceOutcome(s, site_events, {w: out[w]["collapsed"] for w in ways},
                           {w: out[w]["collapse_yr"] for w in ways}, {w: out[w]["u_d_end"] for w in ways},
                           {w: out[w]["tilt_end"] for w in ways}, {w: out[w]["first_yr"] for w in ways},
                           restorations, runs, {w: out[w]["peak"] for w in ways}, asked - runs)


def run_site_sequences(site, model, settings: SequenceSettings = SequenceSettings(), progress=None) -> dict:
    """Draw and run ``settings.n_sequences`` sequences of ``site`` (a :class:`~pycolfrag.site.sources.Site`)
    on ``model``; returns ``{"settings", "outcomes", "wall_s", "total_rate", "outside_share"}``
    (:func:`summarize` reads it). ``progress``: callable(done, total) or None."""
    if not isinstance(settings, SequenceSettings):
        raise ParameterError(f"settings must be a SequenceSettings, got {type(settings).__name__}")
    strata = build_strata(site)   # the site simulation's check: refuses sources outside the models but 'zero'
    pulse_map = PulseMap(settings.pulse_shape, settings.vp_scale, settings.tp_model)
    t0 = time.perf_counter()
    outcomes = []
    for s in range(settings.n_sequences):
        evs = sequence_events(site, settings.years, settings.seed, s, pulse_map, strata.ranges,
                              aftershocks=settings.aftershocks)
        try:
            outcomes.append(run_one(model, s, evs, settings))
        except Exception as exc:
            exc.add_note(f"in sequence {s} (seed {settings.seed}) of {len(evs)} event(s)")
            raise
        if progress is not None:
            progress(s + 1, settings.n_sequences)
    return {"settings": settings, "outcomes": outcomes, "wall_s": time.perf_counter() - t0,
            "total_rate": float(sum(src.rate for src in site.sources)),
            "outside_share": {o.source: o.outside for o in strata.outside}}


def _p(x) -> tuple[float, float]:
    """A proportion and its binomial standard error."""
    x = np.asarray(x, dtype=float)
    p = float(x.mean())
    return p, math.sqrt(p * (1.0 - p) / x.size)


def _paired(d) -> tuple[float, float]:
    """The mean of paired differences and its standard error."""
    d = np.asarray(d, dtype=float)
    return float(d.mean()), (float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else math.nan)


def summarize(run: dict) -> dict:
    """The numbers of a :func:`run_site_sequences` run (see the module's text); every probability as
    ``(p, standard error)``."""
    st, outs = run["settings"], run["outcomes"]
    n = len(outs)
    col = {w: np.array([o.collapsed[w] for o in outs], dtype=float) for w in WAYS}
    diff = col["accumulated"] - col["intact"]
    u_end = np.array([math.inf if o.collapsed["accumulated"] else o.u_d_end["accumulated"] for o in outs])
    u_end_r = np.array([math.inf if o.collapsed["restored"] else o.u_d_end["restored"] for o in outs])
    tilt_end = np.array([math.inf if o.collapsed["accumulated"] else o.tilt_end["accumulated"] for o in outs])
    levels = []
    for i, lv in enumerate(PERFORMANCE_LEVELS):
        row: dict = {"level": lv.label, "name": lv.name}
        for w in WAYS:
            t = np.array([o.first_yr[w][i] for o in outs])
            row[w] = _p(np.isfinite(t))
            row[f"{w}_median_yr"] = float(np.median(t[np.isfinite(t)])) if np.isfinite(t).any() else math.nan
        hit = {w: np.isfinite([o.first_yr[w][i] for o in outs]).astype(float) for w in ("accumulated", "intact")}
        row["difference"] = _paired(hit["accumulated"] - hit["intact"])
        levels.append(row)
    n_events = np.array([len(o.events) for o in outs])
    restor = np.array([o.restorations for o in outs], dtype=float)
    return {
        "n_sequences": n, "years": st.years, "seed": st.seed, "total_rate_per_yr": run["total_rate"],
        "events_per_sequence": float(n_events.mean()), "expected_events": run["total_rate"] * st.years,
        "sequences_without_event": int((n_events == 0).sum()),
        "dropped_outside": int(sum(e.outside for o in outs for e in o.events)),
        "runs": int(sum(o.runs for o in outs)), "shared_runs": int(sum(o.shared for o in outs)),
        "wall_s": run["wall_s"],
        "p_collapse": {w: _p(col[w]) for w in WAYS},
        "collapse_difference": _paired(diff),
        "u_d_end_quantiles": {q: float(np.quantile(u_end, q, method="inverted_cdf")) for q in (0.5, 0.9, 0.99)},
        "u_d_end_quantiles_restored": {q: float(np.quantile(u_end_r, q, method="inverted_cdf")) for q in (0.5, 0.9, 0.99)},
        "u_d_end_mean_standing": float(u_end[np.isfinite(u_end)].mean()) if np.isfinite(u_end).any() else math.nan,
        "tilt_end_quantiles_rad": {q: float(np.quantile(tilt_end, q, method="inverted_cdf"))
                                   for q in (0.5, 0.9, 0.99)},
        "levels": levels, "restoration": st.restoration.describe(),
        "restorations_per_sequence": (float(restor.mean()), float(restor.std(ddof=1) / math.sqrt(n)) if n > 1
                                      else math.nan),
        "p_restored": _p(restor > 0),
    }


def _pct(pe: tuple) -> str:
    return f"{pe[0]:.4f} ± {pe[1]:.4f}"


def format_summary(sm: dict, title: str = "") -> str:
    """:func:`summarize`'s numbers as text (a Markdown table of the levels)."""
    pc = sm["p_collapse"]
    lines = [f"## {title or 'Sequences at a site'}", "",
             f"{sm['n_sequences']} sequences of {sm['years']:g} years (seed {sm['seed']}), total rate "
             f"{sm['total_rate_per_yr']:.4g}/yr: {sm['events_per_sequence']:.3f} events per sequence (expected "
             f"{sm['expected_events']:.3f}), {sm['sequences_without_event']} without an event, "
             f"{sm['dropped_outside']} event(s) outside the models dropped; {sm['runs']} event runs "
             f"({sm['shared_runs']} more shared between the ways), "
             f"{sm['wall_s']:.1f} s.", "",
             f"P(collapse within {sm['years']:g} yr), ± one binomial standard error:",
             f"- with accumulation: {_pct(pc['accumulated'])}",
             f"- without (every event on the intact column): {_pct(pc['intact'])}",
             f"- paired difference (with - without): {_pct(sm['collapse_difference'])}",
             f"- with restoration ({sm['restoration']}): {_pct(pc['restored'])}; restorations per sequence "
             f"{_pct(sm['restorations_per_sequence'])}, P(at least one) {_pct(sm['p_restored'])}", "",
             "Accumulated u_d at the horizon (collapse counted as inf): "
             + ", ".join(f"q{int(q * 100)} {v:.4g}" for q, v in sm["u_d_end_quantiles"].items())
             + f"; mean over standing columns {sm['u_d_end_mean_standing']:.4g}; with restoration: "
             + ", ".join(f"q{int(q * 100)} {v:.4g}" for q, v in sm["u_d_end_quantiles_restored"].items()),
             "Residual tilt at the horizon, rad: "
             + ", ".join(f"q{int(q * 100)} {v:.3g}" for q, v in sm["tilt_end_quantiles_rad"].items()), "",
             f"| level | P(exceeded within {sm['years']:g} yr): accumulated | intact | paired difference | restored "
             "| median years to the first (accumulated) |", "|---|---|---|---|---|---|"]
    for row in sm["levels"]:
        lines.append(f"| {row['level']} ({row['name']}) | {_pct(row['accumulated'])} | {_pct(row['intact'])} | "
                     f"{_pct(row['difference'])} | {_pct(row['restored'])} | {row['accumulated_median_yr']:.1f} |")
    return "\n".join(lines)
