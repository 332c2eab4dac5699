"""``Record``: the one type of every ground motion a run takes -- acceleration components (m/s^2) on
one time axis at a constant step, with their metadata.

* Synthetic records (:func:`pycolfrag.ground_motion.synthesize`) carry the scenario and every
  sampled pulse parameter in ``meta`` (keys fixed in docs/architecture.md) and their parts in
  ``components`` (``"hf"``, ``"pulse"``);
* natural records (:func:`pycolfrag.ground_motion.read_at2`) carry the file's header;
* a member of a record suite (:class:`pycolfrag.ground_motion.record_suites.RecordSet`) carries its ``record_id``, its
  second horizontal ``h2`` and vertical ``v`` components when it has them, and the suite table's
  metadata (:data:`SUITE_KEYS`, read as attributes: ``record.mw``, ``record.rrup_km``, ...);
* the motion of one run (:meth:`Record.motion`: a component or the pair, scaled, cut) is a Record
  too, and is what :func:`pycolfrag.simulate` and :func:`pycolfrag.simulate_batch` take.

A Record's arrays and step are checked once, when it is made (finite float64 samples, a finite step
> 0 s, components of one length); what is derived from a checked Record (:meth:`motion`,
:meth:`rotated`) is not checked again, and the functions that take a Record trust it.
"""
from __future__ import annotations

import hashlib
import math
from typing import cast

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import Parameter
from pycolfrag.core.validate import finite_float, float_array, positive_float

__all__ = ["NAME", "KIND", "PARAMETERS", "SUITE_KEYS", "COMPONENTS", "UNITS", "MAX_SAMPLES", "Record",
           "RecordMetadata"]

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

#: The metadata of a recorded motion that a suite table gives and a record-suite row carries:
#: key -> (value when the table does not give it, meaning). Each is an attribute of a Record
#: (``record.mw`` is ``record.meta.get("mw", nan)``).
SUITE_KEYS = {
    "event": ("", "earthquake name"),
    "year": (math.nan, "year of the earthquake"),
    "station": ("", "recording station"),
    "mw": (math.nan, "moment magnitude"),
    "mechanism": ("", "faulting mechanism"),
    "rjb_km": (math.nan, "Joyner-Boore distance, km"),
    "rrup_km": (math.nan, "closest distance to the rupture, km"),
    "vs30_m_s": (math.nan, "time-averaged shear-wave velocity of the top 30 m, m/s"),
    "tp_s": (math.nan, "pulse period, s (NaN: none given)"),
}
#: The horizontal motions of a run (:meth:`Record.motion`): one component along x, or the pair (H1
#: along x, H2 along y).
COMPONENTS = ("h1", "h2", "both")
#: Units of every acceleration array of a Record.
UNITS = "m/s^2"
#: Most samples of a component: the C kernels and the solver count samples in a C int.
MAX_SAMPLES = 2**31 - 1


def _meta_field(key: str):
    default, doc = SUITE_KEYS[key]
    return property(lambda self: self.meta.get(key, default), doc=f"{doc} (``meta[{key!r}]``)")


class RecordMetadata:
    """The identity of a suite member read off ``record_id`` and ``meta`` (:data:`SUITE_KEYS`):
    shared by :class:`Record` and the marker of an unreadable member
    (:class:`pycolfrag.ground_motion.record_suites.UnreadableRecord`)."""

    record_id: str
    meta: dict

    event = _meta_field("event")
    year = _meta_field("year")
    station = _meta_field("station")
    mw = _meta_field("mw")
    mechanism = _meta_field("mechanism")
    rjb_km = _meta_field("rjb_km")
    rrup_km = _meta_field("rrup_km")
    vs30_m_s = _meta_field("vs30_m_s")
    tp_s = _meta_field("tp_s")


def _component(value, name: str, n: int) -> np.ndarray:
    arr = np.array(float_array(value, name), dtype=np.float64, copy=True)
    if arr.size != n:
        raise ParameterError(f"{name} has {arr.size} samples, the record {n}: components must share one time axis")
    return arr


class Record(RecordMetadata):
    """An acceleration record: one or more components on one time axis.

    Parameters
    ----------
    acc : array_like, 1-D, m/s^2
        The first horizontal component (``h1``): finite samples, converted to a float64 array (a copy).
    dt : float, s (finite, > 0)
    meta : dict, optional
        Anything describing the record (scenario, pulse parameters, file header, suite table row).
    components : dict of array_like, optional
        Named parts of ``acc`` on the same time axis (a synthetic record's ``"hf"`` and ``"pulse"``), m/s^2.
    h2, v : array_like, optional
        The second horizontal component (90 degrees clockwise from ``h1``) and the vertical one, m/s^2,
        as long as ``acc``.
    record_id : str, optional
        The record's name in its suite (PEER: ``"RSN<number>"``); empty for a lone record.
    """

    units = UNITS
    readable = True

    def __init__(self, acc, dt, meta=None, components=None, *, h2=None, v=None, record_id: str = ""):
        self.acc = np.array(float_array(acc, "acc"), dtype=np.float64, copy=True)
        if self.acc.size > MAX_SAMPLES:
            raise ParameterError(f"acc has {self.acc.size} samples, more than the C kernels take ({MAX_SAMPLES})")
        self.dt = positive_float(dt, "dt")
        if meta is not None and not isinstance(meta, dict):
            raise ParameterError(f"meta must be a dict, got {type(meta).__name__}")
        self.meta = dict(meta) if meta else {}
        if not isinstance(record_id, str):
            raise ParameterError(f"record_id must be a str, got {type(record_id).__name__} {record_id!r}")
        self.record_id = record_id
        n = self.acc.size
        self.components = {str(k): _component(a, f"components[{k!r}]", n) for k, a in (components or {}).items()}
        self.h2 = None if h2 is None else _component(h2, "h2", n)
        self.v = None if v is None else _component(v, "v", n)

    @classmethod
    def _checked(cls, acc, dt, meta, *, h2=None, v=None, record_id="", components=None) -> "Record":
        """A Record of values derived from a checked Record (float64 arrays of one length, dt > 0):
        nothing is checked or copied again."""
        rec = object.__new__(cls)
        rec.acc, rec.dt, rec.meta, rec.record_id = acc, dt, meta, record_id
        rec.components, rec.h2, rec.v = components or {}, h2, v
        return rec

    # ------------------------------------------------------------------ the time axis
    @property
    def h1(self) -> np.ndarray:
        """The first horizontal component, m/s^2 (``acc``)."""
        return self.acc

    @property
    def n(self) -> int:
        """Number of samples (of every component)."""
        return int(self.acc.size)

    @property
    def time(self) -> np.ndarray:
        """Sample times, s (``i * dt``)."""
        return np.arange(self.n) * self.dt

    @property
    def duration(self) -> float:
        """Time of the last sample, s (``(n - 1) dt``)."""
        return (self.n - 1) * self.dt

    @property
    def has_h2(self) -> bool:
        """Whether the record has a second horizontal component."""
        return self.h2 is not None

    def component(self, name: str) -> np.ndarray:
        """``"h1"``, ``"h2"`` or ``"v"`` (m/s^2); ParameterError when the record lacks it."""
        if name not in ("h1", "h2", "v"):
            raise ParameterError(f"component must be 'h1', 'h2' or 'v', got {name!r}")
        a = self.acc if name == "h1" else getattr(self, name)
        if a is None:
            raise ParameterError(f"record {self.record_id or '(unnamed)'} has no {name} component")
        return a

    def recorded(self, name: str) -> np.ndarray:
        """A component as recorded: :meth:`component` without the zeros that padded it to the length
        of a longer one (``meta["recorded_samples"]``, set when a pair of unequal lengths was read
        with ``align="pad"``). A one-component run uses this, so it is the same run as
        ``simulate(column, <that component's file>, dt)``."""
        a = self.component(name)
        n = (self.meta.get("recorded_samples") or {}).get(name)
        return a[: int(n)] if n is not None and 0 < int(n) <= a.size else a

    # ------------------------------------------------------------------ the motion of a run
    def motion(self, component: str = "h1", scale: float = 1.0, *, vertical: bool = False,
               max_samples: int | None = None) -> "Record":
        """The ground motion of one run: a new Record of ``scale`` times the chosen components.

        ``component``: ``"h1"`` or ``"h2"`` alone (as recorded, :meth:`recorded`, along the solver's
        x axis) or ``"both"`` (H1 along x, H2 along y: ``h2`` of the result). ``vertical``: add ``v``
        when the record has one. ``max_samples``: cut to at most this many samples. ``meta`` and
        ``record_id`` are kept.
        """
        if component not in COMPONENTS:
            raise ParameterError(f"component must be one of {COMPONENTS}, got {component!r}")
        f = positive_float(scale, "scale")
        n = self.n if component == "both" else self.recorded(component).size
        if max_samples is not None:
            n = min(n, int(max_samples))
        x = self.component("h2" if component == "h2" else "h1")[:n]
        y = self.component("h2")[:n] if component == "both" else None
        z = self.v[:n] if (vertical and self.v is not None) else None
        if f != 1.0:
            with np.errstate(over="ignore"):   # an overflow is refused below, by name
                x = f * x
                y = None if y is None else f * y
                z = None if z is None else f * z
            peak = max(float(np.max(np.abs(a), initial=0.0)) for a in (x, y, z) if a is not None)
            if not math.isfinite(peak):
                raise ParameterError(f"scale {scale!r} makes record {self.record_id or '(unnamed)'} overflow")
        return Record._checked(x, self.dt, dict(self.meta), h2=y, v=z, record_id=self.record_id)

    def horizontals(self) -> tuple["Record", "Record"]:
        """The two horizontal components as one-component Records (H1, H2) on the whole time axis,
        e.g. for the IMs of each (nothing is checked or copied again)."""
        h2 = self.component("h2")
        return (Record._checked(self.acc, self.dt, dict(self.meta), record_id=self.record_id),
                Record._checked(h2, self.dt, dict(self.meta), record_id=self.record_id))

    # ------------------------------------------------------------------ integrals and measures
    def velocity(self) -> np.ndarray:
        """Trapezoidal velocity from rest, m/s (the integral behind PGV)."""
        from pycolfrag.ground_motion.intensity import integrate  # loads C: a Record is read where C may be absent
        return integrate(self.acc, self.dt)[0]

    def displacement(self) -> np.ndarray:
        """Trapezoidal displacement from rest, m (the integral behind PGD)."""
        from pycolfrag.ground_motion.intensity import integrate  # loads C: a Record is read where C may be absent
        return integrate(self.acc, self.dt)[1]

    def measures(self, periods=None, damping=0.05) -> dict:
        """:func:`pycolfrag.ground_motion.intensity.measures` of this record (``periods`` None: its
        ``DEFAULT_PERIODS_S``)."""
        from pycolfrag.ground_motion.intensity import DEFAULT_PERIODS_S, measures  # loads C: as above
        return measures(self.acc, self.dt, periods=DEFAULT_PERIODS_S if periods is None else periods,
                        damping=damping)

    # ------------------------------------------------------------------ the horizontal pair
    def rotated(self, theta_deg: float) -> "Record":
        """The pair rotated by ``theta_deg`` clockwise (:func:`~pycolfrag.ground_motion.rotation.rotate_pair`);
        ``v`` unchanged. The new ``h1`` points along azimuth ``azimuth_h1_deg + theta`` (kept in ``meta``)."""
        from pycolfrag.ground_motion.rotation import (
            rotate_pair,  # the rotation's module loads C (RotD); a Record need not
        )
        theta = finite_float(theta_deg, "theta_deg")
        a1, a2 = rotate_pair(self.acc, self.component("h2"), theta)
        meta = dict(self.meta)
        meta.pop("recorded_samples", None)  # each rotated component mixes both recorded ones
        meta["rotation_deg"] = float(meta.get("rotation_deg", 0.0)) + theta
        az = meta.get("azimuth_h1_deg", math.nan)
        meta["azimuth_h1_deg"] = (float(az) + theta) % 360.0 if _finite(az) else math.nan
        return Record._checked(a1, self.dt, meta, h2=a2, v=self.v, record_id=self.record_id)

    def fault_normal_parallel(self, strike_deg: float | None = None,
                              azimuth_h1_deg: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(FN, FP) accelerations, m/s^2 (:func:`~pycolfrag.ground_motion.rotation.fault_normal_parallel`);
        strike and H1 azimuth default to ``meta["strike_deg"]`` and ``meta["azimuth_h1_deg"]``."""
        from pycolfrag.ground_motion.rotation import fault_normal_parallel  # as in rotated
        strike = self.meta.get("strike_deg") if strike_deg is None else strike_deg
        az = self.meta.get("azimuth_h1_deg") if azimuth_h1_deg is None else azimuth_h1_deg
        if not (_finite(strike) and _finite(az)):
            raise ParameterError(f"record {self.record_id or '(unnamed)'}: fault-normal/parallel needs the strike "
                                 f"and the azimuth of H1 (degrees), got strike={strike!r}, azimuth_h1={az!r}")
        # (_finite has checked that float() reads both)
        return fault_normal_parallel(self.acc, self.component("h2"), float(cast(float, strike)), float(cast(float, az)))

    def rotd(self, measure="pga", percentiles=(50.0, 100.0), damping=0.05, angles_deg=None) -> dict:
        """:func:`~pycolfrag.ground_motion.rotation.rotd` of this record's horizontal pair."""
        from pycolfrag.ground_motion.rotation import rotd  # as in rotated
        return rotd(self.acc, self.component("h2"), self.dt, measure=measure, percentiles=percentiles,
                    damping=damping, angles_deg=angles_deg)

    # ------------------------------------------------------------------ identity
    def digest(self) -> str:
        """SHA-1 of dt and the component samples (identifies the data, e.g. in a grid signature)."""
        h = hashlib.sha1(np.float64(self.dt).tobytes())
        for a in (self.acc, self.h2, self.v):
            h.update(b"-" if a is None else np.ascontiguousarray(a, dtype="<f8").tobytes())
        return h.hexdigest()

    def __repr__(self) -> str:
        comps = "+".join(c for c, a in (("h1", self.acc), ("h2", self.h2), ("v", self.v)) if a is not None)
        head = f"Record({self.record_id!r}, " if self.record_id else "Record("
        keys = ", ".join(sorted(self.meta)[:6])
        return (f"{head}{comps}, n={self.n}, dt={self.dt:g} s, duration={self.duration:g} s, "
                f"pga={np.abs(self.acc).max():.4g} m/s^2, meta keys: {keys}{', ...' if len(self.meta) > 6 else ''})")


def _finite(x) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False
