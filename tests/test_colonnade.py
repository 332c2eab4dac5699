"""Colonnades (pycolfrag.structure.scene): the rocking frame of Makris & Vassiliou (2013) against their closed
forms, the rest state of the portals, a one-column scene against its column's bits, the reports of
columns and epistyles (unseating), the energy ledger, the scene files, and bad input."""
import math
import os
import sys

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.solver import scene_setup as scene_run
from pycolfrag.structure import scene
from pycolfrag.structure.column import JointProperties
from pycolfrag.structure.scene import Colonnade, Epistyle

sys.path.insert(0, os.path.dirname(__file__))
from reference_solutions import rocking_frame_first_excursion  # noqa: E402  (tests/ is not a package)

G = 9.81
EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "examples")

# ---- Makris & Vassiliou (2013): two equal rigid columns with a free rigid cap beam ------------
# Columns 0.5 m x 5 m (b = 0.25, h = 2.5 m: alpha = atan 0.1, R = 2.512 m, p = 1.711 rad/s), 3 m apart;
# a cap beam 0.5 m high and as wide as the columns, bearing on their whole tops; stiff contacts
# (kn = ks = 1e11 Pa/m) and friction 60 degrees (no sliding: the frame's mechanism is rocking alone).
B, H = 0.25, 2.5
ALPHA = math.atan(B / H)
P = math.sqrt(3.0 * G / (4.0 * math.hypot(B, H)))
STIFF = JointProperties(kn=1e11, ks=1e11, friction_deg=60.0)


def frame(gamma):
    """The frame with the beam-to-columns mass ratio gamma (0: the two columns alone)."""
    col = pcf.Column.single_block(2 * B, 2 * H, joints=STIFF)
    if gamma == 0.0:
        return Colonnade(col, 2, 3.0, epistyle=None)
    length, width, height = 3.0 + 2 * B, 2 * B, 0.5
    rho = gamma * 2 * col.mass / (length * width * height)
    return Colonnade(col, 2, 3.0, epistyle=Epistyle(height, density=rho, joints=STIFF))


@pytest.mark.parametrize("gamma", [0.0, 0.5, 2.0])
def test_rocking_frame_uplifts_at_the_columns_own_threshold(gamma):
    """Makris & Vassiliou: the frame starts to rock at a_g = g tan(alpha), whatever the beam's mass.
    A 10 s ramp to 1.3 g tan(alpha); the frame's uplift is its mechanism's -- both columns' base joints
    open (a corner lifted by 10 nm) -- within 2 % (measured +0.03 to +0.12 %: the ramp's lag). The
    beam's inertia, acting at its centre 0.25 m above its bearings, shifts weight from one column to
    the other, so one base alone lifts a corner earlier (measured 0.957 and 0.929 g tan(alpha) for
    gamma 0.5 and 2); the rigid analysis' mechanism is the frame's uplift, as this test reads it."""
    fr = frame(gamma)
    assert fr.gamma == pytest.approx(gamma, rel=1e-9, abs=1e-12)
    t = np.arange(0.0, 10.0, 0.002)
    rate = 1.3 * G * math.tan(ALPHA) / 10.0
    r = pcf.simulate(fr, rate * t, 0.002, history=True, planar=True, early_exit=False, tail_s=0.0,
                     history_dt=0.001)
    both = r.history.joint_opening[:, :2].min(axis=1)   # joints 0 and 1: the two columns' bases
    a_uplift = rate * r.history.t[int(np.argmax(both > 1e-8))]
    assert a_uplift / (G * math.tan(ALPHA)) == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 2.0])
def test_rocking_frame_rocks_as_one_column_of_p_hat(gamma):
    """Makris & Vassiliou: the frame rocks as one column of the same slenderness and frequency
    parameter p_hat = p sqrt((1 + 2 gamma) / (1 + 3 gamma)) (the closed form and the definition of
    gamma, the beam's mass over all the columns', derived from the frame's Lagrangian in
    tests/reference_solutions.py). A one-sine pulse 2.5 g tan(alpha), 1 s: the columns' peak rotation and
    the time of the first impact are those of that column's equation (solve_ivp from the uplift)
    within 2 % (measured 0.3 to 1.2 % on the peak, 0.1 to 0.4 % on the time); with p in place of
    p_hat the peak would be 43 % off at gamma = 2."""
    A, Tp = 2.5 * G * math.tan(ALPHA), 1.0
    t = np.arange(0.0, 4.0, 0.001)
    ag = np.where(t < Tp, A * np.sin(2 * np.pi * t / Tp), 0.0)
    r = pcf.simulate(frame(gamma), ag, 0.001, history=True, planar=True, early_exit=False, tail_s=0.0,
                     history_dt=0.0005)
    theta = -2.0 * np.arcsin(r.history.block_quat[:, 0, 2])   # column 0 tips toward -x: about -y
    t_sim = r.history.t
    impact = t_sim[int(np.argmax((theta < 0) & (t_sim > 0.3)))]
    p_hat = P * math.sqrt((1 + 2 * gamma) / (1 + 3 * gamma))
    ag_fn = lambda s: A * math.sin(2 * math.pi * s / Tp) if s < Tp else 0.0   # noqa: E731
    t_up = math.asin(G * math.tan(ALPHA) / A) * Tp / (2 * math.pi)
    th_max, t_imp = rocking_frame_first_excursion(ag_fn, ALPHA, p_hat, t_up, 6.0)
    assert theta.max() == pytest.approx(th_max, rel=0.02)
    assert impact == pytest.approx(t_imp, rel=0.02)
    if gamma == 2.0:
        th_p, _ = rocking_frame_first_excursion(ag_fn, ALPHA, P, t_up, 6.0)
        assert abs(th_p / th_max - 1.0) > 0.3
    assert r.energy_error < 0.05


# ---- the portals -----------------------------------------------------------------------------

def test_portals_start_at_rest():
    """Without ground motion: the 2-column portal is in exact equilibrium (every body within 1e-9 m
    for 1 s: each column's joints and the bearings pre-compressed by what they carry, beam level).
    The 4-column portal's inner columns carry their two epistyles' ends unequally (the outer blocks
    are longer): an eccentric load the uniform start does not take up, so it vibrates by 18 um
    (measured; under 5e-5 m)."""
    for n, bound in ((2, 1e-9), (4, 5e-5)):
        r = pcf.simulate(Colonnade.portal(n), np.zeros(200), 0.005, history=True, early_exit=False)
        drift = np.abs(r.history.block_pos - r.history.block_pos[0]).max()
        assert drift < bound, (n, drift)


def test_one_column_scene_is_its_columns_bits():
    col = pcf.Column.parthenon()
    t = np.arange(0.0, 2.0, 0.005)
    acc = 0.25 * G * np.sin(2 * np.pi * 2 * t)
    a = pcf.simulate(col, acc, 0.005, history=True)
    b = pcf.simulate(Colonnade(col, 1, epistyle=None), acc, 0.005, history=True)
    assert (a.u_top, a.u_d, a.energy_error, a.n_steps) == (b.u_top, b.u_d, b.energy_error, b.n_steps)
    np.testing.assert_array_equal(a.history.block_pos, b.history.block_pos)
    assert b.columns["u_top"].tolist() == [a.u_top]


def test_portal_reports_columns_and_epistyles():
    t = np.arange(0.0, 3.0, 0.005)
    acc = 0.25 * G * np.sin(2 * np.pi * 2 * t)
    r = pcf.simulate(Colonnade.portal(4), acc, 0.005, history=True)
    assert r.u_top == r.columns["u_top"].max() and r.u_d == np.nanmax(r.columns["u_d"])
    assert r.max_top_disp == r.columns["max_top_disp"].max()
    assert r.epistyle_slip_mm == pytest.approx(r.epistyles["slip"].max() * 1e3)
    assert len(r.epistyles["slip"]) == 3 and np.isnan(r.dowel_shear_kn)
    # the columns' joints, then the bearing tiles: 1 + 2 | 2 + 2 | 2 + 1 (an inner end's half abacus is two squares)
    assert r.history.joint_slip.shape[1] == 4 * 13 + 10
    assert r.energy_error < 0.05


def test_an_epistyle_on_slippery_bearings_is_unseated():
    """Bearings of 5 degrees friction under a 0.3 g 0.5 Hz half-cycle: the epistyle slides until its
    seat's centre leaves a capital's top -- half the seat overhangs -- and the run ends there: reason
    'unseated', the epistyle named, its unseating ratio (slip / half the seat) just past 1."""
    p = Colonnade.portal(2, epistyle=Epistyle(1.35, joints=JointProperties(friction_deg=5.0)))
    t = np.arange(0.0, 2.0, 0.005)
    r = pcf.simulate(p, 0.3 * G * np.sin(2 * np.pi * 0.5 * t), 0.005)
    assert r.collapsed and r.collapse_reason == "unseated" and r.collapse_part == "epistyle 0"
    assert r.collapse_block == 26 and r.epistyles["collapsed"].tolist() == [True]
    assert 1.0 < r.epistyle_unseat < 1.05
    assert np.isnan(r.epistyles["residual_slip"]).all() and np.isnan(r.u_d)


def test_ledger_of_a_portal_converges_with_the_step():
    """A hard case: the 4-column portal rocking under a 0.35 g 1 Hz burst. The balance error falls
    as the step is shortened (dt_factor 0.8 -> 0.2)."""
    t = np.arange(0.0, 3.0, 0.005)
    acc = 0.35 * G * np.sin(2 * np.pi * 1.0 * t)
    errs = [pcf.simulate(Colonnade.portal(4), acc, 0.005, dt_factor=f, early_exit=False, tail_s=1.0).energy_error
            for f in (0.8, 0.4, 0.2)]
    assert errs[0] < 0.05
    assert errs[2] < errs[1] < errs[0]


def _same(a, b, what):
    """Two Responses of a scene bitwise equal (NaN == NaN): EDPs, residuals, every column's and
    epistyle's outputs, histories."""
    for key in ("u_top", "u_d", "n_steps", "t_end", "collapsed", "collapse_block", "collapse_time", "collapse_reason",
                "collapse_part", "energy_error", "energy_scale", "max_top_disp", "message", "epistyle_slip_mm",
                "epistyle_unseat"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=f"{what}: {key}")
    np.testing.assert_array_equal(a.residual_dislocation, b.residual_dislocation, err_msg=f"{what}: residuals")
    for part in ("columns", "epistyles"):
        for key in getattr(a, part):
            np.testing.assert_array_equal(getattr(a, part)[key], getattr(b, part)[key], err_msg=f"{what}: {part} {key}")
    for key in ("t", "top_disp", "block_pos", "block_quat", "joint_opening", "joint_slip", "joint_normal_force"):
        np.testing.assert_array_equal(getattr(a.history, key), getattr(b.history, key), err_msg=f"{what}: {key}")
    for key in a.history.energy:
        np.testing.assert_array_equal(a.history.energy[key], b.history.energy[key], err_msg=f"{what}: {key}")


@pytest.mark.parametrize("n", [2, 4])
def test_batch_of_a_portal_is_its_single_runs(n):
    """A scene of several columns with epistyles runs in SIMD lanes as a column does (each lane's monitor
    reads every body of its run: csrc/solver_batch_lanes.h), and every run of a batch at every width is
    bitwise its single run (tolerance zero: the lanes do the single run's operations in its order),
    its columns' and epistyles' outputs and histories included; records of different lengths (lanes
    refilled), one strong enough to rock the portal hard."""
    p = Colonnade.portal(n)
    recs = [(a * G * np.sin(2 * np.pi * 2 * np.arange(0.0, d, 0.005)), 0.005)
            for a, d in ((0.2, 1.5), (0.45, 1.2), (0.3, 0.5), (0.25, 1.0), (0.35, 0.8))]
    widest = pcf.solver.run.batch_width(p, tail_s=0.5)
    assert widest == pcf.solver.run.batch_width(pcf.Column.parthenon(), tail_s=0.5)
    singles = [pcf.simulate(p, acc, dt, history=True, tail_s=0.5) for acc, dt in recs]
    assert max(s.epistyle_slip_mm for s in singles) > 0.0
    for width in (w for w in (1, 2, 4, 8) if w <= widest):
        for i, (s, b) in enumerate(zip(singles, pcf.simulate_batch(p, recs, history=True, width=width, tail_s=0.5))):
            _same(s, b, f"portal {n} width {width} run {i}")


# ---- files and bad input ------------------------------------------------------------------------

@pytest.mark.parametrize("n", [2, 4])
def test_example_scene_files_are_the_portals(n):
    p = Colonnade.from_file(os.path.join(EXAMPLES, f"portal_{n}.toml"))
    assert p.to_json() == Colonnade.portal(n).to_json()
    assert Colonnade.from_dict(p.to_dict()).to_json() == p.to_json()


def test_bad_scenes_are_refused_naming_the_value(tmp_path):
    col = pcf.Column.parthenon()
    with pytest.raises(pcf.ParameterError, match="the columns overlap"):
        Colonnade(col, 2, spacing=1.5)
    with pytest.raises(pcf.ParameterError, match="wider than the capitals' top square"):
        Colonnade(col, 2, epistyle=Epistyle(1.35, width=2.0))
    with pytest.raises(pcf.ParameterError, match="needs at least 2 columns"):
        Colonnade(col, 1)
    f = tmp_path / "s.toml"
    f.write_text('column = "%s"\nn_columns = 2\nspacng = 4.0\n' % os.path.join(EXAMPLES, "column_parthenon.toml"))
    with pytest.raises(pcf.ParameterError, match=r"unknown keys \['spacng'\]"):
        Colonnade.from_file(f)


def test_the_solver_refuses_a_beam_on_one_column():
    """An epistyle that does not reach two capitals, and two columns too close, refused by the C
    set-up itself (a scene built by hand), nothing run."""
    col = pcf.Column.single_block(0.5, 2.0)
    one = scene.SceneParts([(col, -1.5, 0.0), (col, 1.5, 0.0)],
                               beams=[scene.Beam(-1.5, 0.0, 0.5, 0.5, 0.3, 2700.0)],
                               bearings=[scene.Bearing(0, 0, -1.5, 0.0, 0.5, col.joints)])
    solver = pcf.core.ffi.ffi.gc(pcf.core.ffi.lib.cf_solver_create(), pcf.core.ffi.lib.cf_solver_free)
    d = pcf.SolverOptions().to_c()
    with pytest.raises(pcf.ParameterError, match="beam 0 does not reach two capitals"):
        scene_run.setup(solver, d, one, "test")
    close = scene.SceneParts([(col, 0.0, 0.0), (col, 0.5, 0.0)])
    with pytest.raises(pcf.ParameterError, match="columns 0 and 1 overlap"):
        scene_run.setup(solver, d, close, "test")


def row(n, gamma):
    """n of the frame's columns 3 m apart under epistyles whose mass is gamma x the columns'."""
    col = pcf.Column.single_block(2 * B, 2 * H, joints=STIFF)
    length, width, height = 3.0 * (n - 1) + 2 * B, 2 * B, 0.5
    return Colonnade(col, n, 3.0, epistyle=Epistyle(height, density=gamma * n * col.mass / (length * width * height),
                                                    joints=STIFF))


def test_a_row_of_three_columns_is_not_the_rocking_frame():
    """The frame's threshold g tan(alpha) holds for 2 columns only. Three of the
    frame's columns under two epistyles (the inner column carries each on half its capital), the same
    10 s ramp: every base open at 0.950 and 0.891 g tan(alpha) for gamma 0.5 and 2 (measured), below
    the 2-column frame's 1.000 by more than the 2 % that test allows and lower for the heavier
    epistyles; Colonnade.gamma says so where it is."""
    t = np.arange(0.0, 10.0, 0.002)
    rate = 1.3 * G * math.tan(ALPHA) / 10.0
    lifts = []
    for gamma in (0.5, 2.0):
        r = pcf.simulate(row(3, gamma), rate * t, 0.002, history=True, planar=True, early_exit=False, tail_s=0.0,
                         history_dt=0.001)
        every = r.history.joint_opening[:, :3].min(axis=1)
        lifts.append(rate * r.history.t[int(np.argmax(every > 1e-8))] / (G * math.tan(ALPHA)))
    assert lifts[0] < 0.97 and lifts[1] < lifts[0] - 0.03
    assert lifts == pytest.approx([0.950, 0.891], abs=0.01)
    doc = " ".join(Colonnade.gamma.__doc__.split())
    assert "2-column portal only" in doc and "below ``g tan(alpha)``" in doc
