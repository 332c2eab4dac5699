"""Colonnades: several columns on one ground, with epistyles resting across neighbouring capitals
(docs/scene_format.md; the solver's side: docs/solver.md "Scenes").

A :class:`Colonnade` is a straight row of equal columns, ``spacing`` m apart along x, centred on the
origin, and optionally an :class:`Epistyle` over each span. Each epistyle block spans two
neighbouring capitals: the outer ends of the row end at the outer edge of the end columns' tops
(they bear on the whole top), an inner end at the axis of its column (two epistyles share an inner
column's top, each on its half). Where an epistyle bears on a capital -- the overlap, at rest, of its
underside with the capital's top square -- it rests through square patches with the soft Coulomb law
of the joints (``epistyle.joints``, default the column's); a rectangular overlap is tiled by squares
of its shorter side (their kn and ks scaled to the rectangle's area when they do not tile it exactly).
Adjacent epistyle blocks do not touch each other: each rests on its two capitals only.

Every column is the same :class:`~pycolfrag.structure.column.Column` (with its connectors, if it has any).
``Colonnade.portal(2)`` and ``Colonnade.portal(4)`` are the examples built from the default column.
``simulate(colonnade, ...)`` and ``simulate_batch`` take a colonnade as they take a column; its
:class:`~pycolfrag.solver.run.Response` reports per column and per epistyle.
"""
from __future__ import annotations

import json
import os
import tomllib
from dataclasses import dataclass
from typing import Any

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import integer, positive_float
from pycolfrag.structure.column import Column, JointProperties, _check_keys
from pycolfrag.structure.scene_parts import Beam, Bearing, SceneParts

__all__ = ["Epistyle", "Colonnade", "SceneKind", "column_of", "SceneParts", "Beam", "Bearing", "PORTAL_SPACING",
           "PORTAL_EPISTYLE_HEIGHT"]

#: The portals' axial spacing of the columns, m: an assumption of the order of the Parthenon's
#: (about 4.3 m between the peristyle's axes; the pronaos columns are a little smaller).
PORTAL_SPACING = 4.0
#: The portals' epistyle height, m: of the order of the Parthenon's architrave (about 1.35 m).
PORTAL_EPISTYLE_HEIGHT = 1.35

_SCENE_KEYS = ("name", "description", "provenance", "column", "n_columns", "spacing", "epistyle")
_EPISTYLE_KEYS = ("height", "width", "density", "joints", "provenance")


@dataclass(frozen=True)
class Epistyle:
    """The epistyle blocks over a colonnade's spans.

    Parameters
    ----------
    height : float
        m (> 0).
    width : float or None
        Across the row (y), m; None: the side of the capital's top square.
    density : float or None
        kg/m^3; None: the columns'.
    joints : JointProperties or None
        The law of its bearings on the capitals; None: the columns' joints.
    """

    height: float = PORTAL_EPISTYLE_HEIGHT
    width: float | None = None
    density: float | None = None
    joints: JointProperties | None = None

    def __post_init__(self):
        object.__setattr__(self, "height", positive_float(self.height, "epistyle height (m)"))
        if self.width is not None:
            object.__setattr__(self, "width", positive_float(self.width, "epistyle width (m)"))
        if self.density is not None:
            object.__setattr__(self, "density", positive_float(self.density, "epistyle density (kg/m^3)"))
        if self.joints is not None and not isinstance(self.joints, JointProperties):
            raise ParameterError(f"epistyle joints must be JointProperties, got {type(self.joints).__name__}")

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"height": self.height}
        if self.width is not None:
            d["width"] = self.width
        if self.density is not None:
            d["density"] = self.density
        if self.joints is not None:
            d["joints"] = self.joints.to_dict()
        return d

    @classmethod
    def from_dict(cls, d) -> "Epistyle":
        _check_keys(d, _EPISTYLE_KEYS, "epistyle")
        joints = JointProperties.from_dict(d["joints"]) if "joints" in d else None
        return cls(height=d.get("height", PORTAL_EPISTYLE_HEIGHT), width=d.get("width"), density=d.get("density"),
                   joints=joints)


def top_square(col: Column) -> float:
    """The side of the largest square, sides along x and y, centred on the axis, inside the top face
    of the column's top block (the capital's abacus of the default column: all of it), m."""
    seg = col.blocks[-1].top
    lo, hi = 0.0, 2.0 * seg.r_top
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        h = 0.5 * mid
        if all(seg.inside(sx * h, sy * h, top=True) for sx in (-1, 1) for sy in (-1, 1)):
            lo = mid
        else:
            hi = mid
    return lo


def _tiles(x0: float, x1: float, y0: float, y1: float) -> list[tuple[float, float, float, float]]:
    """A rectangle [x0, x1] x [y0, y1] as squares of its shorter side along its longer one: (x, y,
    side, kn factor), the factor scaling their stiffness to the rectangle's area."""
    dx, dy = x1 - x0, y1 - y0
    side = min(dx, dy)
    n = max(1, int(round(max(dx, dy) / side)))
    factor = dx * dy / (n * side * side)
    out = []
    for k in range(n):
        f = 0.5 if n == 1 else k / (n - 1)
        if dx >= dy:
            out.append((x0 + 0.5 * side + f * (dx - side), 0.5 * (y0 + y1), side, factor))
        else:
            out.append((0.5 * (x0 + x1), y0 + 0.5 * side + f * (dy - side), side, factor))
    return out


def column_of(c, base_dir: str | None, where: str) -> Column:
    """A scene file's column: a file name (relative to ``base_dir``, the scene file's folder) or a table in
    the column format; ``where`` names it in the error."""
    if isinstance(c, str):
        return Column.from_file(c if os.path.isabs(c) or base_dir is None else os.path.join(base_dir, c))
    if isinstance(c, dict):
        return Column.from_dict(c)
    raise ParameterError(f"{where} must be a file name or a table, got {type(c).__name__}")


class SceneKind:
    """What every scene kind has from its parts and its dict (the Structure contract's common part,
    :mod:`pycolfrag.structure.kinds`): its counts, its JSON and its file reader. A kind gives
    ``scene_parts()``, ``to_dict()`` and ``from_dict(d, base_dir)``."""

    @property
    def n_blocks(self) -> int:
        return self.scene_parts().n_blocks  # type: ignore[attr-defined]

    @property
    def n_joints(self) -> int:
        return self.scene_parts().n_joints  # type: ignore[attr-defined]

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)  # type: ignore[attr-defined]

    @classmethod
    def from_file(cls, path):
        """A scene file (TOML or JSON, docs/scene_format.md), read by the one policy for files a user
        names (:mod:`pycolfrag.core.input_files`)."""
        text = input_files.read_text(path, "scene file")
        name = os.fspath(path)
        try:
            d = tomllib.loads(text) if name.lower().endswith(".toml") else input_files.json_loads(text)
        except ValueError as exc:
            raise ParameterError(f"cannot parse scene file {name}: {exc}") from None
        return cls.from_dict(d, os.path.dirname(os.path.abspath(name)))


class Colonnade(SceneKind):
    """A straight row of equal columns on one ground, optionally with epistyles over the spans.

    Parameters
    ----------
    column : Column
        Every column of the row (its connectors included).
    n_columns : int
        >= 1.
    spacing : float
        Between neighbouring axes, m; the columns must not touch.
    epistyle : Epistyle or None
        The epistyles over every span (None: free-standing columns).
    name : str
    """

    def __init__(self, column: Column, n_columns: int = 2, spacing: float = PORTAL_SPACING,
                 epistyle: Epistyle | None = Epistyle(), name: str = "colonnade"):
        if not isinstance(column, Column):
            raise ParameterError(f"column must be a Column, got {type(column).__name__}")
        self.column = column
        self.n_columns = integer(n_columns, "n_columns", minimum=1, maximum=64)
        self.spacing = positive_float(spacing, "spacing (m)")
        if epistyle is not None and not isinstance(epistyle, Epistyle):
            raise ParameterError(f"epistyle must be an Epistyle or None, got {type(epistyle).__name__}")
        if epistyle is not None and self.n_columns < 2:
            raise ParameterError("an epistyle spans two neighbouring capitals: a colonnade with epistyles needs at "
                                 f"least 2 columns, got {self.n_columns}")
        self.epistyle = epistyle
        self.name = str(name)
        rmax = max(max(s.circumradius(), s.circumradius(True)) for b in column.blocks for s in b.segments)
        if self.n_columns > 1 and self.spacing <= 2.0 * rmax:
            raise ParameterError(f"spacing = {spacing!r} m: the columns overlap (their largest radius is {rmax:.4g} m, "
                                 f"so the axes must be more than {2 * rmax:.4g} m apart)")
        if epistyle is not None:
            self._epistyle_geometry()   # bad epistyle widths fail here, before any run

    # ---- the parts -----------------------------------------------------------------------
    @property
    def xs(self) -> list[float]:
        """The columns' axes along x, m."""
        return [(i - 0.5 * (self.n_columns - 1)) * self.spacing for i in range(self.n_columns)]

    def _epistyle_geometry(self):
        a = top_square(self.column)
        e = self.epistyle
        w = e.width if e.width is not None else a
        if w > a * (1.0 + 1e-12):
            raise ParameterError(f"epistyle width = {w!r} m is wider than the capitals' top square ({a:.4g} m): its "
                                 "bearings must lie on the capitals")
        return a, w

    def scene_parts(self) -> SceneParts:
        """The columns at their places, the epistyles and their bearings, the dowels (scene_run)."""
        col, xs = self.column, self.xs
        parts = SceneParts([(col, x, 0.0) for x in xs])
        for i in range(len(xs)):
            parts.dowels += [(i * col.n_blocks + j, dx, dy, law) for j, dx, dy, law in col.dowels()]
        if self.epistyle is None:
            return parts
        a, w = self._epistyle_geometry()
        e = self.epistyle
        joints = e.joints if e.joints is not None else col.joints
        density = e.density if e.density is not None else col.density
        n = self.n_columns
        for b in range(n - 1):
            x0 = xs[b] - 0.5 * a if b == 0 else xs[b]
            x1 = xs[b + 1] + 0.5 * a if b == n - 2 else xs[b + 1]
            parts.beams.append(Beam(0.5 * (x0 + x1), 0.0, x1 - x0, w, e.height, density))
            for c in (b, b + 1):
                lo, hi = max(x0, xs[c] - 0.5 * a), min(x1, xs[c] + 0.5 * a)
                for tx, ty, side, f in _tiles(lo, hi, -0.5 * w, 0.5 * w):
                    parts.bearings.append(Bearing(b, c, tx, ty, side, joints, f))
        return parts

    @property
    def joints(self) -> JointProperties:
        """The columns' joint properties (what a grid's ``--kn`` changes)."""
        return self.column.joints

    def with_joints(self, joints: JointProperties | None = None, **changes) -> "Colonnade":
        """A copy whose columns have other joint properties (:meth:`Column.with_joints`)."""
        return self.replace(column=self.column.with_joints(joints, **changes))

    @property
    def mass(self) -> float:
        """Total mass, kg."""
        return self.n_columns * self.column.mass + sum(b.density * b.length * b.width * b.height
                                                        for b in self.scene_parts().beams)

    @property
    def gamma(self) -> float:
        """The epistyles' mass over the columns' mass (the ratio of Makris & Vassiliou's rocking frame).

        The rocking frame's results hold for a **2-column portal only**: its mechanism lifts at
        ``g tan(alpha)`` whatever gamma, and rocks as one column of ``p sqrt((1 + 2 gamma) / (1 + 3
        gamma))``. A row of 3 or more columns is not that frame: its inner columns carry two
        epistyles' ends, each on half the capital, so the row lifts below ``g tan(alpha)``, the more so
        the heavier its epistyles (measured with rigid contacts, every base open: 0.950 and 0.891
        ``g tan(alpha)`` for 3 columns at gamma 0.5 and 2, 0.932 and 0.855 for 4; docs/solver.md
        "Scenes"). For such a row gamma is a mass ratio, not the frame's parameter."""
        return (self.mass - self.n_columns * self.column.mass) / (self.n_columns * self.column.mass)

    # ---- examples, files -------------------------------------------------------------------
    @classmethod
    def portal(cls, n_columns: int = 2, column: Column | None = None, **kwargs) -> "Colonnade":
        """A portal of ``n_columns`` default columns (or ``column``) with epistyles: the examples
        (spacing :data:`PORTAL_SPACING`, epistyle height :data:`PORTAL_EPISTYLE_HEIGHT`). Only
        ``portal(2)`` is Makris & Vassiliou's rocking frame; ``portal(3)``, ``portal(4)`` lift below
        its ``g tan(alpha)``, depending on :attr:`gamma` (see there)."""
        column = Column.parthenon() if column is None else column
        kwargs.setdefault("name", f"{n_columns}-column portal")
        return cls(column, n_columns, **kwargs)

    def to_dict(self) -> dict:
        d = {"name": self.name, "column": self.column.to_dict(), "n_columns": self.n_columns, "spacing": self.spacing}
        if self.epistyle is not None:
            d["epistyle"] = self.epistyle.to_dict()
        return d

    @classmethod
    def from_dict(cls, d, base_dir: str | None = None) -> "Colonnade":
        """A colonnade from the scene format (docs/scene_format.md); a ``column`` given as a path is read
        relative to ``base_dir``."""
        _check_keys(d, _SCENE_KEYS, "scene")
        if "column" not in d:
            raise ParameterError("scene: missing key 'column' (a column file or a table in the column format)")
        column = column_of(d["column"], base_dir, "scene: column")
        epistyle = Epistyle.from_dict(d["epistyle"]) if "epistyle" in d else None
        return cls(column, d.get("n_columns", 2), d.get("spacing", PORTAL_SPACING), epistyle, d.get("name", "colonnade"))

    def replace(self, **changes) -> "Colonnade":
        """A copy with other arguments (``column``, ``n_columns``, ``spacing``, ``epistyle``, ``name``)."""
        args: dict[str, Any] = {"column": self.column, "n_columns": self.n_columns, "spacing": self.spacing,
                "epistyle": self.epistyle, "name": self.name}
        args.update(changes)
        return Colonnade(**args)

    def __repr__(self) -> str:
        return (f"Colonnade({self.name!r}, {self.n_columns} x {self.column.name!r}, spacing={self.spacing:g} m, "
                f"epistyle={'none' if self.epistyle is None else f'{self.epistyle.height:g} m'})")

