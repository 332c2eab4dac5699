"""One place for each name: physical constants, the intensity measures (IMs) and engineering
demand parameters (EDPs) of a sample row with their units and plot labels, and the type in which the
ground-motion models declare their parameters.

Pure data: this module imports nothing of the package's C side, so that statistics and readers of a
results file (which take their field names from here) never load the C library.

A new IM or EDP is declared here once; :mod:`pycolfrag.solver.sample` (which fills a row),
:mod:`pycolfrag.results` (the ``/samples`` layout), :mod:`pycolfrag.analysis.figures`,
:mod:`pycolfrag.analysis.record_figures`, :mod:`pycolfrag.analysis.report` and the record-suite analysis in
:mod:`pycolfrag.analysis.fragility` iterate over these tables instead of spelling the names again.
A ground-motion model declares its parameters as :class:`Parameter` rows in its own module
(``PARAMETERS``), listed once in :mod:`pycolfrag.ground_motion.registry`.

Constants
---------
``G`` = 9.81 m/s^2 is the package's gravity. Its one text is ``pycolfrag/data/constants.json``:
this module reads it there, and every build of the C library compiles the solver's default
(``cf_solver_def.g``, ``cf_solver_def_default``) from the same file (``pycolfrag/_build.py`` and
``csrc/flags.mk`` pass it as ``CF_G_M_S2``), so the solver, :mod:`pycolfrag.ground_motion.intensity` (PGA and SA in
g) and :func:`pycolfrag.ground_motion.read_at2` (an AT2 file's g to m/s^2) share one value without
this module loading C to ask for it. Keeping 9.81 rather than the standard 9.80665 leaves every
stored result unchanged: a record read from AT2 and expressed back in g gives exactly the file's
numbers (the factor cancels), and the difference to 9.80665 (0.035 %) is far below the scatter of
any fragility estimate.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources

from pycolfrag.core.errors import ModelRangeError
from pycolfrag.core.validate import finite_float

__all__ = ["G", "CM_PER_M", "Quantity", "IMS", "EDPS", "SCALAR_IMS", "SPECTRAL_IMS", "RECORD_FIELDS",
           "Parameter", "im", "edp", "edps_of", "label"]

#: Gravity, m/s^2, from ``pycolfrag/data/constants.json`` (see the module docstring for why 9.81).
G: float = float(json.loads(resources.files("pycolfrag").joinpath("data/constants.json").read_text("utf-8"))
                 ["g_m_s2"])
#: Centimetres per metre (PGV in cm/s, PGD in cm).
CM_PER_M = 100.0


@dataclass(frozen=True)
class Parameter:
    """One parameter of a ground-motion model, declared once in the model's module (``PARAMETERS``).

    Attributes
    ----------
    name : str
        The symbol the model's paper uses (``"Vp"``, ``"fp"``, ``"Mw"``).
    unit : str
        Unit as printed (``"cm/s"``, ``"-"``; ``""`` for a magnitude).
    range : (float, float)
        The values the model accepts, bounds included (``math.inf`` for none); the module's range
        check reads it (:meth:`check`).
    description : str
        What it is, without the unit (the ``/samples`` description is ``"<description>, <unit>"``).
    meta_key : str or None
        Its key in :attr:`pycolfrag.ground_motion.Record.meta`, when records carry it.
    row_field : str or None
        Its field in a sample row and in ``/samples``, when rows carry it.
    low_open : bool
        The lower bound itself is refused (a value must be > it).
    """

    name: str
    unit: str
    range: tuple[float, float]
    description: str
    meta_key: str | None = None
    row_field: str | None = None
    low_open: bool = False

    @property
    def field_description(self) -> str:
        """``"<description>, <unit>"`` (the description alone without a unit): the ``description``
        attribute of its ``/samples`` dataset."""
        return f"{self.description}, {self.unit}" if self.unit else self.description

    def range_text(self) -> str:
        """The accepted range as a reader writes it: ``> 0``, ``[5, 8]``, ``any``."""
        lo, hi = self.range
        if math.isinf(lo) and math.isinf(hi):
            return "any"
        if math.isinf(hi):
            return f"{'>' if self.low_open else '>='} {lo:g}"
        if math.isinf(lo):
            return f"<= {hi:g}"
        return f"{'(' if self.low_open else '['}{lo:g}, {hi:g}]"

    def check(self, value, what: str | None = None, *, error=ModelRangeError, owner: str = "the model's") -> float:
        """``value`` as a float inside :attr:`range`, else ``error`` naming ``what`` (default the
        meta key or the name) and the value; non-numbers and NaN/inf raise ParameterError first."""
        what = what or self.meta_key or self.name
        v = finite_float(value, what)
        lo, hi = self.range
        below = v <= lo if self.low_open else v < lo
        if below or v > hi:
            if math.isinf(lo) or math.isinf(hi):   # both infinite never lands here: any value is inside
                raise error(f"{what} must be {self.range_text()}, got {value!r}")
            unit = f" {self.unit}" if self.unit not in ("", "-") else ""
            raise error(f"{what} = {value!r} is outside {owner} range {self.range}{unit}")
        return v


@dataclass(frozen=True)
class Quantity:
    """One named quantity of a sample row.

    Attributes
    ----------
    name : str
        Key in the row dict and in ``/samples`` (or ``/spectra`` when ``spectral``).
    unit : str
        Unit as printed (``"g"``, ``"cm/s"``, ``"-"``).
    label : str
        Axis label with the unit.
    short : str
        Short symbol (``"PGA"``, ``"SA(T)"``).
    spectral : bool
        One value per spectral period (``/spectra``) instead of a scalar.
    description : str
    response : str or None
        EDPs only: the attribute of :class:`pycolfrag.solver.run.Response` that holds the value (default
        ``name``). A row (:mod:`pycolfrag.solver.sample`), ``/samples`` (:mod:`pycolfrag.results`), the
        figures' labels and the report's statistics table take every EDP from :data:`EDPS`.
    """

    name: str
    unit: str
    label: str
    short: str
    spectral: bool = False
    description: str = ""
    response: str | None = None


#: Intensity measures, in the order they are stored (keys of :func:`pycolfrag.ground_motion.intensity.measures`).
IMS: dict[str, Quantity] = {q.name: q for q in (
    Quantity("pga_g", "g", "PGA (g)", "PGA", description="peak ground acceleration"),
    Quantity("pgv_cm_s", "cm/s", "PGV (cm/s)", "PGV", description="peak ground velocity"),
    Quantity("pgd_cm", "cm", "PGD (cm)", "PGD", description="peak ground displacement"),
    Quantity("arias_m_s", "m/s", "Arias intensity (m/s)", "Ia", description="Arias intensity"),
    Quantity("d5_95_s", "s", "D5-95 (s)", "D5-95", description="significant duration 5-95 % of Arias"),
    Quantity("sa_g", "g", "SA(T) (g)", "SA", spectral=True,
             description="pseudo-spectral acceleration, omega^2 SD"),
    Quantity("sv_cm_s", "cm/s", "SV(T) (cm/s)", "SV", spectral=True,
             description="relative spectral velocity, max |x'|"),
)}
SCALAR_IMS = tuple(k for k, q in IMS.items() if not q.spectral)
SPECTRAL_IMS = tuple(k for k, q in IMS.items() if q.spectral)

#: Engineering demand parameters: the paper's two (dimensionless, section "Fragility assessment"; a
#: colonnade's are the largest over its columns), then those of connectors and epistyles (NaN in a
#: run without dowels or without epistyles: the quantity does not exist there).
EDPS: dict[str, Quantity] = {q.name: q for q in (
    Quantity("u_top", "-", "u_top = max top displacement / base diameter (-)", "u_top",
             description="peak top displacement / base diameter"),
    Quantity("u_d", "-", "u_d = residual drum dislocation / joint diameter (-)", "u_d",
             description="residual joint dislocation (average over the last 2 s) / joint diameter, max over "
                         "joints; NaN after a collapse"),
    Quantity("dowel_shear_kn", "kN", "peak dowel shear force (kN)", "F_dowel",
             description="peak shear force of a dowel, max over the dowels; NaN without dowels"),
    Quantity("dowel_slip_mm", "mm", "peak dowel shear displacement (mm)", "u_dowel",
             description="peak shear displacement of a dowel across its joint, max over the dowels, frozen "
                         "at a dowel's break; NaN without dowels"),
    Quantity("dowels_yielded", "-", "dowels yielded (-)", "n_yielded",
             description="number of dowels that yielded (a plastic shear displacement) in the run, broken ones "
                         "included; NaN without dowels"),
    Quantity("dowels_broken", "-", "dowels broken (-)", "n_broken",
             description="number of dowels broken in the run; NaN without dowels"),
    Quantity("epistyle_slip_mm", "mm", "peak epistyle slip on a capital (mm)", "s_epi",
             description="peak horizontal slip of an epistyle at its bearings, max over the epistyles; NaN "
                         "without epistyles"),
    Quantity("epistyle_unseat", "-", "epistyle unseating ratio = slip / half seat (-)", "unseat",
             description="peak slip of an epistyle / half its shortest seat, max over the epistyles (1: half a "
                         "seat overhangs); NaN without epistyles"),
)}

#: Record metadata carried by a record-sample row (:func:`pycolfrag.solver.sample.run_record_sample`).
RECORD_FIELDS: dict[str, Quantity] = {q.name: q for q in (
    Quantity("record_id", "", "record", "id", description="record identifier (PEER: RSN)"),
    Quantity("event", "", "event", "event", description="earthquake name"),
    Quantity("station", "", "station", "station", description="recording station"),
    Quantity("component", "", "component", "comp.", description="h1, h2, both or rotated angle"),
    Quantity("mw", "-", "Mw (-)", "Mw", description="moment magnitude"),
    Quantity("rrup_km", "km", "Rrup (km)", "Rrup", description="closest distance to the rupture plane"),
    Quantity("scale", "-", "scale factor (-)", "scale", description="amplitude factor applied to the record"),
)}


def im(name: str) -> Quantity:
    """The IM called ``name`` (KeyError naming the known ones)."""
    try:
        return IMS[name]
    except KeyError:
        raise KeyError(f"unknown IM {name!r}; known: {', '.join(IMS)}") from None


def edp(name: str) -> Quantity:
    """The EDP called ``name`` (KeyError naming the known ones)."""
    try:
        return EDPS[name]
    except KeyError:
        raise KeyError(f"unknown EDP {name!r}; known: {', '.join(EDPS)}") from None


def edps_of(table) -> tuple:
    """The EDPs a results table (a mapping of field -> array, e.g. ``/samples``) has values of, in
    :data:`EDPS`' order: each declared EDP the table holds with at least one non-NaN value (an older
    file lacks newer EDPs; a run without dowels or epistyles has theirs NaN throughout)."""
    out = []
    for name in EDPS:
        if name in table:
            values = [float(v) for v in table[name]]
            if any(v == v for v in values):   # v == v: not NaN
                out.append(name)
    return tuple(out)


def label(name: str, period_s: float | None = None) -> str:
    """Axis label of an IM, EDP or record field; a spectral IM at ``period_s`` reads ``SA(1 s) (g)``."""
    for table in (IMS, EDPS, RECORD_FIELDS):
        if name in table:
            q = table[name]
            if q.spectral and period_s is not None:
                return f"{q.short}({period_s:g} s) ({q.unit})"
            return q.label
    return name
