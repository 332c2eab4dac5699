"""Tests that fail when an EDP or collapse definition breaks.

The definitions are those of the paper (Psycharis, Fragiadakis & Stefanou, section
"Performance-based assessment") as docs/solver.md ("Collapse and EDPs") states them:

* ``u_top`` = max over time of the horizontal displacement of the capital's top-face centre
  relative to the base / BASE diameter (lower diameter of drum 1);
* ``u_d`` = max over joints of the residual dislocation / diameter at that joint, the
  dislocation of joint i being the horizontal distance between the centre of the upper
  block's bottom face and the centre of the lower block's top face (the ground's origin for
  the base joint), residual = its average over the last ``residual_window_s`` (2 s) of the
  computed response;
* ``collapsed`` with ``collapse_block`` (0-based: the lowest block of the part that fell,
  i.e. the block above the failing joint) and ``collapse_reason`` (overturning,
  off_footprint, falling: ``CF_SOLVER_COLLAPSE_*`` in csrc/solver.h).

Every expected number is computed here, independently of the solver (closed forms, or a
reconstruction from the solver's own pose histories where the test is about the definition,
not the dynamics), and every tolerance says where it comes from. Each test runs in well under a
second; the mutations each test guards against are listed in its docstring.

Diameters are circumscribed diameters (2 x circumradius of the polygon), as in
``Column.base_diameter`` and ``Column.joint_diameters``.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.structure.column import Block, Segment

G = 9.81
MU37 = math.tan(math.radians(37.0))   # default friction angle of the joints (paper Table I)


# --------------------------------------------------------------------------- helpers

def prism(width, height, n_sides=4):
    """A prismatic block of ``width`` across flats, flat sides normal to x and y for n_sides = 4."""
    r = 0.5 * width / math.cos(math.pi / n_sides)
    return Block((Segment(height, r, r, n_sides, math.pi / n_sides),))


def drum(d_bottom, height, d_top=None, n_sides=10):
    """A 10-gon drum (a frustum when ``d_top`` differs), a vertex along +x."""
    d_top = d_bottom if d_top is None else d_top
    return Block((Segment(height, 0.5 * d_bottom, 0.5 * d_top, n_sides, 0.0),))


def face_area(block, top=False):
    s = block.top if top else block.bottom
    r = s.r_top if top else s.r_bottom
    return 0.5 * s.n_sides * r * r * math.sin(2 * math.pi / s.n_sides)


def rotmat(q):
    """Rotation matrices of quaternions (..., 4) = (w, x, y, z), written out here (not pycolfrag's)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = (q[..., k] for k in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def face_centre(hist, col, i, top):
    """World position (n, 3), in the frame moving with the ground, of block i's top or bottom face
    centre, from the history's centre of mass and quaternion of block i."""
    b = col.blocks[i]
    dz = (b.height if top else 0.0) - b.centroid_height
    return hist.block_pos[:, i, :] + rotmat(hist.block_quat[:, i, :])[..., :, 2] * dz


def tilt_deg(hist, i):
    """Angle (deg) between block i's axis and the vertical, over time."""
    return np.degrees(np.arccos(np.clip(rotmat(hist.block_quat[:, i, :])[..., 2, 2], -1.0, 1.0)))


def rect_pulse(A, t0, dt, t_start=0.0, t_total=None):
    """Samples (step dt) of a rectangular pulse of A (m/s^2) on [t_start, t_start + t0], and its
    effective duration (impulse / A). The solver interpolates the record linearly, so each edge
    is a one-sample ramp worth half a sample: t0 + dt for a pulse starting after t = 0, t0 + dt/2
    for one starting at t = 0 (no ramp before the first sample)."""
    n = int(round((t_total if t_total is not None else t_start + t0 + dt) / dt)) + 1
    t = np.arange(n) * dt
    a = np.where((t >= t_start - 1e-12) & (t <= t_start + t0 + 1e-12), A, 0.0)
    return a, t0 + (dt if t_start > 0 else 0.5 * dt)


def newmark_rect(A, t_eff, mu, t, t_start=0.0):
    """Newmark (1965) rigid-plastic block under a rectangular base pulse A (> mu g) of duration t_eff
    starting at t_start, closed form: slip (m, >= 0, against the pulse) at the times ``t``.

    During the pulse the relative deceleration is A - mu g: s = (A - mu g) tau^2 / 2; after it the
    relative velocity V = (A - mu g) t_eff decays at mu g until the block sticks; final slip
    (A - mu g) A t_eff^2 / (2 mu g) = V^2 / (2 mu g) (1 - mu g / A)."""
    c, d = A - mu * G, mu * G
    tau = np.asarray(t, dtype=float) - t_start
    s1 = 0.5 * c * t_eff ** 2
    V = c * t_eff
    t_stop = V / d
    tau2 = np.clip(tau - t_eff, 0.0, t_stop)
    s = np.where(tau <= 0, 0.0, np.where(tau <= t_eff, 0.5 * c * tau ** 2, s1 + V * tau2 - 0.5 * d * tau2 ** 2))
    return s


def elastic_velocity_bound(A, ks, area, mass):
    """Velocity (m/s) that the elastic shear spring adds to the slip velocity of a rigid-plastic
    block at the onset of sliding under a step of A: during the loading of the spring up to
    mu N the block accelerates at up to A instead of A - mu g, for a time of order 1/omega,
    omega = sqrt(ks area / mass): at most A / omega (undamped step response). Rigid-plastic theory
    (Newmark) has no such spring; this is the tolerance's main term."""
    return A / math.sqrt(ks * area / mass)


# --------------------------------------------------------------------------- u_top

@pytest.mark.parametrize("amp_g", [0.58, 0.60])
def test_u_top_is_max_top_face_displacement_over_base_diameter(amp_g):
    """u_top = max over EVERY solver step of |horizontal displacement of the top face centre relative
    to the start| / base diameter.

    Column: three drums tapering from 1.0 m to 0.6 m (top diameter 0.6 x base, so dividing by the top
    diameter is off by 67 %), 0.58 and 0.60 g one-sine pulses of 1 s: rocks (u_top 0.47, 0.59), no
    collapse; two amplitudes so that the peak does not fall on a multiple of 4 steps in both.
    ``history_dt`` (1e-5 s) is below the solver step, so the history holds every step.

    Expected value: the top face centre reconstructed here from the history's centre of mass and
    quaternion of the top block (its offset from the centre of mass is height - centroid height,
    from the Column's geometry), its horizontal distance from its t = 0 position, maximum over the
    history, divided by ``Column.base_diameter``. Tolerance 1e-9 relative: the same states, only the
    rotation arithmetic differs (round-off, about 1e-15 m on metres); a maximum taken every 4th step
    only misses the peak by 1e-4 to 6e-4 relative (measured) whenever the peak step is not a
    multiple of 4, and fails. Also checks the
    ``top_disp`` history against the same reconstruction.

    Guards against: dividing by the top diameter; measuring the centre of mass or the bottom of
    the top block; sampling the maximum more coarsely than every step.
    """
    col = pcf.Column.from_drums([0.8, 0.8, 0.8], 1.0, 0.6)
    assert col.blocks[-1].top.r_top == pytest.approx(0.6 * col.blocks[0].bottom.r_bottom)
    dt = 0.005
    t = np.arange(0.0, 1.0 + dt / 2, dt)
    r = pcf.simulate(col, amp_g * G * np.sin(2 * np.pi * t), dt, tail_s=2.0, history=True, history_dt=1e-5,
                     early_exit=False)
    h = r.history
    assert not r.collapsed
    assert h.t.size == r.n_steps + 1                                   # every step is in the history
    np.testing.assert_allclose(np.diff(h.t), r.dt, rtol=1e-9)
    top = face_centre(h, col, col.n_blocks - 1, top=True)
    disp = top[:, :2] - top[0, :2]
    np.testing.assert_allclose(h.top_disp, disp, rtol=0, atol=1e-12)
    expected = np.max(np.hypot(disp[:, 0], disp[:, 1])) / col.base_diameter
    assert 0.3 < expected < 1.0
    assert r.u_top == pytest.approx(expected, rel=1e-9)
    assert r.max_top_disp == pytest.approx(expected * col.base_diameter, rel=1e-9)
    top_diam = 2 * col.blocks[-1].top.r_top
    assert r.u_top != pytest.approx(expected * col.base_diameter / top_diam, rel=0.1)


# --------------------------------------------------------------------------- u_d: Newmark sliding

def test_u_d_sliding_block_on_ground_is_newmark_slip_over_diameter():
    """A squat block on the ground that only slides: u_d = Newmark residual slip / base diameter.

    Block 2 m x 2 m x 0.5 m (square, flat sides normal to x; rocking needs a_g > g b/h = 4 g),
    friction 37 deg (mu = 0.754), kn = ks = 1e10 Pa/m, rectangular pulse A = 1.5 g for 0.5 s
    (sampled at 0.5 ms), then 2.5 s at rest: it slides during the pulse and 0.5 s after, then stands
    for the whole 2 s window.

    Expected: Newmark (1965) closed form for the rigid-plastic block,
    slip = (A - mu g) A t^2 / (2 mu g) with t the pulse's effective duration (impulse / A; the
    sampled edges are one-sample ramps). Tolerance: (a) the elastic shear spring (ks x face area)
    adds at most A / omega to the slip velocity at the onset (see ``elastic_velocity_bound``),
    i.e. 2 A / (omega V) relative on a slip proportional to V^2 (0.3 % here), plus (b) the elastic
    shear displacement left at rest, mu m g / (ks area) = 1e-6 m (negligible), plus (c) 1e-3 for
    the time step (1 ms pulse edges and leapfrog). Measured error 0.2 %.

    Guards against: a u_d normalised by anything else than the joint diameter (the block's
    circumscribed diameter 2.83 m; the side 2 m would be 41 % off); a residual taken as the
    maximum instead of the window's average would still pass here (the block stands still in the
    window) -- that is the next test.
    """
    blk = prism(2.0, 0.5)
    col = pcf.Column([blk], joints=pcf.JointProperties(kn=1e10, ks=1e10))
    A, t0, dt = 1.5 * G, 0.5, 0.0005
    a, t_eff = rect_pulse(A, t0, dt)
    r = pcf.simulate(col, a, dt, tail_s=2.5, early_exit=False)
    assert not r.collapsed
    slip = newmark_rect(A, t_eff, MU37, [1e9])[0]
    V = (A - MU37 * G) * t_eff
    m = col.block_masses[0]
    tol = 2 * elastic_velocity_bound(A, 1e10, face_area(blk), m) / V + MU37 * m * G / (1e10 * face_area(blk)) / slip + 1e-3
    D = col.joint_diameters[0]
    assert D == pytest.approx(2 * math.sqrt(2.0))
    print(f"\nslip: solver {r.residual_dislocation[0]:.5f} m, Newmark {slip:.5f} m, tolerance {tol:.2%}")
    assert r.residual_dislocation[0] == pytest.approx(slip, rel=tol)
    assert r.u_d == pytest.approx(slip / D, rel=tol)


def test_u_d_squat_block_on_a_fixed_lower_drum_is_newmark_slip_over_that_joints_diameter():
    """A squat block sliding on a lower drum that stays put: the residual of joint 1 is the Newmark
    slip relative to the drum, u_d = slip / joint 1's diameter.

    Lower drum 6 m x 6 m x 0.5 m (wide enough for the 1.82 m slip: the 2 m block's edge stays
    1.8 m inside the drum's; a 3 m drum let it slide off and fall) on a base joint with friction
    70 deg (mu = 2.75, a per-joint property): under A = 1.5 g it can neither slide (A < mu g) nor
    rock (a_g > g b / h_cg, about 9 g, needed with the upper block on it). Upper block 2 m x 2 m x 0.5 m, joint 1 at the default
    37 deg (mu = 0.754): it slides on the drum. kn = ks = 1e10 Pa/m everywhere; pulse and closed form
    as in the block-on-the-ground test above (Newmark 1965).

    Tolerance: the onset term 2 A / (omega V) of the upper block on joint 1, plus the same term
    for the lower drum ringing on its base springs (it follows the ground elastically, its own
    A / omega_0 feeding the upper block's relative velocity), plus 1e-3 for the time step. The
    base joint's residual must stay elastic: its shear spring carries at most A (m_1 + m_2), a
    displacement of A (m_1 + m_2) / (ks area_0) = 8e-6 m, asserted below 1e-4 m.

    Guards against: u_d measured from the ground or normalised by the base diameter (the drum's
    8.49 m against joint 1's 2.83 m); the base joint not taking its own friction."""
    lower, upper = prism(6.0, 0.5), prism(2.0, 0.5)
    base = pcf.JointProperties(kn=1e10, ks=1e10, friction_deg=70.0)
    col = pcf.Column([lower, upper], joints=pcf.JointProperties(kn=1e10, ks=1e10), joint_overrides={0: base})
    A, t0, dt = 1.5 * G, 0.5, 0.0005
    a, t_eff = rect_pulse(A, t0, dt)
    r = pcf.simulate(col, a, dt, tail_s=2.5, early_exit=False)
    assert not r.collapsed
    slip = newmark_rect(A, t_eff, MU37, [1e9])[0]
    V = (A - MU37 * G) * t_eff
    m1, m2 = col.block_masses
    tol = (2 * elastic_velocity_bound(A, 1e10, face_area(upper), m2) / V
           + 2 * elastic_velocity_bound(A, 1e10, face_area(lower), m1 + m2) / V + 1e-3)
    D1 = col.joint_diameters[1]
    assert D1 == pytest.approx(2 * math.sqrt(2.0)) and col.base_diameter == pytest.approx(6 * math.sqrt(2.0))
    print(f"\nslip on the drum: solver {r.residual_dislocation[1]:.5f} m, Newmark {slip:.5f} m, tolerance {tol:.2%}; "
          f"base joint {r.residual_dislocation[0]:.2e} m")
    assert r.residual_dislocation[0] < 1e-4
    assert r.residual_dislocation[1] == pytest.approx(slip, rel=tol)
    assert r.u_d == pytest.approx(slip / D1, rel=tol)


def test_u_d_is_measured_from_the_drum_below_stack_slides_as_one():
    """u_d of an upper joint is measured from the drum below, not from the ground.

    Two squat blocks: 2 m x 2 m x 0.5 m below, 1 m x 1 m x 0.25 m above (both far from rocking),
    same joints (friction 37 deg, kn = ks = 1e10), rectangular pulse 1.5 g for 0.5 s.

    Why not "a squat block on a fixed lower drum": with one friction coefficient for every joint
    (``JointProperties`` is per column and ``cf_solver_setup`` takes one mu), rigid-plastic theory
    forbids it. If the lower block stuck to the ground while the upper one slid on it, the lower
    block would carry m1 A + mu m2 g horizontally against a capacity mu (m1 + m2) g, i.e. it needs
    A <= mu g, but the upper block slides only if A > mu g. Whatever the lower block's size or mass,
    the stack slides as one on the ground (the upper joint sits exactly at its friction limit).
    Measured: a 6 x 6 x 2 m lower block (194 t under 0.7 t) slides 1.828 m with the upper joint
    at 3.9 mm, as here. A fixed lower drum needs per-joint friction or a "fixed blocks" option
    (not available yet).

    Expected (Newmark, closed form as above): the base joint slips the single-block slip, the upper
    joint 0 relative to the drum below; so u_d = slip / D0. Tolerances: base joint as in the
    single-block test with omega of the whole stack on the base joint; upper joint: the
    onset transient gives the upper block a relative velocity of at most A / omega2
    (omega2 = sqrt(ks area2 / m2)) which friction does not remove while the base slides (the upper
    block's friction and the lower block's acceleration are both mu g), so it drifts for the
    sliding time T = t A / (mu g): at most 2 A T / omega2 (factor 2 for the release transient);
    measured 3.2 mm against the bound 7.6 mm. Measured from the ground the upper joint would show
    the whole 1.8 m slip.

    Guards against: measuring a joint's dislocation from the ground (or from the lower block's
    centre of mass -- 0.25 m below its top face, which moves with rocking only); normalising
    the upper joint by the base diameter.
    """
    lower, upper = prism(2.0, 0.5), prism(1.0, 0.25)
    col = pcf.Column([lower, upper], joints=pcf.JointProperties(kn=1e10, ks=1e10))
    A, t0, dt = 1.5 * G, 0.5, 0.0005
    a, t_eff = rect_pulse(A, t0, dt)
    r = pcf.simulate(col, a, dt, tail_s=2.5, early_exit=False)
    assert not r.collapsed
    slip = newmark_rect(A, t_eff, MU37, [1e9])[0]
    V = (A - MU37 * G) * t_eff
    m1, m2 = col.block_masses
    tol0 = 2 * elastic_velocity_bound(A, 1e10, face_area(lower), m1 + m2) / V + 1e-3
    T_slide = t_eff * A / (MU37 * G)
    tol1 = 2 * elastic_velocity_bound(A, 1e10, face_area(upper), m2) * T_slide
    print(f"\nbase joint {r.residual_dislocation[0]:.5f} m (Newmark {slip:.5f}), upper joint "
          f"{r.residual_dislocation[1] * 1e3:.2f} mm (bound {tol1 * 1e3:.2f} mm)")
    assert r.residual_dislocation[0] == pytest.approx(slip, rel=tol0)
    assert r.residual_dislocation[1] < tol1
    D0, D1 = col.joint_diameters
    assert r.u_d == pytest.approx(max(r.residual_dislocation[0] / D0, r.residual_dislocation[1] / D1), rel=1e-12)
    assert r.u_d == pytest.approx(slip / D0, rel=tol0)


def test_u_d_is_the_window_average_not_the_last_value():
    """The residual is the average over the last ``residual_window_s`` (2 s), not the final value.

    The block of the single-block test (2 x 2 x 0.5 m, kn = ks = 1e10) stands still for 1 s, then a
    1.5 g pulse of 0.3 s makes it slide until t = 1.6 s; the record ends at 1.5 s and the tail is
    1 s, so the run ends at t = 2.5 s and the 2 s window [0.5, 2.5] s holds the whole slide: the
    window's average (about 0.39 m) is well below the final slip (0.66 m).

    Expected: (1) the window average of the solver's own dislocation history (sampled every 5 ms,
    the rate of the solver's residual ring buffer), tolerance 0.5 %: the history and the ring sample
    different instants 5 ms apart at most, on a motion of at most 2.2 m/s (11 mm) -- but at the
    window's ends the block stands still, so only the sample-count difference (1/400) remains;
    (2) the window average of the Newmark closed form (integrated on a 0.1 ms grid), tolerance as in
    the single-block test plus 1/400 for the discrete average; (3) the final value must NOT match
    (it is 1.7 x the average).

    Guards against: shrinking the window (0.01 s gives the last value), taking the last sample or the
    maximum, averaging over the wrong end of the history.
    """
    blk = prism(2.0, 0.5)
    col = pcf.Column([blk], joints=pcf.JointProperties(kn=1e10, ks=1e10))
    A, t0, dt, t1 = 1.5 * G, 0.3, 0.0005, 1.0
    a, t_eff = rect_pulse(A, t0, dt, t_start=t1, t_total=1.5)
    r = pcf.simulate(col, a, dt, tail_s=1.0, early_exit=False, history=True, history_dt=0.005)
    assert not r.collapsed
    assert r.options["residual_window_s"] == 2.0
    h = r.history
    t_end = r.t_end
    assert t_end == pytest.approx(2.5, abs=r.dt)
    D = col.joint_diameters[0]
    # (1) from the history
    win = h.t >= t_end - 2.0 - 1e-9
    mean_vec = h.joint_slip[win, 0, :].mean(axis=0)
    hist_avg = float(np.hypot(*mean_vec))
    final = float(np.hypot(*h.joint_slip[-1, 0, :]))
    # (2) Newmark, starting at t1 - dt/2 (the effective start of the ramped edge)
    tt = np.arange(t_end - 2.0, t_end + 1e-12, 1e-4)
    s = newmark_rect(A, t_eff, MU37, tt, t_start=t1 - 0.5 * dt)
    nm_avg, nm_final = float(s.mean()), float(s[-1])
    V = (A - MU37 * G) * t_eff
    tol = 2 * elastic_velocity_bound(A, 1e10, face_area(blk), col.block_masses[0]) / V + 1e-3 + 1 / 400
    print(f"\nwindow average: solver {r.residual_dislocation[0]:.5f} m, history {hist_avg:.5f} m, Newmark "
          f"{nm_avg:.5f} m; final: history {final:.5f} m, Newmark {nm_final:.5f} m")
    assert final / hist_avg > 1.5 and nm_final / nm_avg > 1.5      # the case discriminates
    assert r.residual_dislocation[0] == pytest.approx(hist_avg, rel=0.005)
    assert r.residual_dislocation[0] == pytest.approx(nm_avg, rel=tol)
    assert r.u_d == pytest.approx(hist_avg / D, rel=0.005)
    assert r.u_d != pytest.approx(final / D, rel=0.2)


# --------------------------------------------------------------------------- collapse

def _local_collapse_run(**kw):
    """Shaft of a 2 m drum and a 2 m -> 0.8 m frustum (0.6 m each; the whole column cannot rock below
    about 1.1 g and slides only above 0.75 g) carrying two 0.8 x 0.8 m drums (rock as one part above 0.5 g
    quasi-statically), 0.68 g one-sine pulse of 1 s: the top two drums overturn on the frustum."""
    col = pcf.Column([drum(2.0, 0.6), drum(2.0, 0.6, d_top=0.8), drum(0.8, 0.8), drum(0.8, 0.8)])
    dt = 0.005
    t = np.arange(0.0, 1.0 + dt / 2, dt)
    return col, pcf.simulate(col, 0.68 * G * np.sin(2 * np.pi * t), dt, tail_s=3.0, **kw)


def test_local_collapse_reports_the_block_that_fell():
    """Local collapse: the top two drums overturn on the shaft, which stands. ``collapse_block`` is
    the 0-based index of the lowest block that fell, here 2 (the block above the failing joint
    2), the reason "overturning".

    Expected: block 2 from the construction; checked on the pose history (every step): at the
    collapse the shaft (blocks 0, 1) is upright within 0.5 deg and blocks 2, 3 are tilted more than
    20 deg, and the criterion's threshold holds: the centre of mass of blocks 2-3 is two
    circumradii of the supporting face (2 x 0.4 m) from that face's centre, horizontally, within
    1 cm (criteria are checked every 4th step, about 3 ms, in which it moves about 4 mm).
    The amplitude 0.68 g lies in the middle of the band 0.60-0.76 g where this column collapses
    this way (scanned at 0.02 g steps, periods 0.8-1.2 s) so that small changes of the contact
    model do not move the case out of it.

    Guards against: reporting block 0 (or the top block) always; disabling the overturning
    criterion (the run then ends later by another reason); ending a run that did not collapse.
    """
    col, r = _local_collapse_run(history=True, history_dt=1e-5)
    assert r.collapsed
    assert r.collapse_block == 2
    assert r.collapse_reason == "overturning"
    assert 1.0 < r.collapse_time < 3.0
    h = r.history
    assert h.t[-1] == pytest.approx(r.collapse_time, abs=1e-9)
    assert tilt_deg(h, 0).max() < 0.5 and tilt_deg(h, 1).max() < 0.5
    assert tilt_deg(h, 2)[-1] > 20 and tilt_deg(h, 3)[-1] > 20
    m = np.array(col.block_masses[2:])
    com = (m[:, None] * h.block_pos[-1, 2:, :2]).sum(axis=0) / m.sum()
    dist = float(np.hypot(*(com - face_centre(h, col, 1, top=True)[-1, :2])))
    rc = col.blocks[1].top.r_top
    assert 2 * rc <= dist < 2 * rc + 0.01


def test_off_footprint_collapse_upper_block_slides_off():
    """off_footprint: a block slides off the block below (its bottom-face centre leaves the
    polygon of the face below).

    Lower block: square frustum 1.2 m -> 0.4 m wide, 0.8 m high; upper block 0.6 x 0.6 x 0.6 m;
    friction 10 deg; the whole column tilted rigidly by 22 deg about its +x base edge
    (``initial_tilt_rad``), no ground motion. On the inclined joint (22 deg > 10 deg) the upper
    block slides down and leaves the small top face (half-width 0.2 m) in about 0.2 s, while the
    column is still rocking back, before it can drop a quarter of its height or overturn. (A
    horizontal ground motion cannot do this with one friction coefficient: see the stack test.
    With a wide lower face the slide takes longer than the column's fall back onto the ground, and
    the undamped vertex contacts then bounce the upper block off instead: not a sliding case.)
    Same outcome, without energy warning, over tilts 18-30 deg and friction 5-15 deg (scanned).

    Expected: reason "off_footprint", block 1; checked on the pose history at the collapse: the
    upper bottom-face centre, in the lower block's top-face frame, is beyond the half-width 0.2 m
    along x or y by less than 1 cm (the criterion is checked every 4th step), still on the face's plane (< 1 cm off it: it slid, it did not fly), and the upper
    block is tilted less than 10 deg relative to the lower one (it did not overturn).

    Guards against: disabling the off_footprint criterion; reporting block 0 always.
    """
    c = 1 / math.cos(math.pi / 4)
    lower = Block((Segment(0.8, 0.6 * c, 0.2 * c, 4, math.pi / 4),))
    col = pcf.Column([lower, prism(0.6, 0.6)], joints=pcf.JointProperties(friction_deg=10.0))
    r = pcf.simulate(col, np.zeros(2), 0.005, tail_s=3.0, initial_tilt_rad=math.radians(22.0),
                     history=True, history_dt=1e-5)
    assert r.collapsed
    assert r.collapse_reason == "off_footprint"
    assert r.collapse_block == 1
    assert 0.05 < r.collapse_time < 1.0
    h = r.history
    cL = face_centre(h, col, 0, top=True)[-1]
    cU = face_centre(h, col, 1, top=False)[-1]
    R0 = rotmat(h.block_quat[-1, 0])
    X = R0.T @ (cU - cL)
    assert 0.2 < max(abs(X[0]), abs(X[1])) < 0.21    # just past the edge: 4 steps move it 5 mm
    assert abs(X[2]) < 0.01
    rel = (R0.T @ rotmat(h.block_quat[-1, 1]))[2, 2]
    assert math.degrees(math.acos(min(rel, 1.0))) < 10.0


def test_falling_collapse_upper_block_slides_down_a_steep_joint():
    """falling: a block's bottom-face centre is a quarter of its height below the top-face centre of
    the block that should carry it.

    Two blocks, 2 x 2 x 0.8 m below and 2 x 2 x 0.4 m above, friction 37 deg, column tilted rigidly
    by 45 deg about its +x base edge (below the whole column's overturning angle, 59 deg), no ground
    motion. On the 45 deg joint (> 37 deg) the upper block slides down; 0.15 m down the slope its
    centre is 0.1 m (a quarter of its height) lower than the lower block's top-face centre while
    still over the face (so neither off_footprint nor overturning applies). Stable over tilts
    38-54 deg and upper heights 0.3-0.5 m (scanned). Note: the criterion compares world heights, so
    sliding down a joint steeper than about 30 deg is a "fall" before the block leaves the face.

    Expected: reason "falling", block 1; checked on the pose history at the collapse: a drop of a
    quarter of 0.4 m exceeded by less than 1 cm (the criterion is checked every 4th step), bottom-face centre still inside the lower face (|x|, |y| < 1 m in its
    frame).

    Guards against: disabling the falling criterion; reporting block 0 always.
    """
    col = pcf.Column([prism(2.0, 0.8), prism(2.0, 0.4)])
    r = pcf.simulate(col, np.zeros(2), 0.005, tail_s=3.0, initial_tilt_rad=math.radians(45.0),
                     history=True, history_dt=1e-5)
    assert r.collapsed
    assert r.collapse_reason == "falling"
    assert r.collapse_block == 1
    assert 0.1 < r.collapse_time < 1.0
    h = r.history
    cL = face_centre(h, col, 0, top=True)[-1]
    cU = face_centre(h, col, 1, top=False)[-1]
    assert -0.25 * 0.4 - 0.01 < cU[2] - cL[2] < -0.25 * 0.4   # just past a quarter height (4 steps: 2 mm)
    X = rotmat(h.block_quat[-1, 0]).T @ (cU - cL)
    assert max(abs(X[0]), abs(X[1])) < 1.0
    assert abs(X[2]) < 0.01                     # on the joint's plane: it slid down, it did not fly


@pytest.mark.parametrize("amp_g", [0.36, 0.38, 0.40])
def test_multidrum_column_reaching_u_top_about_1_recovers_and_is_not_collapsed(amp_g):
    """The paper reports u_top = 1.15 without collapse: a run that reaches u_top about 1 and recovers
    must not be flagged.

    Default Parthenon column (12 drums + capital), one-sine pulse of period 2 s and amplitude
    0.36-0.40 g: u_top 0.90-1.16, the column rocks back and stands. These amplitudes lie inside the
    band 0.34-0.41 g where u_top grows smoothly from 0.82 to 1.23 without collapse (scanned at
    0.01 g; the column collapses at 0.20-0.33 g and above 0.41 g), so the case is deterministic
    and not on a knife edge.

    Expected: not collapsed, u_top > 0.8 (the definition of "about 1": beyond the 0.35 level and
    within 20 % of 1), and the column came back: over the last 2 s of a 6 s tail the top
    displacement stays below half of its peak (the undamped vertex contacts keep it rocking at
    0.13-0.39 of the peak; a fallen column would stay at or beyond it).

    Guards against: collapse criteria that fire on large but recoverable rocking (e.g. an
    overturning radius of one circumradius, or a falling/off_footprint test on rocking uplift).
    """
    col = pcf.Column.parthenon()
    dt = 0.005
    t = np.arange(0.0, 2.0 + dt / 2, dt)
    r = pcf.simulate(col, amp_g * G * np.sin(np.pi * t), dt, tail_s=6.0, history=True, history_dt=0.01)
    assert not r.collapsed and r.collapse_block is None and r.collapse_reason == ""
    assert 0.8 < r.u_top < 1.3
    h = r.history
    late = np.hypot(h.top_disp[:, 0], h.top_disp[:, 1])[h.t > r.t_end - 2.0] / col.base_diameter
    assert late.max() < 0.5 * r.u_top
    # u_d: max over joints of the residual dislocation over that joint's diameter (Column's definition)
    ratios = r.residual_dislocation / np.array(col.joint_diameters)
    assert r.u_d == pytest.approx(ratios.max(), rel=1e-12)
    print(f"\nu_top {r.u_top:.3f}, u_d {r.u_d:.4f} at joint {int(np.argmax(ratios))}")


# --------------------------------------------------------------------------- EDPs of a collapsed run

def test_collapsed_run_has_nan_u_d():
    """A collapsed run has no residual state: u_d is NaN (not the average of the last 2 s before
    the collapse was detected, which depends on when the criterion fired)."""
    _, r = _local_collapse_run()
    assert r.collapsed
    assert math.isnan(r.u_d)


def test_collapsed_run_has_nan_residual_dislocations():
    """Likewise the per-joint residual dislocations of a collapsed run are NaN."""
    _, r = _local_collapse_run()
    assert r.collapsed
    assert np.all(np.isnan(r.residual_dislocation))


def test_collapsed_run_keeps_u_top_and_standing_run_has_finite_u_d():
    """u_top of a collapsed run stays the maximum up to the collapse (finite, documented as such);
    a standing run has a finite u_d (the NaN is reserved to collapse)."""
    _, r = _local_collapse_run()
    assert r.collapsed and np.isfinite(r.u_top) and r.u_top > 0
    col = pcf.Column.parthenon()
    dt = 0.005
    t = np.arange(0.0, 2.0 + dt / 2, dt)
    s = pcf.simulate(col, 0.38 * G * np.sin(np.pi * t), dt, tail_s=4.0)
    assert not s.collapsed and np.isfinite(s.u_d) and np.all(np.isfinite(s.residual_dislocation))


# --------------------------------------------------------------------------- consumers of u_d
#
# A collapsed run's u_d is NaN (no residual state). Every consumer must give the same answer whether
# the collapsed rows hold NaN or the finite numbers the solver returned before (their EDPs are never
# used: collapse counts as exceeding every level; means, fits, plots and tables use the non-collapsed
# runs). Reference: the same computation on a copy of the table with finite placeholders in the
# collapsed rows (u_top 1.5, u_d 0.3: what today's solver returns after a collapse), compared exactly
# (the collapsed rows are masked before any arithmetic, so not even round-off may differ).

from pycolfrag.analysis import fragility as fr  # noqa: E402


def _table(seed=1, n=24):
    """Two magnitudes x two distances x n runs; about a third collapsed (more at Mw 7.5)."""
    g = np.random.default_rng(seed)
    mw = np.repeat([6.5, 7.5], 2 * n)
    dist = np.tile(np.repeat([5.0, 20.0], n), 2)
    pgv = 30 * np.exp(0.6 * g.standard_normal(mw.size)) * (mw - 5.5)
    u_top = 0.008 * pgv * np.exp(0.5 * g.standard_normal(mw.size))
    collapsed = u_top > 0.9
    u_d = 0.02 * u_top * np.exp(0.7 * g.standard_normal(mw.size))
    u_d[g.random(mw.size) < 0.1] = 0.0           # runs that never slid: exact zeros
    finite = dict(mw=mw, dist_km=dist, pgv=pgv, u_top=u_top.copy(), u_d=u_d.copy(), collapsed=collapsed)
    finite["u_top"][collapsed] = 1.5
    finite["u_d"][collapsed] = 0.3
    nan = dict(finite, u_top=finite["u_top"].copy(), u_d=finite["u_d"].copy())
    nan["u_d"][collapsed] = np.nan
    nan["u_top"][collapsed] = np.nan
    assert 5 < collapsed.sum() < mw.size // 2
    return finite, nan


def _same(a, b):
    """Exact equality of nested results (NaN == NaN), dataclasses and tuples included."""
    if hasattr(a, "__dataclass_fields__"):
        for k in a.__dataclass_fields__:
            _same(getattr(a, k), getattr(b, k))
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, (list, tuple)) and not isinstance(a, str):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    elif isinstance(a, (str, type(None))):
        assert a == b
    else:
        np.testing.assert_array_equal(a, b)


def test_fragility_ignores_the_edps_of_collapsed_runs():
    """Eqs. (1)-(4), bootstrap intervals, scenario tables, surfaces, stripe curves and the MLE curve
    are identical with NaN or finite placeholders in the collapsed rows; and the mean u_d of a
    scenario is the plain mean of its non-collapsed values (paper Fig. 8b)."""
    A, B = _table()
    for edp, thr in (("u_d", 0.01), ("u_top", 0.35)):
        for fn in (fr.exceedance, fr.empirical_exceedance):
            _same(fn(A[edp], A["collapsed"], thr), fn(B[edp], B["collapsed"], thr))
        for stat in ("eq4", "empirical", "mean"):
            kw = dict(statistic=stat, n_boot=100, rng=3)
            t = None if stat == "mean" else thr
            _same(fr.bootstrap_interval(A[edp], A["collapsed"], t, **kw),
                  fr.bootstrap_interval(B[edp], B["collapsed"], t, **kw))
        _same(fr.exceedance_surface(A["mw"], A["dist_km"], A[edp], A["collapsed"], thr, n_boot=50, rng=4),
              fr.exceedance_surface(B["mw"], B["dist_km"], B[edp], B["collapsed"], thr, n_boot=50, rng=4))
        _same(fr.mean_edp_surface(A["mw"], A["dist_km"], A[edp], A["collapsed"], n_boot=50, rng=5),
              fr.mean_edp_surface(B["mw"], B["dist_km"], B[edp], B["collapsed"], n_boot=50, rng=5))
        _same(fr.stripe_curve(A["pgv"], A[edp], A["collapsed"], thr, n_stripes=4, n_boot=50, rng=6),
              fr.stripe_curve(B["pgv"], B[edp], B["collapsed"], thr, n_stripes=4, n_boot=50, rng=6))
        _same(fr.fit_lognormal_fragility(A["pgv"], A[edp], A["collapsed"], thr, n_boot=10, rng=7),
              fr.fit_lognormal_fragility(B["pgv"], B[edp], B["collapsed"], thr, n_boot=10, rng=7))
    rows_a = fr.scenario_table(A["mw"], A["dist_km"], {"u_top": A["u_top"], "u_d": A["u_d"]}, A["collapsed"],
                               n_boot=50, rng=8)
    rows_b = fr.scenario_table(B["mw"], B["dist_km"], {"u_top": B["u_top"], "u_d": B["u_d"]}, B["collapsed"],
                               n_boot=50, rng=8)
    _same(rows_a, rows_b)
    for row in rows_b:
        sel = (B["mw"] == row.mw) & (B["dist_km"] == row.dist_km) & ~B["collapsed"]
        assert row.mean["u_d"] == pytest.approx(np.mean(A["u_d"][sel]), rel=1e-12)
        assert np.isfinite(row.mean["u_d"]) and np.isfinite(row.mu_ln["u_d"])


def test_fragility_still_refuses_nan_edps_of_standing_runs():
    """NaN is reserved to collapsed runs: a NaN u_d of a run that did not collapse is an error."""
    _, B = _table()
    e = B["u_d"].copy()
    e[np.flatnonzero(~B["collapsed"])[0]] = np.nan
    with pytest.raises(pcf.ParameterError, match="non-collapsed"):
        fr.exceedance(e, B["collapsed"], 0.01)


def _results_pair(tmp_path):
    """The synthetic results file of tests/test_figures.py (NaN EDPs in collapsed rows) and a copy
    with finite placeholders there."""
    import h5py

    from test_figures import write_results
    nan_path = write_results(tmp_path / "nan.h5", mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=2, vp_scale=3.0)
    fin_path = write_results(tmp_path / "finite.h5", mws=(6.5, 7.5), dists=(5.0, 20.0), n=20, n_failed=2, vp_scale=3.0)
    with h5py.File(fin_path, "r+") as f:
        c = f["samples/collapsed"][...].astype(bool)
        assert c.sum() > 3
        for k, v in (("u_top", 1.5), ("u_d", 0.3)):
            x = f[f"samples/{k}"][...]
            assert np.all(np.isnan(x[c]))
            x[c] = v
            f[f"samples/{k}"][...] = x
    return nan_path, fin_path


def test_report_and_validation_ignore_the_edps_of_collapsed_runs(tmp_path, monkeypatch):
    """The Markdown report and the validation claims are the same text with NaN or finite EDPs in the
    collapsed rows (the file names excepted), and print no "nan" for a mean u_d. Bootstrap sizes are
    cut (fewer resamples, no MLE band) to keep the test at a few seconds: the comparison is between
    two identical computations, so their size does not matter."""
    from pycolfrag.analysis import figures, report, validation
    orig_curves, orig_fit = report.im_curves, fr.fit_lognormal_fragility
    monkeypatch.setattr(report, "im_curves", lambda d, v, **kw: orig_curves(d, v, **{**kw, "n_boot": 5, "n_boot_mle": 0}))
    monkeypatch.setattr(fr, "fit_lognormal_fragility", lambda *a, **kw: orig_fit(*a, **{**kw, "n_boot": min(kw.get("n_boot", 0), 5)}))
    monkeypatch.setattr(validation, "N_BOOT", 50)
    nan_path, fin_path = _results_pair(tmp_path)
    texts = []
    for p in (nan_path, fin_path):
        out = report.write_report(p, tmp_path / (p.stem + ".md"), n_boot=20, figures_dir=tmp_path / "none")
        texts.append([ln.replace(str(p), "RESULTS") for ln in open(out).read().splitlines()])
    assert texts[0] == texts[1]
    table = [ln for ln in texts[0] if ln.startswith("| 7.5 |")][0]
    assert "nan" not in table.lower()
    d_nan, d_fin = figures.read_results(nan_path), figures.read_results(fin_path)
    _same(validation.key_numbers(d_nan, rng=1), validation.key_numbers(d_fin, rng=1))
    _same(validation.claims(d_nan, rng=1), validation.claims(d_fin, rng=1))


def test_figures_ignore_the_edps_of_collapsed_runs(tmp_path):
    """Figs. 7, 14 (scatter of the non-collapsed runs) show the same points, and Figs. 8, 13 (means
    and fragility surfaces) the same surfaces, with NaN or finite EDPs in the collapsed rows."""
    from pycolfrag.analysis import figures
    nan_path, fin_path = _results_pair(tmp_path)
    d = [figures.read_results(p) for p in (nan_path, fin_path)]
    for fig_fn in (figures.fig_07, figures.fig_14):
        f0, f1 = (fig_fn(x) for x in d)
        for a0, a1 in zip(f0.axes, f1.axes):
            for c0, c1 in zip(a0.collections, a1.collections):
                np.testing.assert_array_equal(c0.get_offsets(), c1.get_offsets())
            assert a0.get_title() == a1.get_title()
    for fig_fn in (figures.fig_08, figures.fig_13):
        f0, f1 = (fig_fn(x, n_boot=20, rng=2) for x in d)
        for a0, a1 in zip(f0.axes, f1.axes):
            for c0, c1 in zip(a0.collections, a1.collections):
                v0 = getattr(c0, "_vec", None)
                if v0 is not None:
                    np.testing.assert_array_equal(v0, c1._vec)


def test_plots_show_nan_u_d_of_a_collapsed_run_as_not_available():
    """Debug plots of a collapsed run (u_d NaN) draw, and say "n/a (collapsed)" instead of "nan"."""
    from types import SimpleNamespace

    from pycolfrag.plots import response as plots
    col = pcf.Column.from_drums([1.0, 1.0], 1.0)
    dt = 0.01
    t = np.arange(0.0, 1.0, dt)
    res = pcf.simulate(col, 0.3 * G * np.sin(2 * np.pi * t), dt, history=True, history_dt=0.02, tail_s=0.5)
    res = SimpleNamespace(**{k: getattr(res, k) for k in res.__dataclass_fields__})
    res.u_d, res.collapsed, res.collapse_time, res.collapse_block, res.collapse_reason = (
        math.nan, True, 1.2, 1, "overturning")
    fig = plots.plot_joint_slips(res, col)
    title = fig.axes[0].get_title()
    assert "n/a (collapsed)" in title and "nan" not in title
    fig = plots.plot_record_response(col, 0.3 * G * np.sin(2 * np.pi * t), dt, res=res)
    assert "u_d = n/a (collapsed)" in fig.get_suptitle()
