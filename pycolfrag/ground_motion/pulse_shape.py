"""The interface of a velocity-pulse shape: what :func:`pycolfrag.ground_motion.synthesize`, the pulse
sampling and the grid's ``--pulse`` read of it.

A pulse shape is a module of kind ``"pulse"`` listed in :data:`pycolfrag.ground_motion.registry.MODELS`
(:data:`~pycolfrag.ground_motion.registry.PULSE_SHAPES` holds them by ``SHAPE``). It declares, as data
at its top:

* ``NAME`` (the registry's name, after the paper), ``KIND = "pulse"``;
* ``SHAPE`` -- its short name: a choice of the grid's ``--pulse`` and ``synthesize(shape=...)``
  ("none" is taken: the grid's choice of the stochastic record alone);
* ``PARAMETERS`` -- :class:`pycolfrag.core.names.Parameter` rows: the keys its records carry in ``meta`` and
  the fields it gives a sample row, in order (a row field another shape declares too must mean the
  same: same meta key, unit and description; the registry checks it);
* ``INPUTS`` -- the parameters a pulse row must give (``synthesize(pulse=row)``), a subset of
  ``PARAMETERS``;
* ``NORMALS`` -- the names of the standard normals its inputs are made from, in order (the pulse's
  part of ``synthesize(normals=...)``);

and offers three functions:

* ``sample_parameters(Mw, dist_km, n, seed, vp_scale=1.0, tp_model=..., amplitude=True, vp_model=...)`` ->
  dict of ``n`` rows (meta key -> 1-D array, the ``INPUTS`` among them): the pulses of a scenario (``tp_model``
  is a pulse-period relation of :data:`~pycolfrag.ground_motion.registry.TP_MODELS`, ``vp_model`` a
  pulse-amplitude relation of :data:`~pycolfrag.ground_motion.registry.VP_MODELS`, as modules;
  ``amplitude=False``: without derived values that cost a search per sample, the others bitwise the
  same -- a grid asks only for what its rows read, the ``INPUTS``);
* ``parameters_from_normals(Mw, dist_km, z, vp_scale=1.0, tp_model=..., vp_model=...)`` -> dict (meta key -> float)
  of the ``INPUTS``: one pulse of the scenario from ``len(NORMALS)`` standard normals, by inverse CDFs,
  so that N(0, I) normals give the distributions ``sample_parameters`` samples;
* ``prepare(*inputs)`` -> :class:`PreparedPulse`: one pulse from the values of ``INPUTS`` (in their
  order), ready to be placed on a record.

:class:`PulseShape` states the same as a typing protocol; :func:`missing` lists what a module lacks of it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

__all__ = ["PulseShape", "PreparedPulse", "missing"]


@dataclass(frozen=True)
class PreparedPulse:
    """One pulse of a shape, before it is placed: times are counted from its epoch ``t0`` (where
    :func:`~pycolfrag.ground_motion.synthesize` puts it so that the pulse's peak velocity falls on the
    high-frequency record's).

    peak_offset_s : float -- time of the pulse's peak |velocity| after its epoch, s
    peak_sign : float -- +1.0 or -1.0, the sign of the velocity at that peak
    before_s, after_s : float -- the pulse's support, [t0 - before_s, t0 + after_s], s
    acceleration : callable (t, t0) -> array -- its acceleration at the times t (s) for epoch t0,
        m/s^2 (zero outside the support)
    meta : callable (t0, acc) -> tuple -- the values of the shape's ``PARAMETERS`` (in order) for the
        pulse placed at epoch t0, whose acceleration on the record's time axis is ``acc`` (m/s^2)
    """

    peak_offset_s: float
    peak_sign: float
    before_s: float
    after_s: float
    acceleration: Callable[[np.ndarray, float], np.ndarray]
    meta: Callable[[float, np.ndarray], tuple]


class PulseShape(Protocol):
    """What a pulse-shape module declares and offers (the module docstring above says each)."""

    NAME: str
    KIND: str
    SHAPE: str
    PARAMETERS: tuple
    INPUTS: tuple
    NORMALS: tuple

    def sample_parameters(self, Mw, dist_km, n, seed, vp_scale=1.0, tp_model=None, amplitude=True,
                          vp_model=None) -> dict: ...

    def parameters_from_normals(self, Mw, dist_km, z, vp_scale=1.0, tp_model=None, vp_model=None) -> dict: ...

    def prepare(self, *inputs) -> PreparedPulse: ...


def missing(module) -> list[str]:
    """The names of :class:`PulseShape` that ``module`` does not define (empty: it is a pulse shape)."""
    return [name for name in ("NAME", "KIND", "SHAPE", "PARAMETERS", "INPUTS", "NORMALS", "sample_parameters",
                              "parameters_from_normals", "prepare")
            if not hasattr(module, name)]
