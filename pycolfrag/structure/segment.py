"""A segment of a block: a frustum whose section is a regular polygon, or one scaled along y.

A :class:`Segment`'s section is the regular ``n_sides``-gon of circumradius r (r_bottom at its
bottom, r_top at its top, linear between) whose first vertex lies at ``phase_rad`` from +x, scaled
by ``aspect`` along the block's y axis (1: the regular polygon, a drum). :meth:`Segment.rectangle`
builds the rectangular block of a wall this way: the square of side ``width`` (across x) at phase
45 degrees, scaled by ``depth / width`` along y. The solver's mass properties (csrc/geometry.h)
are exact for either; the file keys are in ``docs/column_format.md``.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import lib as _lib
from pycolfrag.core.validate import positive_float, real

#: Most polygon sides the solver handles (``CF_SOLVER_MAX_SIDES`` in csrc/solver.h).
MAX_SIDES = int(_lib.CF_SOLVER_MAX_SIDES)

__all__ = ["Segment", "MAX_SIDES"]

_SEGMENT_KEYS = ("height", "diameter_bottom", "diameter_top", "n_sides", "phase_deg", "aspect", "width", "depth")


def _check_keys(d, known, where: str) -> dict:
    """``d`` must be a mapping whose keys are all in ``known`` (a typo must not fall back to a default)."""
    if not isinstance(d, dict):
        raise ParameterError(f"{where} must be a mapping (JSON object / TOML table), got {type(d).__name__}: {d!r}")
    unknown = set(d) - set(known)
    if unknown:
        raise ParameterError(f"{where}: unknown keys {sorted(unknown)} (known: {sorted(known)})")
    return d


def _n_sides(value, where: str) -> int:
    """An integral number of polygon sides (10 and 10.0 pass; 3.7 and "ten" do not)."""
    msg = f"{where + ': ' if where else ''}n_sides must be an integer in [3, {MAX_SIDES}], got {value!r}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(msg)
    v = float(value)
    if not math.isfinite(v) or v != int(v) or not 3 <= v <= MAX_SIDES:
        raise ParameterError(msg)
    return int(v)


def inside_polygon(x: float, y: float, r: float, n: int, phase: float, aspect: float = 1.0) -> bool:
    """Is (x, y) inside the regular n-gon of circumradius r whose first vertex is at angle phase,
    scaled by ``aspect`` along y?"""
    apo = r * math.cos(math.pi / n)
    y = y / aspect
    return all(x * math.cos(phase + math.pi / n + 2.0 * math.pi * k / n)
               + y * math.sin(phase + math.pi / n + 2.0 * math.pi * k / n) <= apo * (1.0 + 1e-12) for k in range(n))


@dataclass(frozen=True)
class Segment:
    """A frustum (prism when ``r_bottom == r_top``) whose section is a regular ``n_sides``-gon scaled by
    ``aspect`` along y.

    Parameters
    ----------
    height : float
        Height of the segment, m (> 0).
    r_bottom, r_top : float
        Circumradius of the bottom and top polygon before the scaling, m (> 0).
    n_sides : int
        Number of polygon sides (>= 3).
    phase_rad : float
        Angle of the first vertex from +x, rad. Default 0 (a vertex points along x).
    aspect : float
        The section's scale along the block's y axis (> 0). Default 1: the regular polygon.
        :meth:`rectangle` makes a rectangular block.
    """

    height: float
    r_bottom: float
    r_top: float
    n_sides: int = 10
    phase_rad: float = 0.0
    aspect: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "height", positive_float(self.height, "segment height (m)"))
        object.__setattr__(self, "r_bottom", positive_float(self.r_bottom, "segment bottom radius (m)"))
        object.__setattr__(self, "r_top", positive_float(self.r_top, "segment top radius (m)"))
        object.__setattr__(self, "n_sides", _n_sides(self.n_sides, "segment"))
        ph = real(self.phase_rad, "phase_rad")
        if not math.isfinite(ph):
            raise ParameterError(f"phase_rad must be finite, got {self.phase_rad!r}")
        object.__setattr__(self, "phase_rad", ph)
        object.__setattr__(self, "aspect", positive_float(self.aspect, "segment aspect (the section's scale along y)"))

    @classmethod
    def rectangle(cls, height: float, width: float, depth: float) -> "Segment":
        """A rectangular prism: ``width`` (m) along x, ``depth`` (m) along y, ``height`` (m)."""
        w = positive_float(width, "rectangle width (m)")
        d = positive_float(depth, "rectangle depth (m)")
        r = w / math.sqrt(2.0)
        return cls(height, r, r, 4, math.pi / 4.0, d / w)

    @property
    def _k(self) -> float:
        """Area of the section of unit circumradius: (n/2) sin(2 pi / n) aspect."""
        return 0.5 * self.n_sides * math.sin(2.0 * math.pi / self.n_sides) * self.aspect

    @property
    def volume(self) -> float:
        """Exact volume, m^3: k h (r0^2 + r0 r1 + r1^2) / 3."""
        r0, r1 = self.r_bottom, self.r_top
        return self._k * self.height * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0

    @property
    def centroid_height(self) -> float:
        """Height of the centroid above the segment's bottom face, m (exact for linear taper)."""
        r0, r1, h = self.r_bottom, self.r_top, self.height
        # integral of z * (r0 + (r1 - r0) z/h)^2 dz over [0, h] divided by the volume integral
        num = h * h * (r0 * r0 / 2.0 + 2.0 * r0 * (r1 - r0) / 3.0 + (r1 - r0) ** 2 / 4.0)
        den = h * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0
        return num / den

    def vertices(self, top: bool = False) -> list[tuple[float, float]]:
        """The bottom (or top) section's vertices (x, y), m, counter-clockwise."""
        r = self.r_top if top else self.r_bottom
        return [(r * math.cos(self.phase_rad + 2.0 * math.pi * k / self.n_sides),
                 self.aspect * r * math.sin(self.phase_rad + 2.0 * math.pi * k / self.n_sides))
                for k in range(self.n_sides)]

    def circumradius(self, top: bool = False) -> float:
        """The largest distance of the bottom (or top) section's vertices from the axis, m."""
        if self.aspect == 1.0:
            return self.r_top if top else self.r_bottom
        return max(math.hypot(x, y) for x, y in self.vertices(top))

    def inside(self, x: float, y: float, top: bool = False) -> bool:
        """Is (x, y) (m, from the axis) inside the bottom (or top) section?"""
        return inside_polygon(x, y, self.r_top if top else self.r_bottom, self.n_sides, self.phase_rad, self.aspect)

    def to_dict(self) -> dict:
        d = {
            "height": self.height,
            "diameter_bottom": 2.0 * self.r_bottom,
            "diameter_top": 2.0 * self.r_top,
            "n_sides": int(self.n_sides),
            "phase_deg": math.degrees(self.phase_rad),
        }
        if self.aspect != 1.0:
            d["aspect"] = self.aspect
        return d

    @classmethod
    def from_dict(cls, d: dict, where: str = "segment") -> "Segment":
        _check_keys(d, _SEGMENT_KEYS, where)
        rect = [k for k in ("width", "depth") if k in d]
        try:
            if rect:
                other = sorted(set(d) - {"height", "width", "depth"})
                if len(rect) < 2 or other:
                    raise ParameterError(f"a rectangular segment takes height, width and depth only (got keys "
                                         f"{sorted(d)})")
                return cls.rectangle(d["height"], d["width"], d["depth"])
            return cls(
                height=d["height"],
                r_bottom=0.5 * real(d["diameter_bottom"], "diameter_bottom (m)"),
                r_top=0.5 * real(d.get("diameter_top", d["diameter_bottom"]), "diameter_top (m)"),
                n_sides=_n_sides(d.get("n_sides", 10), ""),  # where is prefixed below
                phase_rad=math.radians(real(d.get("phase_deg", 0.0), "phase_deg")),
                aspect=d.get("aspect", 1.0),
            )
        except KeyError as exc:
            raise ParameterError(f"{where}: missing key {exc}") from None
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"{where}: {exc}") from None
