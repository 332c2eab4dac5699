"""A sequence of records on one structure, each starting from the state the previous one left
(docs/sequences.md, "A sequence of records").

:func:`run_sequence` runs record after record through the continuation API (``simulate(...,
initial_state=state)``, :mod:`pycolfrag.solver.state`): every event is one run of its record and the
free tail ``tail_s`` (the EDPs as the grid measures them), then, unless ``settle=None``, a *settling* run
from its state (a record of zeros, mass-proportional damping ``Settle.damping_alpha`` from its start,
stopped by the solver's at-rest exit): the undamped model of the paper rocks on for minutes after a
record, and the next earthquake comes years later, on a column at rest. A state is **at rest** when
every body's speed ``|v|`` and the speed ``|w| H`` its angular velocity gives over the model's height
``H`` are at most ``Settle.rest_speed`` (default 1 mm/s; :func:`at_rest`); the accumulated measures
(``u_d`` and the tilt) are read from that state. A collapse ends the sequence. A restoration policy
(:class:`Restoration`) reassembles the structure -- back to the sequence's initial state, the as-built
rest -- after an event whose accumulated ``u_d`` or tilt exceeds its thresholds, and counts it.

Each run is a call of the continuation API, so a sequence equals, bit for bit, the same calls made by
hand (tests/test_sequence_runs.py).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion.record import Record
from pycolfrag.solver import run as _run  # through the module, as sample.py calls it
from pycolfrag.solver.state import _HEAD, _MON, State

__all__ = ["Restoration", "NO_RESTORATION", "Settle", "EventResult", "SequenceResult", "run_sequence", "at_rest",
           "tilt_rad", "model_height"]


def _threshold(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number > 0 (inf: never), got {value!r}") from None
    if isinstance(value, bool) or not v > 0:   # NaN fails too
        raise ParameterError(f"{name} must be a number > 0 (inf: never), got {value!r}")
    return v


@dataclass(frozen=True)
class Restoration:
    """Reassemble the structure (back to the sequence's initial state: the as-built rest) after an event
    whose accumulated ``u_d`` (dimensionless, as the EDP) exceeds ``u_d`` or whose largest residual tilt
    of a block exceeds ``tilt_rad`` (rad); ``inf`` (the default) never. The sequence counts them."""

    u_d: float = math.inf
    tilt_rad: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "u_d", _threshold(self.u_d, "Restoration.u_d"))
        object.__setattr__(self, "tilt_rad", _threshold(self.tilt_rad, "Restoration.tilt_rad"))

    @property
    def active(self) -> bool:
        return math.isfinite(self.u_d) or math.isfinite(self.tilt_rad)

    def due(self, u_d: float, tilt: float) -> bool:
        return bool(u_d > self.u_d or tilt > self.tilt_rad)

    def describe(self) -> str:
        if not self.active:
            return "none"
        parts = [f"u_d > {self.u_d:g}"] if math.isfinite(self.u_d) else []
        parts += [f"tilt > {self.tilt_rad:g} rad"] if math.isfinite(self.tilt_rad) else []
        return "reassemble when " + " or ".join(parts)


#: No restoration: the damage accumulates until the end or a collapse.
NO_RESTORATION = Restoration()


@dataclass(frozen=True)
class Settle:
    """How an event's free tail brings the structure to rest: a run of a zero record with mass-proportional
    damping ``damping_alpha`` (1/s; 5, the value of Table II's damped procedure) for at most ``max_s``
    seconds, stopped by the solver's at-rest exit; ``rest_speed`` (m/s) is :func:`at_rest`'s bound."""

    damping_alpha: float = 5.0
    max_s: float = 60.0
    rest_speed: float = 1e-3

    def __post_init__(self):
        for name in ("damping_alpha", "max_s", "rest_speed"):
            object.__setattr__(self, name, _threshold(getattr(self, name), f"Settle.{name}"))
        if not math.isfinite(self.max_s) or not math.isfinite(self.damping_alpha):
            raise ParameterError(f"Settle.max_s and Settle.damping_alpha must be finite, got {self.max_s!r}, "
                                 f"{self.damping_alpha!r}")


def model_height(model) -> float:
    """The model's height, m: a column's, or a scene's column's (the length :func:`at_rest` scales by)."""
    h = getattr(model, "height", None)
    if h is None:
        h = getattr(getattr(model, "column", None), "height", None)
    return float(h) if h is not None else 1.0


def at_rest(state: State, height: float, rest_speed: float = Settle.rest_speed) -> bool:
    """Whether every body of ``state`` moves slower than ``rest_speed`` (m/s): its speed and its angular
    speed times ``height`` (m, the model's)."""
    b = state.bodies()
    v = float(np.max(np.linalg.norm(b["v"], axis=1), initial=0.0))
    w = float(np.max(np.linalg.norm(b["w"], axis=1), initial=0.0))
    return v <= rest_speed and w * height <= rest_speed


def tilt_rad(state: State) -> float:
    """The largest tilt of a body's axis from the vertical (of the foundation's frame) in ``state``, rad:
    ``2 asin(sqrt(q_x^2 + q_y^2))`` of each body's unit quaternion (w, x, y, z), the ground excluded."""
    q = state.bodies()["q"][1:]
    if q.size == 0:
        return 0.0
    s = np.sqrt(np.clip(q[:, 1] ** 2 + q[:, 2] ** 2, 0.0, 1.0))
    return float(np.max(2.0 * np.arcsin(s)))


@dataclass
class EventResult:
    """One event of a sequence. ``u_top`` is the sequence's peak so far (the monitor carries over: measured
    from the rest the sequence, or its last restoration, started from), ``u_d`` the event run's residual
    dislocation (the grid's measure, the last ``residual_window_s`` of its tail), ``collapsed`` its
    collapse; ``u_d_rest`` and ``tilt_rad`` the accumulated measures of the state the next event starts
    from (after the settling run; NaN after a collapse), ``at_rest`` whether that state is at rest,
    ``restored`` whether the policy then reassembled the structure. ``response`` is the event run's
    :class:`~pycolfrag.solver.run.Response` (for a plain column continued from a state, its ``u_top`` is
    the event's own), ``settled`` the settling run's (None without one). ``u_top_event``: the peak of the
    event alone (the top's displacement from the as-built rest, over the base diameter; a scene's largest
    over its columns)."""

    index: int
    u_top: float
    u_d: float
    collapsed: bool
    u_d_rest: float
    tilt_rad: float
    at_rest: bool
    restored: bool
    response: object = field(repr=False, default=None)
    settled: object = field(repr=False, default=None)
    u_top_event: float = math.nan


@dataclass
class SequenceResult:
    """A sequence's events (up to its collapse), its end state (None after a collapse), and the count of
    restorations; ``accumulated_u_d`` and ``tilt_rad`` are those of the end state (NaN after a collapse;
    when the last event was followed by a restoration: 0 from the as-built rest, and from a given
    ``initial_state`` its tilt and NaN for its u_d, which is its run's, not kept); ``reused``: how many of its events
    were taken from ``run_sequence``'s ``known`` rather than run (its event runs: ``len(events) - reused``)."""

    events: list
    final_state: State | None
    collapsed: bool
    restorations: int
    accumulated_u_d: float
    tilt_rad: float
    reused: int = 0

    @property
    def collapse_event(self) -> int | None:
        return self.events[-1].index if self.collapsed else None


#: Where a state holds the monitor's running peak of the top's displacement (m): the header's 22 values,
#: then the monitor's, of which it is the 11th (csrc/solver_state.c, ``mon[10]``).
_PEAK = _HEAD + 10
#: csrc/solver_state.c's layout: CF_ST_HEAD + CF_ST_MON values, then CF_ST_BODY per body, the residual ring
#: (the header's values 8 x 9), then a scene's running peak of each column's top (the header's value 6 of them).
_BODIES, _BODY = _HEAD + _MON, 22


def _peak_slots(state: State) -> list[int]:
    """Where ``state`` keeps running peaks of a top's displacement (m): the monitor's (:data:`_PEAK`), and in a
    scene's state (columns with beams, several columns) each column's, from which its ``u_top`` is read."""
    v = state.values
    k = _BODIES + _BODY * int(v[2]) + int(v[8] * v[9])
    return [_PEAK, *range(k, k + int(v[6]))]


def _u_top(model, state: State, slots: list[int]) -> float:
    """The ``u_top`` the peaks of ``state`` give: the top's over the base diameter, a scene's largest over its
    column's (csrc/solver_monitor.c)."""
    if len(slots) == 1:
        return float(state.values[_PEAK]) / model.base_diameter
    cols = model.scene_parts().columns
    return max(float(state.values[k]) / col.base_diameter for k, (col, _, _) in zip(slots[1:], cols))


def _with_peaks(state: State | None, slots: list[int], peaks) -> State | None:
    """``state`` with its running peaks at ``slots`` set to ``peaks``."""
    if state is None:
        return state
    v = state.values.copy()
    v[slots] = peaks
    return dataclasses.replace(state, values=v)


def _event_run(model, rec, state, options, overrides):
    """An event's run, the peak u_top of the event alone and the sequence's peak u_top up to its end. From a
    state the run starts with its running peaks at 0 (the monitor's, and a scene's per column), and its final
    state gets the larger of the two back: the same bits as the run from ``state`` as it is (the monitor keeps
    the larger of its running value and each step's; nothing else reads them)."""
    if state is None:
        res = _simulate(model, rec, state, options, overrides)
        return res, float(res.u_top), float(res.u_top)
    slots = _peak_slots(state)
    before = _u_top(model, state, slots)
    res = _simulate(model, rec, _with_peaks(state, slots, 0.0), options, overrides)
    if res.final_state is not None:
        res.final_state = _with_peaks(res.final_state, slots,
                                      np.maximum(state.values[slots], res.final_state.values[slots]))
    return res, float(res.u_top), max(before, float(res.u_top))


def _records(records) -> list:
    if isinstance(records, (str, bytes, Record, dict)) or not hasattr(records, "__iter__"):
        raise ParameterError(f"records must be a sequence of records, got {type(records).__name__}")
    out = list(records)
    if not out:
        raise ParameterError("records is empty: a sequence needs at least one record")
    for i, rec in enumerate(out):
        ok = isinstance(rec, Record) or (isinstance(rec, (tuple, list)) and len(rec) == 2)
        if not ok:
            raise ParameterError(f"records[{i}] must be a Record or a tuple (acc_x, dt), got {type(rec).__name__}")
    return out


def _simulate(model, rec, state, options, overrides):
    if isinstance(rec, Record):
        return _run.simulate(model, rec, options=options, initial_state=state, **overrides)
    return _run.simulate(model, rec[0], rec[1], options=options, initial_state=state, **overrides)


def _settle(model, res, settle: Settle, dt: float, options, overrides):
    """The settling run from ``res``'s state: two zero samples, then the damped free tail."""
    kw = {**overrides, "tail_s": settle.max_s, "damping_alpha": settle.damping_alpha, "damping_start_s": 0.0,
          "early_exit": True}
    return _run.simulate(model, np.zeros(2), dt, options=options, initial_state=res.final_state, **kw)


def _measures(last, height: float, rest_speed: float) -> tuple:
    """(the state the next event starts from, its accumulated u_d, tilt, whether at rest) after ``last``
    (the event's last run); (None, NaN, NaN, False) after a collapse."""
    state = last.final_state
    if last.collapsed or state is None:
        return None, math.nan, math.nan, False
    return state, float(last.u_d), tilt_rad(state), at_rest(state, height, rest_speed)


def _record_dt(rec) -> float:
    return float(rec.dt if isinstance(rec, Record) else rec[1])


def run_sequence(model, records, *, restoration: Restoration = NO_RESTORATION, settle: Settle | None = Settle(),
                 initial_state: State | None = None, options=None, known=None, **overrides) -> SequenceResult:
    """Run ``records`` (Records, or ``(acc_x, dt)`` tuples) one after the other on ``model``, each from
    the state the previous one left (see the module's text); ``initial_state`` (None: the as-built rest)
    is where the sequence and every restoration start; ``options`` and ``**overrides`` as
    :func:`pycolfrag.simulate`'s, for every event run (the settling run overrides ``tail_s``,
    ``damping_alpha``, ``damping_start_s`` and ``early_exit``). ``settle=None``: no settling run (the
    next event starts where the event's tail ended: the continuation API's chain).

    ``known``: None, or a callable ``known(k, restorations, fresh)`` giving record ``k``'s :class:`EventResult`
    already computed by the same calls from the same state -- ``restorations`` done before it, ``fresh`` when its
    state is ``initial_state`` itself (the start, or right after a restoration: a flag, no state compared) -- or
    None to run it. The caller vouches that it is the same computation (the same model, record, settling and
    options from that state); its runs are taken as they are (its ``index`` and ``restored`` set here), not run,
    and counted in the result's ``reused`` (docs/sequences.md, "Runs shared between the ways")."""
    recs = _records(records)
    if not isinstance(restoration, Restoration):
        raise ParameterError(f"restoration must be a Restoration, got {type(restoration).__name__}")
    if settle is not None and not isinstance(settle, Settle):
        raise ParameterError(f"settle must be a Settle or None, got {type(settle).__name__}")
    if initial_state is not None and not isinstance(initial_state, State):
        raise ParameterError(f"initial_state must be a State or None, got {type(initial_state).__name__}")
    if known is not None and not callable(known):
        raise ParameterError(f"known must be None or a callable (k, restorations, fresh), got {type(known).__name__}")
    height = model_height(model)
    state, events, restored_count, reused, fresh = initial_state, [], 0, 0, True
    u_d_acc, tilt = math.nan, math.nan
    rest_speed = settle.rest_speed if settle else Settle.rest_speed
    for k, rec in enumerate(recs):
        done = None if known is None else known(k, restored_count, fresh)
        if done is not None and not isinstance(done, EventResult):
            raise ParameterError(f"known({k}, {restored_count}, {fresh}) must give an EventResult or None, got "
                                 f"{type(done).__name__}")
        if done is not None:   # the same calls from the same state, made already: taken as they are
            reused += 1
            last = done.settled if done.settled is not None else done.response
            state, u_d_acc, tilt, still = _measures(last, height, rest_speed)
            restore = (not done.collapsed) and restoration.due(u_d_acc, tilt)
            events.append(dataclasses.replace(done, index=k, restored=restore))
        else:
            res, u_top_event, peak = _event_run(model, rec, state, options, overrides)
            last = res
            settled = None
            if not res.collapsed and settle is not None:
                settled = last = _settle(model, res, settle, _record_dt(rec), options, overrides)
            state, u_d_acc, tilt, still = _measures(last, height, rest_speed)
            restore = (not last.collapsed) and restoration.due(u_d_acc, tilt)
            events.append(EventResult(k, max(peak, float(last.u_top)), float(res.u_d), bool(last.collapsed), u_d_acc,
                                      tilt, still, restore, res, settled, u_top_event))
        fresh = False
        if events[-1].collapsed:
            break
        if restore:
            restored_count += 1
            state, u_d_acc, tilt, fresh = initial_state, 0.0, 0.0, True
    if initial_state is not None and events and events[-1].restored:
        u_d_acc, tilt = math.nan, tilt_rad(initial_state)   # the as-built state's u_d is its run's, not kept
    return SequenceResult(events, state, bool(events[-1].collapsed), restored_count, u_d_acc, tilt, reused)
