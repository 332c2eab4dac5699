"""The parts a site source is built from: magnitude, distance and pulse-occurrence models.

Each model is a class that reads its own table of a site file (``from_table``) and offers both
forms the risk needs:

* quadrature (``points(breaks)``): points and weights of an integral over the model's density,
  Gauss-Legendre on each segment between the breaks (:mod:`pycolfrag.risk.site_risk` sets them at
  the grid's nodes, where the interpolated fragility surface has kinks);
* random draws (``sample(n, rng)``): events drawn from the whole model;
* bins, for the stratified event-based simulation of :mod:`pycolfrag.rare`: a continuous model gives
  ``support``, ``probability_between(lo, hi)`` and ``draw_between(u, lo, hi)`` (the inverse CDF of its
  density restricted to [lo, hi], with the library's own exp and log, so that the same u gives the
  same bits on every CPU); a discrete one gives ``atoms`` ((value, probability) pairs).

A model is registered in the table of its kind (:data:`MAGNITUDE_MODELS`, :data:`DISTANCE_MODELS`,
:data:`PULSE_MODELS`) under the ``type`` (or, for pulses, ``model``) a site file names it by; the
site file reader looks it up there and never tests the name itself. Every value a model reads is
checked where it enters (:class:`Table`), and refused with the file, the key and the value named.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import registry as gm_registry

__all__ = ["Table", "QUAD_POINTS", "c_exp", "c_log", "MW_RANGE", "R_RANGE_KM", "B_RANGE", "MAGNITUDE_MODELS", "DISTANCE_MODELS",
           "PULSE_MODELS", "GutenbergRichter", "Characteristic", "FixedDistance", "UniformDistance",
           "AreaDistance", "DiscreteDistance", "GivenProbability", "PulseOnly", "ShahiBakerPulse", "Spread",
           "quadrature"]

#: Gauss-Legendre points per segment between breaks.
QUAD_POINTS = 12
#: Magnitudes a site file may give (moment magnitude; nothing outside it is an earthquake).
MW_RANGE = (0.0, 10.0)
#: Distances a site file may give, km: positive, and at most half the Earth's circumference (about
#: 20 000 km). Beyond it a distance means nothing, and the areal density's r^2 terms leave the
#: floating-point range long before 1e154 km.
R_RANGE_KM = (0.0, 20000.0)
#: Gutenberg-Richter b-values accepted: > 0 (b -> 0 is the uniform density, computed with expm1
#: so that a tiny b gives that limit, not 0/0 or inf), and at most 5, far above the b of any
#: catalogue (about 0.5-2): the quadrature cuts the magnitude range into pieces 2/beta wide, so
#: that bound also keeps it to a few dozen pieces.
B_RANGE = (0.0, 5.0)


def c_exp(x: float) -> float:
    """exp(x) by the library's own function (``csrc/cf_math.c``): the same bits on every CPU. Loaded on
    first use: reading a site file needs no C library."""
    from pycolfrag.core.ffi import lib  # loads C on first use (docstring)
    return float(lib.cf_math_exp(float(x)))


def c_log(x: float) -> float:
    """ln(x) by the library's own function (see :func:`c_exp`)."""
    from pycolfrag.core.ffi import lib  # loads C on first use (see c_exp)
    return float(lib.cf_math_log(float(x)))


def _overlap(support, lo, hi):
    """[lo, hi] cut to the model's support (a, b), or None when they do not overlap."""
    a, b = max(lo, support[0]), min(hi, support[1])
    return (a, b) if b > a else None


# --------------------------------------------------------------------------- reading a table

class Table:
    """One table of a site file, with its place (file and key path) for the messages."""

    def __init__(self, d, origin: str, where: str, allowed=None):
        self.origin, self.path = origin, where
        if not isinstance(d, dict):
            raise ParameterError(f"{self.where()} must be a table, got {d!r}")
        self.d = d
        if allowed is not None:
            self.only(allowed)

    def where(self, key: str | None = None) -> str:
        name = self.path if key is None else f"{self.path}.{key}"
        return f"{self.origin}: {name}" if self.origin else name

    def only(self, allowed) -> None:
        unknown = sorted(set(self.d) - set(allowed))
        if unknown:
            raise ParameterError(f"{self.where()}: unknown key(s) {', '.join(map(repr, unknown))}; "
                                 f"allowed: {', '.join(sorted(allowed))}")

    def sub(self, key: str, allowed=None) -> "Table":
        if key not in self.d:
            raise ParameterError(f"{self.where()}: missing {key!r} table")
        return Table(self.d[key], self.origin, f"{self.path}.{key}", allowed)

    def number(self, key: str, rng=(-math.inf, math.inf), *, low_open=False, default=None, value=None,
               why: str = "") -> float:
        """The finite number at ``key`` (or ``value``) within ``rng``; ``low_open`` refuses the lower bound."""
        if value is None:
            if key not in self.d:
                if default is not None:
                    return default
                raise ParameterError(f"{self.where()}: missing {key!r}")
            value = self.d[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ParameterError(f"{self.where(key)} must be a finite number, got {value!r}")
        lo, hi = rng
        if value < lo or (low_open and value == lo) or value > hi:
            if math.isinf(hi):
                text = f"{'>' if low_open else '>='} {lo:g}"
            elif math.isinf(lo):
                text = f"<= {hi:g}"
            else:
                text = f"in {'(' if low_open else '['}{lo:g}, {hi:g}]"
            raise ParameterError(f"{self.where(key)} must be {text}{why}, got {value!r}")
        return float(value)

    def choice(self, key: str, registry: dict, kind: str):
        v = self.d.get(key)
        try:
            return registry[v]
        except (KeyError, TypeError):
            raise ParameterError(f"{self.where(key)} must be one of {', '.join(map(repr, registry))} "
                                 f"({kind}), got {v!r}") from None


def _register(registry: dict, name: str):
    """Class decorator: ``registry[name]`` is the class's ``from_table`` (a site file's table -> model)."""
    def add(cls):
        if name in registry:
            raise ValueError(f"site model {name!r} is registered twice")
        registry[name] = cls.from_table
        cls.TYPE = name
        return cls
    return add


def quadrature(pdf, lo, hi, breaks, n=QUAD_POINTS, max_width=math.inf):
    """Points and weights of int_lo^hi g(x) pdf(x) dx: Gauss-Legendre on each segment between breaks,
    a segment wider than ``max_width`` cut into equal pieces no wider (for a density that changes by
    many e-folds over a segment)."""
    x0, w0 = np.polynomial.legendre.leggauss(n)
    inner = [b for b in np.asarray(breaks, dtype=float) if lo < b < hi]
    edges = [lo] + sorted(inner) + [hi]
    cuts = [edges[0]]
    for a, b in zip(edges[:-1], edges[1:]):
        k = max(1, math.ceil((b - a) / max_width))
        cuts += list(np.linspace(a, b, k + 1)[1:])
    xs, ws = [], []
    for a, b in zip(cuts[:-1], cuts[1:]):
        x = 0.5 * (b - a) * x0 + 0.5 * (a + b)
        xs.append(x)
        ws.append(0.5 * (b - a) * w0 * pdf(x))
    return np.concatenate(xs), np.concatenate(ws)


# --------------------------------------------------------------------------- magnitudes

#: Magnitude models: the ``type`` a site file names one by -> its reader (a :class:`Table` -> the model).
MAGNITUDE_MODELS: dict = {}


@_register(MAGNITUDE_MODELS, "gutenberg-richter")
@dataclass(frozen=True)
class GutenbergRichter:
    """Doubly truncated Gutenberg-Richter magnitudes (Cornell & Vanmarcke 1969).

    f(m) = beta exp(-beta (m - m_min)) / (1 - exp(-beta (m_max - m_min))), beta = b ln 10,
    m_min <= m <= m_max; the source's ``rate`` is the annual rate of M >= m_min. The denominator
    is ``-expm1(...)`` so that b -> 0 gives the uniform density.
    """

    b: float
    m_min: float
    m_max: float
    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("type", "b", "m_min", "m_max"))
        b = t.number("b", B_RANGE, low_open=True)
        lo, hi = (t.number(k, MW_RANGE) for k in ("m_min", "m_max"))
        if hi <= lo:
            raise ParameterError(f"{t.where()}: m_max = {hi:g} must be > m_min = {lo:g}")
        return cls(b, lo, hi)

    @property
    def beta(self) -> float:
        return self.b * math.log(10.0)

    def pdf(self, m):
        m = np.asarray(m, dtype=float)
        inside = (m >= self.m_min) & (m <= self.m_max)
        norm = -math.expm1(-self.beta * (self.m_max - self.m_min))
        return np.where(inside, self.beta * np.exp(-self.beta * (m - self.m_min)) / norm, 0.0)

    def points(self, breaks=()):
        """Quadrature on pieces at most two e-folds of the density wide (2 / beta magnitude units), where
        12 Gauss-Legendre points integrate the exponential times a linear surface to round-off."""
        return quadrature(self.pdf, self.m_min, self.m_max, breaks, max_width=2.0 / self.beta)

    def sample(self, n, rng):
        """Inverse of the truncated exponential CDF at n uniform draws."""
        u = rng.random(n)
        return self.m_min - np.log1p(u * math.expm1(-self.beta * (self.m_max - self.m_min))) / self.beta

    atoms = None  # a continuous density: bins are drawn by draw_between

    @property
    def support(self):
        return (self.m_min, self.m_max)

    def probability_between(self, lo, hi) -> float:
        """P(lo <= M <= hi): (e^(-beta (a - m_min)) - e^(-beta (b - m_min))) / (1 - e^(-beta (m_max - m_min)))
        on [a, b] = [lo, hi] cut to the support."""
        ab = _overlap(self.support, lo, hi)
        if ab is None:
            return 0.0
        a, b = ab
        norm = -math.expm1(-self.beta * (self.m_max - self.m_min))
        return c_exp(-self.beta * (a - self.m_min)) * (1.0 - c_exp(-self.beta * (b - a))) / norm

    def draw_between(self, u, lo, hi) -> float:
        """The magnitude at CDF fraction ``u`` in [0, 1] of the density restricted to [lo, hi] (a
        truncated exponential again): a - ln(1 - u (1 - e^(-beta (b - a)))) / beta."""
        a, b = _overlap(self.support, lo, hi)
        return a - c_log(1.0 - u * (1.0 - c_exp(-self.beta * (b - a)))) / self.beta

    def describe(self):
        return f"truncated G-R, b = {self.b:g}, Mw {self.m_min:g}-{self.m_max:g}"


@_register(MAGNITUDE_MODELS, "characteristic")
@dataclass(frozen=True)
class Characteristic:
    """A single (characteristic) magnitude; the source's ``rate`` is the annual rate of that event."""

    mw: float
    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("type", "mw"))
        return cls(t.number("mw", MW_RANGE))

    def points(self, breaks=()):
        return np.array([self.mw]), np.array([1.0])

    def sample(self, n, rng):
        return np.full(n, self.mw)

    @property
    def atoms(self):
        """(magnitude, probability) pairs: one."""
        return ((self.mw, 1.0),)

    def describe(self):
        return f"characteristic Mw {self.mw:g}"


# --------------------------------------------------------------------------- distances

#: Distance models: ``type`` -> reader, as :data:`MAGNITUDE_MODELS`.
DISTANCE_MODELS: dict = {}


def _range_table(cls, t: Table):
    t.only(("type", "min_km", "max_km"))
    lo, hi = (t.number(k, R_RANGE_KM, low_open=True) for k in ("min_km", "max_km"))
    if hi <= lo:
        raise ParameterError(f"{t.where()}: max_km = {hi:g} must be > min_km = {lo:g}")
    return cls(lo, hi)


@_register(DISTANCE_MODELS, "fixed")
@dataclass(frozen=True)
class FixedDistance:
    """One distance R (km, the grid's distance) for every event."""

    r_km: float
    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("type", "r_km"))
        return cls(t.number("r_km", R_RANGE_KM, low_open=True))

    def points(self, breaks=()):
        return np.array([self.r_km]), np.array([1.0])

    def sample(self, n, rng):
        return np.full(n, self.r_km)

    @property
    def atoms(self):
        """(distance km, probability) pairs: one."""
        return ((self.r_km, 1.0),)

    def describe(self):
        return f"R = {self.r_km:g} km"


@dataclass(frozen=True)
class _RangeDistance:
    """A continuous density of R on [min_km, max_km] (a subclass gives ``pdf``, ``sample``,
    ``probability_between`` and ``draw_between``): its reading, quadrature nodes and support."""

    min_km: float
    max_km: float
    TYPE: ClassVar[str]
    from_table = classmethod(_range_table)
    atoms = None  # a continuous density: bins are drawn by draw_between

    def points(self, breaks=()):
        return quadrature(self.pdf, self.min_km, self.max_km, breaks)

    @property
    def support(self):
        return (self.min_km, self.max_km)


@_register(DISTANCE_MODELS, "uniform")
@dataclass(frozen=True)
class UniformDistance(_RangeDistance):
    """R uniform on [min_km, max_km]."""

    def pdf(self, r):
        r = np.asarray(r, dtype=float)
        return np.where((r >= self.min_km) & (r <= self.max_km), 1.0 / (self.max_km - self.min_km), 0.0)

    def sample(self, n, rng):
        return self.min_km + (self.max_km - self.min_km) * rng.random(n)

    def probability_between(self, lo, hi) -> float:
        """P(lo <= R <= hi) = (b - a) / (max - min) on [a, b] = [lo, hi] cut to the support."""
        ab = _overlap(self.support, lo, hi)
        return 0.0 if ab is None else (ab[1] - ab[0]) / (self.max_km - self.min_km)

    def draw_between(self, u, lo, hi) -> float:
        """The distance at CDF fraction ``u`` of the density restricted to [lo, hi]: a + u (b - a)."""
        a, b = _overlap(self.support, lo, hi)
        return a + u * (b - a)

    def describe(self):
        return f"R uniform {self.min_km:g}-{self.max_km:g} km"


@_register(DISTANCE_MODELS, "area")
@dataclass(frozen=True)
class AreaDistance(_RangeDistance):
    """Epicentres spread evenly over an annulus around the site: f(r) = 2 r / (max^2 - min^2)."""

    def pdf(self, r):
        r = np.asarray(r, dtype=float)
        inside = (r >= self.min_km) & (r <= self.max_km)
        return np.where(inside, 2.0 * r / (self.max_km ** 2 - self.min_km ** 2), 0.0)

    def sample(self, n, rng):
        return np.sqrt(self.min_km ** 2 + (self.max_km ** 2 - self.min_km ** 2) * rng.random(n))

    def probability_between(self, lo, hi) -> float:
        """P(lo <= R <= hi) = (b^2 - a^2) / (max^2 - min^2) on [a, b] = [lo, hi] cut to the support."""
        ab = _overlap(self.support, lo, hi)
        return 0.0 if ab is None else (ab[1] ** 2 - ab[0] ** 2) / (self.max_km ** 2 - self.min_km ** 2)

    def draw_between(self, u, lo, hi) -> float:
        """The distance at CDF fraction ``u`` of the density restricted to [lo, hi]: sqrt(a^2 + u (b^2 - a^2))
        (sqrt is correctly rounded: the same bits on every CPU)."""
        a, b = _overlap(self.support, lo, hi)
        return math.sqrt(a * a + u * (b * b - a * a))

    def describe(self):
        return f"R area {self.min_km:g}-{self.max_km:g} km"


@_register(DISTANCE_MODELS, "discrete")
@dataclass(frozen=True)
class DiscreteDistance:
    """Distances ``r_km`` with probabilities ``weights`` (summing to 1)."""

    r_km: tuple
    weights: tuple
    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("type", "r_km", "weights"))
        r, w = t.d.get("r_km"), t.d.get("weights")
        if not isinstance(r, list) or not isinstance(w, list) or len(r) != len(w) or not r:
            raise ParameterError(f"{t.where()}: r_km and weights must be lists of equal, non-zero "
                                 f"length, got {r!r} and {w!r}")
        rr = tuple(t.number("r_km", R_RANGE_KM, low_open=True, value=x) for x in r)
        ww = tuple(t.number("weights", (0.0, 1.0), value=x) for x in w)
        if abs(sum(ww) - 1.0) > 1e-6:
            raise ParameterError(f"{t.where('weights')} must sum to 1, they sum to {sum(ww):.6g}")
        return cls(rr, ww)

    def points(self, breaks=()):
        return np.array(self.r_km, dtype=float), np.array(self.weights, dtype=float)

    def sample(self, n, rng):
        w = np.asarray(self.weights, dtype=float)
        return np.asarray(self.r_km, dtype=float)[rng.choice(w.size, size=n, p=w / w.sum())]

    @property
    def atoms(self):
        """(distance km, probability) pairs."""
        return tuple(zip(self.r_km, self.weights))

    def describe(self):
        return "R " + ", ".join(f"{r:g} km ({w:g})" for r, w in zip(self.r_km, self.weights))


# --------------------------------------------------------------------------- pulse occurrence

#: Pulse-occurrence models: the ``model`` a site file names one by -> reader.
PULSE_MODELS: dict = {}


@dataclass(frozen=True)
class Spread:
    """A directivity quantity: one value (``lo == hi``) or drawn per event, uniform on [lo, hi]."""

    lo: float
    hi: float

    @classmethod
    def read(cls, t: Table, key: str, rng, unit: str) -> "Spread":
        v = t.d.get(key)
        if isinstance(v, dict):
            s = Table(v, t.origin, f"{t.path}.{key}", ("min", "max"))
            lo, hi = (s.number(k, rng) for k in ("min", "max"))
            if hi <= lo:
                raise ParameterError(f"{s.where()}: max = {hi:g} must be > min = {lo:g}")
            return cls(lo, hi)
        x = t.number(key, rng)
        return cls(x, x)

    @property
    def fixed(self) -> bool:
        return self.lo == self.hi

    def nodes(self, sqrt=False):
        """Gauss-Legendre points and weights (summing to 1) of the uniform density; one point when fixed.

        ``sqrt``: place them in u = sqrt(x) (x = u^2, dx = 2u du), for integrands smooth in sqrt(x)
        but not in x at 0, as the logistic pulse models' sqrt(s) term: 12 points then integrate it
        to round-off instead of to 5e-6."""
        if self.fixed:
            return np.array([self.lo]), np.array([1.0])
        x, w = np.polynomial.legendre.leggauss(QUAD_POINTS)
        if sqrt:
            a, b = math.sqrt(self.lo), math.sqrt(self.hi)
            u = 0.5 * (b - a) * x + 0.5 * (a + b)
            return u * u, 0.5 * (b - a) * w * 2.0 * u / (self.hi - self.lo)
        return 0.5 * (self.hi - self.lo) * x + 0.5 * (self.hi + self.lo), 0.5 * w

    def sample(self, n, rng):
        return np.full(n, self.lo) if self.fixed else self.lo + (self.hi - self.lo) * rng.random(n)

    def text(self, unit):
        return f"{self.lo:g} {unit}" if self.fixed else f"{self.lo:g}-{self.hi:g} {unit} (drawn per event)"


@_register(PULSE_MODELS, "probability")
@dataclass(frozen=True)
class GivenProbability:
    """A constant probability ``p`` that a motion carries a pulse."""

    p: float
    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("model", "probability"))
        return cls(t.number("probability", (0.0, 1.0)))

    def mean_probability(self, r_km):
        return np.full(np.shape(r_km), self.p)

    def draw(self, r_km, rng):
        return self.mean_probability(r_km), {}

    @property
    def needs_no_pulse_branch(self) -> bool:
        return self.p < 1.0

    def describe(self):
        return f"p_pulse = {self.p:g} (given)"


@_register(PULSE_MODELS, "pulse-only")
@dataclass(frozen=True)
class PulseOnly:
    """Every motion carries a pulse (p = 1), asked for explicitly."""

    TYPE: ClassVar[str]

    @classmethod
    def from_table(cls, t: Table):
        t.only(("model",))
        return cls()

    def mean_probability(self, r_km):
        return np.ones(np.shape(r_km))

    def draw(self, r_km, rng):
        return self.mean_probability(r_km), {}

    needs_no_pulse_branch = False

    def describe(self):
        return "PULSE-ONLY (p_pulse = 1, asked for explicitly: every motion carries a pulse)"


@dataclass(frozen=True)
class ShahiBakerPulse:
    """A logistic pulse-occurrence model of the Shahi & Baker family at r = the event's R.

    ``module`` is a ground-motion module of kind ``pulse_occurrence`` (its ``pulse_probability``,
    ``MECHANISMS``, ``PROVENANCE``). The directivity length ``s`` and angle are each one value or
    drawn per event (:class:`Spread`); for the grid convolution p is averaged over their densities
    (Gauss-Legendre, :data:`QUAD_POINTS` per spread quantity), which is exact for the mixture of the
    two branches because it is linear in p.
    """

    module: object
    mechanism: str
    s_km: Spread
    angle_deg: Spread
    TYPE: ClassVar[str] = "shahi_baker"

    @classmethod
    def reader(cls, module):
        def from_table(t: Table):
            t.only(("model", "mechanism", "s_km", "angle_deg"))
            mech = t.d.get("mechanism")
            if mech not in module.MECHANISMS:
                raise ParameterError(f"{t.where('mechanism')} must be one of {', '.join(module.MECHANISMS)} "
                                     f"for {module.NAME}, got {mech!r}")
            lo_s, lo_a = (p.range for p in module.PARAMETERS[1:3])
            return cls(module, mech, Spread.read(t, "s_km", lo_s, "km"), Spread.read(t, "angle_deg", lo_a, "deg"))
        return from_table

    def mean_probability(self, r_km):
        r = np.asarray(r_km, dtype=float)
        (s, ws), (a, wa) = self.s_km.nodes(sqrt=True), self.angle_deg.nodes()
        S, A = np.meshgrid(s, a, indexing="ij")
        w = np.outer(ws, wa)
        p = self.module.pulse_probability(r[..., None, None], S, A, self.mechanism)
        return np.sum(np.asarray(p) * w, axis=(-2, -1))

    def draw(self, r_km, rng):
        r = np.asarray(r_km, dtype=float)
        s, a = self.s_km.sample(r.size, rng), self.angle_deg.sample(r.size, rng)
        p = np.asarray(self.module.pulse_probability(r, s, a, self.mechanism), dtype=float)
        return p, {"s_km": s, "angle_deg": a}

    needs_no_pulse_branch = True

    def describe(self):
        return (f"{self.module.CITATION}, {self.mechanism}, directivity length {self.s_km.text('km')}, "
                f"angle {self.angle_deg.text('deg')}, r = R")


# every pulse-occurrence model the ground-motion registry declares is a branch a site file can name
for _name, _module in gm_registry.MODELS.items():
    if _module.KIND == "pulse_occurrence":
        PULSE_MODELS[_name] = ShahiBakerPulse.reader(_module)
