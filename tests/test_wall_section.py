"""A section scaled along y (csrc/geometry.h, pycolfrag/structure/segment.py): the rectangular block of a
wall, ``Segment.rectangle(h, b, d)`` -- width b along x, depth d along y.

The closed forms: a rigid rectangular block of width b (in the direction of shaking) and height h on
rigid ground lifts off, and under a held acceleration overturns, at a = g b / h (its centre of mass
h / 2 over the pivot edge b / 2 away); shaken along y it lifts at g d / h. The method is
tests/test_as_built.py's quasi-static ramp and hold (2 s ramp, 6 s hold), stiff joints (kn = ks = 1e11
Pa/m): the block stands at 0.99x and overturns at 1.01x. Measured by bisection (10 halvings) for b = 0.4,
d = 1.0, h = 2: vertex 0.99995 both ways, perimeter the same. The exact model's pressure is linear over the
compressed part, a tensionless Winkler foundation: its quasi-static threshold is lower by the soft joint's
shift of the lever arm, which the closed form of :func:`winkler_threshold` gives independently of the code
(0.9659 of g b/h along x, 0.9815 of g d/h along y here); measured by bisection 0.96113 and 0.97725, 0.5 %
and 0.4 % under it (the closed form's small-rotation lever and no sinking of the block), so the test
holds the exact model to the closed form within 1 %; the block turned a quarter (b and d swapped) swaps
the two thresholds between the axes -- the section's orientation.
"""
import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib, segment_arrays
from pycolfrag.structure.column import Block, Column
from pycolfrag.structure.segment import Segment

G = 9.81
JOINTS = pcf.JointProperties(kn=1e11, ks=1e11)
B, D, H = 0.4, 1.0, 2.0


def wall_block(b=B, d=D, h=H, joints=JOINTS):
    return Column((Block((Segment.rectangle(h, b, d),), name="block"),), joints=joints)


def overturns(col, level_g, axis, contact, t_ramp=2.0, t_hold=6.0, dt=0.01):
    t = np.arange(0.0, t_ramp + t_hold, dt)
    a = level_g * G * np.minimum(t / t_ramp, 1.0)
    if axis == "x":
        r = pcf.simulate(col, a, dt, tail_s=0.0, contact=contact)
    else:
        r = pcf.simulate(col, np.zeros_like(a), dt, acc_y=a, tail_s=0.0, contact=contact)
    # Overturned: flagged, or lying on its side (the top moved by more than the block's height). A block squat
    # in the direction it falls (twice its corner ellipse's radius that way above its centre of mass's height:
    # here d = 1 m along y, 2 x 0.71 m > 1 m) is never flagged "overturning" -- no more than a regular block as
    # squat (csrc/solver_monitor.c, beyond(), continuous at aspect 1) -- "falling" at most.
    assert not r.collapsed or r.collapse_reason in ("overturning", "falling"), r.collapse_reason
    return r.collapsed or r.max_top_disp > col.height


@pytest.mark.parametrize("contact", ["vertex", "perimeter"])
@pytest.mark.parametrize("axis", ["x", "y"])
def test_rectangular_block_lifts_at_g_width_over_height_in_each_direction(contact, axis):
    closed = (B if axis == "x" else D) / H
    col = wall_block()
    assert not overturns(col, 0.99 * closed, axis, contact)
    assert overturns(col, 1.01 * closed, axis, contact)


def winkler_threshold(w, h, rho, kn, g=G) -> float:
    """Quasi-static overturning acceleration (in g) of a rigid block of width ``w`` along the shaking, height
    ``h`` and density ``rho`` on a tensionless Winkler foundation of modulus ``kn`` (Pa/m), small rotations:
    turned by theta about its toe, the contact strip is c = K / sqrt(theta) long, K = sqrt(2 rho g w h / kn)
    (the weight rho g w h per unit depth on a triangular pressure kn theta x), its resultant c/3 from the
    toe, and the weight's lever shrinks by (h/2) theta: a/g = max over theta of (w/2 - c/3 - (h/2) theta) /
    (h/2), at theta* = (K / (3 h))^(2/3). Whatever the block's depth."""
    k = math.sqrt(2.0 * rho * g * w * h / kn)
    theta = (k / (3.0 * h)) ** (2.0 / 3.0)
    return (0.5 * w - k / math.sqrt(theta) / 3.0 - 0.5 * h * theta) / (0.5 * h)


def test_exact_model_sees_the_section_turned_with_the_block():
    """The exact model's thresholds hold the Winkler closed form (the module's text) within 1 % both ways,
    and swapping b and d swaps them between the axes."""
    rho = wall_block().density
    for (b, d), axis in (((B, D), "x"), ((B, D), "y"), ((D, B), "y"), ((D, B), "x")):
        w = b if axis == "x" else d
        closed = winkler_threshold(w, H, rho, JOINTS.kn)
        col = wall_block(b, d)
        assert not overturns(col, 0.99 * closed, axis, "exact"), (b, d, axis)
        assert overturns(col, 1.01 * closed, axis, "exact"), (b, d, axis)


@pytest.mark.parametrize("contact", ["vertex", "perimeter", "exact"])
def test_wall_of_courses_stands_at_rest(contact):
    """Three courses 1 m high, 0.5 x 2 m, no ground motion: every block stays within 1e-9 m (the joints
    pre-compressed by what they carry) and the energy balance closes."""
    col = Column([Block((Segment.rectangle(1.0, 0.5, 2.0),)) for _ in range(3)], joints=JOINTS)
    r = pcf.simulate(col, np.zeros(100), 0.01, history=True, early_exit=False, contact=contact)
    assert np.abs(r.history.block_pos - r.history.block_pos[0]).max() < 1e-9
    assert not r.collapsed and r.energy_error < 1e-6


def _housner_impact_time(b, h, th0, dt=1e-6):
    """Housner's rigid block (width b, height h) released at rest tilted by th0 about its edge: the time to
    its first impact, theta'' = -p^2 sin(alpha - theta), p^2 = 3 g / (4 R) (I_O = 4/3 m R^2 for a box about
    its edge, R the half-diagonal of the rocking plane), integrated by RK4 to theta = 0."""
    alpha, p2 = math.atan(b / h), 3.0 * G / (2.0 * math.hypot(b, h))
    th, w, t = th0, 0.0, 0.0

    def f(x):
        return -p2 * math.sin(alpha - x)

    while True:
        k1 = (w, f(th))
        k2 = (w + 0.5 * dt * k1[1], f(th + 0.5 * dt * k1[0]))
        k3 = (w + 0.5 * dt * k2[1], f(th + 0.5 * dt * k2[0]))
        k4 = (w + dt * k3[1], f(th + dt * k3[0]))
        thn = th + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        w += dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        if thn <= 0.0:
            return t + dt * th / (th - thn)
        th, t = thn, t + dt


@pytest.mark.parametrize("b, d", [(B, D), (D, B)])
def test_free_rocking_takes_the_inertia_about_y(b, d):
    """Released tilted by half its slenderness about its +x edge, the block falls back to its first impact
    in Housner's time, which holds the inertia about y (m (b^2 + h^2) / 12, not about x: that one, m (d^2 +
    h^2) / 12, would move the time by 2.5 % for (b, d) = (0.4, 1)); the time is read where the centre of mass
    crosses back over the base's centre (history every 0.5 ms, interpolated). Measured: -1.9e-4 and
    -1.7e-4 of the closed form (the joints' compliance, kn = 1e11 Pa/m)."""
    th0 = 0.5 * math.atan(b / H)
    r = pcf.simulate(wall_block(b, d), np.zeros(100), 0.01, history=True, history_dt=0.0005, initial_tilt_rad=th0,
                     early_exit=False, tail_s=0.0)
    x, t = r.history.block_pos[:, 0, 0], r.history.t
    i = int(np.nonzero(x <= 0.0)[0][0])
    t1 = t[i - 1] + (t[i] - t[i - 1]) * x[i - 1] / (x[i - 1] - x[i])
    assert t1 == pytest.approx(_housner_impact_time(b, H, th0), rel=1e-3)


def test_mass_properties_are_the_boxs():
    """C's block properties (csrc/geometry.c) against m = rho b d h, ixx = m (d^2 + h^2) / 12, iyy =
    m (b^2 + h^2) / 12, izz = m (b^2 + d^2) / 12, and Python's volume and centroid."""
    seg = Segment.rectangle(H, B, D)
    segs, _ = segment_arrays([Block((seg,))])
    p = ffi.new("cf_geometry_massprops *")
    assert lib.cf_geometry_block_props(segs, 1, 2700.0, p) == lib.CF_OK
    m = 2700.0 * B * D * H
    assert p.mass == pytest.approx(m, rel=1e-13) and seg.volume == pytest.approx(B * D * H, rel=1e-13)
    assert p.ixx == pytest.approx(m * (D * D + H * H) / 12, rel=1e-12)
    assert p.iyy == pytest.approx(m * (B * B + H * H) / 12, rel=1e-12)
    assert p.izz == pytest.approx(m * (B * B + D * D) / 12, rel=1e-12)
    assert seg.centroid_height == pytest.approx(H / 2, rel=1e-13)
    assert seg.circumradius() == pytest.approx(0.5 * math.hypot(B, D), rel=1e-13)
    xs, ys = zip(*seg.vertices())
    assert max(xs) == pytest.approx(B / 2, rel=1e-13) and max(ys) == pytest.approx(D / 2, rel=1e-13)


def test_segment_aspect_is_checked_and_read_from_files():
    for bad in (0.0, -1.0, float("nan"), float("inf"), "wide"):
        with pytest.raises(ParameterError, match="aspect"):
            Segment(1.0, 0.5, 0.5, 4, 0.0, bad)
    with pytest.raises(ParameterError, match="rectangle depth"):
        Segment.rectangle(1.0, 0.5, -2.0)
    seg = Segment.rectangle(1.0, 0.5, 2.0)
    assert Segment.from_dict(seg.to_dict()) == seg
    assert Segment.from_dict({"height": 1.0, "width": 0.5, "depth": 2.0}) == seg
    assert "aspect" not in Segment(1.0, 0.5, 0.5).to_dict()   # a drum's table as before
    with pytest.raises(ParameterError, match="segment: a rectangular segment takes height, width and depth only"):
        Segment.from_dict({"height": 1.0, "width": 0.5, "depth": 2.0, "n_sides": 4})
    with pytest.raises(ParameterError, match="segment: a rectangular segment"):
        Segment.from_dict({"height": 1.0, "width": 0.5})
    col = wall_block()
    assert Column.from_dict(col.to_dict()).to_json() == col.to_json()


def test_c_refuses_a_bad_aspect_by_name():
    """A NaN aspect reaching C (past Python's checks) is refused by the set-up, naming the segment."""
    col = wall_block()
    object.__setattr__(col.blocks[0].segments[0], "aspect", float("nan"))
    with pytest.raises(ParameterError, match="segment 0: aspect must be finite"):
        pcf.simulate(col, np.zeros(10), 0.01)


def test_as_built_values_on_a_scaled_section_are_refused_by_name():
    seg = Segment.rectangle(1.0, 0.5, 2.0)
    with pytest.raises(ParameterError, match="are for regular sections; a segment here has aspect 4"):
        Column((Block((seg,)), Block((seg,), offset=(0.01, 0.0))), joints=JOINTS)


def test_c_refuses_as_built_values_on_a_scaled_section():
    """Past Python's check (the aspect set after the column was made), C's set-up refuses the placement."""
    seg = Segment.rectangle(1.0, 0.5, 0.5)
    col = Column((Block((seg,)), Block((seg,), offset=(0.01, 0.0))), joints=JOINTS)
    object.__setattr__(col.blocks[1].segments[0], "aspect", 2.0)
    with pytest.raises(ParameterError, match="as-built values .* are for regular sections; a face here has aspect 2"):
        pcf.simulate(col, np.zeros(10), 0.01)


def test_tilted_foundation_threshold_takes_the_sections_reach():
    """The static overturning tilt of a b x d x h block on a tilted foundation (pycolfrag/structure/foundation.py)
    is atan(b / h) towards x and atan(d / h) towards y (its centre of mass h / 2 over an edge b / 2 or d / 2
    away)."""
    from pycolfrag.structure import foundation
    col = wall_block()
    for az, w in ((0.0, B), (90.0, D), (180.0, B)):
        what, deg = foundation.thresholds(col, az)[0]
        assert deg == pytest.approx(math.degrees(math.atan(w / H)), rel=1e-12), what


def test_dowels_lie_on_the_scaled_face():
    """A dowel at y = 0.8 m lies on a 0.4 x 2 m course (its face reaches 1 m along y, the unscaled square
    0.2 m); one at x = 0.3 m does not (the face reaches 0.2 m along x): refused naming the joint."""
    from pycolfrag.structure.connectors import Connectors
    col = Column([Block((Segment.rectangle(1.0, 0.4, 2.0),)) for _ in range(2)], joints=JOINTS)
    assert len(col.with_connectors(Connectors.of("titanium", (1,), radius=0.8, count=2, phase_deg=90.0)).dowels()) == 2
    with pytest.raises(ParameterError, match="lies outside the face of joint 1"):
        col.with_connectors(Connectors.of("titanium", (1,), radius=0.3, count=2, phase_deg=0.0))


def _wall(b, d, courses=3):
    return Column([Block((Segment.rectangle(1.0, b, d),)) for _ in range(courses)], joints=JOINTS)


@pytest.mark.parametrize("b, d", [(0.5, 2.0), (2.0, 0.5)])
def test_base_diameter_is_the_one_c_normalises_by(b, d):
    """One base diameter (csrc/geometry.c, cf_geometry_section_diameter): 2 r min(1, aspect), sqrt 2 times the
    wall's thickness whichever way it lies; C's u_top is the top's peak displacement (m) over it, and the
    joints' diameters are the same face's. Before, Python had 2 r and C twice the half-diagonal."""
    col = _wall(b, d)
    assert col.base_diameter == pytest.approx(math.sqrt(2.0) * min(b, d), rel=1e-15)
    assert col.joint_diameters == [col.base_diameter] * 3
    t = np.arange(0.0, 2.0, 0.005)
    r = pcf.simulate(col, 0.2 * G * np.sin(2 * np.pi * 1.5 * t), 0.005, acc_y=0.2 * G * np.sin(2 * np.pi * t), tail_s=1.0)
    assert r.max_top_disp > 1e-3 and not r.collapsed
    assert r.u_top * col.base_diameter == pytest.approx(r.max_top_disp, rel=1e-12)   # round-off of one division


def test_lintel_scene_columns_are_normalised_by_their_base_diameters():
    """Each column of the lintel scene (the column and the wall): its u_top times its Python base diameter
    is its peak top displacement (m), to round-off."""
    from pycolfrag.structure.lintel import LintelOnWall
    m = LintelOnWall.example()
    t = np.arange(0.0, 2.0, 0.005)
    r = pcf.simulate(m, 0.4 * G * np.sin(2 * np.pi * 1.5 * t), 0.005)
    diam = [c.base_diameter for c, _, _ in m.scene_parts().columns]
    np.testing.assert_allclose(r.columns["u_top"] * diam, r.columns["max_top_disp"], rtol=1e-12)


def test_sequence_u_top_of_a_quiet_second_event_is_the_first_events():
    """A wall's sequence: a record, then one of zeros (no settling). The second event's sequence u_top is
    the peak the first left in the state over Python's base diameter, and equals the first event's u_top
    as C normalised it (round-off)."""
    from pycolfrag.solver.sequence import run_sequence
    col = _wall(0.5, 2.0)
    t = np.arange(0.0, 2.0, 0.005)
    s = run_sequence(col, [(0.2 * G * np.sin(2 * np.pi * 1.5 * t), 0.005), (np.zeros(20), 0.005)], settle=None,
                     tail_s=0.0)
    first, second = s.events
    assert first.u_top > 0.0 and not s.collapsed
    assert second.u_top == pytest.approx(first.response.u_top, rel=1e-12)


def _released(col, th0, contact="vertex"):
    return pcf.simulate(col, np.zeros(100), 0.01, initial_tilt_rad=th0, tail_s=3.0, contact=contact)


@pytest.mark.parametrize("contact", ["vertex", "exact"])
def test_overturning_criterion_is_continuous_at_aspect_one(contact):
    """A 0.4 x 0.4 x 2 block released tilted by 1.5 times its slenderness about its +x edge overturns at the
    same time whether its square is regular (aspect 1) or scaled by 1 -+ 1e-9: the scaled face's "two radii"
    (csrc/solver_monitor.c, beyond()) tend to the regular face's. Measured: the three within 1e-11 s; before,
    the scaled faces used their vertices' furthest projection (rc cos 45 deg along x) and flagged it at 0.458 s
    against 0.779 s."""
    b, h = 0.4, 2.0
    r = b / math.sqrt(2.0)
    times = [_released(Column((Block((Segment(h, r, r, 4, math.pi / 4.0, a),)),), joints=JOINTS),
                       1.5 * math.atan(b / h), contact) for a in (1.0 - 1e-9, 1.0, 1.0 + 1e-9)]
    assert all(x.collapsed and x.collapse_reason == "overturning" for x in times)
    np.testing.assert_allclose([x.collapse_time for x in times], times[1].collapse_time, rtol=1e-8)


@pytest.mark.parametrize("d", [0.2, 0.25, 1.0, 4.0])
def test_wall_toppling_across_its_thickness_is_flagged_as_the_square_column(d):
    """A b x d x h wall block (b = 0.5 m, the thickness along x, h = 2 m) released tilted by 1.5 times its
    slenderness atan(b / h) about its +x edge overturns, and is flagged when the b x b square block is (the
    rocking in x-z does not depend on d, and the criterion's radius along x is b / sqrt 2 whatever d): the
    collapse times within 1e-3 (measured: d >= b equal to 1e-15, d < b within 5e-4)."""
    b, h = 0.5, 2.0
    th0 = 1.5 * math.atan(b / h)
    square = _released(wall_block(b, b, h), th0)
    wall = _released(wall_block(b, d, h), th0)
    assert square.collapsed and wall.collapsed and wall.collapse_reason == "overturning"
    assert wall.collapse_time == pytest.approx(square.collapse_time, rel=1e-3)


@pytest.mark.parametrize("b, d", [(0.5, 2.0), (2.0, 0.5), (1.0, 1.0), (0.1, 3.0)])
def test_mean_radius_of_a_rectangle_is_the_integrals(b, d):
    """cf_geometry_section_mean_radius, (1/A) int |r| dA in closed form per edge, against scipy's dblquad of
    |r| over the b x d rectangle (Segment.rectangle's square scaled by d / b; four times a quadrant, no warning):
    measured within 2e-15; tolerance 1e-9, over the quadrature's 1e-11."""
    from scipy.integrate import dblquad
    ref = 4.0 * dblquad(lambda y, x: math.hypot(x, y), 0.0, b / 2, 0.0, d / 2, epsabs=1e-13, epsrel=1e-11)[0] / (b * d)
    got = lib.cf_geometry_section_mean_radius(4, b / math.sqrt(2.0), math.pi / 4.0, d / b)
    assert got == pytest.approx(ref, rel=1e-9)


def test_mean_radius_of_a_forty_gon_is_near_the_discs():
    """A regular 40-gon of circumradius 1 (aspect 1 and 0, which reads as 1): near a disc's 2/3 (its inradius
    cos(pi / 40) = 0.9969; measured 0.66530, 0.2 % under)."""
    for a in (1.0, 0.0):
        assert lib.cf_geometry_section_mean_radius(40, 1.0, 0.0, a) == pytest.approx(2.0 / 3.0, rel=3e-3)


def test_exact_models_torsion_cap_takes_the_faces_shape():
    """A 0.5 x 2 x 1 m block on the ground (exact model), given a spin w0 = 0.5 rad/s about z, turns until
    friction stops it: angle Izz w0^2 / (2 mu m g arm), Izz = m (b^2 + d^2) / 12. The arm of a scaled face
    (csrc/solver_exact.c, cf_face.tarm) is the regular one's disc arm (2/3) sqrt(A / pi) times
    (rbar / sqrt A) of the rectangle over that of the square: 0.5214 m (rbar itself 0.5304; the disc's,
    as before, 0.3761 gave an angle 38 % larger). Measured: 0.3 % over (the torsional spring's stick-slip at
    the stop); tolerance 1 %. The spin's kinetic energy is booked as work in the state (monitor W) so that
    the energy balance closes."""
    import dataclasses
    b, d, h, w0 = 0.5, 2.0, 1.0, 0.5
    col = Column((Block((Segment.rectangle(h, b, d),)),), joints=JOINTS)
    rest = pcf.simulate(col, np.zeros(10), 0.01, tail_s=0.0, contact="exact", early_exit=False).final_state
    izz = col.mass * (b * b + d * d) / 12.0
    v = rest.values.copy()
    assert rest.bodies()["w"].shape == (2, 3)
    k = 22 + 12 + 3 * 2 * 2 + 4 * 2   # header, monitor, x and v of 2 bodies, q of 2 (solver_state.c)
    v[k + 3 + 2] = w0                 # the block's w_z
    v[22 + 3] += 0.5 * izz * w0 * w0  # monitor's W
    st = dataclasses.replace(rest, values=v)
    assert st.bodies()["w"][1][2] == w0
    r = pcf.simulate(col, np.zeros(200), 0.01, tail_s=0.0, contact="exact", early_exit=False, initial_state=st)
    q = r.final_state.bodies()["q"][1]
    angle = 2.0 * math.atan2(q[3], q[0])
    square = lib.cf_geometry_section_mean_radius(4, 1.0, math.pi / 4.0, 1.0) / math.sqrt(2.0)   # unit area
    arm = lib.cf_geometry_section_mean_radius(4, b / math.sqrt(2.0), math.pi / 4.0, d / b) * (
        (2.0 / 3.0) / math.sqrt(math.pi) / square)
    mu = math.tan(math.radians(JOINTS.friction_deg))
    assert angle == pytest.approx(izz * w0 * w0 / (2.0 * mu * col.mass * G * arm), rel=1e-2)
