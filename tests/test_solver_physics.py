"""Physics benchmarks of the solver against closed forms and independent integrations:
quasi-static overturning (rigid threshold g b / h_cg), Housner (1963) free rocking, and
one-sine pulse overturning of a single block (Housner's equation integrated with scipy's
solve_ivp in tests/reference_solutions.py)."""
import math
import os
import sys

import numpy as np
import pytest

import pycolfrag as pcf

sys.path.insert(0, os.path.dirname(__file__))
from reference_solutions import housner_overturns  # noqa: E402  (tests/ is not a package)

G = 9.81


def ramp_and_hold(col, level_g, t_ramp=2.0, t_hold=6.0, dt=0.01, **kw):
    """Base acceleration ramped linearly to level_g over t_ramp, then held (no tail)."""
    t = np.arange(0.0, t_ramp + t_hold, dt)
    a = level_g * G * np.minimum(t / t_ramp, 1.0)
    return pcf.simulate(col, a, dt, tail_s=0.0, **kw)


def rigid_threshold_g(col, vertex_along_load):
    """Quasi-static overturning threshold of the rigid column about its base joint:
    support distance in the loading direction / height of the centre of mass.
    A 10-gon with a vertex along x supports at the circumradius; with a flat side
    normal to x at the apothem (0.170 g and 0.162 g for the default column)."""
    seg = col.blocks[0].bottom
    b = seg.r_bottom if vertex_along_load else seg.r_bottom * math.cos(math.pi / seg.n_sides)
    return b / col.com_height


@pytest.mark.parametrize("phase_deg, vertex", [(0.0, True), (18.0, False)])
def test_quasi_static_overturning_stiff_joints(phase_deg, vertex):
    """kn = ks = 1e11 Pa/m (rigid limit): stands at 0.97 x and overturns at 1.03 x the rigid
    threshold. The 3 % margin covers the joint compliance at this stiffness
    (the toe compresses ~W/(kn A_toe) ~ 0.1 mm) and the finite hold time."""
    col = pcf.Column.parthenon(phase_deg=phase_deg).with_joints(kn=1e11, ks=1e11)
    thr = rigid_threshold_g(col, vertex)
    assert thr == pytest.approx(0.170 if vertex else 0.162, abs=0.003)
    low = ramp_and_hold(col, 0.97 * thr, planar=True)
    high = ramp_and_hold(col, 1.03 * thr, planar=True)
    assert not low.collapsed
    assert high.collapsed and high.collapse_reason == "overturning" and high.collapse_block == 0


def threshold_by_bisection(col, lo_g, hi_g, iters=5):
    for _ in range(iters):
        mid = 0.5 * (lo_g + hi_g)
        if ramp_and_hold(col, mid, t_hold=8.0, planar=True).collapsed:
            hi_g = mid
        else:
            lo_g = mid
    return 0.5 * (lo_g + hi_g), hi_g - lo_g


def test_quasi_static_threshold_rises_with_joint_stiffness(capsys):
    """Soft joints let the toe compress, which lowers the overturning threshold; it must rise
    monotonically towards the rigid value as kn grows (an earlier independent estimate: about
    0.15 g at 1 GPa/m with vertex sub-contacts). Measured here (planar mode, vertex along x, rigid 0.171 g):
    about 0.148 g at 1e9, 0.163 at 1e10, 0.169 at 1e11 Pa/m. Each threshold is bracketed to
    +-0.001 g by bisection, so 'rises' is asserted with that margin."""
    base = pcf.Column.parthenon()
    rigid = rigid_threshold_g(base, True)
    thr = {}
    for kn in (1e9, 1e10, 1e11):
        t, width = threshold_by_bisection(base.with_joints(kn=kn, ks=kn), 0.12, 0.18)
        thr[kn] = t
    with capsys.disabled():
        print(f"\nquasi-static overturning threshold (g): rigid {rigid:.4f}; "
              + ", ".join(f"kn={k:.0e}: {v:.4f}" for k, v in thr.items()))
    assert 0.13 < thr[1e9] < 0.16            # the earlier estimate: about 0.15 g
    assert thr[1e9] + 0.002 < thr[1e10] < thr[1e11] + 0.002
    assert thr[1e11] < rigid + 0.002
    assert thr[1e11] > 0.95 * rigid


# ---- Housner (1963) free rocking -------------------------------------------------------

def test_housner_free_rocking():
    """Slender square block, half-width b = 0.15 m, height 3 m (alpha = atan(b/h) = 0.0997,
    R = 1.507 m, p = sqrt(3 g / 4 R)), kn = ks = 1e11 Pa/m, released from theta0 = alpha/2.

    Housner (1963), linearised equation theta'' = p^2 (theta - alpha) for slender blocks:
    time to the first impact T/4 = arccosh(alpha / (alpha - theta0)) / p; the time between
    two impacts at amplitude theta_m is 2 arccosh(alpha / (alpha - theta_m)) / p.
    Tolerances 1 % and 2 %; the linearisation itself costs about alpha^2/6 = 0.17 %.
    """
    b, H = 0.15, 3.0
    col = pcf.Column.single_block(2 * b, H, n_sides=4, joints=pcf.JointProperties(kn=1e11, ks=1e11))
    alpha = math.atan(b / (H / 2))
    p = math.sqrt(3 * G / (4 * math.hypot(b, H / 2)))
    th0 = 0.5 * alpha
    res = pcf.simulate(col, np.zeros(2), 0.01, history=True, tail_s=4.0, initial_tilt_rad=th0,
                       history_dt=0.0005, early_exit=False)
    q = res.history.block_quat[:, 0]
    th = 2 * np.arctan2(q[:, 2], q[:, 0])           # rotation about y
    t = res.history.t
    assert th[0] == pytest.approx(th0, rel=1e-12)
    sgn = np.sign(th)
    idx = np.where(sgn[:-1] * sgn[1:] < 0)[0]
    tz = t[idx] - th[idx] * (t[idx + 1] - t[idx]) / (th[idx + 1] - th[idx])
    assert tz[0] == pytest.approx(math.acosh(alpha / (alpha - th0)) / p, rel=0.01)
    assert len(tz) >= 3
    for k in range(len(tz) - 1):
        seg = (t > tz[k]) & (t < tz[k + 1])
        amp = np.abs(th[seg]).max()
        assert tz[k + 1] - tz[k] == pytest.approx(2 * math.acosh(alpha / (alpha - amp)) / p, rel=0.02)
    assert res.energy_error < 0.01


# ---- pulse overturning of a single block ---------------------------------------------

def test_one_sine_pulse_overturning_single_block():
    """Block 0.4 m x 0.4 m x 2 m (alpha = 0.197), kn = ks = 1e11, one-sine pulse of period
    0.25 s. Friction angle 80 deg (mu = 5.7 > A/g): Housner's equation assumes the block
    does not slide, and at 4 g a block on mu = 0.75 slides a lot. The threshold amplitude is found by bisecting the independent integration
    of Housner's equation with his restitution (reference_solutions.housner_overturns, about 4.0 g); the soft-contact block must survive 0.95 x and overturn at
    1.05 x it. Note: at this short period the block overturns in its first excursion, before
    any impact: the bisection gives 4.016 g with Housner's restitution, with r = 0.3 and with
    r = 0 alike (checked by hand), so this case tests uplift and rocking of the soft contacts,
    not the impact law; the cases where impacts matter (Tp = 0.5, 1 and 2 s) are in
    tests/test_hard_cases.py."""
    b, H, Tp = 0.2, 2.0, 0.25
    lo, hi = 2.0 * G, 6.0 * G
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        def ag(x, A=mid):
            return A * math.sin(2 * math.pi * x / Tp) if x < Tp else 0.0
        if housner_overturns(ag, b, H / 2, t_end=3.0):
            hi = mid
        else:
            lo = mid
    thr = 0.5 * (lo + hi)
    assert 3.5 * G < thr < 4.5 * G
    col = pcf.Column.single_block(2 * b, H, n_sides=4,
                                  joints=pcf.JointProperties(kn=1e11, ks=1e11, friction_deg=80.0))
    dt = 0.001
    t = np.arange(0.0, Tp + dt / 2, dt)
    below = pcf.simulate(col, 0.95 * thr * np.sin(2 * np.pi * t / Tp), dt, tail_s=3.0)
    above = pcf.simulate(col, 1.05 * thr * np.sin(2 * np.pi * t / Tp), dt, tail_s=3.0)
    assert not below.collapsed
    assert above.collapsed and above.collapse_block == 0
    assert below.energy_error < 0.01 and above.energy_error < 0.01


def test_perimeter_refinement_converges_to_exact():
    """Static rocking stiffness proxy: the quasi-static tilt of a soft single drum under a
    small steady base acceleration. Refining the face mesh (points_per_edge 1, 2, 4, 8)
    must approach the exact interface monotonically (trapezoidal quadrature error ~ 1/m^2);
    the vertex-only model is much stiffer in rocking (points on the rim only)."""
    col = pcf.Column.single_block(1.6, 1.2, n_sides=10, joints=pcf.JointProperties(kn=1e8, ks=1e8))
    dt = 0.01
    t = np.arange(0.0, 6.0, dt)
    a = 0.05 * G * np.minimum(t / 3.0, 1.0)

    def tilt(**kw):
        r = pcf.simulate(col, a, dt, tail_s=0.0, history=True, damping_alpha=20.0, **kw)
        q = r.history.block_quat[-1, 0]
        return abs(2 * math.atan2(q[2], q[0]))

    exact = tilt(contact="exact")
    errs = [abs(tilt(contact="perimeter", points_per_edge=m) - exact) / exact for m in (1, 2, 4, 8)]
    vertex = tilt(contact="vertex")
    assert all(e2 < e1 for e1, e2 in zip(errs, errs[1:]))
    assert errs[-1] < 0.01
    assert vertex < 0.8 * exact
