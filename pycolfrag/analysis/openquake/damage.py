"""OpenQuake's classical damage: a hazard curve convolved with a fragility model."""
from __future__ import annotations

import warnings

import numpy as np

from ..._validate import finite_float, integer
from ...errors import ParameterError
from .functions import FragilityModel
from .hazard import annual_rates, occurrence_rates


def _fine_graining(points, steps):
    """``steps`` equal sub-intervals in every interval of ``points`` (OpenQuake's steps_per_interval)."""
    pts = np.asarray(points, dtype=float)
    if steps < 2:
        return pts
    inner = [np.linspace(a, b, steps + 1)[:-1] for a, b in zip(pts[:-1], pts[1:])]
    return np.concatenate(inner + [pts[-1:]])


class HazardRangeWarning(UserWarning):
    """The hazard curve's levels miss the range over which the fragility functions vary: the damage rates
    then rest on the value OpenQuake holds outside that range and on the discretisation settings."""


def _check_inputs(model, imls, poes, investigation_time, risk_investigation_time, steps, cfd):
    """The checked arrays and times of :func:`classical_damage` (ParameterError naming a bad one)."""
    if not isinstance(model, FragilityModel):
        raise ParameterError(f"classical_damage: model must be a FragilityModel, got {type(model).__name__}")
    imls = np.asarray(imls, dtype=float)
    poes = np.asarray(poes, dtype=float)
    if imls.ndim != 1 or poes.shape[-1:] != imls.shape:
        raise ParameterError(f"classical_damage: {imls.size} levels but poes of shape {poes.shape}")
    if imls.size < 2 or not (np.all(np.isfinite(imls)) and imls[0] > 0 and np.all(np.diff(imls) > 0)):
        # one level: its rate of occurrence, the difference of the rates around it, is 0 (no risk at all)
        raise ParameterError(f"classical_damage: the hazard curve needs at least two increasing levels > 0, got "
                             f"{imls.tolist()}")
    if not np.all((poes >= 0) & (poes < 1)):
        bad = poes[~((poes >= 0) & (poes < 1))].ravel()[0]
        raise ParameterError(f"classical_damage: probability of exceedance {bad!r} outside [0, 1) "
                             "(1 would be an infinite annual rate)")
    t = finite_float(investigation_time, "investigation_time")
    tr = t if risk_investigation_time is None else finite_float(risk_investigation_time, "risk investigation time")
    if not (t > 0 and tr > 0):
        raise ParameterError(f"investigation times must be > 0 years, got {investigation_time!r} (hazard) and "
                             f"{risk_investigation_time!r} (risk)")
    integer(steps, "steps_per_interval", 1)
    integer(cfd, "continuous_fragility_discretization", 2)
    return imls, poes, t, tr


def _levels(model, imls, poes, steps, cfd):
    """The levels the fragility is evaluated at and the hazard's poes there: the hazard's own levels, or
    with ``steps > 1`` OpenQuake's finer levels (``build_imls`` and ``classical_damage`` in
    ``openquake/risklib/scientific.py``): a discrete function's IMLs (with the no-damage point) cut into
    ``steps`` intervals each, or ``cfd`` levels spaced linearly from minIML to maxIML of a continuous one,
    clipped to the hazard curve's range, the poes interpolated linearly."""
    if steps <= 1:
        return imls, poes
    f0 = model.functions[0]
    fine = (_fine_graining(f0._points()[0], steps) if model.format == "discrete"
            else np.linspace(f0.min_iml, f0.max_iml, cfd))
    fine = np.clip(fine, imls[0], imls[-1])
    return fine, np.apply_along_axis(lambda p: np.interp(fine, imls, p), -1, poes)


def _warn_out_of_range(model, imls) -> None:
    lo, hi = model.domain
    if imls[-1] >= lo and imls[0] <= hi:
        return
    side, edge = ("below", "minIML") if imls[-1] < lo else ("above", "maxIML")
    held = [float(f(lo if side == "below" else hi)) for f in model.functions]
    warnings.warn(f"every hazard level ({imls[0]:.4g} to {imls[-1]:.4g}) lies {side} the fragility's range "
                  f"{lo:.4g}-{hi:.4g}: OpenQuake holds each limit state at its value at {edge} there "
                  f"({', '.join(f'{p:.3g}' for p in held)}), so the damage rates rest on that value and on the "
                  "discretisation (steps_per_interval > 1 squeezes the levels onto one and gives 0); give hazard "
                  "levels that cover the fragility's range", HazardRangeWarning, stacklevel=3)


def classical_damage(model: FragilityModel, imls, poes, investigation_time, risk_investigation_time=None, *,
                     steps_per_interval: int = 1, continuous_fragility_discretization: int = 20) -> dict:
    """Damage-state probabilities of one asset from a hazard curve, the way OpenQuake's classical damage
    calculator computes them (``scientific.classical_damage`` of ``openquake/risklib``; module docstring).

    Parameters
    ----------
    model : FragilityModel
    imls : array (L,) -- hazard levels (the model's IMT and units), increasing, L >= 2
    poes : array (L,) or (N, L) -- probabilities of exceedance in ``investigation_time`` (N sites)
    investigation_time : float -- years of the hazard
    risk_investigation_time : float -- years of the result (default: ``investigation_time``)
    steps_per_interval : int -- OpenQuake's ``steps_per_interval``; > 1: evaluate on finer levels (:func:`_levels`)
    continuous_fragility_discretization : int -- OpenQuake's parameter of that name: the number of levels
        from minIML to maxIML of a continuous model when ``steps_per_interval > 1``; default 20, OpenQuake's
        (``continuous_fragility_discretization = valid.Param(valid.positiveint, 20)`` in
        ``openquake/commonlib/oqvalidation.py``)

    Refused (ParameterError): fewer than two hazard levels, a probability outside [0, 1), times that
    are not > 0, and a model whose limit states cross at the levels evaluated (:meth:`FragilityModel.crossing`:
    a negative damage-state probability). Warned (:class:`HazardRangeWarning`): hazard levels that all
    lie outside the fragility's range.

    Returns
    -------
    dict of arrays (last axis over limit states or damage states):
    ``rates`` -- annual rate of exceeding each limit state, 1/yr;
    ``poes`` -- probability of exceeding each limit state in the risk investigation time;
    ``damage`` -- probabilities of the damage states (no damage, then one per limit state), summing to 1.
    """
    steps, cfd = steps_per_interval, continuous_fragility_discretization
    imls, poes, t, tr = _check_inputs(model, imls, poes, investigation_time, risk_investigation_time, steps, cfd)
    _warn_out_of_range(model, imls)
    imls, poes = _levels(model, imls, poes, int(steps), int(cfd))
    cross = model.crossing(imls)
    if cross:
        raise ParameterError(f"the limit states of {model.taxonomy!r} cross: {cross}; the damage state between "
                             "them would get a negative probability")
    occ = occurrence_rates(annual_rates(poes, t))
    rates = np.stack([occ @ f(imls) for f in model.functions], axis=-1)
    p = -np.expm1(-rates * tr)
    ones = np.ones(p.shape[:-1] + (1,))
    damage = -np.diff(np.concatenate([ones, p, 0 * ones], axis=-1), axis=-1)
    return {"rates": rates, "poes": p, "damage": damage}
