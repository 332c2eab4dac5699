"""Debug plots of one run (pycolfrag/plots/response.py): the matplotlib objects, not pixels.

Most tests use a small fake response (a SimpleNamespace with the fields of solver.History and
Response): a 3-block column rocking rigidly about its +x base edge with a known tilt, so the 3D
placement can be checked against geometry computed here. One test runs the real solver on a short
record and checks that the drawn top face sits where the solver says the top is (history.top_disp).
"""
import math
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import pycolfrag as pcf  # noqa: E402
from pycolfrag import ParameterError  # noqa: E402
from pycolfrag.plots import response as plots

N_SIDES = 8


@pytest.fixture(scope="module")
def col():
    return pcf.Column.from_drums([1.0, 1.0], 1.0, 0.9, n_sides=N_SIDES,
                                 capital=pcf.Column.doric_capital(0.2, 0.9, 1.1, 0.1, 1.1, n_sides=N_SIDES),
                                 name="fake column")


def rocking_response(col, n=201, t_end=4.0, amp=0.05, collapsed=False):
    """The whole column tilting rigidly about the base edge at x = +r0 (rotation about y by theta)."""
    t = np.linspace(0.0, t_end, n)
    theta = amp * np.sin(2 * np.pi * 0.5 * t) ** 2  # >= 0: rocks on the +x edge
    r0 = col.base_diameter / 2
    nb = col.n_blocks
    pivot = np.array([r0, 0.0, 0.0])
    com0 = np.array([[0.0, 0.0, z + b.centroid_height] for z, b in zip(col.joint_heights, col.blocks)])
    pos = np.empty((n, nb, 3))
    quat = np.empty((n, nb, 4))
    top = np.empty((n, 2))
    for k, th in enumerate(theta):
        c, s = math.cos(th), math.sin(th)
        rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # about +y: the top moves to +x
        pos[k] = pivot + (com0 - pivot) @ rot.T
        quat[k] = [math.cos(th / 2), 0.0, math.sin(th / 2), 0.0]
        top[k] = (pivot + (np.array([0, 0, col.height]) - pivot) @ rot.T)[:2]
    nj = col.n_joints
    opening = np.zeros((n, nj))
    opening[:, 0] = 2 * r0 * np.sin(theta)
    slip = np.zeros((n, nj, 2))
    slip[:, 1, 0] = 1e-3 * t / t_end
    ke = 100 * np.cos(2 * np.pi * 0.5 * t) ** 2
    energy = {"kinetic": ke, "gravity": 100 - ke, "spring": np.zeros(n), "slip_dissipated": 0.1 * t,
              "damping_dissipated": np.zeros(n), "ground_work": 0.1 * t + 100, "contact_switch": np.zeros(n),
              "balance_error": 1e-3 * np.sin(t)}
    hist = SimpleNamespace(t=t, top_disp=top, block_pos=pos, block_quat=quat, joint_opening=opening,
                           joint_slip=slip, energy=energy)
    umax = float(np.max(np.hypot(top[:, 0], top[:, 1])))
    return SimpleNamespace(history=hist, u_top=umax / col.base_diameter, u_d=0.001, collapsed=collapsed,
                           collapse_time=3.0 if collapsed else float("nan"),
                           collapse_block=2 if collapsed else None, collapse_reason="overturned" if collapsed else "",
                           energy_error=1e-3 / 100, energy_scale=100.0, max_top_disp=umax)


@pytest.fixture(scope="module")
def res(col):
    return rocking_response(col)


def n_lines_with_data(ax):
    """Lines that are not horizontal/vertical guides (axhline/axvline have 2-point data)."""
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]


def test_top_displacement(col, res):
    fig = plots.plot_top_displacement(res, col)
    assert isinstance(fig, Figure)
    a1, a2 = fig.axes
    assert a1.get_ylabel() == "top displacement (mm)" and a2.get_xlabel() == "time (s)"
    assert [ln.get_label() for ln in n_lines_with_data(a1)] == ["x", "y"]
    np.testing.assert_allclose(a1.get_lines()[0].get_ydata(), 1e3 * res.history.top_disp[:, 0])
    guides = [ln for ln in a2.get_lines() if len(ln.get_xdata()) == 2]
    assert sorted(ln.get_ydata()[0] for ln in guides) == list(plots.U_TOP_LEVELS)  # Table III levels
    assert "D_base = 1.000 m" in a2.get_ylabel()
    assert f"{res.u_top:.3g}" in a2.get_title()
    assert a1.get_title()


def test_top_displacement_without_column_infers_diameter(res):
    fig = plots.plot_top_displacement(res)
    assert "D_base = 1.000 m" in fig.axes[1].get_ylabel()
    bare = SimpleNamespace(history=res.history)  # nothing to infer the diameter from
    fig = plots.plot_top_displacement(bare)
    assert fig.axes[1].get_ylabel() == "|u| (mm)"


def test_collapse_is_marked(col):
    r = rocking_response(col, collapsed=True)
    fig = plots.plot_top_displacement(r, col)
    vlines = [ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("collapse")]
    assert len(vlines) == 1 and vlines[0].get_xdata()[0] == 3.0 and "block 2" in vlines[0].get_label()


def test_joint_openings_heatmap_and_lines(col, res):
    fig = plots.plot_joint_openings(res, col)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time (s)" and ax.get_ylabel() == "joint (0 = base)"
    (mesh,) = ax.collections
    assert mesh.get_array().size == res.history.t.size * col.n_joints
    assert fig.axes[1].get_ylabel() == "opening (mm)"  # the colour bar
    assert np.nanmax(mesh.get_array()) == pytest.approx(1e3 * res.history.joint_opening.max())
    fig = plots.plot_joint_openings(res, col, kind="lines")
    ax = fig.axes[0]
    assert len(n_lines_with_data(ax)) == col.n_joints and ax.get_ylabel() == "opening (mm)"
    assert ax.get_lines()[0].get_label() == "base joint"
    with pytest.raises(ParameterError, match="kind"):
        plots.plot_joint_openings(res, col, kind="pie")


def test_joint_slips(col, res):
    fig = plots.plot_joint_slips(res)
    ax = fig.axes[0]
    assert ax.get_ylabel() == "dislocation (mm)" and len(n_lines_with_data(ax)) == col.n_joints
    np.testing.assert_allclose(ax.get_lines()[1].get_ydata(), 1e3 * res.history.joint_slip[:, 1, 0])
    fig = plots.plot_joint_slips(res, col)
    ax = fig.axes[0]
    assert "joint diameter" in ax.get_ylabel() and "Table IV" in ax.get_title()
    guides = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2]
    assert sorted(ln.get_ydata()[0] for ln in guides) == list(plots.U_D_LEVELS)
    np.testing.assert_allclose(ax.get_lines()[1].get_ydata(),
                               res.history.joint_slip[:, 1, 0] / col.joint_diameters[1])


def test_energy(res):
    fig = plots.plot_energy(res)
    a1, a2 = fig.axes
    labels = [ln.get_label() for ln in a1.get_lines()]
    assert {"kinetic", "gravity", "slip dissipated", "ground work"} <= set(labels)
    assert "spring" not in labels  # all-zero terms are left out
    assert a1.get_ylabel() == "energy (J)" and a2.get_xlabel() == "time (s)"
    np.testing.assert_allclose(a2.get_lines()[0].get_ydata(), res.history.energy["balance_error"] / 100.0)
    assert "1.00e-05" in a2.get_title()


def test_ground_motion():
    rec = SimpleNamespace(acc=9.81 * 0.2 * np.sin(np.linspace(0, 10, 500)), dt=0.01)
    fig = plots.plot_ground_motion(rec)
    ax = fig.axes[0]
    assert ax.get_ylabel() == "ground acceleration (g)" and "PGA = 0.2 g" in ax.get_title()
    assert ax.get_lines()[0].get_xdata()[-1] == pytest.approx(4.99)
    with pytest.raises(ParameterError, match="dt"):
        plots.plot_ground_motion(rec.acc)


def test_quaternion_matrix():
    np.testing.assert_allclose(plots.quat_to_matrix([1, 0, 0, 0]), np.eye(3))
    h = math.sqrt(0.5)
    np.testing.assert_allclose(plots.quat_to_matrix([h, 0, 0, h]) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(plots.quat_to_matrix([h, h, 0, 0]) @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    with pytest.raises(ParameterError, match="quaternion"):
        plots.quat_to_matrix([0, 0, 0, 0])


def test_block_faces_at_rest(col):
    faces = plots.block_faces(col)
    assert len(faces) == col.n_blocks
    # a drum: bottom and top polygon + one quad per side
    assert len(faces[0]) == 2 + N_SIDES
    assert len(faces[-1]) == 2 * (2 + N_SIDES) - (N_SIDES - 4)  # echinus (8 sides) + abacus (4 sides)
    bottom = faces[0][0]
    assert bottom.shape == (N_SIDES, 3) and np.all(bottom[:, 2] == 0)
    np.testing.assert_allclose(np.hypot(bottom[:, 0], bottom[:, 1]), 0.5)  # circumscribed diameter 1.0
    assert bottom[0, 0] == pytest.approx(0.5) and bottom[0, 1] == pytest.approx(0.0)  # phase 0
    zmax = max(f[:, 2].max() for fs in faces for f in fs)
    assert zmax == pytest.approx(col.height)
    # joints close: drum 1's top polygon is drum 2's bottom polygon
    np.testing.assert_allclose(faces[0][1], faces[1][0], atol=1e-15)
    with pytest.raises(ParameterError, match="block_pos"):
        plots.block_faces(col, np.zeros((2, 3)))


def test_block_faces_follow_the_rocking(col, res):
    h = res.history
    k = int(np.argmax(h.joint_opening[:, 0]))
    faces = plots.block_faces(col, h.block_pos[k], h.block_quat[k])
    pts = np.vstack([f for fs in faces for f in fs])
    assert pts[:, 2].min() == pytest.approx(0.0, abs=1e-12)  # pivoting on the base edge, never below ground
    top_face = faces[-1][2 + N_SIDES + 1]  # abacus top polygon
    np.testing.assert_allclose(top_face.mean(axis=0)[:2], h.top_disp[k], atol=1e-12)
    # the heel of the base lifts by the joint opening
    assert faces[0][0][:, 2].max() == pytest.approx(h.joint_opening[k, 0], rel=1e-9)


def test_snapshot(col, res):
    fig = plots.plot_snapshot(col, res, [0.0, 1.009, 2.027])
    axes = fig.axes
    assert len(axes) == 3
    for ax, want in zip(axes, ("t = 0.00 s", "t = 1.00 s", "t = 2.02 s")):  # nearest sample
        assert ax.get_title() == want
        polys = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
        assert len(polys) == col.n_blocks + 1  # one per block + the ground plate
        assert ax.get_xlabel() == "x (m)" and ax.get_zlabel() == "z (m)"
        assert ax.get_zlim()[1] >= col.height
    fig = plots.plot_snapshot(col, res, 1.0)  # a single time
    assert len(fig.axes) == 1
    with pytest.raises(ParameterError, match="99"):
        plots.plot_snapshot(col, res, [99.0])
    with pytest.raises(ParameterError, match="blocks"):
        plots.plot_snapshot(pcf.Column.single_block(1.0, 2.0), res, [1.0])
    with pytest.raises(ParameterError, match="history=True"):
        plots.plot_snapshot(col, SimpleNamespace(history=None), [1.0])


def test_snapshot_into_given_axes(col, res):
    fig = Figure()
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    assert plots.plot_snapshot(col, res, [1.0], ax=ax) is fig
    assert len(ax.collections) == col.n_blocks + 1


def test_animate_gif(col, res, tmp_path):
    from PIL import Image
    path = tmp_path / "rock.gif"
    out = plots.animate(col, res, path, fps=5, t_start=1.0, t_end=2.0, max_frames=4, dpi=30)
    assert out == str(path)
    with Image.open(path) as im:
        assert im.format == "GIF" and im.n_frames == 4
    with pytest.raises(ParameterError, match="t_start"):
        plots.animate(col, res, tmp_path / "x.gif", t_start=50.0)
    with pytest.raises(ParameterError, match="fps"):
        plots.animate(col, res, tmp_path / "x.gif", fps=0)


def test_record_response_page(col, res):
    acc = 0.1 * 9.81 * np.sin(np.linspace(0, 20, 300))
    fig = plots.plot_record_response(col, acc, 0.01, res)
    titles = [ax.get_title() for ax in fig.axes]
    assert any(t.startswith("Ground motion") for t in titles)
    assert any(t.startswith("Top displacement") for t in titles)
    assert any(t.startswith("Joint opening") for t in titles)
    assert any(t.startswith("Joint dislocation") for t in titles)
    assert any(t.startswith("Energy balance") for t in titles)
    assert sum(ax.name == "3d" for ax in fig.axes) == 2
    assert "fake column" in fig._suptitle.get_text() and "standing" in fig._suptitle.get_text()


def test_real_simulation(tmp_path):
    """A short real run: the drawn top face sits at history.top_disp, and the page builds."""
    col = pcf.Column.parthenon()
    dt = 0.01
    t = np.arange(0.0, 2.0, dt)
    acc = 0.3 * 9.81 * np.sin(2 * np.pi * t)
    res = pcf.simulate(col, acc, dt, history=True, history_dt=0.02, tail_s=1.0)
    h = res.history
    assert res.u_top > 0.05  # it rocked, so the rotations matter in the check below
    n_cap = col.blocks[-1].segments[0].n_sides
    for k in range(0, h.t.size, 10):
        faces = plots.block_faces(col, h.block_pos[k], h.block_quat[k])
        top_face = faces[-1][2 + n_cap + 1]
        np.testing.assert_allclose(top_face.mean(axis=0)[:2], h.top_disp[k], atol=1e-6)
    fig = plots.plot_record_response(col, acc, dt, res)
    assert len(fig.axes) >= 9
    fig.savefig(tmp_path / "page.png", dpi=40)
    assert (tmp_path / "page.png").stat().st_size > 0


@pytest.fixture(scope="module")
def portal_run():
    """A 2-column portal (26 drums and capitals, one epistyle) rocking under 2 s of a 1 Hz, 0.41 g sine."""
    from pycolfrag.structure.scene import Colonnade
    sc = Colonnade.portal(2)
    dt = 0.01
    t = np.arange(0.0, 3.0, dt)
    acc = 4.0 * np.sin(2 * np.pi * t) * (t < 2.0)
    return sc, acc, dt, pcf.simulate(sc, acc, dt, history=True, history_dt=0.02)


def test_a_colonnade_is_plotted(portal_run, tmp_path):
    """Every plot takes a Colonnade (each raised AttributeError before). The drawing places each block by
    the history: the epistyle's box centre at rest (x = 0, on the capitals at 10.08 m, 1.35 m high) moved
    to its block_pos; the two columns 4 m apart; the slips of the columns' 26 joints (bearings left out),
    named by column; the top displacement normalised by the first column's base diameter (1.65 m)."""
    sc, acc, dt, res = portal_run
    h = res.history
    assert h.block_pos.shape[1] == sc.n_blocks == 27
    faces = plots.block_faces(sc, h.block_pos[-1], h.block_quat[-1])
    assert len(faces) == 27
    beam = np.concatenate(faces[-1])
    np.testing.assert_allclose(beam.mean(axis=0), h.block_pos[-1][-1], atol=1e-9)   # a box's vertices: its centre
    rest = plots.block_faces(sc)
    assert np.concatenate(rest[0])[:, 0].mean() == pytest.approx(-2.0) and \
        np.concatenate(rest[13])[:, 0].mean() == pytest.approx(2.0)
    assert np.concatenate(rest[-1])[:, 2].min() == pytest.approx(sc.column.height)
    fig = plots.plot_top_displacement(res, sc)
    assert "D_base = 1.650 m" in fig.axes[1].get_ylabel() and "first column" in fig.axes[1].get_title()
    fig = plots.plot_joint_slips(res, sc)
    labels = [ln.get_label() for ln in fig.axes[0].get_lines() if not ln.get_label().startswith("_")]
    assert len(labels) == 26 and labels[0] == "c1 base" and labels[-1] == "c2 joint 12"
    fig = plots.plot_joint_openings(res, sc, kind="lines")
    assert [ln.get_label() for ln in fig.axes[0].get_lines()][-2:] == ["bearing 1", "bearing 2"]
    fig = plots.plot_snapshot(sc, res, [1.0, 2.0])
    assert all(sum(isinstance(c, Poly3DCollection) for c in a.collections) == 28 for a in fig.axes)
    page = plots.plot_record_response(sc, acc, dt, res)
    assert "2-column portal" in page._suptitle.get_text()
    plots.animate(sc, res, tmp_path / "portal.gif", max_frames=3)
    assert (tmp_path / "portal.gif").stat().st_size > 0


def test_dowel_forces_are_plotted():
    """The titanium column (a dowel at the centre of each of its 13 joints, 50 kN yield): one force and
    one displacement line per dowel, the largest drawn force the history's largest (kN), at most the
    yield force; a run without dowels is refused by name."""
    from pathlib import Path
    col = pcf.Column.from_file(Path(__file__).resolve().parents[1] / "examples" / "column_parthenon_titanium.toml")
    dt = 0.01
    t = np.arange(0.0, 3.0, dt)
    acc = 4.0 * np.sin(2 * np.pi * t) * (t < 2.0)
    res = pcf.simulate(col, acc, dt, history=True, history_dt=0.02)
    fig = plots.plot_dowels(res, col)
    a1, a2 = fig.axes
    assert len(a1.get_lines()) == len(a2.get_lines()) == 13
    assert a1.get_ylabel() == "shear force |F| (kN)" and a2.get_ylabel() == "shear displacement |u| (mm)"
    peak = max(np.max(ln.get_ydata()) for ln in a1.get_lines())
    assert peak == pytest.approx(np.max(res.history.dowels[:, :, 1]) / 1000.0)
    assert peak <= 50.0 * (1 + 1e-9)
    assert any("(joint 0)" in ln.get_label() for ln in a1.get_lines())
    free = pcf.simulate(pcf.Column.parthenon(), acc, dt, history=True, history_dt=0.02)
    with pytest.raises(ParameterError, match="history has no dowels"):
        plots.plot_dowels(free)
