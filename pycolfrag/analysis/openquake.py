"""OpenQuake interchange and the IM route of site risk: hazard curves in, IM-based fragility out, and
OpenQuake's ``classical_damage`` convolution of the two (docs/risk.md, "IM route and OpenQuake").

Three pieces, none of which needs OpenQuake installed:

* :func:`read_hazard_curves` -- an OpenQuake hazard-curve CSV (``hazard_curve-mean-PGA_*.csv``):
  one metadata comment line (the current ``#,,,,"generated_by=..., investigation_time=50.0,
  imt='PGA'"`` or the older ``# ..., investigation_time=50.0, imt="PGA"``), a header
  ``[custom_site_id,]lon,lat[,depth],poe-<IML>,...`` and one row per site. The values are probabilities
  of exceedance in the investigation time T, not rates: the annual rate is ``-ln(1 - poe) / T`` (Poisson).
* :class:`ContinuousFragility`, :class:`DiscreteFragility`, :class:`FragilityModel` -- fragility
  functions with OpenQuake's semantics (``minIML``/``maxIML`` clipping, ``noDamageLimit``), built
  from pycolfrag's maximum-likelihood lognormal fits (:func:`fragility_from_results`) and written /
  read as NRML 0.5 ``fragilityModel`` (:func:`write_nrml`, :func:`read_nrml`). OpenQuake's
  continuous ``mean`` and ``stddev`` are the mean and standard deviation of the capacity IML itself,
  not a median and a log-dispersion: ``mean = median exp(beta^2 / 2)``,
  ``stddev = mean sqrt(exp(beta^2) - 1)`` (:meth:`ContinuousFragility.from_lognormal`).
* :func:`classical_damage` -- OpenQuake's classical damage algorithm: annual exceedance rates of
  the hazard levels; the rate of occurrence attributed to level i is the difference of the rates at
  the midpoints around it, ``(rate[i-1] - rate[i+1]) / 2`` (half differences at both ends: the rate
  above the highest level is not counted); the annual rate of exceeding a limit state is the sum of
  those rates times the fragility at each level; its probability in the risk investigation time
  ``T_r`` is ``1 - exp(-rate T_r)``; the damage-state probabilities are the differences of
  consecutive limit-state probabilities.

Command line::

    python -m pycolfrag.analysis.openquake export results/grid.h5 column_fragility.xml --im pga_g
    python -m pycolfrag.analysis.openquake damage hazard_curve-mean-PGA.csv column_fragility.xml --risk-time 50

Units are OpenQuake's: PGA and SA in g, PGV in cm/s (pycolfrag's ``pga_g``, ``sa_g``, ``pgv_cm_s``).
"""
from __future__ import annotations

import argparse
import csv
import math
import re
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

from ..errors import HazardFileError, ParameterError
from . import fragility as _frag
from .data import read_table
from .fragility import U_D_LEVELS, U_TOP_LEVELS
from .outputs import NRML_NS, WRITERS, write_fragility, write_nrml

__all__ = ["NRML_NS", "MIN_IML", "HazardCurves", "read_hazard_curves", "imt_of", "im_of_imt", "annual_rates",
           "occurrence_rates", "ContinuousFragility", "DiscreteFragility", "FragilityModel",
           "classical_damage", "fragility_from_results", "write_nrml", "read_nrml", "main"]

#: XML namespace of NRML 0.5.

#: pycolfrag IM name -> OpenQuake IMT (spectral ones take a period: ``SA(1.0)``); units agree.
_IMT = {"pga_g": "PGA", "pgv_cm_s": "PGV", "sa_g": "SA"}


def imt_of(im: str, period_s: float | None = None) -> str:
    """OpenQuake IMT string of a pycolfrag IM: ``pga_g`` -> ``PGA``, ``pgv_cm_s`` -> ``PGV``,
    ``sa_g`` at ``period_s`` -> ``SA(1.0)``."""
    if im not in _IMT:
        raise ParameterError(f"IM {im!r} has no OpenQuake intensity measure type (known: {', '.join(_IMT)})")
    if im == "sa_g":
        if period_s is None or not (math.isfinite(float(period_s)) and float(period_s) > 0):
            raise ParameterError(f"sa_g needs a period > 0 s for its OpenQuake IMT, got {period_s!r}")
        return f"SA({float(period_s)!r})"
    return _IMT[im]


def im_of_imt(imt: str) -> tuple[str, float | None]:
    """(pycolfrag IM name, period in s or None) of an OpenQuake IMT string (``PGA``, ``PGV``, ``SA(0.3)``)."""
    m = re.fullmatch(r"\s*SA\(\s*([0-9.eE+-]+)\s*\)\s*", imt)
    if m:
        return "sa_g", float(m.group(1))
    for k, v in _IMT.items():
        if imt.strip() == v and k != "sa_g":
            return k, None
    raise ParameterError(f"OpenQuake IMT {imt!r} has no pycolfrag IM (known: PGA, PGV, SA(T))")


# --------------------------------------------------------------------------- hazard curves

@dataclass
class HazardCurves:
    """Hazard curves of one IMT at N sites (an OpenQuake hazard-curve CSV).

    Attributes
    ----------
    imt : str
        OpenQuake intensity measure type (``PGA``, ``PGV``, ``SA(1.0)``).
    imls : ndarray (L,)
        Intensity measure levels, increasing (g for PGA/SA, cm/s for PGV).
    poes : ndarray (N, L)
        Probabilities of exceedance of each level in ``investigation_time``.
    investigation_time : float
        Years.
    lon, lat, depth : ndarray (N,)
        Site coordinates (``depth`` NaN when the file has no depth column).
    path : str
    site_ids : list of str
        OpenQuake's ``custom_site_id`` of each site (empty strings when the file has none).
    """

    imt: str
    imls: np.ndarray
    poes: np.ndarray
    investigation_time: float
    lon: np.ndarray
    lat: np.ndarray
    depth: np.ndarray
    path: str = ""
    site_ids: list = field(default_factory=list)

    def annual_rates(self) -> np.ndarray:
        """Annual rates of exceedance of every level at every site, 1/yr (:func:`annual_rates`)."""
        return annual_rates(self.poes, self.investigation_time)


#: Columns of a hazard-curve CSV besides ``poe-<IML>`` (OpenQuake writes ``custom_site_id`` first when
#: the site model has one).
_SITE_COLUMNS = ("custom_site_id", "lon", "lat", "depth")


def _metadata(comment: str) -> dict:
    """``key=value`` pairs of an OpenQuake CSV comment line, both spellings: the current one
    (``#,,,,"generated_by='...', investigation_time=50.0, imt='PGA'"``) and the older one
    (``# ..., investigation_time=50.0, imt="PGA"``). Values are kept as text."""
    text = comment.lstrip("#, ").rstrip(", \r\n")
    out = {}
    for m in re.finditer(r"(\w+)\s*=\s*('[^']*'|\"[^\"]*\"|\[[^\]]*\]|[^,]*)", text):
        v = m.group(2).strip()
        if len(v) >= 2 and v[0] == v[-1] and v[0] in "'\"":
            v = v[1:-1]
        out[m.group(1)] = v
    return out


def read_hazard_curves(path, *, investigation_time: float | None = None, imt: str | None = None) -> HazardCurves:
    """Read an OpenQuake hazard-curve CSV file.

    The investigation time and the IMT come from the file's comment line; ``investigation_time`` and
    ``imt`` supply them for a file without one (and must agree with it when both are given).
    Refused with :class:`~pycolfrag.errors.HazardFileError` naming the file and the problem: no
    ``lon``/``lat`` or no ``poe-<IML>`` column, an IML that is not a positive number or not
    increasing, a value that is not a number, a probability outside [0, 1) (1 would be an infinite
    annual rate), a curve that increases with the level, a missing investigation time or IMT.
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            lines = [ln for ln in f.read().splitlines() if ln.strip()]
    except OSError as exc:
        raise HazardFileError(f"{path}: cannot read the hazard-curve file: {exc.strerror or exc}") from None
    meta = {}
    while lines and lines[0].lstrip().startswith("#"):
        meta.update(_metadata(lines.pop(0)))
    if not lines:
        raise HazardFileError(f"{path}: no header line (lon,lat,poe-<IML>,...) in the hazard-curve file")
    rows = list(csv.reader(lines))
    header = [h.strip() for h in rows[0]]
    for name in ("lon", "lat"):
        if name not in header:
            raise HazardFileError(f"{path}: the header has no {name!r} column (header: {','.join(header)})")
    poe_cols = [j for j, h in enumerate(header) if h.startswith("poe-")]
    if not poe_cols:
        raise HazardFileError(f"{path}: the header has no poe-<IML> column (header: {','.join(header)})")
    unknown = [h for j, h in enumerate(header) if j not in poe_cols and h not in _SITE_COLUMNS]
    if unknown:
        raise HazardFileError(f"{path}: unknown column(s) {unknown} (expected {', '.join(_SITE_COLUMNS)}, "
                              "poe-<IML>)")
    imls = []
    for j in poe_cols:
        try:
            x = float(header[j][4:])
        except ValueError:
            x = math.nan
        if not (math.isfinite(x) and x > 0):
            raise HazardFileError(f"{path}: column {header[j]!r} does not name a positive intensity level")
        imls.append(x)
    imls = np.array(imls)
    if np.any(np.diff(imls) <= 0):
        raise HazardFileError(f"{path}: the poe-<IML> columns must have increasing levels, got {imls.tolist()}")
    data = []
    for i, r in enumerate(rows[1:], start=1):
        if len(r) != len(header):
            raise HazardFileError(f"{path}: data row {i} has {len(r)} values, the header {len(header)} columns")
        vals = []
        for h, v in zip(header, r):
            if h == "custom_site_id":
                vals.append(math.nan)
                continue
            try:
                x = float(v)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                raise HazardFileError(f"{path}: data row {i}, column {h!r}: {v!r} is not a finite number")
            vals.append(x)
        data.append(vals)
    if not data:
        raise HazardFileError(f"{path}: no site rows below the header")
    data = np.array(data)
    poes = data[:, poe_cols]
    bad = np.argwhere((poes < 0) | (poes >= 1))
    if bad.size:
        i, j = bad[0]
        raise HazardFileError(f"{path}: data row {i + 1}, column {header[poe_cols[j]]!r}: probability "
                              f"{poes[i, j]!r} outside [0, 1) (1 would be an infinite annual rate)")
    inc = np.argwhere(np.diff(poes, axis=1) > 0)
    if inc.size:
        i, j = inc[0]
        raise HazardFileError(f"{path}: data row {i + 1}: the probability of exceedance increases from "
                              f"{header[poe_cols[j]]!r} ({poes[i, j]!r}) to {header[poe_cols[j + 1]]!r} "
                              f"({poes[i, j + 1]!r}); a hazard curve decreases with the level")
    t_file = meta.get("investigation_time")
    if t_file is not None:
        try:
            t_file = float(t_file)
        except ValueError:
            raise HazardFileError(f"{path}: investigation_time={meta['investigation_time']!r} "
                                  "is not a number") from None
    t = _agree(path, "investigation_time", t_file, None if investigation_time is None else float(investigation_time))
    if not (math.isfinite(t) and t > 0):
        raise HazardFileError(f"{path}: investigation_time must be > 0 years, got {t!r}")
    imt_ = _agree(path, "imt", meta.get("imt"), imt)
    im_of_imt(imt_)   # a known IMT, or ParameterError naming it
    col = {h: j for j, h in enumerate(header)}
    depth = data[:, col["depth"]] if "depth" in col else np.full(len(data), np.nan)
    ids = [r[col["custom_site_id"]].strip() for r in rows[1:]] if "custom_site_id" in col else [""] * len(data)
    return HazardCurves(imt_, imls, poes, t, data[:, col["lon"]], data[:, col["lat"]], depth, str(path), ids)


def _agree(path, name, in_file, given):
    if in_file is None and given is None:
        raise HazardFileError(f"{path}: no {name} in the file's comment line; give it ({name}=...)")
    if in_file is not None and given is not None and in_file != given:
        raise HazardFileError(f"{path}: the file says {name}={in_file!r}, the call {given!r}")
    return in_file if in_file is not None else given


def annual_rates(poes, investigation_time) -> np.ndarray:
    """Annual rates of exceedance from probabilities in ``investigation_time`` years (Poisson):
    ``-ln(1 - poe) / T``."""
    poes = np.asarray(poes, dtype=float)
    return -np.log1p(-poes) / float(investigation_time)


def occurrence_rates(rates) -> np.ndarray:
    """OpenQuake's rate of occurrence attributed to each level from the exceedance rates along the
    last axis: the rate between the midpoints around the level, ``(rate[i-1] - rate[i+1]) / 2``, with
    ``(rate[0] - rate[1]) / 2`` and ``(rate[-2] - rate[-1]) / 2`` at the ends (their sum is
    ``rate[0] - rate[-1]``: the rate above the highest level is not counted)."""
    r = np.asarray(rates, dtype=float)
    mid = np.concatenate([r[..., :1], 0.5 * (r[..., :-1] + r[..., 1:]), r[..., -1:]], axis=-1)
    return mid[..., :-1] - mid[..., 1:]


# --------------------------------------------------------------------------- fragility functions

@dataclass(frozen=True)
class ContinuousFragility:
    """OpenQuake's continuous lognormal fragility function (``format="continuous"``, ``shape="logncdf"``).

    ``mean`` and ``stddev`` are those of the capacity IML itself (OpenQuake's convention). At an
    IML x, clipped first to [``min_iml``, ``max_iml``], the probability of exceedance is the lognormal
    CDF with median ``mean / sqrt(1 + (stddev/mean)^2)`` and dispersion ``sqrt(ln(1 + (stddev/mean)^2))``;
    it is 0 where the clipped x <= ``no_damage_limit``.
    """

    mean: float
    stddev: float
    min_iml: float
    max_iml: float
    no_damage_limit: float | None = None

    def __post_init__(self):
        for name in ("mean", "stddev", "min_iml", "max_iml"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"continuous fragility: {name} must be a finite number > 0, got {v!r}")
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
        x = np.clip(np.asarray(imls, dtype=float), self.min_iml, self.max_iml)
        p = stats.lognorm.cdf(x, self.beta, scale=self.median)
        if self.no_damage_limit:
            p = np.where(x <= self.no_damage_limit, 0.0, p)
        return p


#: OpenQuake's stand-in for an absent or zero noDamageLimit of a discrete function (it avoids log(0)).
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
    came from (:class:`~pycolfrag.analysis.fragility.LognormalFragility` per limit state), when built from results.
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
        if self.format == "discrete":
            f0 = self.functions[0]
            if any(f.imls != f0.imls or f.no_damage_limit != f0.no_damage_limit for f in self.functions):
                raise ParameterError("discrete fragility model: the limit states must share IMLs and noDamageLimit")
        im_of_imt(self.imt)

    @property
    def format(self) -> str:
        return "continuous" if isinstance(self.functions[0], ContinuousFragility) else "discrete"


# --------------------------------------------------------------------------- classical damage

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


# --------------------------------------------------------------------------- from pycolfrag results

def _ls_name(level) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", level.name.strip()).strip("_").lower()


#: Largest excess of a limit state's probability over the previous one's tolerated in an export (a
#: damage-state probability of -1e-6 at worst: below what any report prints).
CROSSING_TOL = 1e-6


def fragility_from_results(results, im: str = "pga_g", *, period_s: float | None = None, levels=None,
                           collapse: bool = True, fmt: str = "continuous", imls=None, n_imls: int = 20,
                           iml_range=None, no_damage_limit: float | None = None, taxonomy: str = "column",
                           model_id: str = "pycolfrag", description: str | None = None) -> FragilityModel:
    """IM-based fragility of a results file as an OpenQuake fragility model.

    Every limit state is pycolfrag's binomial maximum-likelihood lognormal fit
    (:func:`pycolfrag.analysis.fragility.fit_lognormal_fragility`) over the successful rows: exceedance of a
    performance level (a collapse counts as exceeding), and collapse itself last when ``collapse``.

    Parameters
    ----------
    results : path, :class:`~pycolfrag.analysis.data.Results` or a suite table (dict)
    im : ``pga_g``, ``pgv_cm_s`` or ``sa_g`` (with ``period_s``)
    levels : performance levels in increasing severity (default: Table III, ``U_TOP_LEVELS``)
    fmt : ``continuous`` (``mean``/``stddev`` of the IML, :meth:`ContinuousFragility.from_lognormal`)
        or ``discrete`` (the fitted curves at ``imls``, default ``n_imls`` levels log-spaced over
        ``iml_range``)
    iml_range : (lo, hi) -- ``minIML``/``maxIML`` of a continuous model, range of a discrete one;
        default the range of the IM over the rows the curves were fitted to (beyond it OpenQuake holds the
        curve constant)
    no_damage_limit : IML below which OpenQuake sets every probability to 0 (default none)

    The fitted curves must not cross within the exported IML range (each limit state at most as
    probable as the one before it), else ParameterError naming the two: OpenQuake would turn such
    curves into negative damage-state probabilities.
    """
    if fmt not in ("continuous", "discrete"):
        raise ParameterError(f"fmt must be 'continuous' or 'discrete', got {fmt!r}")
    levels = tuple(U_TOP_LEVELS if levels is None else levels)
    table = read_table(results)
    x, label = _frag.table_im(table, im, period_s)
    imt = imt_of(im, period_s)
    ok = _frag.ok_rows(table) & np.isfinite(x) & (x > 0)
    x = x[ok]
    coll = np.asarray(table["collapsed"])[ok].astype(bool)
    fits, names = [], []
    for lev in levels:
        edp = np.asarray(table[lev.edp], dtype=float)[ok]
        try:
            fits.append(_frag.fit_lognormal_fragility(x, edp, coll, lev.threshold))
        except ParameterError as exc:
            raise ParameterError(f"limit state {lev.label} on {label}: {exc}") from None
        names.append(_ls_name(lev))
    if collapse:
        try:
            fits.append(_frag.fit_lognormal_fragility(x, np.zeros(x.size), coll, 1.0))
        except ParameterError as exc:
            raise ParameterError(f"limit state collapse on {label}: {exc}") from None
        names.append("collapse")
    lo, hi = (float(x.min()), float(x.max())) if iml_range is None else (float(iml_range[0]), float(iml_range[1]))
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ParameterError(f"iml_range must be 0 < lo < hi, got {(lo, hi)}")
    check = np.geomspace(lo, hi, 200)
    for (a, fa), (b, fb) in zip(zip(names, fits), zip(names[1:], fits[1:])):
        worse = np.asarray(fb(check)) - np.asarray(fa(check))
        if worse.max() > CROSSING_TOL:
            at = check[int(np.argmax(worse))]
            raise ParameterError(f"limit states cross on {label}: P({b}) exceeds P({a}) by {worse.max():.3g} at "
                                 f"{at:.4g} (within the exported range {lo:.4g}-{hi:.4g}); OpenQuake would give a "
                                 "negative damage-state probability there. Leave a limit state out (levels=..., "
                                 "collapse=False; --no-collapse) or narrow iml_range")
    if fmt == "continuous":
        funcs = [ContinuousFragility.from_lognormal(f.median, f.beta, lo, hi, no_damage_limit) for f in fits]
    else:
        grid = np.geomspace(lo, hi, int(n_imls)) if imls is None else np.asarray(imls, dtype=float)
        funcs = [DiscreteFragility(tuple(grid), tuple(np.asarray(f(grid), dtype=float)), no_damage_limit)
                 for f in fits]
    desc = description or (f"pycolfrag IM-based fragility on {label}: binomial MLE lognormal fits over "
                           f"{x.size} runs")
    return FragilityModel(imt, tuple(names), funcs, taxonomy=taxonomy, model_id=model_id, description=desc,
                          fits=fits)


# --------------------------------------------------------------------------- NRML 0.5

def _floats(text, what, path):
    try:
        vals = [float(v) for v in (text or "").split()]
    except ValueError:
        raise HazardFileError(f"{path}: {what} must be numbers, got {text!r}") from None
    return vals


def read_nrml(path) -> dict:
    """The fragility functions of an NRML 0.5 ``fragilityModel`` file: ``{taxonomy: FragilityModel}``
    (``logncdf`` continuous and discrete functions; bad or missing values raise
    :class:`~pycolfrag.errors.HazardFileError` naming them)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise HazardFileError(f"{path}: cannot read the NRML file: {exc}") from None
    ns = root.tag[1:root.tag.index("}")] if root.tag.startswith("{") else ""
    q = (lambda tag: f"{{{ns}}}{tag}") if ns else (lambda tag: tag)  # noqa: E731
    fm = root.find(q("fragilityModel"))
    if fm is None:
        raise HazardFileError(f"{path}: no fragilityModel element (NRML 0.5)")
    ls_el = fm.find(q("limitStates"))
    if ls_el is None or not (ls_el.text or "").split():
        raise HazardFileError(f"{path}: the fragilityModel has no limitStates")
    limit_states = tuple(ls_el.text.split())
    desc_el = fm.find(q("description"))
    out = {}
    for ff in fm.findall(q("fragilityFunction")):
        tax, fmt = ff.get("id", ""), ff.get("format")
        im_el = ff.find(q("imls"))
        if im_el is None or not im_el.get("imt"):
            raise HazardFileError(f"{path}: fragilityFunction {tax!r} has no imls element with an imt")
        ndl = im_el.get("noDamageLimit")
        ndl = None if ndl is None else _floats(ndl, "noDamageLimit", path)[0]
        funcs = {}
        try:
            if fmt == "continuous":
                lo, hi = (_floats(im_el.get(k), k, path)[0] if im_el.get(k) else math.nan
                          for k in ("minIML", "maxIML"))
                for p in ff.findall(q("params")):
                    funcs[p.get("ls")] = ContinuousFragility(float(p.get("mean")), float(p.get("stddev")), lo, hi,
                                                             ndl)
            elif fmt == "discrete":
                x = _floats(im_el.text, "imls", path)
                for p in ff.findall(q("poes")):
                    funcs[p.get("ls")] = DiscreteFragility(tuple(x), tuple(_floats(p.text, "poes", path)), ndl)
            else:
                raise HazardFileError(f"{path}: fragilityFunction {tax!r} has format {fmt!r} (continuous or discrete)")
        except (ValueError, TypeError) as exc:   # ParameterError is a ValueError
            raise HazardFileError(f"{path}: fragilityFunction {tax!r}: {exc}") from None
        missing = [ls for ls in limit_states if ls not in funcs]
        if missing:
            raise HazardFileError(f"{path}: fragilityFunction {tax!r} lacks limit state(s) {missing}")
        out[tax] = FragilityModel(im_el.get("imt"), limit_states, [funcs[ls] for ls in limit_states], taxonomy=tax,
                                  model_id=fm.get("id", "pycolfrag"),
                                  description=(desc_el.text or "").strip() if desc_el is not None else "",
                                  asset_category=fm.get("assetCategory", "buildings"),
                                  loss_category=fm.get("lossCategory", "structural"))
    if not out:
        raise HazardFileError(f"{path}: the fragilityModel has no fragilityFunction")
    return out


# --------------------------------------------------------------------------- command line

def _parser():
    p = argparse.ArgumentParser(prog="python -m pycolfrag.analysis.openquake",
                                description="OpenQuake interchange: export IM-based fragility as NRML 0.5, or "
                                            "convolve OpenQuake hazard curves with a fragility model "
                                            "(OpenQuake's classical damage). docs/risk.md")
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export", help="fit IM-based fragility curves to a results file and write NRML 0.5")
    e.add_argument("results", help="results file (run_grid.py)")
    e.add_argument("out", help="file to write (" + ", ".join(f"{w.name}: {w.suffix}" for w in WRITERS.values()) + ")")
    e.add_argument("--to", choices=sorted(WRITERS), default="nrml",
                   help="output format: " + "; ".join(f"{w.name}: {w.description}" for w in WRITERS.values()))
    d = sub.add_parser("damage", help="damage-state probabilities from a hazard-curve CSV and a fragility model")
    d.add_argument("hazard", help="OpenQuake hazard-curve CSV")
    d.add_argument("fragility", help="NRML fragility model (.xml) or a results file (.h5, fitted as by export)")
    d.add_argument("--risk-time", type=float, default=None, help="risk investigation time, years "
                   "(default: the hazard's investigation time)")
    d.add_argument("--steps-per-interval", type=int, default=1, help="OpenQuake's steps_per_interval")
    d.add_argument("--taxonomy", default=None, help="fragilityFunction id to use (default: the only one)")
    for a in (e, d):
        a.add_argument("--im", default=None, choices=sorted(_IMT),
                       help="IM of the fitted curves (export: default pga_g; damage with a results file: the "
                            "hazard's IMT)")
        a.add_argument("--period", type=float, default=None, help="period of sa_g, s")
        a.add_argument("--levels", choices=("u_top", "u_d"), default="u_top",
                       help="performance levels: Table III (u_top) or Table IV (u_d)")
        a.add_argument("--no-collapse", action="store_true", help="leave out the collapse limit state")
        a.add_argument("--format", choices=("continuous", "discrete"), default="continuous")
        a.add_argument("--iml-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                       help="minIML/maxIML (continuous) or range of the levels (discrete); default the data's")
        a.add_argument("--n-imls", type=int, default=20, help="levels of a discrete model")
        a.add_argument("--no-damage-limit", type=float, default=None, help="OpenQuake noDamageLimit")
    return p


def _model_from_args(results, args, im, period):
    return fragility_from_results(results, im, period_s=period,
                                  levels=U_TOP_LEVELS if args.levels == "u_top" else U_D_LEVELS,
                                  collapse=not args.no_collapse, fmt=args.format, n_imls=args.n_imls,
                                  iml_range=args.iml_range, no_damage_limit=args.no_damage_limit)


def main(argv=None) -> int:
    """Command-line entry point; exit code 0, or 2 with one line naming the bad input."""
    args = _parser().parse_args(argv)
    try:
        if args.cmd == "export":
            model = _model_from_args(args.results, args, args.im or "pga_g", args.period)
            write_fragility(model, args.out, args.to)
            print(f"{args.out}: {model.format} fragility on {model.imt}, limit states {', '.join(model.limit_states)}")
            for ls, f, fit in zip(model.limit_states, model.functions, model.fits):
                print(f"  {ls:24s} median {fit.median:.4g}  beta {fit.beta:.3f}  ({fit.n_exceed} of {fit.n} runs)")
            return 0
        hc = read_hazard_curves(args.hazard)
        if str(args.fragility).endswith((".h5", ".hdf5")):
            im, period = im_of_imt(hc.imt)
            model = _model_from_args(args.fragility, args, im, period)
        else:
            models = read_nrml(args.fragility)
            if args.taxonomy is None and len(models) > 1:
                raise ParameterError(f"{args.fragility} holds {sorted(models)}: choose one with --taxonomy")
            model = models[args.taxonomy] if args.taxonomy else next(iter(models.values()))
        if model.imt != hc.imt:
            raise ParameterError(f"the fragility is on {model.imt}, the hazard curves on {hc.imt}")
        tr = args.risk_time or hc.investigation_time
        res = classical_damage(model, hc.imls, hc.poes, hc.investigation_time, tr,
                               steps_per_interval=args.steps_per_interval)
        print(f"hazard {hc.path}: {hc.imt}, {len(hc.lon)} site(s), investigation time {hc.investigation_time:g} yr; "
              f"risk investigation time {tr:g} yr")
        for i in range(len(hc.lon)):
            print(f"site lon {hc.lon[i]:g} lat {hc.lat[i]:g}")
            for j, ls in enumerate(model.limit_states):
                print(f"  {ls:24s} rate {res['rates'][i, j]:.4e} /yr   P({tr:g} yr) {res['poes'][i, j]:.4e}")
            states = ("no_damage",) + model.limit_states
            print("  damage states: " + ", ".join(f"{s} {p:.4e}" for s, p in zip(states, res["damage"][i])))
        return 0
    except (ParameterError, HazardFileError, OSError) as exc:
        print(f"pycolfrag.analysis.openquake: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
