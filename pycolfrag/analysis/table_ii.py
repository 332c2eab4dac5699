"""The paper's Table II check: residual drum dislocation u_d computed without damping (the grid's
procedure) and with mass-proportional damping from the end of the strong motion (docs/records.md).

Psycharis, Fragiadakis & Stefanou, section "Numerical modelling": the residual dislocation of the
grid is the average of the last 2 s of an undamped response; Table II compares it, for five records,
with the value after "significant mass-proportional damping" switched on at the end of the strong
motion, and reads errors of 2 % to 18 % as acceptable "taking under consideration the sensitivity of
the response".

Rocking is chaotic: the record scaled by 1 +- 1e-4 (an imperceptible change) already moves u_d by as
much. So each record is run as an ensemble of such scalings and the table gives, per procedure, the
**median over the members that did not collapse, the 10-90 % range of those members, and how many
members collapsed** (a collapsed run has no residual state). Percentiles estimate a fixed property of
the ensemble's distribution; the min-max range would widen with the ensemble size. The error is
100 (no damping - damping) / damping, as in the paper, per member (paired: the same scaling), over
the members where neither run collapsed. The paper's own values (:data:`PAPER_TABLE_II`) are shown
beside, marked as the paper's.
"""
from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import finite_float, integer, positive_float
from pycolfrag.ground_motion.intensity import measures
from pycolfrag.ground_motion.record_suites import load_records
from pycolfrag.solver import run as _solver
from pycolfrag.structure.column import Column

__all__ = ["DEFAULT_TABLE_II_ALPHA", "DEFAULT_ENSEMBLE", "RANGE_PERCENTILES", "PAPER_TABLE_II",
           "strong_motion_end", "paper_row", "table_ii", "format_table_ii"]

#: Mass-proportional damping of the Table II check, 1/s (see :func:`table_ii`).
DEFAULT_TABLE_II_ALPHA = 5.0
#: Ensemble members per record (the record scaled by factors evenly spaced in 1 +- perturbation).
DEFAULT_ENSEMBLE = 5
#: Percentiles of the reported range over the ensemble's standing members.
RANGE_PERCENTILES = (10.0, 90.0)

#: The paper's Table II, as printed: u_d with mass damping, u_d without damping (both normalised by the
#: drum diameter), error % = 100 (no damping - damping) / damping. Keys are the paper's record names
#: ("ERZICAN" is its spelling of Erzincan; it does not say which Chi-Chi station it used).
PAPER_TABLE_II = {
    "GAZLI": (1.226e-2, 1.450e-2, 18.2),
    "SAN SALVADOR": (0.906e-2, 0.992e-2, 9.5),
    "ERZICAN": (0.651e-2, 0.614e-2, -5.6),
    "NORTHRIDGE (JFA)": (0.770e-2, 0.645e-2, -16.3),
    "CHICHI": (0.868e-2, 0.886e-2, 2.1),
}

# how a record's event (and station) name is matched to a row of the paper's table
_PAPER_NAMES = (("GAZLI", r"gazli", None), ("SAN SALVADOR", r"san\s*salvador", None),
                ("ERZICAN", r"erzi(n)?can", None), ("NORTHRIDGE (JFA)", r"northridge", r"jensen"),
                ("CHICHI", r"chi[-\s]*chi", None))


#: Rows of the paper's table whose station the paper does not name.
_STATION_NOT_GIVEN = ("CHICHI",)


def paper_row(event: str, station: str = "") -> str | None:
    """The key of :data:`PAPER_TABLE_II` for a record of this event (and station), or None."""
    for key, ev, st in _PAPER_NAMES:
        if re.search(ev, str(event), re.I) and (st is None or re.search(st, str(station), re.I)):
            return key
    return None


def strong_motion_end(acc, dt) -> float:
    """End of the strong motion, s: the time at which the Husid plot reaches 95 % of the Arias
    intensity (the end of the D5-95 interval, :func:`pycolfrag.ground_motion.intensity.measures` ``t95_s``)."""
    return float(measures(acc, dt, periods=(1.0,))["t95_s"])


def _summary(values) -> dict:
    """Median and RANGE_PERCENTILES of the finite values (NaN when none), and how many there are."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": math.nan, "low": math.nan, "high": math.nan, "n": 0}
    lo, hi = np.percentile(v, RANGE_PERCENTILES)
    return {"median": float(np.median(v)), "low": float(lo), "high": float(hi), "n": int(v.size)}


def table_ii(records, column=None, *, component="h1", damping_alpha=DEFAULT_TABLE_II_ALPHA,
             perturbation=1e-4, n_ensemble=DEFAULT_ENSEMBLE, solver_options=None) -> list[dict]:
    """Table II of the paper on ``records``: u_d without and with damping after the strong motion.

    For each record (one horizontal component, ``component``) and each ensemble member (the record
    scaled by one of ``n_ensemble`` factors evenly spaced in ``[1 - perturbation, 1 + perturbation]``,
    1 always among them), the column is run (i) without damping, u_d the average over the last
    ``residual_window_s`` (2 s) as in the grid, and (ii) with mass-proportional damping
    ``damping_alpha`` (1/s) from ``damping_start_s`` = the end of D5-95 (:func:`strong_motion_end`).

    Damping coefficient: mass-proportional damping ``-alpha m v`` (and ``-alpha I w``) gives a mode of
    circular frequency ``omega`` the damping ratio ``alpha / (2 omega)``; free rocking after the
    shaking is slow (period of the order of 1 s, omega about 2 pi rad/s), so ``alpha = 5 /s`` damps it
    at about 40 % of critical and its amplitude by ``exp(-alpha t / 2)`` = 0.08 per second: the free
    oscillations are gone within the run's 3 s tail, while the strong motion itself is undamped.

    Parameters
    ----------
    records : RecordSet, sequence of Record, or a source for :func:`pycolfrag.ground_motion.record_suites.load_records`
    column : Column, optional (default ``Column.parthenon()``)
    component : "h1" or "h2"
    damping_alpha : float, 1/s (>= 0)
    perturbation : float (>= 0); n_ensemble : int (>= 1; 1 runs the record unscaled only)
    solver_options : dict, extra :func:`pycolfrag.simulate` keywords (not ``damping_*``)

    Returns
    -------
    list of dict, one per record: ``record_id``, ``event``, ``station``, ``component``,
    ``t_strong_end_s``, ``damping_alpha``, ``scales``; per member ``u_d_damped_members``,
    ``u_d_undamped_members`` (NaN where that run collapsed) and ``error_pct_members``;
    ``damped``, ``undamped`` and ``error_pct``: dicts with ``median``, ``low``, ``high`` (the
    :data:`RANGE_PERCENTILES` of the standing members) and ``n`` (members they are over);
    ``n_collapsed_damped``, ``n_collapsed_undamped`` (of ``n_members``); ``paper``: the paper's
    ``(damped, undamped, error %)`` for this record (:func:`paper_row`) or None.
    """
    recs = load_records(records) if isinstance(records, (str, os.PathLike)) else records
    col = Column.parthenon() if column is None else column
    opts = dict(solver_options or {})
    for k in ("damping_alpha", "damping_start_s"):
        if k in opts:
            raise ParameterError(f"table_ii sets {k} itself; remove it from solver_options")
    if component not in ("h1", "h2"):
        raise ParameterError(f"component must be 'h1' or 'h2', got {component!r}")
    n_ens = integer(n_ensemble, "n_ensemble", 1)
    alpha = positive_float(damping_alpha, "damping_alpha", allow_zero=True)
    pert = positive_float(perturbation, "perturbation", allow_zero=True)
    scales = np.array([1.0]) if n_ens == 1 else 1.0 + finite_float(pert, "perturbation") * np.linspace(-1.0, 1.0, n_ens)
    if n_ens % 2 == 0:
        scales = np.sort(np.append(scales, 1.0))      # the unscaled record is always a member
    rows = []
    for rec in recs:
        acc = rec.component(component)
        t_end = strong_motion_end(acc, rec.dt)
        und, dam = [], []
        for f in scales:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                r0 = _solver.simulate(col, f * acc, rec.dt, **opts)
                r1 = _solver.simulate(col, f * acc, rec.dt, damping_alpha=alpha, damping_start_s=t_end, **opts)
            und.append(math.nan if r0.collapsed else r0.u_d)
            dam.append(math.nan if r1.collapsed else r1.u_d)
        und, dam = np.array(und), np.array(dam)
        with np.errstate(divide="ignore", invalid="ignore"):
            err = 100.0 * (und - dam) / dam
        event, station = rec.meta.get("event", ""), rec.meta.get("station", "")
        key = paper_row(event, station)
        rows.append({
            "record_id": rec.record_id, "event": event, "station": station, "component": component,
            "t_strong_end_s": t_end, "damping_alpha": alpha, "scales": scales.tolist(),
            "u_d_damped_members": dam.tolist(), "u_d_undamped_members": und.tolist(),
            "error_pct_members": err.tolist(),
            "damped": _summary(dam), "undamped": _summary(und), "error_pct": _summary(err),
            "n_members": int(scales.size), "n_collapsed_damped": int(np.isnan(dam).sum()),
            "n_collapsed_undamped": int(np.isnan(und).sum()),
            "paper_key": key, "paper": PAPER_TABLE_II.get(key),
        })
    return rows


def _cell(s: dict, scale: float, digits: int) -> str:
    """``median [p10, p90]`` of a summary, or what stands in for it."""
    if s["n"] == 0:
        return "all collapsed"
    med = f"{scale * s['median']:.{digits}f}"
    if s["n"] == 1:
        return f"{med} (1 member)"
    return f"{med} [{scale * s['low']:.{digits}f}, {scale * s['high']:.{digits}f}]"


def format_table_ii(rows: list[dict]) -> str:
    """Table II as a Markdown table: per procedure the ensemble median of u_d (x 1e-2) with the
    10-90 % range of the standing members and the collapse count, the error, and the paper's values."""
    lo, hi = RANGE_PERCENTILES
    head = ["record", "event", "comp.", "mass damping", "collapsed", "no damping", "collapsed", "error %",
            "paper: mass damping", "paper: no damping", "paper: error %"]
    L = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        p = r.get("paper")
        star = "*" if r.get("paper_key") in _STATION_NOT_GIVEN else ""
        paper = (["-", "-", "-"] if p is None else [f"{100 * p[0]:.3f}{star}", f"{100 * p[1]:.3f}{star}",
                                                      f"{p[2]:.1f}{star}"])
        n = r["n_members"]
        L.append("| " + " | ".join([
            str(r["record_id"]), f"{r['event']}" + (f" ({r['station']})" if r.get("station") else ""),
            r["component"].upper(),
            _cell(r["damped"], 100.0, 3), f"{r['n_collapsed_damped']} of {n}",
            _cell(r["undamped"], 100.0, 3), f"{r['n_collapsed_undamped']} of {n}",
            _cell(r["error_pct"], 1.0, 1) if r["error_pct"]["n"] else "-",
            *paper]) + " |")
    L += ["", f"u_d x 1e-2: median over the ensemble members that did not collapse [{lo:g}-{hi:g} % range of "
          "those members]; collapsed: members of the ensemble (the record scaled by 1 +- the perturbation) whose "
          "run collapsed; error % = 100 (no damping - damping) / damping per member, over the members where "
          "neither run collapsed. The last three columns are the paper's Table II as printed, for the record of "
          "the same event (and station where the paper names one); * the paper does not say which station it "
          "used, so its values stand beside every record of that event."]
    return "\n".join(L)
