"""The plots draw a column as built where the solver puts it: each block's faces at its offset and turned by
its rotation, its centre of mass where the solver's body starts (a block missing a part included).

Expected values: the faces are those of :func:`pycolfrag.structure.as_built.face` (the polygons the C set-up
reads through ``cf_solver_setup_as_built``), compared to 1e-9 m (the same arithmetic up to round-off); the
centres of mass horizontally are the C solver's at the first history sample of a run under no motion, to
1e-6 m (the bodies start at rest where the set-up put them), so a block drawn on its axis instead of at its
offset (4 to 35 mm in the example) or about its geometric centre instead of its moved one (10 mm) is
caught. Vertically the bodies sit lower by the joints' settlement under the weight above, which the drawing
at rest leaves out (1.7 mm at the example's capital: its joints' kn), so z is not compared.
"""
from __future__ import annotations

import numpy as np

import pycolfrag as pcf
from pycolfrag.plots import block_faces
from pycolfrag.plots.response import _rest_faces
from pycolfrag.structure import as_built
from pycolfrag.structure.column import Block, Column

EXAMPLE = "examples/column_as_built.json"


def _solver_rest(col) -> np.ndarray:
    res = pcf.simulate(col, np.zeros(200), 0.005, history=True)
    return np.asarray(res.history.block_pos)[0]


def test_an_as_built_column_is_drawn_where_the_solver_sets_it():
    col = Column.from_file(EXAMPLE)
    assert any(b.offset != (0.0, 0.0) or b.rotation_deg for b in col.blocks)   # the example is placed
    faces = block_faces(col)
    for i in range(col.n_blocks):
        drawn = sorted(map(tuple, faces[i][0][:, :2].round(9)))
        expected = sorted(map(tuple, np.array(as_built.face(col, i, top=False)).round(9)))
        assert np.allclose(drawn, expected, atol=1e-9), i
    coms = np.array([c for _, c in _rest_faces(col)])
    assert np.abs(coms - _solver_rest(col))[:, :2].max() < 1e-6


def test_a_block_missing_a_part_is_drawn_about_its_moved_centre_of_mass():
    """Housner's block (0.4 m square, 2 m tall) missing 0.02 m^3 at x = 0.15 m: its centre of mass at
    x = -0.01 m (tests/test_as_built.py's hand calculation)."""
    one = Column.single_block(0.4, 2.0)
    col = Column((Block(one.blocks[0].segments, "block", missing_part=(0.02, 0.15, 0.0, 1.0)),), joints=one.joints)
    (_, com), = _rest_faces(col)
    assert abs(com[0] + 0.01) < 1e-9
    assert np.abs(com - _solver_rest(col)[0])[:2].max() < 1e-6


def test_a_turned_block_missing_a_part_is_drawn_about_the_solvers_centre():
    """The same block turned by 90 degrees about z: the missing part, given in the block's frame at +x,
    sits at +y in the column's axes, so the centre of mass moves to y = -0.01 m (x = 0), where the solver's
    body starts; drawn without the turn it would sit at x = -0.01 m."""
    one = Column.single_block(0.4, 2.0)
    col = Column((Block(one.blocks[0].segments, "block", rotation_deg=90.0, missing_part=(0.02, 0.15, 0.0, 1.0)),),
                 joints=one.joints)
    (_, com), = _rest_faces(col)
    assert abs(com[1] + 0.01) < 1e-9 and abs(com[0]) < 1e-9, com
    assert np.abs(com - _solver_rest(col)[0])[:2].max() < 1e-6
