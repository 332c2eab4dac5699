"""``Record``: one acceleration time history (m/s^2) at a constant step, with its metadata.

Synthetic records (:func:`pycolfrag.ground_motion.synthesize`) carry the scenario and every
sampled pulse parameter in ``meta`` (keys fixed in docs/architecture.md) and their parts in
``components``; natural records (:func:`pycolfrag.ground_motion.read_at2`) carry the file's
header. Any 1-D array plus a step makes a Record, so natural and synthetic records go through
the same pipeline.
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import float_array, positive_float
from ..errors import ParameterError
from ..names import Parameter

__all__ = ["NAME", "KIND", "PARAMETERS", "Record"]

#: Name in the registry (:mod:`pycolfrag.ground_motion.registry`).
NAME = "record"
#: The keys every synthetic record's ``meta`` carries (the pulse model's keys are declared with it).
KIND = "record"
#: The scenario and generator keys of a synthetic record's ``meta`` (:func:`pycolfrag.ground_motion.synthesize`,
#: :func:`~pycolfrag.ground_motion.stochastic`) and their sample-row fields. The ranges are what any
#: record may carry; each model checks its own, narrower range (the Atkinson & Silva and the pulse
#: modules).
PARAMETERS = (
    Parameter("Mw", "", (-math.inf, math.inf), "moment magnitude", "Mw", "mw"),
    Parameter("R", "km", (0.0, math.inf), "closest distance to the rupture", "dist_km", "dist_km"),
    Parameter("seed", "-", (0.0, math.inf), "seed of the high-frequency noise (an integer)", "seed"),
    Parameter("dt", "s", (0.0, math.inf), "time step of the record", "dt_s", low_open=True),
)


class Record:
    """An acceleration record.

    Parameters
    ----------
    acc : array_like, 1-D, m/s^2
        Finite samples, converted to a float64 array (a copy).
    dt : float, s (finite, > 0)
    meta : dict, optional
        Anything describing the record (scenario, pulse parameters, file header, ...).
    components : dict of array_like, optional
        Named parts on the same time axis (e.g. ``"hf"``, ``"pulse"``), m/s^2.
    """

    def __init__(self, acc, dt, meta=None, components=None):
        self.acc = np.array(float_array(acc, "acc"), dtype=np.float64, copy=True)
        self.dt = positive_float(dt, "dt")
        if meta is not None and not isinstance(meta, dict):
            raise ParameterError(f"meta must be a dict, got {type(meta).__name__}")
        self.meta = dict(meta) if meta else {}
        comps = {}
        for name, value in (components or {}).items():
            arr = np.array(float_array(value, f"components[{name!r}]"), copy=True)
            if arr.shape != self.acc.shape:
                raise ParameterError(f"components[{name!r}] has {arr.size} samples, the record {self.acc.size}")
            comps[str(name)] = arr
        self.components = comps

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.acc.size)

    @property
    def time(self) -> np.ndarray:
        """Sample times, s (``i * dt``)."""
        return np.arange(self.n) * self.dt

    @property
    def duration(self) -> float:
        """Time of the last sample, s (``(n - 1) dt``)."""
        return (self.n - 1) * self.dt

    def velocity(self) -> np.ndarray:
        """Trapezoidal velocity from rest, m/s (the integral behind PGV)."""
        from ..intensity import integrate  # loads C: a Record is read where C may be absent
        return integrate(self.acc, self.dt)[0]

    def displacement(self) -> np.ndarray:
        """Trapezoidal displacement from rest, m (the integral behind PGD)."""
        from ..intensity import integrate  # loads C: a Record is read where C may be absent
        return integrate(self.acc, self.dt)[1]

    def measures(self, periods=None, damping=0.05) -> dict:
        """:func:`pycolfrag.intensity.measures` of this record (``periods`` None: its
        ``DEFAULT_PERIODS_S``)."""
        from ..intensity import DEFAULT_PERIODS_S, measures  # loads C: as above
        return measures(self.acc, self.dt, periods=DEFAULT_PERIODS_S if periods is None else periods,
                        damping=damping)

    def __repr__(self) -> str:
        keys = ", ".join(sorted(self.meta)[:6])
        return (f"Record(n={self.n}, dt={self.dt:g} s, duration={self.duration:g} s, "
                f"pga={np.abs(self.acc).max():.4g} m/s^2, meta keys: {keys}{', ...' if len(self.meta) > 6 else ''})")
