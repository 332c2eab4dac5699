"""OpenQuake's classical damage: a hazard curve convolved with a fragility model."""
from __future__ import annotations

import warnings

import numpy as np

from pycolfrag.analysis.openquake.functions import FragilityModel
from pycolfrag.analysis.openquake.hazard import annual_rates, occurrence_rates
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import finite_float, integer


def _fine_graining(points, steps):
    """``steps`` equal sub-intervals in every interval of ``points`` (OpenQuake's steps_per_interval)."""
    pts = np.asarray(points, dtype=float)
    if steps < 2:
        return pts
    inner = [np.linspace(a, b, steps + 1)[:-1] for a, b in zip(pts[:-1], pts[1:])]
    return np.concatenate(inner + [pts[-1:]])


#: Largest relative difference between a limit state's rate with the user's ``steps_per_interval`` > 1
#: levels and the fine answer (:func:`fine_rates`) that passes without a :class:`DiscretisationWarning`:
#: beyond OpenQuake's own QA case with 4 steps and 20 levels (up to 22 % there is warned; the
#: hazard's 28 levels alone are within 6 %), far below what the export's wide range gave the engine
#: (collapse rate x 406 with 20 levels, x 57 with 40, x 2.8 with 100; docs/risk.md).
DISCRETISATION_RTOL = 0.10
#: Largest share of a limit state's rate that hazard levels below a continuous model's minIML (where OpenQuake
#: holds the function at its value at minIML) may carry without a :class:`HazardRangeWarning`. The export's
#: default minIML holds at most 1e-8 (docs/risk.md), far below it.
HELD_SHARE_TOL = 0.01
#: Linear sub-steps per hazard interval of the fine answer.
FINE_STEPS = 50


class DiscretisationWarning(UserWarning):
    """OpenQuake's ``steps_per_interval`` > 1 levels give damage rates that differ from the fine answer
    (the same interpolation taken to fine levels) by more than :data:`DISCRETISATION_RTOL`."""


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


def fine_rates(model: FragilityModel, imls, poes, investigation_time, chunk: int = 4096) -> np.ndarray:
    """Annual rate of exceeding each limit state (last axis) with OpenQuake's ``steps_per_interval``
    interpolation taken to its limit: every interval of the hazard's levels cut into :data:`FINE_STEPS`
    linear steps, the poes interpolated linearly there (as the engine does), the fragility evaluated at
    each. Sites are taken ``chunk`` at a time (a large site model stays within memory)."""
    imls = np.asarray(imls, dtype=float)
    poes = np.asarray(poes, dtype=float)
    x = _fine_graining(imls, FINE_STEPS)
    i = np.clip(np.searchsorted(imls, x, side="right") - 1, 0, imls.size - 2)
    w = (x - imls[i]) / (imls[i + 1] - imls[i])
    fx = np.stack([f(x) for f in model.functions], axis=-1)
    flat = poes.reshape(-1, imls.size)
    out = np.empty((flat.shape[0], fx.shape[1]))
    for a in range(0, flat.shape[0], chunk):
        p = flat[a:a + chunk]
        out[a:a + chunk] = occurrence_rates(annual_rates(p[:, i] * (1 - w) + p[:, i + 1] * w,
                                                         investigation_time)) @ fx
    return out.reshape(poes.shape[:-1] + (fx.shape[1],))


def _enough_levels(model, imls, poes, t, cfd, want) -> int | None:
    """The smallest continuous_fragility_discretization (cfd doubled) within the tolerance at one site."""
    n = cfd
    while n < 100_000:
        n *= 2
        x, p = _levels(model, imls, poes, 2, n)
        got = occurrence_rates(annual_rates(p, t)) @ np.stack([f(x) for f in model.functions], axis=-1)
        if np.all(np.abs(got - want) <= DISCRETISATION_RTOL * want):
            return n
    return None


def _warn_discretisation(model, imls, poes, t, rates, steps, cfd) -> None:
    """:class:`DiscretisationWarning` where the ``steps > 1`` rates differ from :func:`fine_rates`'."""
    fine = fine_rates(model, imls, poes, t)
    off = np.abs(rates - fine) > DISCRETISATION_RTOL * fine
    if not np.any(off):
        return
    ratio = np.where(fine > 0, rates / np.where(fine > 0, fine, 1.0), np.inf)
    k = np.unravel_index(np.argmax(np.where(off, np.abs(np.log(np.where(ratio > 0, ratio, 1e-300))), -1.0)), off.shape)
    site, j = (k[0], k[1]) if off.ndim == 2 else (None, k[0])
    where = "" if site is None else f" at site {site} ({int(off.any(axis=1).sum())} of {off.shape[0]} sites off)"
    if model.format == "continuous":
        lo, hi = model.domain
        how = (f"{cfd} levels spaced linearly from minIML {lo:.4g} to maxIML {hi:.4g} (every {(hi - lo) / (cfd - 1):.3g}),"
               f" clipped to the hazard's {imls[0]:.4g}-{imls[-1]:.4g}")
        p1 = poes if site is None else poes[site]
        n = _enough_levels(model, imls, p1, t, cfd, fine if site is None else fine[site])
        fix = (f"use steps_per_interval 1 (the hazard's own levels), continuous_fragility_discretization >= {n}"
               if n else "use steps_per_interval 1 (the hazard's own levels)") + \
            ", or a range that fits the hazard (export --iml-range) or --format discrete"
    else:
        how = f"the discrete function's IMLs cut into {steps} steps each"
        fix = "use more steps_per_interval or more levels in the function (--n-imls)"
    warnings.warn(f"steps_per_interval {steps}: OpenQuake evaluates the fragility at {how}; the rate of "
                  f"{model.limit_states[j]}{where} is then {rates[k]:.4g} /yr, {ratio[k]:.3g} times the fine answer "
                  f"{fine[k]:.4g} /yr (the same interpolation on {FINE_STEPS} steps per hazard interval), beyond "
                  f"{DISCRETISATION_RTOL:.0%}; OpenQuake's engine computes the same number. {fix[0].upper() + fix[1:]} (docs/risk.md)",
                  DiscretisationWarning, stacklevel=3)


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


def _warn_held_below(model, imls, poes, t) -> None:
    """:class:`HazardRangeWarning` where hazard levels below a continuous model's minIML, at which OpenQuake
    holds each function at its value at minIML, carry more than :data:`HELD_SHARE_TOL` of a limit state's
    rate (on the hazard's own levels; with ``steps_per_interval`` > 1 the engine drops them instead)."""
    lo = model.domain[0]
    below = imls < lo
    if model.format != "continuous" or not below.any() or below.all():
        return
    occ = occurrence_rates(annual_rates(poes, t))
    fx = np.stack([f(imls) for f in model.functions], axis=-1)
    total, held = occ @ fx, occ[..., below] @ fx[below]
    share = np.where(total > 0, held / np.where(total > 0, total, 1.0), 0.0)
    if share.max() <= HELD_SHARE_TOL:
        return
    k = np.unravel_index(np.argmax(share), share.shape)
    site = f" at site {k[0]}" if share.ndim == 2 else ""
    warnings.warn(f"{int(below.sum())} of the {imls.size} hazard levels ({imls[0]:.4g} to {imls[below][-1]:.4g}) lie "
                  f"below the fragility's minIML {lo:.4g}, where OpenQuake holds each limit state at its value there "
                  f"({', '.join(f'{float(f(lo)):.3g}' for f in model.functions)}): they carry {share[k]:.1%} of the "
                  f"rate of {model.limit_states[k[-1]]}{site}, a number that rests on that held value (with "
                  "steps_per_interval > 1 the engine leaves those levels out instead); export a lower minIML "
                  "(the export's default holds at most 1e-8) or give hazard levels from minIML up",
                  HazardRangeWarning, stacklevel=3)


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
    lie outside the fragility's range, and levels below a continuous model's minIML that carry more than
    :data:`HELD_SHARE_TOL` of a rate (OpenQuake holds the function there); with ``steps_per_interval > 1``, rates more than
    :data:`DISCRETISATION_RTOL` from :func:`fine_rates`' (:class:`DiscretisationWarning`: the export's wide
    range spaced linearly by ``continuous_fragility_discretization`` levels, docs/risk.md).

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
    _warn_held_below(model, imls, poes, t)
    levels, fine_poes = _levels(model, imls, poes, int(steps), int(cfd))
    cross = model.crossing(levels)
    if cross:
        raise ParameterError(f"the limit states of {model.taxonomy!r} cross: {cross}; the damage state between "
                             "them would get a negative probability")
    occ = occurrence_rates(annual_rates(fine_poes, t))
    rates = np.stack([occ @ f(levels) for f in model.functions], axis=-1)
    if int(steps) > 1:
        _warn_discretisation(model, imls, poes, t, rates, int(steps), int(cfd))
    p = -np.expm1(-rates * tr)
    ones = np.ones(p.shape[:-1] + (1,))
    damage = -np.diff(np.concatenate([ones, p, 0 * ones], axis=-1), axis=-1)
    return {"rates": rates, "poes": p, "damage": damage}
