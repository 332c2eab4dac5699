"""A column's foundation tilt (as-built geometry; docs/sequences.md, "As-built geometry: a tilted
foundation"): its check against the static thresholds (``pycolfrag/solver/run.py`` hands the checked
tilt to ``cf_solver_def.foundation_tilt_rad`` and ``foundation_tilt_azimuth_rad``).

The foundation's surface descends by ``tilt_deg`` towards the horizontal direction at
``azimuth_deg`` (from +x towards +y, in the column's axes). The solver works in the foundation's
frame: gravity there has a downhill pull ``g sin(tilt)`` along the surface and ``g cos(tilt)``
normal to it, and the ground record (world axes) is rotated into that frame.

The static threshold is the smallest of, over every joint j (under block j):

* overturning of everything above the joint: ``atan(b_j / h_j)``, ``b_j`` the support distance of
  the joint's face towards downhill (the smaller of the two faces' supports, from the axis; the
  face of the block above for the base joint) and ``h_j`` the height of the centre of mass of the
  blocks above (block j included) over the joint;
* sliding of the joint: ``atan(mu_j)``.

A tilt at or beyond it is refused (the column would not stand): there is nothing to simulate.
"""
from __future__ import annotations

import math

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import real


def _support(seg, top: bool, azimuth_rad: float) -> float:
    """The support distance (m) of a segment's bottom (or top) polygon towards azimuth."""
    if seg.aspect != 1.0:   # a scaled section (pycolfrag/structure/segment.py)
        return max(x * math.cos(azimuth_rad) + y * math.sin(azimuth_rad) for x, y in seg.vertices(top))
    r = seg.r_top if top else seg.r_bottom
    return max(r * math.cos(seg.phase_rad + 2.0 * math.pi * k / seg.n_sides - azimuth_rad)
               for k in range(seg.n_sides))


def thresholds(col, azimuth_deg: float = 0.0) -> list[tuple[str, float]]:
    """Every static threshold (what, angle in degrees) of the column for a tilt towards
    ``azimuth_deg``: per joint its overturning (stack above) and its sliding (friction)."""
    az = math.radians(azimuth_deg)
    out = []
    z_joint = col.joint_heights
    masses = col.block_masses
    for j in range(col.n_blocks):
        b = _support(col.blocks[j].bottom, False, az)
        if j > 0:
            b = min(b, _support(col.blocks[j - 1].top, True, az))
        m = sum(masses[j:])
        zc = sum(mk * (z_joint[k] + col.blocks[k].centroid_height) for k, mk in enumerate(masses) if k >= j) / m
        out.append((f"overturning of the blocks above joint {j} (b = {b:.4g} m, h = {zc - z_joint[j]:.4g} m)",
                    math.degrees(math.atan2(b, zc - z_joint[j]))))
        out.append((f"sliding of joint {j} (mu = {col.joint(j).mu:.4g})", math.degrees(math.atan(col.joint(j).mu))))
    return out


def static_threshold(col, azimuth_deg: float = 0.0) -> tuple[str, float]:
    """The smallest static threshold (what, degrees) of the column for a tilt towards azimuth."""
    return min(thresholds(col, azimuth_deg), key=lambda t: t[1])


def check(col, tilt_deg, azimuth_deg) -> tuple[float, float]:
    """The tilt and azimuth (degrees) as floats, or ParameterError: a tilt that is negative, not
    finite, or at or beyond the column's static threshold (named with its value)."""
    t = real(tilt_deg, "foundation_tilt_deg")
    a = real(azimuth_deg, "foundation_tilt_azimuth_deg")
    if not math.isfinite(a):
        raise ParameterError(f"foundation_tilt_azimuth_deg must be finite, got {azimuth_deg!r}")
    if not (math.isfinite(t) and t >= 0.0):
        raise ParameterError(f"foundation_tilt_deg must be finite and >= 0 (the direction is "
                             f"foundation_tilt_azimuth_deg), got {tilt_deg!r}")
    if t > 0.0:
        what, limit = static_threshold(col, a)
        if t >= limit:
            raise ParameterError(f"foundation_tilt_deg = {t:g} is at or beyond the column's static threshold "
                                 f"{limit:.4f} deg ({what}, towards azimuth {a:g} deg): the column would not "
                                 "stand on it")
    return t, a


def kw(col) -> dict:
    """The column's tilt as Column's keyword arguments (and the column file's keys)."""
    return {"foundation_tilt_deg": col.foundation_tilt_deg, "foundation_tilt_azimuth_deg": col.foundation_tilt_azimuth_deg}


def file_kw(d: dict) -> dict:
    """The tilt keys of a column file's mapping d as Column's keyword arguments (absent: level)."""
    return {"foundation_tilt_deg": d.get("foundation_tilt_deg", 0.0),
            "foundation_tilt_azimuth_deg": d.get("foundation_tilt_azimuth_deg", 0.0)}


def tilted(col, d: dict):
    """The column col (built from a column file's mapping d) with d's tilt keys."""
    if "foundation_tilt_deg" not in d and "foundation_tilt_azimuth_deg" not in d:
        return col
    return type(col)(col.blocks, density=col.density, joints=col.joints, name=col.name, connectors=col.connectors,
                     **file_kw(d))
