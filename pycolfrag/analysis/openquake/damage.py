"""OpenQuake's classical damage: a hazard curve convolved with a fragility model."""
from __future__ import annotations

import math

import numpy as np

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


def classical_damage(model: FragilityModel, imls, poes, investigation_time, risk_investigation_time=None, *,
                     steps_per_interval: int = 1, continuous_fragility_discretization: int = 20) -> dict:
    """Damage-state probabilities of one asset from a hazard curve, the way OpenQuake's classical damage
    calculator computes them (module docstring).

    Parameters
    ----------
    model : FragilityModel
    imls : array (L,) -- hazard levels (the model's IMT and units)
    poes : array (L,) or (N, L) -- probabilities of exceedance in ``investigation_time`` (N sites)
    investigation_time : float -- years of the hazard
    risk_investigation_time : float -- years of the result (default: ``investigation_time``)
    steps_per_interval : int -- > 1: evaluate on finer levels, the hazard curve interpolated linearly
        between its levels and the levels clipped to the curve's range: the fragility's IMLs with that
        many steps per interval (discrete), or ``continuous_fragility_discretization`` levels from
        ``min_iml`` to ``max_iml`` (continuous), as OpenQuake does

    Returns
    -------
    dict of arrays (last axis over limit states or damage states):
    ``rates`` -- annual rate of exceeding each limit state, 1/yr;
    ``poes`` -- probability of exceeding each limit state in the risk investigation time;
    ``damage`` -- probabilities of the damage states (no damage, then one per limit state), summing to 1.
    """
    imls = np.asarray(imls, dtype=float)
    poes = np.asarray(poes, dtype=float)
    if imls.ndim != 1 or poes.shape[-1:] != imls.shape:
        raise ParameterError(f"classical_damage: {imls.size} levels but poes of shape {poes.shape}")
    if not np.all((poes >= 0) & (poes < 1)):
        bad = poes[~((poes >= 0) & (poes < 1))].ravel()[0]
        raise ParameterError(f"classical_damage: probability of exceedance {bad!r} outside [0, 1) "
                             "(1 would be an infinite annual rate)")
    t = float(investigation_time)
    tr = t if risk_investigation_time is None else float(risk_investigation_time)
    if not (t > 0 and tr > 0 and math.isfinite(t) and math.isfinite(tr)):
        raise ParameterError(f"investigation times must be > 0 years, got {investigation_time!r}, "
                             f"{risk_investigation_time!r}")
    if int(steps_per_interval) > 1:
        f0 = model.functions[0]
        fine = (_fine_graining(f0._points()[0], int(steps_per_interval)) if model.format == "discrete"
                else np.linspace(f0.min_iml, f0.max_iml, int(continuous_fragility_discretization)))
        fine = np.clip(fine, imls[0], imls[-1])
        poes = np.apply_along_axis(lambda p: np.interp(fine, imls, p), -1, poes)
        imls = fine
    occ = occurrence_rates(annual_rates(poes, t))
    rates = np.stack([occ @ f(imls) for f in model.functions], axis=-1)
    p = -np.expm1(-rates * tr)
    ones = np.ones(p.shape[:-1] + (1,))
    damage = -np.diff(np.concatenate([ones, p, 0 * ones], axis=-1), axis=-1)
    return {"rates": rates, "poes": p, "damage": damage}

