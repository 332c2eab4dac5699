"""A lintel resting on a column and a wall (pycolfrag/structure/lintel.py): a scene kind that is its class
and its line in KINDS (pycolfrag/structure/kinds.py) and nothing else -- the wall a column of rectangular
blocks (tests/test_wall_section.py), the lintel a beam on bearings as a colonnade's epistyle."""
import json

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.analysis.data import load
from pycolfrag.core.errors import ParameterError
from pycolfrag.structure import kinds
from pycolfrag.structure.lintel import LintelOnWall
from pycolfrag.structure.scene import Epistyle
from test_grid import _ok, _serial  # noqa: E402  (tests/ is not a package)

G = 9.81


def _same(a, b, what):
    """Two Responses of a scene bitwise equal (NaN == NaN), as tests/test_colonnade.py compares a portal's."""
    for key in ("u_top", "u_d", "n_steps", "t_end", "collapsed", "collapse_block", "collapse_time", "collapse_reason",
                "collapse_part", "energy_error", "max_top_disp", "epistyle_slip_mm", "epistyle_unseat"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=f"{what}: {key}")
    for part in ("columns", "epistyles"):
        for key in getattr(a, part):
            np.testing.assert_array_equal(getattr(a, part)[key], getattr(b, part)[key], err_msg=f"{what}: {part} {key}")
    np.testing.assert_array_equal(a.history.block_pos, b.history.block_pos, err_msg=f"{what}: history")


def test_the_kind_is_its_registry_line():
    m = LintelOnWall.example()
    assert kinds.kind_of(m).name == "lintel" and kinds.kind_of_dict(m.to_dict()).cls is LintelOnWall
    parts = m.scene_parts()
    assert [(x, y) for _, x, y in parts.columns] == [(-1.25, 0.0), (1.25, 0.0)]
    assert len(parts.beams) == 1 and {b.column for b in parts.bearings} == {0, 1}
    assert m.n_blocks == 3 + 3 + 1 and m.n_joints == 3 + 3 + len(parts.bearings)


@pytest.mark.parametrize("contact", ["vertex", "perimeter", "exact"])
def test_lintel_on_a_wall_starts_at_rest(contact):
    """No ground motion: every body within 1e-9 m for 1 s (each support's tiles centred on its axis, the
    lintel's weight shared by the lever rule: the start is exact equilibrium; measured 2e-14 m)."""
    r = pcf.simulate(LintelOnWall.example(), np.zeros(200), 0.005, history=True, early_exit=False, contact=contact)
    assert np.abs(r.history.block_pos - r.history.block_pos[0]).max() < 1e-9
    assert not r.collapsed and r.energy_error < 1e-6


def test_lintel_on_a_wall_reports_its_column_wall_and_lintel():
    t = np.arange(0.0, 3.0, 0.005)
    r = pcf.simulate(LintelOnWall.example(), 0.4 * G * np.sin(2 * np.pi * 1.5 * t), 0.005)
    assert len(r.columns["u_top"]) == 2 and len(r.epistyles["slip"]) == 1
    assert r.u_top == r.columns["u_top"].max() > 0.0 and r.epistyle_slip_mm > 0.0
    assert r.energy_error < 0.05


def test_batch_of_a_lintel_on_a_wall_is_its_single_runs():
    """Every run of a batch at every width is bitwise its single run (tolerance zero), records of
    different lengths (lanes refilled)."""
    m = LintelOnWall.example()
    recs = [(a * G * np.sin(2 * np.pi * 1.5 * np.arange(0.0, d, 0.005)), 0.005)
            for a, d in ((0.2, 1.5), (0.45, 1.2), (0.3, 0.5), (0.25, 1.0), (0.35, 0.8))]
    singles = [pcf.simulate(m, acc, dt, history=True, tail_s=0.5) for acc, dt in recs]
    widest = pcf.solver.run.batch_width(m, tail_s=0.5)
    for width in (w for w in (1, 2, 4, 8) if w <= widest):
        for i, (s, b) in enumerate(zip(singles, pcf.simulate_batch(m, recs, history=True, width=width, tail_s=0.5))):
            _same(s, b, f"width {width} run {i}")


def test_files_round_trip(tmp_path):
    m = LintelOnWall.example().replace(lintel=Epistyle(0.35, width=0.3, density=2400.0), name="gate")
    assert LintelOnWall.from_dict(m.to_dict()).to_json() == m.to_json()
    assert kinds.model_from_dict(json.loads(m.to_json())).to_json() == m.to_json()   # a results file's attribute
    path = tmp_path / "gate.json"
    path.write_text(m.to_json())
    assert kinds.scene_from_file(path).to_json() == m.to_json()
    (tmp_path / "wall.json").write_text(m.wall.to_json())
    toml = tmp_path / "gate.toml"
    toml.write_text('name = "gate"\nwall = "wall.json"\nspan = 2.5\n[column]\nblocks = '
                    + json.dumps([b.to_dict() for b in m.column.blocks]).replace('":', '" =').replace("{", "{ ")
                    + "\n[lintel]\nheight = 0.35\nwidth = 0.3\ndensity = 2400.0\n")
    got = kinds.scene_from_file(toml)
    assert isinstance(got, LintelOnWall) and got.wall.to_json() == m.wall.to_json() and got.span == 2.5
    assert got.with_joints(kn=2e9).wall.joints.kn == 2e9 == got.with_joints(kn=2e9).column.joints.kn


def test_bad_lintels_are_refused_naming_the_value():
    m = LintelOnWall.example()
    with pytest.raises(ParameterError, match="the column and the wall overlap"):
        m.replace(span=0.5)
    with pytest.raises(ParameterError, match="lintel width = 0.9 m is wider than the column's top square"):
        m.replace(lintel=Epistyle(0.4, width=0.9))
    with pytest.raises(ParameterError, match="wall must be a Column, got str"):
        m.replace(wall="wall")
    with pytest.raises(ParameterError, match="lintel scene: missing key 'wall'"):
        LintelOnWall.from_dict({"column": m.column.to_dict()})
    with pytest.raises(ParameterError, match="does not fit on the wall's top face"):
        m.replace(wall=LintelOnWall.wall(0.5, 0.2, [1.0] * 3))


def test_grid_of_a_lintel_on_a_wall(tmp_path):
    """The grid takes the kind by its scene file's key (``wall``): every row runs, the lintel's EDPs are
    stored, and the results file's model is the scene read back."""
    m = LintelOnWall.example()
    scene, out = tmp_path / "gate.json", tmp_path / "gate.h5"
    scene.write_text(m.to_json())
    _ok(_serial(["--mw", "6.5", "--dist", "5", "20", "--samples", "2", "--max-record-s", "4", "--no-figures",
                 "--no-progress", "--scene", str(scene), "--out", str(out)]))
    r = load(out)
    s = r.samples
    assert r.complete and (s["status"] == 0).all() and np.isfinite(s["epistyle_slip_mm"]).all()
    assert kinds.model_from_dict(json.loads(r.attrs["column"])).to_json() == m.to_json()
