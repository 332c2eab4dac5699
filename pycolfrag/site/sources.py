"""A site and its earthquake sources, read from a site file (TOML; format in ``docs/risk.md``).

A :class:`Site` holds site sources. A source is a class that yields weighted (Mw, R) events, as a
seismic source of OpenQuake yields ruptures with their occurrence rates, in the two forms a site
risk needs (:class:`SiteSource`):

* ``quadrature(mw_breaks, r_breaks)``: events whose weights are the quadrature of the source's
  joint density of (Mw, R) times its annual rate -- what the grid convolution of
  :mod:`pycolfrag.risk.site_risk` sums. The density is joint: a source whose distance depends on the
  magnitude (a fault whose larger ruptures come closer to the site) is one class like the others;
* ``sample(n, rng)``: n random events, each carrying the annual rate it stands for -- what an
  event-based simulation of the site draws;
* ``cells(mw_step, mw_inner, r_inner)``: the events cut into Mw x R cells, what the rare route's
  stratified simulation draws from (:mod:`pycolfrag.site.cells`); every source has them from its
  quadrature, so a new type serves both risk routes with its one class.

Every event carries the probability that its motion has a velocity pulse, from the source's
pulse-occurrence model (:mod:`pycolfrag.site.models`). The shipped source type is
:class:`MagnitudeDistanceSource` (magnitude and distance drawn independently, the site file's
``magnitude`` and ``distance`` tables); a new type is one class registered with
:func:`source_type` (docs/architecture.md walks through one). Every bad value of a site file raises
:class:`~pycolfrag.core.errors.ParameterError` naming the file, the key and the value; the file itself is
read by the one policy for files a user names (:mod:`pycolfrag.core.input_files`).
"""
from __future__ import annotations

import abc
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError
from pycolfrag.site import cells as _cells
from pycolfrag.site.models import DISTANCE_MODELS, MAGNITUDE_MODELS, PULSE_MODELS, Table

__all__ = ["Events", "SiteSource", "SOURCE_TYPES", "source_type", "MagnitudeDistanceSource", "Site",
           "DEFAULT_YEARS", "OUTSIDE_CHOICES", "DEFAULT_SOURCE_TYPE", "load_site", "site_from_dict", "read_pulse_model"]

#: Time horizons always reported, years (475: the return period of the 10 %-in-50-years design level,
#: used here as a horizon like the others).
DEFAULT_YEARS = (50.0, 100.0, 475.0)
#: What the part of a source outside the simulated (Mw, R) range contributes (see docs/risk.md).
OUTSIDE_CHOICES = ("refuse", "clamp", "zero")


@dataclass(frozen=True)
class Events:
    """Weighted (Mw, R) events of a source.

    Attributes
    ----------
    mw, r_km : ndarray
        Magnitude and distance (km, the grid's distance) of each event.
    weight : ndarray
        Annual rate each event stands for, 1/yr: quadrature weights times the source's rate, or the
        rate over the number of draws for random events.
    p_pulse : ndarray
        Probability that the event's motion carries a velocity pulse (for quadrature events,
        averaged over the directivity geometry the pulse model draws per event).
    geometry : dict of str -> ndarray
        What the pulse model drew per event (``s_km``, ``angle_deg``), random events only.
    """

    mw: np.ndarray
    r_km: np.ndarray
    weight: np.ndarray
    p_pulse: np.ndarray
    geometry: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(np.size(self.mw))


class SiteSource(abc.ABC):
    """The contract of a site source (docs/risk.md, docs/architecture.md).

    A subclass has ``name``, ``rate`` (annual rate of its events, 1/yr) and ``pulse`` (a
    pulse-occurrence model of :mod:`pycolfrag.site.models`), reads its own keys of the site file's
    ``[[sources]]`` table (:meth:`from_table`), and yields its events in both forms.
    """

    TYPE: ClassVar[str]
    #: Keys of the ``[[sources]]`` table this type reads besides the common ones.
    KEYS: ClassVar[tuple] = ()
    name: str
    rate: float
    pulse: object

    @classmethod
    @abc.abstractmethod
    def from_table(cls, t: Table, name: str, rate: float, pulse) -> "SiteSource":
        """The source of a ``[[sources]]`` table whose common keys (name, rate, pulse) are read."""

    @abc.abstractmethod
    def quadrature(self, mw_breaks=(), r_breaks=()) -> Events:
        """Events whose weights integrate the source's joint (Mw, R) density times its rate; the
        breaks are where the integrand has kinks (the grid's nodes): segments end there."""

    @abc.abstractmethod
    def sample(self, n: int, rng: np.random.Generator) -> Events:
        """``n`` random events, each of weight ``rate / n``, the pulse geometry drawn per event."""

    @abc.abstractmethod
    def describe(self) -> str:
        """One line for the outputs."""

    def with_pulse(self, pulse) -> "SiteSource":
        """The same source with another pulse-occurrence model (``--pulse-model``, ``--pulse-only`` of both
        routes); a dataclass source's by :func:`dataclasses.replace`, another type overrides it."""
        return replace(self, pulse=pulse)  # type: ignore[type-var]  # dataclass sources; others override it

    def cells(self, mw_step: float, mw_inner, r_inner) -> list:
        """Its events cut into cells (:class:`pycolfrag.site.cells.Cell`: a Mw bin x an R bin, the rates
        with and without a pulse, how an event of the cell is placed), what the rare route stratifies:
        magnitude edges at ``mw_inner`` and the multiples of ``mw_step``, distance edges at ``r_inner``.
        Every source has them from its :meth:`quadrature` (:func:`pycolfrag.site.cells.quadrature_cells`);
        a type may give exact ones instead."""
        return _cells.quadrature_cells(self, mw_step, mw_inner, r_inner)


#: Site source types: the ``type`` a ``[[sources]]`` table names -> the class.
SOURCE_TYPES: dict = {}
#: The type of a ``[[sources]]`` table without a ``type`` key.
DEFAULT_SOURCE_TYPE = "magnitude-distance"


def source_type(name: str):
    """Class decorator: register a :class:`SiteSource` subclass as the site file's ``type = name``."""
    def register(cls):
        if name in SOURCE_TYPES:
            raise ValueError(f"site source type {name!r} is registered twice")
        if not issubclass(cls, SiteSource):
            raise TypeError(f"{cls.__name__} is not a SiteSource")
        cls.TYPE = name
        SOURCE_TYPES[name] = cls
        return cls
    return register


@source_type(DEFAULT_SOURCE_TYPE)
@dataclass(frozen=True)
class MagnitudeDistanceSource(SiteSource):
    """A source whose magnitude and distance are independent: f(m, r) = f(m) f(r).

    ``magnitude`` and ``distance`` are models of :mod:`pycolfrag.site.models` (site file tables
    ``magnitude = {type = ...}``, ``distance = {type = ...}``).
    """

    name: str
    rate: float
    magnitude: object
    distance: object
    pulse: object
    KEYS: ClassVar[tuple] = ("magnitude", "distance")

    @classmethod
    def from_table(cls, t, name, rate, pulse):
        mt, dt = t.sub("magnitude"), t.sub("distance")
        return cls(name, rate, mt.choice("type", MAGNITUDE_MODELS, "magnitude models")(mt),
                   dt.choice("type", DISTANCE_MODELS, "distance models")(dt), pulse)

    def quadrature(self, mw_breaks=(), r_breaks=()):
        mm, wm = self.magnitude.points(mw_breaks)
        rr, wr = self.distance.points(r_breaks)
        M, R = (a.ravel() for a in np.meshgrid(mm, rr, indexing="ij"))
        return Events(M, R, (self.rate * np.outer(wm, wr)).ravel(), self.pulse.mean_probability(R))

    def sample(self, n, rng):
        m, r = self.magnitude.sample(n, rng), self.distance.sample(n, rng)
        p, geometry = self.pulse.draw(r, rng)
        return Events(m, r, np.full(n, self.rate / n), np.asarray(p, dtype=float), geometry)

    def describe(self):
        return f"{self.magnitude.describe()}, {self.distance.describe()}, rate {self.rate:.4g} /yr"

    def cells(self, mw_step, mw_inner, r_inner):
        """Exact bins of the two independent models (:func:`pycolfrag.site.cells.independent_cells`) when
        they give bins, else the quadrature's (:meth:`SiteSource.cells`)."""
        if _cells.gives_bins(self):
            return _cells.independent_cells(self, mw_step, mw_inner, r_inner)
        return super().cells(mw_step, mw_inner, r_inner)


@dataclass(frozen=True)
class Site:
    """A site: its sources, the treatment of the part outside the grid, the time horizons."""

    name: str
    sources: tuple
    outside: str = "refuse"
    years: tuple = DEFAULT_YEARS
    description: str = ""
    path: str = ""


# logic_tree: a logic tree over the site's and the model's choices, read by pycolfrag/risk/logic_tree.py
_SITE_KEYS = ("name", "description", "outside", "years", "pulse", "sources", "logic_tree")
_COMMON_KEYS = ("type", "name", "rate", "pulse")


def read_pulse_model(t: Table):
    """The pulse-occurrence model of a site file's pulse table (``probability = p`` is short for
    ``model = "probability"``)."""
    if "model" not in t.d and "probability" in t.d:        # the short form: probability = p
        t = Table({**t.d, "model": "probability"}, t.origin, t.path)
    return t.choice("model", PULSE_MODELS, "pulse-occurrence models")(t)


def _source(raw, i: int, origin: str, default_pulse, names):
    t = Table(raw, origin, f"sources[{i}]")
    cls = SOURCE_TYPES.get(t.d.get("type", DEFAULT_SOURCE_TYPE))
    if cls is None:
        raise ParameterError(f"{t.where('type')} must be one of {', '.join(map(repr, SOURCE_TYPES))}, "
                             f"got {t.d.get('type')!r}")
    t.only(_COMMON_KEYS + cls.KEYS)
    name = str(t.d.get("name", f"source {i + 1}"))
    if name in names:                                     # the outputs list the sources by name
        raise ParameterError(f"{t.where('name')} {name!r} is the name of an earlier source; "
                             "give every source its own name")
    rate = t.number("rate", (0.0, float("inf")))
    pulse = read_pulse_model(t.sub("pulse")) if "pulse" in t.d else default_pulse
    if pulse is None:
        raise ParameterError(
            f"{t.where()} ({name}): no pulse model. Every motion of a grid carries a velocity "
            "pulse, so the site file must say how often pulses occur: a [pulse] table with "
            "probability = p, or model = 'shahi_baker_2014' (or another pulse-occurrence model), or "
            "model = 'pulse-only' to ask for the pulse branch alone")
    return cls.from_table(t, name, rate, pulse)


def site_from_dict(d: dict, origin: str = "") -> Site:
    """Build a :class:`Site` from the dict of a site file (see ``docs/risk.md``); every bad value
    raises :class:`~pycolfrag.core.errors.ParameterError` naming the file, the key and the value."""
    top = Table(d, origin, "site", _SITE_KEYS)
    outside = d.get("outside", "refuse")
    if outside not in OUTSIDE_CHOICES:
        raise ParameterError(f"{top.where('outside')} must be one of {', '.join(OUTSIDE_CHOICES)}, "
                             f"got {outside!r}")
    years = d.get("years", [])
    if not isinstance(years, list):
        raise ParameterError(f"{top.where('years')} must be a list of years, got {years!r}")
    extra = [top.number("years", (0.0, float("inf")), low_open=True, value=y) for y in years]
    default_pulse = read_pulse_model(top.sub("pulse")) if "pulse" in d else None
    raw = d.get("sources")
    if not isinstance(raw, list) or not raw:
        raise ParameterError(f"{top.where('sources')}: at least one [[sources]] table is needed")
    sources = []
    for i, s in enumerate(raw):
        sources.append(_source(s, i, origin, default_pulse, [src.name for src in sources]))
    return Site(str(d.get("name", Path(origin).stem if origin else "site")), tuple(sources), outside,
                tuple(sorted(set(DEFAULT_YEARS) | set(extra))), str(d.get("description", "")), origin)


def load_site(path) -> Site:
    """Read a site file (TOML, ``docs/risk.md``): a regular UTF-8 file of at most
    ``input_files.LIMITS["site file"]`` bytes."""
    text = input_files.read_text(path, "site file")
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    return site_from_dict(d, str(path))
