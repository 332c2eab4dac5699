"""The parts of the results report (:mod:`pycolfrag.analysis.report`) a new reader needs to read it: the
EDPs' definitions, the column (or scene) as tables, numbers to sensible significant digits, the marks of
intervals that exclude what was observed, and a caption under every figure.

* :data:`DEFINITIONS`: u_top and u_d as the paper defines them (peak, residual over the last 2 s), the IMs' units, collapse.
* :func:`model_lines`: the results file's ``column`` attribute (a column's or a colonnade's
  ``to_dict()``) as a summary and a table of blocks (heights, diameters), density and joint
  properties, dowels and epistyles; a description it cannot read is listed key by key, never cut.
* :func:`sig`: a number to 3 significant digits in plain notation (``11286.634`` -> ``11300``); the
  column's geometry to 4 (10.08 m).
* :data:`CAPTIONS`: what each figure of :data:`pycolfrag.analysis.figures.FIGURES` shows, with units.
"""
from __future__ import annotations

import json
import math

import numpy as np

__all__ = ["DEFINITIONS", "CAPTIONS", "OUTSIDE_MARK", "OUTSIDE_NOTE", "model_lines", "sig", "solver_lines"]

DEFINITIONS = [
    "## Quantities", "",
    "- **u_top** (-): the largest horizontal displacement of the capital relative to the base over the "
    "whole response, divided by the base diameter (the lower diameter of drum 1). Performance levels "
    "(Table III): 0.15, 0.35, 1.0.",
    "- **u_d** (-): the residual dislocation of each joint (horizontal distance between the centre of the "
    "upper drum's bottom face and the centre of the lower drum's top face, averaged over the last 2 s of "
    "the response), divided by the diameter at that joint; the largest over the joints. NaN for a "
    "collapsed run (no residual state). Performance levels (Table IV): 0.005, 0.01, 0.02.",
    "- **collapse**: a drum (or the column) fell, locally or as a whole; Eq. (3) is the share of collapsed "
    "runs, and Eq. (4) counts a collapse as exceeding every level.",
    "- Intensity measures: PGA and SA in g, PGV and SV in cm/s; magnitude Mw, distance R in km.",
]

#: Appended to an Eq. (4) cell whose 90 % interval does not meet the binomial interval of its empirical ratio.
OUTSIDE_MARK = " \u2020"
OUTSIDE_NOTE = ("\u2020 The 90 % interval of Eq. (4) excludes the empirical ratio, beyond the ratio's own sampling "
                "error (its exact 90 % binomial interval does not meet the Eq. (4) interval): the lognormal model "
                "of the standing runs' EDP does not fit that scenario at that level; read the empirical ratio "
                "there.")


def sig(x, n: int = 3) -> str:
    """``x`` to ``n`` significant digits in plain notation between 1e-3 and 1e6, else ``1.23e-05``;
    ``n/a`` for None or NaN."""
    if x is None or not np.isfinite(x):
        return "n/a"
    x = float(x)
    if x == 0:
        return "0"
    e = math.floor(math.log10(abs(x)))
    if not -3 <= e < 6:
        return f"{x:.{n - 1}e}"
    decimals = n - 1 - e
    r = round(x, decimals)
    return f"{r:.{max(decimals, 0)}f}"


def sig_ci(v, ci=None, n: int = 3) -> str:
    """``11300 [10500, 12400]``: :func:`sig` of a value and its interval; ``n/a`` for NaN."""
    if v is None or not np.isfinite(v):
        return "n/a"
    s = sig(v, n)
    if ci is not None and np.all(np.isfinite(ci)):
        s += f" [{sig(ci[0], n)}, {sig(ci[1], n)}]"
    return s


def _mm(x_m) -> str:
    return sig(1000.0 * x_m)


def _column_lines(col) -> list:
    j = col.joints
    out = [f"- column: {col.name}; {col.n_blocks} blocks, height {sig(col.height, 4)} m, base diameter "
           f"{sig(col.base_diameter, 4)} m, mass {sig(col.mass / 1000.0)} t, density {sig(col.density)} kg/m\u00b3",
           f"- joints: kn = {j.kn:.3g} Pa/m, ks = {j.ks:.3g} Pa/m, friction angle {j.friction_deg:g}\u00b0, "
           f"cohesion {j.cohesion:g} Pa, tensile strength {j.tensile_strength:g} Pa"]
    for c in col.connectors:
        law = c.law
        out.append(f"- dowels: {c.count} per joint at radius {sig(c.radius)} m, joints {c.joints}; law "
                   f"`{law.name or law.kind}` ({law.kind}): shear stiffness {law.k_shear:.3g} N/m, yield "
                   f"{sig(law.f_yield / 1000.0)} kN, breaks at {_mm(law.u_ultimate)} mm")
    out += ["", "| block | name | height (m) | bottom diameter (m) | top diameter (m) | sides |",
            "|---:|---|---:|---:|---:|---:|"]
    for i, b in enumerate(col.blocks, start=1):
        segs = b.segments
        out.append(f"| {i} | {b.name} | {sig(sum(s.height for s in segs), 4)} | {sig(2 * segs[0].r_bottom, 4)} | "
                   f"{sig(2 * segs[-1].r_top, 4)} | {segs[0].n_sides} |")
    return out


def _listing(d: dict) -> list:
    """A description the package cannot read as a model, key by key (nested values as compact JSON)."""
    return [f"- `{k}`: `{json.dumps(v, sort_keys=True) if isinstance(v, (dict, list)) else v}`"
            for k, v in sorted(d.items())]


def _json_object(raw) -> dict | None:
    """An attribute's JSON object, or None when it is not one (then it is printed as it is)."""
    try:
        d = json.loads(raw)
    except (TypeError, ValueError):
        return None
    return d if isinstance(d, dict) else None


def model_lines(raw) -> list:
    """The ``column`` attribute of a results file as Markdown lines (see the module docstring)."""
    from pycolfrag.core.errors import PycolfragError
    from pycolfrag.structure.kinds import kind_of, model_from_dict
    from pycolfrag.structure.scene import Colonnade
    d = _json_object(raw)
    if d is None:
        return [f"- column: `{raw}`"]
    try:
        model = model_from_dict(d)
    except (PycolfragError, KeyError, TypeError, ValueError) as exc:
        return [f"The column description could not be read as a model ({exc}); its keys:", ""] + _listing(d)
    kind = kind_of(model).name
    if kind == "column":
        return _column_lines(model)
    if not isinstance(model, Colonnade):   # a kind of its own: what every structure has
        return [f"- {kind}: {model.name}; {model.n_blocks} blocks, {model.n_joints} joints"]
    e = model.epistyle
    head = [f"- scene: {model.name}; {model.n_columns} columns, axes {sig(model.spacing, 4)} m apart"
            + ("" if e is None else f"; an epistyle {sig(e.height, 4)} m high over every span (its mass over the "
               f"columns', gamma = {sig(model.gamma)})")]
    return head + _column_lines(model.column)


def solver_lines(raw) -> list:
    """The ``solver`` attribute (the solver's options) as one line of ``key = value`` pairs."""
    d = _json_object(raw)
    if d is None:
        return [f"- solver: `{raw}`"]
    return ["- solver options: " + ", ".join(f"{k} = `{v}`" for k, v in sorted(d.items()))]


CAPTIONS = {
    "fig07_ud_vs_utop": "Fig. 7: residual dislocation u_d against peak top displacement u_top (both "
    "dimensionless, log axes), one point per standing run; dotted lines: the performance levels.",
    "fig08_mean_edp_collapse": "Fig. 8: mean u_top and mean u_d of the standing runs (dimensionless) and the "
    "collapse probability, Eq. (3), over magnitude Mw and distance R (km); grey wireframes: 90 % bootstrap "
    "interval. The maps below give the values.",
    "fig08m_mean_edp_collapse_map": "Fig. 8 as maps: the same three quantities as filled contours over R (km) "
    "and Mw, each with its colour bar; dots: the simulated scenarios.",
    "fig09_pulse_amplitudes": "Fig. 9: mean sampled pulse velocity amplitude Vp (cm/s) and pulse acceleration "
    "amplitude Ap (g) against Mw, one line per distance R.",
    "fig11_pulse_period_collapse": "Fig. 11: (a) u_top (-) against the pulse period Tp (s); (b, c) PGA and Ap "
    "(g) against the pulse frequency fp (Hz) for Mw >= 6.5, collapsed runs as crosses.",
    "fig12_fragility_utop": "Fig. 12: probability that u_top exceeds 0.15, 0.35 and 1.0 (Eq. (4), -) over Mw "
    "and R (km), with the 90 % bootstrap interval as grey wireframes.",
    "fig12m_fragility_utop_map": "Fig. 12 as maps: the three probabilities as filled contours over R (km) and "
    "Mw on one colour scale (0-1, one colour bar); dots: the simulated scenarios.",
    "fig13_fragility_ud": "Fig. 13: probability that u_d exceeds 0.005, 0.01 and 0.02 (Eq. (4), -) over Mw and "
    "R (km), with the 90 % bootstrap interval as grey wireframes.",
    "fig13m_fragility_ud_map": "Fig. 13 as maps: the three probabilities as filled contours over R (km) and Mw "
    "on one colour scale (0-1, one colour bar); dots: the simulated scenarios.",
    "fig14_pga_vs_edp": "Fig. 14: PGA (g) against u_top and u_d (-, log axes) of the standing runs; dotted: "
    "the performance levels.",
    "fig15_pgv_vs_edp": "Fig. 15: PGV (cm/s) against u_top and u_d (-, log axes) of the standing runs; dotted: "
    "the performance levels.",
    "fig16_im_fragility": "Fig. 16: probability of exceeding each level against PGA (g) and PGV (cm/s): points, "
    "Eq. (4) in 12 equal-width IM stripes with 90 % bootstrap bars; lines, maximum-likelihood lognormal "
    "curves with their 90 % bands. Red rings mark stripes the fitted curve misses beyond their binomial "
    "interval (listed in the IM table above).",
    "fig16s_spectral_fragility": "Fig. 16 (spectral): as Fig. 16 against SA(T) (g) and SV(T) (cm/s) at the "
    "stored period nearest 1 s.",
}
