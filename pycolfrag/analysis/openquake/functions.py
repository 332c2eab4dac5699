"""Fragility functions with OpenQuake's semantics (continuous ``logncdf`` and discrete) and the model of
one taxonomy (one NRML ``fragilityFunction``)."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pycolfrag.analysis.openquake.hazard import im_of_imt
from pycolfrag.core.errors import ParameterError


@dataclass(frozen=True)
class ContinuousFragility:
    """OpenQuake's continuous lognormal fragility function (``format="continuous"``, ``shape="logncdf"``).

    ``mean`` and ``stddev`` are those of the capacity IML itself (OpenQuake's convention). At an
    IML x, clipped first to [``min_iml``, ``max_iml``], the probability of exceedance is the lognormal
    CDF with median ``mean / sqrt(1 + (stddev/mean)^2)`` and dispersion ``sqrt(ln(1 + (stddev/mean)^2))``;
    it is 0 where the clipped x <= ``no_damage_limit``. A ``min_iml`` of 0 clips nothing below, as in
    OpenQuake's ``FragilityFunctionContinuous.__call__`` (``if self.minIML:`` guards the clip;
    ``openquake/risklib/scientific.py``); its NRML reader puts :data:`MIN_IML` in its place, and so does
    :func:`~pycolfrag.analysis.openquake.read_nrml`.
    """

    mean: float
    stddev: float
    min_iml: float
    max_iml: float
    no_damage_limit: float | None = None

    def __post_init__(self):
        for name in ("mean", "stddev", "min_iml", "max_iml"):
            v = getattr(self, name)
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            if not (ok and (v > 0 or (v == 0 and name == "min_iml"))):
                raise ParameterError(f"continuous fragility: {name} must be a finite number "
                                     f"{'>= 0' if name == 'min_iml' else '> 0'}, got {v!r}")
        if self.max_iml <= self.min_iml:
            raise ParameterError(f"continuous fragility: max_iml {self.max_iml!r} must exceed min_iml {self.min_iml!r}")

    @classmethod
    def from_lognormal(cls, median, beta, min_iml, max_iml, no_damage_limit=None) -> "ContinuousFragility":
        """From a median and a log-dispersion (Phi(ln(x / median) / beta)): ``mean = median exp(beta^2/2)``,
        ``stddev = mean sqrt(exp(beta^2) - 1)`` (the moments of a lognormal variable)."""
        median, beta = float(median), float(beta)
        if not (median > 0 and beta > 0 and math.isfinite(median) and math.isfinite(beta)):
            raise ParameterError(f"lognormal fragility needs median > 0 and beta > 0, got {median!r}, {beta!r}")
        mean = median * math.exp(beta * beta / 2.0)
        return cls(mean, mean * math.sqrt(math.expm1(beta * beta)), float(min_iml), float(max_iml),
                   None if no_damage_limit is None else float(no_damage_limit))

    @property
    def beta(self) -> float:
        """Log-dispersion: sqrt(ln(1 + (stddev/mean)^2))."""
        return math.sqrt(math.log1p((self.stddev / self.mean) ** 2))

    @property
    def median(self) -> float:
        """Median capacity: mean / sqrt(1 + (stddev/mean)^2)."""
        return self.mean / math.sqrt(1.0 + (self.stddev / self.mean) ** 2)

    def __call__(self, imls) -> np.ndarray:
        x = np.clip(np.asarray(imls, dtype=float), self.min_iml or None, self.max_iml)
        p = stats.lognorm.cdf(x, self.beta, scale=self.median)
        if self.no_damage_limit:
            p = np.where(x <= self.no_damage_limit, 0.0, p)
        return p


#: Largest excess of a limit state's probability over the previous one's taken as round-off rather than a
#: crossing (a damage-state probability of -1e-6 at worst: below what any report prints).
CROSSING_TOL = 1e-6

#: OpenQuake's stand-in for an absent or zero noDamageLimit of a discrete function and for a continuous
#: function's minIML of 0 (``ffconvert``'s ``min_iml=1E-10`` in ``openquake/risklib/read_nrml.py``: it
#: avoids log(0)).
MIN_IML = 1e-10


@dataclass(frozen=True)
class DiscreteFragility:
    """OpenQuake's discrete fragility function: probabilities of exceedance at given IMLs, linear in
    between, the last value beyond the last IML; 0 below the no-damage limit. As in OpenQuake, the
    point (limit, 0) is put in front of the IMLs when the limit is at or below the first IML, the
    limit being ``no_damage_limit`` or, when that is absent or 0, :data:`MIN_IML`: below the first IML
    the curve falls linearly to 0 (a first IML of 0 keeps its own value)."""

    imls: tuple
    poes: tuple
    no_damage_limit: float | None = None

    def __post_init__(self):
        x = np.asarray(self.imls, dtype=float)
        p = np.asarray(self.poes, dtype=float)
        if x.ndim != 1 or x.size < 2 or x.shape != p.shape:
            raise ParameterError(f"discrete fragility: needs as many poes as imls (>= 2), got {x.size} and {p.size}")
        if not (np.all(np.isfinite(x)) and np.all(x >= 0) and np.all(np.diff(x) > 0)):
            raise ParameterError(f"discrete fragility: imls must be increasing and >= 0, got {x.tolist()}")
        if not (np.all(np.isfinite(p)) and np.all((p >= 0) & (p <= 1))):
            raise ParameterError(f"discrete fragility: poes must be in [0, 1], got {p.tolist()}")
        object.__setattr__(self, "imls", tuple(float(v) for v in x))
        object.__setattr__(self, "poes", tuple(float(v) for v in p))

    def _points(self):
        x, p = np.array(self.imls), np.array(self.poes)
        ndl = self.no_damage_limit or MIN_IML
        if ndl <= x[0]:
            x, p = np.concatenate([[ndl], x]), np.concatenate([[0.0], p])
        return x, p

    def __call__(self, imls) -> np.ndarray:
        xs, ps = self._points()
        x = np.minimum(np.asarray(imls, dtype=float), xs[-1])
        p = np.interp(x, xs, ps)
        return np.where(x < (self.no_damage_limit or MIN_IML), 0.0, p)


@dataclass
class FragilityModel:
    """One NRML ``fragilityFunction``: the limit states of one taxonomy on one IMT, in increasing severity.

    ``functions``: one :class:`ContinuousFragility` or :class:`DiscreteFragility` per limit state (all of
    one format; a discrete model shares its IMLs and no-damage limit). ``fits``: the pycolfrag fits it
    came from (:class:`~pycolfrag.analysis.fragility.LognormalFragility` per limit state), when built from results;
    ``joint``: the groups of limit states fitted together with one dispersion (their separate fits crossed);
    ``notes``: what every printout of the model must repeat (degenerate fits, an incomplete results file).
    """

    imt: str
    limit_states: tuple
    functions: list
    taxonomy: str = "column"
    model_id: str = "pycolfrag"
    description: str = ""
    asset_category: str = "buildings"
    loss_category: str = "structural"
    fits: list = field(default_factory=list)
    joint: tuple = ()
    notes: tuple = ()

    def __post_init__(self):
        self.limit_states = tuple(self.limit_states)
        if len(self.limit_states) != len(self.functions) or not self.functions:
            raise ParameterError(f"fragility model {self.taxonomy!r}: {len(self.limit_states)} limit states, "
                                 f"{len(self.functions)} functions")
        for ls in self.limit_states + (self.taxonomy, self.model_id):
            if not re.fullmatch(r"[A-Za-z0-9_\-.]+", ls):
                raise ParameterError(f"fragility model: {ls!r} is not a valid NRML name (letters, digits, _ - .)")
        kinds = {type(f) for f in self.functions}
        if len(kinds) != 1 or not kinds <= {ContinuousFragility, DiscreteFragility}:
            raise ParameterError("fragility model: every function must be continuous, or every one discrete")
        f0 = self.functions[0]
        shared = ("imls", "no_damage_limit") if self.format == "discrete" else ("min_iml", "max_iml", "no_damage_limit")
        if any(getattr(f, k) != getattr(f0, k) for f in self.functions for k in shared):
            # NRML stores them once per fragilityFunction (its imls element)
            raise ParameterError(f"{self.format} fragility model: the limit states must share {', '.join(shared)}")
        im_of_imt(self.imt)

    @property
    def format(self) -> str:
        return "continuous" if isinstance(self.functions[0], ContinuousFragility) else "discrete"

    @property
    def domain(self) -> tuple[float, float]:
        """The IMLs between which the functions vary (OpenQuake holds them constant outside): a continuous
        model's ``[min_iml, max_iml]``, a discrete model's first to last IML."""
        f0 = self.functions[0]
        if self.format == "continuous":
            return f0.min_iml, f0.max_iml
        return f0.imls[0], f0.imls[-1]

    def crossing(self, imls) -> str:
        """Where a limit state is more probable than the one before it by more than :data:`CROSSING_TOL`
        at one of ``imls`` (the first such pair, as a sentence), or ``""``. Damage-state probabilities are
        differences of consecutive limit states (:func:`~pycolfrag.analysis.openquake.classical_damage`),
        so such a model gives a negative one; OpenQuake computes it all the same (its
        ``scientific.classical_damage`` has no check), which is why pycolfrag checks."""
        x = np.asarray(imls, dtype=float)
        p = [np.asarray(f(x), dtype=float) for f in self.functions]
        for (a, pa), (b, pb) in zip(zip(self.limit_states, p), zip(self.limit_states[1:], p[1:])):
            worse = pb - pa
            if worse.size and worse.max() > CROSSING_TOL:
                k = int(np.argmax(worse))
                return f"P({b}) exceeds P({a}) by {worse[k]:.3g} at {x[k]:.4g} ({pb[k]:.4g} against {pa[k]:.4g})"
        return ""

