"""One place for each name: physical constants, and the intensity measures (IMs) and engineering
demand parameters (EDPs) of a sample row, with their units and plot labels.

A new IM or EDP is declared here once; :mod:`pycolfrag.sample` (which fills a row),
:mod:`pycolfrag.analysis.record_figures` and the record-suite analysis in :mod:`pycolfrag.analysis.fragility`
iterate over these tables instead of spelling the names again.

Constants
---------
``G`` = 9.81 m/s^2 is the package's gravity, read from the C library's default solver definition
(``cf_solver_def_default`` in ``csrc/solver.c``), so the solver, :mod:`pycolfrag.intensity`
(PGA and SA in g) and :func:`pycolfrag.ground_motion.read_at2` (an AT2 file's g to m/s^2) share
one value. Keeping 9.81 rather than the standard 9.80665 leaves every stored result unchanged: a
record read from AT2 and expressed back in g gives exactly the file's numbers (the factor
cancels), and the difference to 9.80665 (0.035 %) is far below the scatter of any fragility
estimate.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["G", "CM_PER_M", "Quantity", "IMS", "EDPS", "SCALAR_IMS", "SPECTRAL_IMS", "RECORD_FIELDS",
           "im", "edp", "label"]

def _solver_default_g() -> float:
    from ._ffi import ffi, lib
    d = ffi.new("cf_solver_def *")
    lib.cf_solver_def_default(d)
    return float(d.g)


#: Gravity, m/s^2: the C library's default (see the module docstring for why 9.81).
G = _solver_default_g()
#: Centimetres per metre (PGV in cm/s, PGD in cm).
CM_PER_M = 100.0


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
    """

    name: str
    unit: str
    label: str
    short: str
    spectral: bool = False
    description: str = ""


#: Intensity measures, in the order they are stored (keys of :func:`pycolfrag.intensity.measures`).
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

#: Engineering demand parameters (dimensionless, paper section "Fragility assessment").
EDPS: dict[str, Quantity] = {q.name: q for q in (
    Quantity("u_top", "-", "u_top = max top displacement / base diameter (-)", "u_top",
             description="peak top displacement / base diameter"),
    Quantity("u_d", "-", "u_d = residual drum dislocation / joint diameter (-)", "u_d",
             description="residual joint dislocation (average over the last 2 s) / joint diameter, max over "
                         "joints; NaN after a collapse"),
)}

#: Record metadata carried by a record-sample row (:func:`pycolfrag.sample.run_record_sample`).
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


def label(name: str, period_s: float | None = None) -> str:
    """Axis label of an IM, EDP or record field; a spectral IM at ``period_s`` reads ``SA(1 s) (g)``."""
    for table in (IMS, EDPS, RECORD_FIELDS):
        if name in table:
            q = table[name]
            if q.spectral and period_s is not None:
                return f"{q.short}({period_s:g} s) ({q.unit})"
            return q.label
    return name
