"""A scenario's synthetic records, prepared once: what every record of a scenario (Mw, R, dt, vp_scale,
pulse shape) shares is found when the scenario is prepared, and a record then needs only its own seed
and pulse (the grid's rows: docs/architecture.md, "A row of the synthetic grid").

Prepared once (:func:`prepare`, which checks the scenario as :func:`pycolfrag.ground_motion.synthesize`
does): the scenario's checks, the Atkinson & Silva generator set up in C (its source spectrum, window and
FFT length for this Mw, R and dt), the generator's info for the records' ``meta``, the pulse shape, and
the FFT plans of the combination. Per record (:meth:`ScenarioSynthesis.record`): the white noise of the
seed through the prepared generator, the pulse of the row's inputs (the shape's ``prepare``), then
:func:`near_fault` (the paper's steps 2-6, one text with ``synthesize``'s). Values are checked where
they enter (``pycolfrag.ground_motion._checked_row``: the seed and a pulse row) and taken as they are after.

``prepare(Mw, R, dt, vp_scale, shape).record(seed, inputs)`` is bitwise ``synthesize(Mw, R, seed, dt,
vp_scale, pulse=row, shape=shape)`` (``shape=None``: ``stochastic(Mw, R, seed, dt)``).
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.core.ffi import check, ffi, lib, ptr
from pycolfrag.core.validate import positive_float
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.ground_motion import combine as _combine
from pycolfrag.ground_motion import record, registry, rupakhety_2011
from pycolfrag.ground_motion.intensity import _integrated
from pycolfrag.ground_motion.record import Record

__all__ = ["ScenarioSynthesis", "prepare", "near_fault"]

def _keyed(parameters, values) -> dict:
    """``{meta key: value}`` of declared parameters, in their order."""
    return {p.meta_key: v for p, v in zip(parameters, values, strict=True)}


def _stochastic_meta(Mw, dist_km, seed, dt, generator_meta) -> dict:
    """The meta of a stochastic record (:func:`pycolfrag.ground_motion.stochastic`, a prepared scenario's record
    without a pulse): the record's parameters, its kind, the generator's details."""
    return {**_keyed(record.PARAMETERS, (Mw, dist_km, seed, dt)), "kind": "stochastic", **generator_meta}


def _generator_meta(info):
    out = {"generator": info.get("generator", "atkinson_silva_2000")}
    for k, v in info.items():
        if k != "generator":
            out[f"hf_{k}"] = v
    return out


def _place(prepared, hf, dt, t_peak):
    """The pulse's epoch t0 that puts its velocity peak at t_peak (s), the HF record padded with whole
    samples of zeros where the pulse's support reaches past it, and the times counted from the first
    sample: (hf, t0, t_peak, n_pre, n_post)."""
    t0 = t_peak - prepared.peak_offset_s
    n_pre = max(0, int(math.ceil((prepared.before_s - t0) / dt - 1e-9)))
    t_last = (hf.size - 1) * dt
    n_post = max(0, int(math.ceil((t0 + prepared.after_s - t_last) / dt - 1e-9)))
    if n_pre or n_post:
        hf = np.concatenate([np.zeros(n_pre), hf, np.zeros(n_post)])
    return hf, t0 + n_pre * dt, t_peak + n_pre * dt, n_pre, n_post


def _combined(hf, pulse_acc, plan):
    """:func:`pycolfrag.ground_motion.combine.combine` of checked arrays (float64, one length) with the
    FFT ``plan`` of their length (``combine._plan``)."""
    out = np.empty_like(hf)
    msg = ffi.new("char[]", lib.CF_MSG_LEN)
    check(lib.cf_combine_subtract_plan(plan, ptr(hf), ptr(pulse_acc), hf.size, ptr(out), msg), msg)
    return out


def near_fault(Mw, dist_km, seed, dt, vp_scale, model, prepared, hf, generator_meta, *, match_polarity=True,
               source="argument", plans=None, components=True) -> Record:
    """Steps 2-6 of :func:`pycolfrag.ground_motion.synthesize` (the one text of them): the Record of the
    high-frequency record ``hf`` (m/s^2, step ``dt`` s, made with ``generator_meta``: :func:`_generator_meta`)
    and the ``prepared`` pulse of the shape ``model``, the scenario's values (checked) in its ``meta``.
    ``plans``: FFT plans by length, filled and reused (None: looked up); ``components=False`` leaves out
    the record's ``hf``, ``pulse`` and ``hf_modified`` parts."""
    vel_hf = _integrated(hf, dt)[0]
    k_peak = int(np.argmax(np.abs(vel_hf)))
    t_peak = k_peak * dt
    polarity = 1.0                                                                  # step 2
    if match_polarity and prepared.peak_sign * vel_hf[k_peak] < 0:
        polarity = -1.0
        hf = -hf
    hf, t0, t_peak, n_pre, n_post = _place(prepared, hf, dt, t_peak)
    pulse_acc = prepared.acceleration(np.arange(hf.size) * dt, t0)                 # m/s^2
    plan = None if plans is None else plans.get(hf.size)
    if plan is None:
        plan = _combine._plan(hf.size)
        if plans is not None:
            plans[hf.size] = plan
    acc = _combined(hf, pulse_acc, plan)                                            # steps 3-6
    meta = {**_keyed(record.PARAMETERS, (Mw, dist_km, seed, dt)), "kind": "near-fault",
            "vp_scale": vp_scale, **_keyed(model.PARAMETERS, prepared.meta(t0, pulse_acc)),
            "pulse_shape": model.SHAPE, "t_peak_s": t_peak, "pad_before_s": n_pre * dt, "pad_after_s": n_post * dt,
            "hf_polarity": int(polarity), "pulse_seeded_from": source, **generator_meta}
    parts = {"hf": hf, "pulse": pulse_acc, "hf_modified": acc - pulse_acc} if components else None
    return Record._checked(acc, dt, meta, components=parts)


class ScenarioSynthesis:
    """The records of one scenario, prepared (:func:`prepare`): ``record(seed, inputs)`` per record.

    Attributes: ``Mw``, ``dist_km``, ``dt``, ``vp_scale`` (floats), ``model`` (the pulse shape's module,
    None for the stochastic record alone), ``info`` (the generator's, as :func:`atkinson_silva_2000.simulate`
    gives it).
    """

    def __init__(self, Mw, dist_km, dt, vp_scale, model) -> None:
        self.Mw, self.dist_km, self.dt, self.vp_scale, self.model = Mw, dist_km, dt, vp_scale, model
        gen = self._generator = as00._generator(Mw, dist_km, as00._check_dt(dt))
        self.info = as00._info(gen, dt)
        self._n_out = int(gen.info["n_out"])
        self._generator_meta = _generator_meta(self.info)
        self._plans: dict = {}

    def _noise_record(self, seed) -> np.ndarray:
        """The high-frequency record of ``seed`` (:meth:`atkinson_silva_2000._Generator.run`'s C call on
        the prepared generator)."""
        gen = self._generator
        acc = np.empty(self._n_out, dtype=np.float64)
        with gen.lock:
            check(lib.cf_stochastic_run(gen.ptr, seed, ptr(acc), acc.size), lib.cf_stochastic_message(gen.ptr))
        return acc

    def record(self, seed, inputs, *, components=True, source="argument") -> Record:
        """The record of a checked ``seed`` and pulse ``inputs`` (``ground_motion._checked_row``), bitwise
        ``synthesize`` 's (``stochastic`` 's without a pulse). ``components=False`` leaves out the
        ``hf``, ``pulse`` and ``hf_modified`` parts (a grid row runs ``acc`` alone)."""
        hf = self._noise_record(seed)
        if self.model is None:
            return Record._checked(hf, self.dt, _stochastic_meta(self.Mw, self.dist_km, seed, self.dt,
                                                                  self._generator_meta))
        return near_fault(self.Mw, self.dist_km, seed, self.dt, self.vp_scale, self.model, self.model.prepare(*inputs),
                          hf, self._generator_meta, source=source, plans=self._plans, components=components)


def prepare(Mw, dist_km, dt=0.005, vp_scale=1.0, shape=registry.DEFAULT_PULSE_SHAPE) -> ScenarioSynthesis:
    """The :class:`ScenarioSynthesis` of a scenario, its arguments checked as :func:`synthesize` checks
    them (``shape`` None: the stochastic record alone, checked as :func:`stochastic` does)."""
    if shape is None:
        dt = positive_float(dt, "dt")
        Mw_f, dist_f = as00.check_scenario(Mw, dist_km)
        return ScenarioSynthesis(Mw_f, dist_f, dt, 1.0, None)
    model = registry.pulse_shape_of(shape)
    as00.check_scenario(Mw, dist_km)
    Mw_f, dist_f = rupakhety_2011.check_scenario(Mw, dist_km)
    dt = positive_float(dt, "dt")
    rupakhety_2011.mean_vp_cm_s(Mw_f, dist_f, vp_scale)   # ParameterError naming a bad vp_scale
    return ScenarioSynthesis(Mw_f, dist_f, dt, float(vp_scale), model)
