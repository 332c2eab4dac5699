"""Sequences at a site by crude Monte Carlo (pycolfrag/risk/sequences.py; docs/sequences.md, "Sequences
at a site"): the Poisson process of the site's mainshocks, streams per (sequence, event) so that results
do not depend on order, no run for a sequence without an event, the three ways on the same events
(paired), the restoration's count, the summary's standard errors, refusals by name."""
from __future__ import annotations

import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.errors import ParameterError
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import model_ranges
from pycolfrag.risk import sequences as sq
from pycolfrag.site.sources import site_from_dict
from pycolfrag.solver.sequence import NO_RESTORATION, Restoration

COL = pcf.Column.parthenon()


def site(rate_near=0.2, rate_far=0.1, outside="zero", near_r=(5.0, 10.0)):
    return site_from_dict({
        "name": "test", "outside": outside, "pulse": {"probability": 0.5},
        "sources": [
            {"name": "near", "rate": rate_near, "magnitude": {"type": "characteristic", "mw": 6.5},
             "distance": {"type": "uniform", "min_km": near_r[0], "max_km": near_r[1]}},
            {"name": "far", "rate": rate_far, "magnitude": {"type": "characteristic", "mw": 5.5},
             "distance": {"type": "uniform", "min_km": 20.0, "max_km": 40.0}}]})


PM = PulseMap(sq.DEFAULT_PULSE_SHAPE, 1.0, sq.DEFAULT_TP_MODEL)
RANGES = model_ranges()
# short records keep the runs cheap (a quick look: changes the numbers, not the logic under test)
QUICK = dict(max_record_s=8.0)


def same(a, b) -> bool:
    """Outcomes equal field by field (NaN equal to NaN: by their repr)."""
    return repr((a.sequence, a.events, a.collapsed, a.collapse_yr, a.u_d_end, a.tilt_end, a.first_yr,
                 a.restorations, a.runs)) == repr((b.sequence, b.events, b.collapsed, b.collapse_yr, b.u_d_end,
                                                   b.tilt_end, b.first_yr, b.restorations, b.runs))


def test_the_mainshocks_are_a_poisson_process_of_the_sites_rate():
    # 4000 sequences of 20 years at 0.3/yr: the count's mean 6 (sd of the mean sqrt(6/4000) = 0.039), the
    # sources in proportion 2:1, the times uniform on [0, 20) (mean 10, sd of the mean ~0.047): 4 sd each
    st = site()
    evs = [sq.sequence_events(st, 20.0, 7, s, PM, RANGES) for s in range(4000)]
    counts = np.array([len(e) for e in evs])
    assert abs(counts.mean() - 6.0) < 4 * math.sqrt(6.0 / 4000)
    assert abs(counts.var() - 6.0) < 0.5                       # Poisson: variance = mean
    flat = [e for es in evs for e in es]
    near = np.mean([e.source == 0 for e in flat])
    assert abs(near - 2 / 3) < 4 * math.sqrt(2 / 9 / len(flat))
    t = np.array([e.time_yr for e in flat])
    assert t.min() >= 0 and t.max() < 20 and abs(t.mean() - 10.0) < 4 * 20 / math.sqrt(12 * len(flat))
    assert all(np.all(np.diff([e.time_yr for e in es]) >= 0) for es in evs)
    pulses = np.mean([e.pulse is not None for e in flat])
    assert abs(pulses - 0.5) < 4 * math.sqrt(0.25 / len(flat))


def test_a_sequences_events_do_not_depend_on_which_others_are_drawn():
    st = site()
    alone = sq.sequence_events(st, 50.0, 11, 37, PM, RANGES)
    after = [sq.sequence_events(st, 50.0, 11, s, PM, RANGES) for s in (40, 3, 37)][2]
    assert alone == after and len(alone) > 0
    assert sq.sequence_events(st, 50.0, 12, 37, PM, RANGES) != alone   # another seed, other events


def test_a_sequence_without_an_event_costs_no_run():
    out = sq.run_one(COL, 0, [], sq.SequenceSettings(**QUICK))
    assert out.runs == 0 and not any(out.collapsed.values())
    assert out.u_d_end["accumulated"] == 0.0 and math.isnan(out.u_d_end["intact"])


def test_outcomes_do_not_depend_on_order_and_the_ways_are_paired():
    st = sq.SequenceSettings(years=10.0, n_sequences=4, seed=5, **QUICK)
    run = sq.run_site_sequences(site(), COL, st)
    outs = run["outcomes"]
    assert [o.sequence for o in outs] == [0, 1, 2, 3]
    # sequence 2 alone, run from its own streams, gives the same outcome bit for bit
    again = sq.run_one(COL, 2, sq.sequence_events(site(), 10.0, 5, 2, PM, RANGES), st)
    assert len(outs[2].events) > 0 and same(again, outs[2])
    assert sum(o.runs for o in outs) >= sum(len(o.events) for o in outs)
    # a sequence of one event: accumulated and intact are the same run
    for o in outs:
        if len(o.events) == 1:
            assert o.collapsed["accumulated"] == o.collapsed["intact"]
            assert repr(o.first_yr["accumulated"]) == repr(o.first_yr["intact"])


def test_a_restoration_policy_that_acts_is_counted_and_one_that_never_acts_changes_nothing():
    evs = sq.sequence_events(site(rate_near=0.5), 20.0, 3, 0, PM, RANGES)
    assert len(evs) >= 3
    often = sq.run_one(COL, 0, evs, sq.SequenceSettings(restoration=Restoration(u_d=1e-6), **QUICK))
    assert often.restorations >= 1
    if not often.collapsed["restored"]:   # every event that leaves any dislocation is followed by a restoration
        assert often.u_d_end["restored"] == 0.0
    never = sq.run_one(COL, 0, evs, sq.SequenceSettings(restoration=Restoration(u_d=10.0), **QUICK))
    assert never.restorations == 0
    assert repr(never.first_yr["restored"]) == repr(never.first_yr["accumulated"])
    # the restored way is run only when the policy acts: never acting, its events are the accumulated way's (shared,
    # no run); acting, it may make none either (each event right after a restoration is the intact way's run)
    assert never.runs <= often.runs and never.shared >= len(evs)


def test_the_summary_gives_binomial_standard_errors():
    outs = [sq.SequenceOutcome(i, [], {w: i < 3 for w in sq.WAYS}, {w: math.nan for w in sq.WAYS},
                               {w: 0.001 for w in sq.WAYS}, {w: 0.0 for w in sq.WAYS},
                               {w: [math.nan] * 6 for w in sq.WAYS}, 0, 0) for i in range(12)]
    sm = sq.summarize({"settings": sq.SequenceSettings(), "outcomes": outs, "wall_s": 0.0, "total_rate": 0.1})
    p, se = sm["p_collapse"]["accumulated"]
    assert p == 0.25 and se == pytest.approx(math.sqrt(0.25 * 0.75 / 12))
    assert sm["collapse_difference"] == (0.0, 0.0)
    assert "P(collapse within 50 yr)" in sq.format_summary(sm)


@pytest.mark.parametrize("kw, match", [
    (dict(years=0), "years must be a finite number > 0, got 0"),
    (dict(years=float("inf")), "years must be"),
    (dict(n_sequences=0), "n_sequences must be an integer >= 1, got 0"),
    (dict(n_sequences=2.5), "n_sequences"),
    (dict(seed=-1), "seed must be an integer >= 0, got -1"),
    (dict(restoration=NO_RESTORATION), "restoration must be a Restoration with a finite threshold"),
    (dict(settle=None), "settle must be a Settle"),
    (dict(max_record_s=0), "max_record_s must be None or a number > 0"),
    (dict(solver_options=[1]), "solver_options must be a dict"),
])
def test_bad_settings_are_refused_by_name(kw, match):
    with pytest.raises(ParameterError, match=match):
        sq.SequenceSettings(**kw)


def test_a_site_beyond_the_models_is_refused_unless_outside_is_zero():
    with pytest.raises(ParameterError, match="outside = 'zero'"):
        sq.run_site_sequences(site(outside="refuse", near_r=(5.0, 90.0)), COL, sq.SequenceSettings(n_sequences=1))
    with pytest.raises(ParameterError, match="settings must be a SequenceSettings"):
        sq.run_site_sequences(site(), COL, {"years": 50})


def test_an_events_run_is_the_grids_synthetic_row_bitwise():
    # the record of an event, with or without its pulse, is the grid's row's (run_synthetic_sample)
    from pycolfrag.solver.sample import run_synthetic_sample
    evs = [e for s in range(12) for e in sq.sequence_events(site(), 10.0, 2, s, PM, RANGES)]
    picked = [next(e for e in evs if e.pulse is None), next(e for e in evs if e.pulse is not None)]
    for e in picked:
        row = run_synthetic_sample(COL, e.mw, e.r_km, e.hf_seed, e.pulse, with_pulse=e.pulse is not None)
        res = pcf.simulate(COL, sq._motion(e, sq.SequenceSettings()))
        assert (row["u_d"], row["u_top"], row["collapsed"]) == (res.u_d, res.u_top, int(res.collapsed))
