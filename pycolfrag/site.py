"""A site and its earthquake sources, read from a site file (TOML; format in ``docs/risk.md``).

A :class:`Site` holds :class:`Source` objects: an annual rate, a magnitude model (doubly truncated
Gutenberg-Richter or a characteristic magnitude), a distance model (fixed, uniform, areal or
discrete) and a pulse-occurrence model (a given probability, Shahi & Baker 2014, or pulse-only).
Magnitude and distance models give quadrature points and weights (``points(breaks)``: Gauss-Legendre
on each segment between the breaks, which :mod:`pycolfrag.analysis.risk` sets at the grid's nodes).
Every bad value of a site file raises :class:`~pycolfrag.errors.ParameterError` naming the file,
the key and the value.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ParameterError
from .ground_motion import shahi_baker_2014

__all__ = ["GutenbergRichter", "Characteristic", "Distance", "PulseModel", "Source", "Site",
           "DEFAULT_YEARS", "OUTSIDE_CHOICES", "QUAD_POINTS", "load_site", "site_from_dict"]

#: Time horizons always reported, years (475: the return period of the 10 %-in-50-years design level,
#: used here as a horizon like the others).
DEFAULT_YEARS = (50.0, 100.0, 475.0)
#: What the part of a source outside the simulated (Mw, R) range contributes (see docs/risk.md).
OUTSIDE_CHOICES = ("refuse", "clamp", "zero")
#: Gauss-Legendre points per segment between breaks.
QUAD_POINTS = 12


def _gl(n=QUAD_POINTS):
    return np.polynomial.legendre.leggauss(n)


def _segments(lo, hi, breaks):
    inner = [b for b in np.asarray(breaks, dtype=float) if lo < b < hi]
    return np.array([lo] + sorted(inner) + [hi])


def _quadrature(pdf, lo, hi, breaks):
    """Points and weights of int_lo^hi g(x) pdf(x) dx, Gauss-Legendre on each segment between breaks."""
    x0, w0 = _gl()
    edges = _segments(lo, hi, breaks)
    xs, ws = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        x = 0.5 * (b - a) * x0 + 0.5 * (a + b)
        xs.append(x)
        ws.append(0.5 * (b - a) * w0 * pdf(x))
    return np.concatenate(xs), np.concatenate(ws)


@dataclass(frozen=True)
class GutenbergRichter:
    """Doubly truncated Gutenberg-Richter magnitudes (Cornell & Vanmarcke 1969).

    f(m) = beta exp(-beta (m - m_min)) / (1 - exp(-beta (m_max - m_min))), beta = b ln 10,
    m_min <= m <= m_max; the source's ``rate`` is the annual rate of M >= m_min.
    """

    b: float
    m_min: float
    m_max: float

    def pdf(self, m):
        beta = self.b * math.log(10.0)
        m = np.asarray(m, dtype=float)
        inside = (m >= self.m_min) & (m <= self.m_max)
        return np.where(inside, beta * np.exp(-beta * (m - self.m_min))
                        / (1.0 - math.exp(-beta * (self.m_max - self.m_min))), 0.0)

    def points(self, breaks=()):
        return _quadrature(self.pdf, self.m_min, self.m_max, breaks)

    def describe(self):
        return f"truncated G-R, b = {self.b:g}, Mw {self.m_min:g}-{self.m_max:g}"


@dataclass(frozen=True)
class Characteristic:
    """A single (characteristic) magnitude; the source's ``rate`` is the annual rate of that event."""

    mw: float

    def points(self, breaks=()):
        return np.array([self.mw]), np.array([1.0])

    def describe(self):
        return f"characteristic Mw {self.mw:g}"


@dataclass(frozen=True)
class Distance:
    """Source-to-site distance R (km, the grid's distance), independent of the magnitude.

    kind : ``fixed`` (``r_km``), ``uniform`` on [min_km, max_km], ``area`` (f(r) = 2 r / (max^2 -
    min^2): epicentres spread evenly over an annulus around the site) or ``discrete`` (``r_km``
    with ``weights`` summing to 1).
    """

    kind: str
    r_km: tuple = ()
    weights: tuple = ()
    min_km: float = 0.0
    max_km: float = 0.0

    def pdf(self, r):
        r = np.asarray(r, dtype=float)
        inside = (r >= self.min_km) & (r <= self.max_km)
        if self.kind == "uniform":
            return np.where(inside, 1.0 / (self.max_km - self.min_km), 0.0)
        return np.where(inside, 2.0 * r / (self.max_km ** 2 - self.min_km ** 2), 0.0)

    def points(self, breaks=()):
        if self.kind in ("fixed", "discrete"):
            return np.array(self.r_km, dtype=float), np.array(self.weights, dtype=float)
        return _quadrature(self.pdf, self.min_km, self.max_km, breaks)

    def describe(self):
        if self.kind == "fixed":
            return f"R = {self.r_km[0]:g} km"
        if self.kind == "discrete":
            return "R " + ", ".join(f"{r:g} km ({w:g})" for r, w in zip(self.r_km, self.weights))
        return f"R {self.kind} {self.min_km:g}-{self.max_km:g} km"


@dataclass(frozen=True)
class PulseModel:
    """Probability that a motion carries a velocity pulse, p(r).

    kind : ``probability`` (a constant ``p``), ``shahi_baker_2014`` (``mechanism``, directivity
    length ``s_km`` and angle ``angle_deg``, :mod:`pycolfrag.ground_motion.shahi_baker_2014`,
    r = the event's R) or ``pulse-only`` (p = 1, asked for explicitly).
    """

    kind: str
    p: float = 1.0
    mechanism: str = ""
    s_km: float = 0.0
    angle_deg: float = 0.0

    def probability(self, r_km):
        r = np.asarray(r_km, dtype=float)
        if self.kind == "shahi_baker_2014":
            return np.asarray(shahi_baker_2014.pulse_probability(r, self.s_km, self.angle_deg, self.mechanism),
                              dtype=float) * np.ones_like(r)
        return np.full(r.shape, self.p if self.kind == "probability" else 1.0)

    @property
    def needs_no_pulse_branch(self) -> bool:
        return self.kind == "shahi_baker_2014" or (self.kind == "probability" and self.p < 1.0)

    def describe(self):
        if self.kind == "probability":
            return f"p_pulse = {self.p:g} (given)"
        if self.kind == "pulse-only":
            return "PULSE-ONLY (p_pulse = 1, asked for explicitly: every motion carries a pulse)"
        return (f"Shahi & Baker (2014), {self.mechanism}, directivity length {self.s_km:g} km, "
                f"angle {self.angle_deg:g} deg, r = R")


@dataclass(frozen=True)
class Source:
    """One earthquake source: annual ``rate``, magnitude model, distance model, pulse model."""

    name: str
    rate: float
    magnitude: GutenbergRichter | Characteristic
    distance: Distance
    pulse: PulseModel

    def describe(self):
        return f"{self.magnitude.describe()}, {self.distance.describe()}, rate {self.rate:.4g} /yr"


@dataclass(frozen=True)
class Site:
    """A site: its sources, the treatment of the part outside the grid, the time horizons."""

    name: str
    sources: tuple
    outside: str = "refuse"
    years: tuple = DEFAULT_YEARS
    description: str = ""
    path: str = ""


def _where(origin, key):
    return f"{origin}: {key}" if origin else key


def _check_keys(d, allowed, origin, where):
    if not isinstance(d, dict):
        raise ParameterError(f"{_where(origin, where)} must be a table, got {d!r}")
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise ParameterError(f"{_where(origin, where)}: unknown key(s) {', '.join(map(repr, unknown))}; "
                             f"allowed: {', '.join(sorted(allowed))}")


def _num(d, key, origin, where, *, positive=False, nonneg=False, default=None):
    if key not in d:
        if default is not None:
            return default
        raise ParameterError(f"{_where(origin, where)}: missing {key!r}")
    v = d[key]
    name = f"{where}.{key}"
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ParameterError(f"{_where(origin, name)} must be a finite number, got {v!r}")
    if positive and v <= 0:
        raise ParameterError(f"{_where(origin, name)} must be > 0, got {v!r}")
    if nonneg and v < 0:
        raise ParameterError(f"{_where(origin, name)} must be >= 0, got {v!r}")
    return float(v)


def _magnitude(d, origin, where):
    kind = d.get("type") if isinstance(d, dict) else None
    if kind == "gutenberg-richter":
        _check_keys(d, ("type", "b", "m_min", "m_max"), origin, where)
        b = _num(d, "b", origin, where, positive=True)
        m_min = _num(d, "m_min", origin, where)
        m_max = _num(d, "m_max", origin, where)
        if m_max <= m_min:
            raise ParameterError(f"{_where(origin, where)}: m_max = {m_max:g} must be > m_min = {m_min:g}")
        return GutenbergRichter(b, m_min, m_max)
    if kind == "characteristic":
        _check_keys(d, ("type", "mw"), origin, where)
        return Characteristic(_num(d, "mw", origin, where))
    raise ParameterError(f"{_where(origin, where)}.type must be 'gutenberg-richter' or 'characteristic', "
                         f"got {kind!r}")


def _distance(d, origin, where):
    kind = d.get("type") if isinstance(d, dict) else None
    if kind == "fixed":
        _check_keys(d, ("type", "r_km"), origin, where)
        return Distance("fixed", (_num(d, "r_km", origin, where, positive=True),), (1.0,))
    if kind in ("uniform", "area"):
        _check_keys(d, ("type", "min_km", "max_km"), origin, where)
        lo = _num(d, "min_km", origin, where, positive=True)
        hi = _num(d, "max_km", origin, where, positive=True)
        if hi <= lo:
            raise ParameterError(f"{_where(origin, where)}: max_km = {hi:g} must be > min_km = {lo:g}")
        return Distance(kind, min_km=lo, max_km=hi)
    if kind == "discrete":
        _check_keys(d, ("type", "r_km", "weights"), origin, where)
        r, w = d.get("r_km"), d.get("weights")
        if not isinstance(r, list) or not isinstance(w, list) or len(r) != len(w) or not r:
            raise ParameterError(f"{_where(origin, where)}: r_km and weights must be lists of equal, non-zero "
                                 f"length, got {r!r} and {w!r}")
        rr = [_num({"r_km": x}, "r_km", origin, f"{where}", positive=True) for x in r]
        ww = [_num({"weights": x}, "weights", origin, f"{where}", nonneg=True) for x in w]
        if abs(sum(ww) - 1.0) > 1e-6:
            raise ParameterError(f"{_where(origin, where)}.weights must sum to 1, they sum to {sum(ww):.6g}")
        return Distance("discrete", tuple(rr), tuple(ww))
    raise ParameterError(f"{_where(origin, where)}.type must be 'fixed', 'uniform', 'area' or 'discrete', "
                         f"got {kind!r}")


def _pulse(d, origin, where):
    _check_keys(d, ("model", "probability", "mechanism", "s_km", "angle_deg"), origin, where)
    model = d.get("model", "probability" if "probability" in d else None)
    if model == "probability":
        _check_keys(d, ("model", "probability"), origin, where)
        p = _num(d, "probability", origin, where, nonneg=True)
        if p > 1:
            raise ParameterError(f"{_where(origin, where)}.probability must be in [0, 1], got {p!r}")
        return PulseModel("probability", p=p)
    if model == "pulse-only":
        _check_keys(d, ("model",), origin, where)
        return PulseModel("pulse-only")
    if model == "shahi_baker_2014":
        _check_keys(d, ("model", "mechanism", "s_km", "angle_deg"), origin, where)
        mech = d.get("mechanism")
        if mech not in shahi_baker_2014.MECHANISMS:
            raise ParameterError(f"{_where(origin, where)}.mechanism must be one of "
                                 f"{', '.join(shahi_baker_2014.MECHANISMS)}, got {mech!r}")
        s = _num(d, "s_km", origin, where, nonneg=True)
        a = _num(d, "angle_deg", origin, where, nonneg=True)
        if a > 90:
            raise ParameterError(f"{_where(origin, where)}.angle_deg must be in [0, 90], got {a!r}")
        return PulseModel("shahi_baker_2014", mechanism=mech, s_km=s, angle_deg=a)
    raise ParameterError(f"{_where(origin, where)}.model must be 'probability', 'shahi_baker_2014' or "
                         f"'pulse-only', got {model!r}")


def site_from_dict(d: dict, origin: str = "") -> Site:
    """Build a :class:`Site` from the dict of a site file (see ``docs/risk.md``); every bad value
    raises :class:`~pycolfrag.errors.ParameterError` naming the file, the key and the value."""
    _check_keys(d, ("name", "description", "outside", "years", "pulse", "sources"), origin, "site")
    outside = d.get("outside", "refuse")
    if outside not in OUTSIDE_CHOICES:
        raise ParameterError(f"{_where(origin, 'outside')} must be one of {', '.join(OUTSIDE_CHOICES)}, "
                             f"got {outside!r}")
    years = d.get("years", [])
    if not isinstance(years, list):
        raise ParameterError(f"{_where(origin, 'years')} must be a list of years, got {years!r}")
    extra = [_num({"years": y}, "years", origin, "site", positive=True) for y in years]
    default_pulse = _pulse(d["pulse"], origin, "pulse") if "pulse" in d else None
    raw = d.get("sources")
    if not isinstance(raw, list) or not raw:
        raise ParameterError(f"{_where(origin, 'sources')}: at least one [[sources]] table is needed")
    sources = []
    for i, s in enumerate(raw):
        where = f"sources[{i}]"
        _check_keys(s, ("name", "rate", "magnitude", "distance", "pulse"), origin, where)
        name = str(s.get("name", f"source {i + 1}"))
        if name in [src.name for src in sources]:     # the outputs list the sources by name
            raise ParameterError(f"{_where(origin, where)}.name {name!r} is the name of an earlier source; "
                                 "give every source its own name")
        rate = _num(s, "rate", origin, where, nonneg=True)
        for key in ("magnitude", "distance"):
            if key not in s:
                raise ParameterError(f"{_where(origin, where)}: missing {key!r} table")
        mag = _magnitude(s["magnitude"], origin, f"{where}.magnitude")
        dist = _distance(s["distance"], origin, f"{where}.distance")
        pulse = _pulse(s["pulse"], origin, f"{where}.pulse") if "pulse" in s else default_pulse
        if pulse is None:
            raise ParameterError(
                f"{_where(origin, where)} ({name}): no pulse model. Every motion of a grid carries a velocity "
                "pulse, so the site file must say how often pulses occur: a [pulse] table with "
                "probability = p, or model = 'shahi_baker_2014', or model = 'pulse-only' to ask for the "
                "pulse branch alone")
        sources.append(Source(name, rate, mag, dist, pulse))
    return Site(str(d.get("name", Path(origin).stem if origin else "site")), tuple(sources), outside,
                tuple(sorted(set(DEFAULT_YEARS) | set(extra))), str(d.get("description", "")), origin)


def load_site(path) -> Site:
    """Read a site file (TOML, ``docs/risk.md``)."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            d = tomllib.load(f)
    except FileNotFoundError:
        raise ParameterError(f"site file {path} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    return site_from_dict(d, str(path))
