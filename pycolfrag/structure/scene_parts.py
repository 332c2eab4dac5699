"""What the solver builds of a structure: :class:`SceneParts` -- its columns at their places, its beams
(:class:`Beam`), their bearings (:class:`Bearing`) and its dowels -- the data of the Structure contract
(:mod:`pycolfrag.structure.kinds`): every kind of structure gives its parts through ``scene_parts()`` (a
:class:`~pycolfrag.structure.column.Column` is a one-column scene), and :func:`pycolfrag.solver.scene_setup.setup` is
the one text that hands them to C (``cf_solver_setup_scene``).

Plain data without imports from the package: the structures (``column.py``, ``scene.py``) make it
and the run (``solver/scene_setup.py``, ``solver/run.py``) reads it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["SceneParts", "Beam", "Bearing"]


@dataclass(frozen=True)
class Beam:
    """A rectangular block resting on two columns: the centre of its underside (x, y) m, its
    length (x), width (y), height (z) m, density kg/m^3."""

    x: float
    y: float
    length: float
    width: float
    height: float
    density: float


@dataclass(frozen=True)
class Bearing:
    """A square patch of beam ``beam`` on the top of column ``column``: centre (x, y) m, side m, and
    the joint law there (a :class:`~pycolfrag.structure.column.JointProperties`, kn scaled by ``kn_factor`` when
    tiles stand for a rectangle of another area)."""

    beam: int
    column: int
    x: float
    y: float
    side: float
    joints: object
    kn_factor: float = 1.0


@dataclass
class SceneParts:
    """What the solver builds: columns at their places ((Column, x, y)), beams, bearings (listed beam
    by beam), dowels ((scene joint, x, y, DowelLaw): every column's joints, column by column, then the
    bearings)."""

    columns: list
    beams: list = field(default_factory=list)
    bearings: list = field(default_factory=list)
    dowels: list = field(default_factory=list)

    @property
    def n_blocks(self) -> int:
        return sum(c.n_blocks for c, _, _ in self.columns) + len(self.beams)

    @property
    def n_joints(self) -> int:
        return sum(c.n_blocks for c, _, _ in self.columns) + len(self.bearings)
