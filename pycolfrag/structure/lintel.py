"""A lintel resting on a column and a wall (docs/scene_format.md "A lintel on a wall"): a scene kind
built of the parts the solver has, and nothing else (docs/architecture.md, "Costs of change").

The column stands at x = -span/2, the wall at x = +span/2 (both on one ground, their axes along z);
the wall is a :class:`~pycolfrag.structure.column.Column` of rectangular blocks (:meth:`LintelOnWall.wall`:
:meth:`~pycolfrag.structure.segment.Segment.rectangle`, thickness along x, length along y). The lintel is
a rectangular block (an :class:`~pycolfrag.structure.scene.Epistyle`'s height, width, density, joints)
from the outer edge of the column's top square to the outer face of the wall: it bears on the whole
top square of the column and on the wall's top across the wall's thickness, through square patches
of its joint law as an epistyle does (a rectangle tiled by squares of its shorter side). Column and
wall must be of like height (the solver's levelling course takes up settlement only).
"""
from __future__ import annotations

from typing import Any

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.validate import positive_float
from pycolfrag.structure.column import Block, Column, JointProperties, _check_keys
from pycolfrag.structure.scene import Epistyle, SceneKind, _tiles, column_of, top_square
from pycolfrag.structure.scene_parts import Beam, Bearing, SceneParts
from pycolfrag.structure.segment import Segment

__all__ = ["LintelOnWall", "LINTEL"]

#: The default lintel: 0.5 m high, as wide as the column's top square, of the column's stone and joints.
LINTEL = Epistyle(height=0.5)

_KEYS = ("name", "description", "provenance", "column", "wall", "span", "lintel")


def _x_extent(seg, half_w: float) -> float:
    """The largest half-length (m) along x of a rectangle of half-width ``half_w`` along y, centred on
    the axis, inside the top face of ``seg`` (0 when none fits)."""
    lo, hi = 0.0, seg.circumradius(True)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if all(seg.inside(sx * mid, sy * half_w, top=True) for sx in (-1, 1) for sy in (-1, 1)):
            lo = mid
        else:
            hi = mid
    return lo


def _reach(col: Column, sign: float) -> float:
    """How far (m) col's sections reach from its axis towards sign * x."""
    return max(sign * x for b in col.blocks for s in b.segments for top in (False, True) for x, _ in s.vertices(top))


class LintelOnWall(SceneKind):
    """A lintel resting on a column and a wall.

    Parameters
    ----------
    column : Column
        The free-standing column at x = -span/2 (its connectors included).
    wall : Column
        The wall at x = +span/2: a column of blocks, typically rectangular (:meth:`wall`).
    span : float
        Between the column's axis and the wall's, m; they must not touch.
    lintel : Epistyle
        The lintel's height, width (across, y; None: the column's top square), density (None: the
        column's) and bearing law (None: the column's joints).
    name : str
    """

    def __init__(self, column: Column, wall: Column, span: float = 2.5, lintel: Epistyle = LINTEL,
                 name: str = "lintel on a wall"):
        for what, c in (("column", column), ("wall", wall)):
            if not isinstance(c, Column):
                raise ParameterError(f"{what} must be a Column, got {type(c).__name__}")
        if not isinstance(lintel, Epistyle):
            raise ParameterError(f"lintel must be an Epistyle (height, width, density, joints), got {type(lintel).__name__}")
        self.column, self.wall, self.lintel, self.name = column, wall, lintel, str(name)
        self.span = positive_float(span, "span (m)")
        gap = self.span - _reach(column, 1.0) - _reach(wall, -1.0)
        if not gap > 0.0:
            raise ParameterError(f"span = {span!r} m: the column and the wall overlap by {-gap:.4g} m along x")
        self._geometry()   # a bad lintel width fails here, before any run

    def _geometry(self) -> tuple[float, float, float]:
        """(the column's top square, the lintel's width, the wall top's half-thickness under it), m."""
        a = top_square(self.column)
        w = self.lintel.width if self.lintel.width is not None else a
        if w > a * (1.0 + 1e-12):
            raise ParameterError(f"lintel width = {w!r} m is wider than the column's top square ({a:.4g} m): its "
                                 "bearings must lie on the column")
        t = _x_extent(self.wall.blocks[-1].top, 0.5 * w)
        if not t > 0.0:
            raise ParameterError(f"lintel width = {w!r} m: the lintel does not fit on the wall's top face")
        return a, w, t

    @staticmethod
    def wall(thickness: float, length: float, heights, density: float = 2700.0,
             joints: JointProperties | None = None) -> Column:
        """A wall of rectangular blocks ``heights`` (m, bottom up), ``thickness`` (x) by ``length`` (y) m."""
        hs = list(heights) if not isinstance(heights, (int, float)) else [heights]
        blocks = [Block((Segment.rectangle(h, thickness, length),), name=f"course {i}") for i, h in enumerate(hs)]
        return Column(blocks, density=density, joints=joints, name="wall")

    @classmethod
    def example(cls) -> "LintelOnWall":
        """A small example: a column of three 1 m drums (0.6 m, 12 sides) and a wall of three 1 m
        courses 0.5 m thick and 2 m long, 2.5 m apart, under a 0.4 m lintel."""
        column = Column.from_drums([1.0] * 3, 0.6, n_sides=12)
        return cls(column, cls.wall(0.5, 2.0, [1.0] * 3), 2.5, Epistyle(height=0.4))

    # ---- the Structure contract (structure/kinds.py) ---------------------------------------
    def scene_parts(self) -> SceneParts:
        """The column and the wall at their places, the lintel and its bearings, the dowels."""
        xc, xw = -0.5 * self.span, 0.5 * self.span
        parts = SceneParts([(self.column, xc, 0.0), (self.wall, xw, 0.0)])
        nc = self.column.n_blocks
        parts.dowels += [(j, dx, dy, law) for j, dx, dy, law in self.column.dowels()]
        parts.dowels += [(nc + j, dx, dy, law) for j, dx, dy, law in self.wall.dowels()]
        a, w, t = self._geometry()
        e = self.lintel
        joints = e.joints if e.joints is not None else self.column.joints
        density = e.density if e.density is not None else self.column.density
        x0, x1 = xc - 0.5 * a, xw + t
        parts.beams.append(Beam(0.5 * (x0 + x1), 0.0, x1 - x0, w, e.height, density))
        for c, lo, hi in ((0, x0, xc + 0.5 * a), (1, xw - t, x1)):
            for tx, ty, side, f in _tiles(lo, hi, -0.5 * w, 0.5 * w):
                parts.bearings.append(Bearing(0, c, tx, ty, side, joints, f))
        return parts

    @property
    def joints(self) -> JointProperties:
        """The column's joint properties (what a grid's ``--kn`` changes)."""
        return self.column.joints

    def with_joints(self, joints: JointProperties | None = None, **changes) -> "LintelOnWall":
        """A copy whose column and wall have other joint properties (:meth:`Column.with_joints`)."""
        return self.replace(column=self.column.with_joints(joints, **changes),
                            wall=self.wall.with_joints(joints, **changes))

    @property
    def mass(self) -> float:
        """Total mass, kg."""
        return self.column.mass + self.wall.mass + sum(b.density * b.length * b.width * b.height
                                                       for b in self.scene_parts().beams)

    # ---- files ------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"name": self.name, "column": self.column.to_dict(), "wall": self.wall.to_dict(), "span": self.span,
                "lintel": self.lintel.to_dict()}

    @classmethod
    def from_dict(cls, d, base_dir: str | None = None) -> "LintelOnWall":
        """From the scene format (docs/scene_format.md); a ``column`` or ``wall`` given as a path is read
        relative to ``base_dir``."""
        _check_keys(d, _KEYS, "lintel scene")
        for k in ("column", "wall"):
            if k not in d:
                raise ParameterError(f"lintel scene: missing key {k!r} (a column file or a table in the column format)")
        lintel = Epistyle.from_dict(d["lintel"]) if "lintel" in d else LINTEL
        return cls(column_of(d["column"], base_dir, "lintel scene: column"),
                   column_of(d["wall"], base_dir, "lintel scene: wall"), d.get("span", 2.5),
                   lintel, d.get("name", "lintel on a wall"))

    def replace(self, **changes) -> "LintelOnWall":
        """A copy with other arguments (``column``, ``wall``, ``span``, ``lintel``, ``name``)."""
        args: dict[str, Any] = {"column": self.column, "wall": self.wall, "span": self.span, "lintel": self.lintel,
                                "name": self.name}
        args.update(changes)
        return LintelOnWall(**args)

    def __repr__(self) -> str:
        return (f"LintelOnWall({self.name!r}, column {self.column.name!r}, wall of {self.wall.n_blocks} blocks, "
                f"span={self.span:g} m, lintel={self.lintel.height:g} m)")
