"""Runs shared between the three ways of a sequence (pycolfrag/risk/sequences.py's ``run_one``, ``run_sequence``'s
``known``; docs/sequences.md, "Runs shared between the ways"): the restored way takes the accumulated way's runs
until its policy first acts and the intact way's run of an event right after a restoration, the intact way the
accumulated way's first run. The outcomes are those of the three ways run apart (``sq._SHARE = False``: every
way's every event run) bit for bit -- compared as their journal lines, JSON keeping every float's bits -- and
the runs made fall by the count the definition gives, the runs saved counted as ``shared``."""
from __future__ import annotations

import json

import pytest

import pycolfrag as pcf
from pycolfrag.rare.plans import PulseMap
from pycolfrag.rare.strata import model_ranges
from pycolfrag.risk import sequences as sq
from pycolfrag.risk.sequences_run import outcome_to_dict
from pycolfrag.site.sources import site_from_dict
from pycolfrag.solver.sequence import NO_RESTORATION, Restoration, run_sequence

COL = pcf.Column.parthenon()
PM = PulseMap(sq.DEFAULT_PULSE_SHAPE, 1.0, sq.DEFAULT_TP_MODEL)
# a site of frequent strong events (0.5 /yr of Mw 6.5 at 5-10 km): sequences of 10 years, seed 3, hold 5, 6 and 2
# events (sequences 0, 1, 2); short records keep the runs cheap (the numbers change, not the bookkeeping)
SITE = site_from_dict({"name": "sharing", "outside": "zero", "pulse": {"probability": 0.5}, "sources": [
    {"name": "near", "rate": 0.5, "magnitude": {"type": "characteristic", "mw": 6.5},
     "distance": {"type": "uniform", "min_km": 5.0, "max_km": 10.0}},
    {"name": "far", "rate": 0.1, "magnitude": {"type": "characteristic", "mw": 5.5},
     "distance": {"type": "uniform", "min_km": 20.0, "max_km": 40.0}}]})
QUICK = dict(max_record_s=8.0)
# the policies: acting after nearly every event (u_d > 1e-6), after some (u_d > 0.002: 3 of sequence 0's 5 events,
# 4 of sequence 1's 6), never (u_d > 10)
POLICIES = (1e-6, 0.002, 10.0)


def _events(s: int) -> list:
    return sq.sequence_events(SITE, 10.0, 3, s, PM, model_ranges())


def _line(o) -> tuple:
    """(the outcome's journal line without its run counts, (runs, shared))."""
    d = outcome_to_dict(o, 0.0)
    counts = (d.pop("runs"), d.pop("shared"))
    return json.dumps(d), counts


def _apart(monkeypatch, s: int, st):
    with monkeypatch.context() as m:
        m.setattr(sq, "_SHARE", False)
        return sq.run_one(COL, s, _events(s), st)


@pytest.mark.parametrize("u_d", POLICIES)
def test_the_shared_ways_are_the_ways_run_apart_bit_for_bit(monkeypatch, u_d):
    st = sq.SequenceSettings(restoration=Restoration(u_d=u_d), **QUICK)
    for s in (0, 1, 2):
        shared, apart = sq.run_one(COL, s, _events(s), st), _apart(monkeypatch, s, st)
        (line, (runs, saved)), (line_apart, (runs_apart, saved_apart)) = _line(shared), _line(apart)
        assert line == line_apart, (s, u_d)
        assert saved_apart == 0 and runs + saved == runs_apart and saved > 0, (s, u_d, runs, saved, runs_apart)
        if u_d == 1e-6:
            assert shared.restorations >= 2   # the policy acts more than once: the intact way's runs are taken


def _expected_runs(s: int, st) -> tuple:
    """(runs made, runs of the three ways apart) from the definition, on the ways run apart: the accumulated way's
    events a, the intact way's n (its first is the accumulated way's), and -- when the policy acts -- the restored
    way's events after its first restoration that do not follow a restoration directly."""
    motions = [sq._motion(e, st) for e in _events(s) if not e.outside]
    acc = run_sequence(COL, motions, settle=st.settle).events
    res = run_sequence(COL, motions, restoration=st.restoration, settle=st.settle).events
    a, n = len(acc), len(motions)
    first = next((k for k, e in enumerate(res) if e.restored), None)
    new = 0 if first is None else sum(not res[k - 1].restored for k in range(first + 1, len(res)))
    return a + (n - 1) + new, a + n + len(res)


@pytest.mark.parametrize("u_d", (1e-6, 0.002))
def test_the_runs_made_are_the_definitions_count(u_d):
    st = sq.SequenceSettings(restoration=Restoration(u_d=u_d), **QUICK)
    for s in (0, 1):
        made, apart = _expected_runs(s, st)
        o = sq.run_one(COL, s, _events(s), st)
        assert (o.runs, o.shared) == (made, apart - made), (s, u_d)


def test_two_events_cost_three_runs_whether_the_policy_acts_or_not():
    """Sequence 2: two events, no collapse. Apart the three ways make 2 + 2 + 2 = 6 runs. Shared: the accumulated
    way's 2, the intact way's second (its first is the accumulated way's), and none of the restored way's -- the
    policy never acting, it is the accumulated way; acting after both events (u_d > 1e-6), its first event is the
    accumulated way's and its second, right after a restoration, meets the intact column: the intact way's."""
    assert len(_events(2)) == 2
    for u_d, restorations in ((10.0, 0), (1e-6, 2)):
        o = sq.run_one(COL, 2, _events(2), sq.SequenceSettings(restoration=Restoration(u_d=u_d), **QUICK))
        assert (o.runs, o.shared, o.restorations) == (3, 3, restorations), u_d


def test_known_runs_are_taken_as_they_are_and_counted():
    """``run_sequence``'s hook: a sequence whose every event is handed back by ``known`` from the same sequence run
    before makes no run and equals it event for event; one handed nothing is the plain sequence."""
    st = sq.SequenceSettings(**QUICK)
    motions = [sq._motion(e, st) for e in _events(2)]
    ref = run_sequence(COL, motions, restoration=NO_RESTORATION, settle=st.settle)
    again = run_sequence(COL, motions, settle=st.settle, known=lambda k, restorations, fresh: ref.events[k])
    none = run_sequence(COL, motions, settle=st.settle, known=lambda k, restorations, fresh: None)
    assert (again.reused, none.reused, ref.reused) == (2, 0, 0)
    for seq in (again, none):
        assert [repr((e.index, e.u_top, e.u_d, e.u_d_rest, e.tilt_rad, e.collapsed, e.restored)) for e in seq.events] \
            == [repr((e.index, e.u_top, e.u_d, e.u_d_rest, e.tilt_rad, e.collapsed, e.restored)) for e in ref.events]
        assert repr((seq.accumulated_u_d, seq.tilt_rad)) == repr((ref.accumulated_u_d, ref.tilt_rad))
        assert seq.final_state.values.tobytes() == ref.final_state.values.tobytes()   # NaN slots too


def _way(o, w: str) -> str:
    """A way's outcome as text (floats by repr: their bits)."""
    return repr((o.collapsed[w], o.collapse_yr[w], o.u_d_end[w], o.tilt_end[w], o.first_yr[w], o.peak[w]))


@pytest.mark.parametrize("ways", [("accumulated",), ("accumulated", "restored"), ("accumulated", "intact")])
def test_the_ways_asked_for_are_those_of_the_three_bit_for_bit_with_fewer_runs(ways):
    """``run_one(..., ways)`` (the rare sequences' ``ways``): each way asked for is, bit for bit, that way of the three
    run together, the others are absent, and the runs made are the definition's count for those ways alone: the
    accumulated way's a; the intact way's n - 1 more (its first is the accumulated way's); the restored way's events
    after its first restoration that do not follow a restoration directly -- and, without the intact way, those that
    do (the intact way's run of the event, no longer made for it). Policy u_d > 0.002: it acts in sequences 0 and 1."""
    st = sq.SequenceSettings(restoration=Restoration(u_d=0.002), **QUICK)
    for s in (0, 1):
        every, some = sq.run_one(COL, s, _events(s), st), sq.run_one(COL, s, _events(s), st, ways)
        assert set(some.collapsed) == set(ways) and set(some.peak) == set(ways)
        for w in ways:
            assert _way(some, w) == _way(every, w), (s, w)
        motions = [sq._motion(e, st) for e in _events(s) if not e.outside]
        acc = run_sequence(COL, motions, settle=st.settle).events
        res = run_sequence(COL, motions, restoration=st.restoration, settle=st.settle).events
        first = next(k for k, e in enumerate(res) if e.restored)
        made = len(acc) + (len(motions) - 1 if "intact" in ways else 0)
        if "restored" in ways:
            made += len(res) - 1 - first   # every event after the first restoration
        assert some.runs == made and some.runs < every.runs, (s, ways, some.runs, made, every.runs)
        assert some.restorations == (every.restorations if "restored" in ways else 0)


def test_ways_without_the_accumulated_one_or_unknown_are_refused_by_name():
    st = sq.SequenceSettings(**QUICK)
    for ways in (("intact",), ("accumulated", "all"), ("accumulated", "accumulated"), "accumulated"):
        with pytest.raises(sq.ParameterError, match="ways"):
            sq.run_one(COL, 2, _events(2), st, ways)
