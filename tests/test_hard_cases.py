"""Hard cases for the solver's numerical stability and accuracy (docs/accuracy.md, "Hard cases").
Each bound states its source; independent references are in tests/reference_solutions.py."""
import math
import os
import sys
import warnings

import numpy as np
import pytest

pcf = pytest.importorskip("pycolfrag")
if not hasattr(pcf, "simulate"):
    pytest.skip("pycolfrag.simulate not available", allow_module_level=True)
sys.path.insert(0, os.path.dirname(__file__))
import reference_solutions as R  # noqa: E402

G = 9.81


def finite(res):
    return math.isfinite(res.u_top) and math.isfinite(res.u_d) and math.isfinite(res.energy_error)


# ---- undamped free rocking, 60 s ------------------------------------------------------------

def test_free_rocking_60s_energy_balance_shrinks_with_step():
    """Default column released from a rigid tilt of 0.02 rad (about 1/5 of its slenderness angle),
    no ground motion, 60 s, no damping. Bound: the solver's own warning level (energy_tolerance
    0.05 of the energy scale, docs/solver.md); the error must fall as the step halves
    (docs/solver.md measures order ~1.8, so halving must gain at least a factor 1.5)."""
    col = pcf.Column.parthenon()
    errs = {}
    for f in (0.8, 0.4):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = pcf.simulate(col, np.zeros(2), 0.01, tail_s=60.0, initial_tilt_rad=0.02, dt_factor=f,
                             early_exit=False)
        assert finite(r) and not r.collapsed
        errs[f] = r.energy_error
    print(f"\nfree rocking 60 s: energy error {errs}")
    assert errs[0.8] < 0.05
    assert errs[0.4] < errs[0.8] / 1.5


def test_step_above_stability_limit_is_reported():
    """dt_solver = 1.5 x the whole-stack stability limit (docs/solver.md): an explicit step above
    the limit must not pass silently (friction can hide it: the slip then "dissipates" the
    spurious energy while displacements still look plausible) -> SolverError or the
    energy-warning flag."""
    col = pcf.Column.parthenon()
    dcrit = pcf.simulate(col, np.zeros(2), 0.01, tail_s=0.01).dt_crit
    t = np.arange(0, 4, 0.01)
    acc = 0.2 * G * np.sin(2 * np.pi * 2 * t)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = pcf.simulate(col, acc, 0.01, dt_solver=1.5 * dcrit, tail_s=2.0)
        except pcf.errors.SolverError:
            return
    assert r.energy_warning or not finite(r), f"unstable step not reported: energy error {r.energy_error}"


# ---- quasi-static ramp and hold at the current joint stiffness -----------------------------

def ramp_and_hold(col, level_g, t_ramp=2.0, t_hold=8.0, dt=0.01):
    t = np.arange(0.0, t_ramp + t_hold, dt)
    return pcf.simulate(col, level_g * G * np.minimum(t / t_ramp, 1.0), dt, tail_s=0.0, planar=True)


def test_ramp_and_hold_at_measured_threshold():
    """Default column, default joints (1 GPa/m): bisect the quasi-static overturning level
    (bracketed by 0.5x and 1x the rigid threshold b/h_cg, R.quasi_static_threshold_g), then it must
    stand at 0.97x and overturn at 1.03x (the margin of the stiff-joint test in
    tests/test_solver_physics.py; the bisection's bracket is under 0.5 %)."""
    col = pcf.Column.parthenon()
    seg = col.blocks[0].bottom
    rigid = R.quasi_static_threshold_g(seg.r_bottom, col.com_height)
    lo, hi = 0.5 * rigid, 1.0 * rigid
    assert not ramp_and_hold(col, lo).collapsed
    for _ in range(7):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if ramp_and_hold(col, mid).collapsed else (mid, hi)
    thr = 0.5 * (lo + hi)
    print(f"\nquasi-static threshold at kn=1e9: {thr:.4f} g (rigid {rigid:.4f} g)")
    assert not ramp_and_hold(col, 0.97 * thr).collapsed
    r = ramp_and_hold(col, 1.03 * thr)
    assert r.collapsed and r.collapse_block == 0


# ---- stick-slip vs Newmark -------------------------------------------------------------------

def test_stick_slip_harmonic_vs_newmark():
    """Squat block 4 m x 4 m x 1 m (b/h_cg = 4, cannot rock at 0.9 g), friction 37 deg
    (mu = 0.754), base a_g = 1.2 mu g sin(2 pi 2 t): slides both ways each cycle. Slip per cycle
    (peak-to-peak over the last of 6 cycles) within 5 % of the Newmark rigid-plastic integration
    (R.newmark_harmonic_slip_per_cycle); 5 % allows for the elastic shear spring (ks A) which
    the rigid-plastic model lacks."""
    mu = math.tan(math.radians(37.0))
    A, f = 1.2 * mu * G, 2.0
    col = pcf.Column.single_block(4.0, 1.0, n_sides=4, joints=pcf.JointProperties(kn=1e10, ks=1e10, friction_deg=37.0))
    dt = 0.001
    t = np.arange(0, 6 / f, dt)
    r = pcf.simulate(col, A * np.sin(2 * np.pi * f * t), dt, history=True, history_dt=0.001, tail_s=0.0,
                     early_exit=False)
    assert finite(r)
    h = r.history
    s = h.joint_slip[:, 0, 0]
    m = h.t >= 5 / f
    sim = float(s[m].max() - s[m].min())
    ref = R.newmark_harmonic_slip_per_cycle(A, f, mu)
    print(f"\nslip per cycle: solver {sim * 1e3:.3f} mm, Newmark {ref * 1e3:.3f} mm")
    assert sim == pytest.approx(ref, rel=0.05)


# ---- one-sine pulses at +-5 % of the rigid-block threshold -------------------------------------

@pytest.mark.parametrize("Tp", [1.0, 2.0])
def test_one_sine_pulse_threshold_two_periods(Tp):
    """Block 0.4 x 0.4 x 2 m (alpha = 0.197), kn = ks = 1e11 (rigid limit), friction 80 deg so it
    cannot slide (Housner's model). Threshold by bisection of Housner's equations with his
    restitution (R.one_sine_threshold; 0.253 g at Tp = 1 s, 0.229 g at 2 s). Survives at 0.95x,
    overturns at 1.05x (5 %: the soft contacts' restitution is not exactly Housner's, see the next
    test). Tp = 0.25 s is in tests/test_solver_physics.py; Tp = 0.5 s,
    where overturning comes after several impacts, is test_one_sine_threshold_follows_soft_restitution."""
    b, H = 0.2, 2.0
    thr = R.one_sine_threshold(b, H / 2, Tp, lo_g=0.2, hi_g=20.0)
    col = pcf.Column.single_block(2 * b, H, n_sides=4,
                                  joints=pcf.JointProperties(kn=1e11, ks=1e11, friction_deg=80.0))
    dt = 0.001
    t = np.arange(0.0, Tp + dt / 2, dt)
    pulse = np.sin(2 * np.pi * t / Tp)
    below = pcf.simulate(col, 0.95 * thr * pulse, dt, tail_s=4.0)
    above = pcf.simulate(col, 1.05 * thr * pulse, dt, tail_s=4.0)
    print(f"\nTp={Tp}: threshold {thr / G:.4f} g")
    assert not below.collapsed
    assert above.collapsed and above.collapse_block == 0


def test_one_sine_threshold_follows_soft_restitution(monkeypatch):
    """Impact dissipation of the soft vertex contacts (docs/accuracy.md "Impact
    dissipation", bench/restitution.py). Same block as above: 0.4 x 0.4 x 2 m, alpha = 0.197,
    kn = ks = 1e11 (rigid limit), friction 80 deg.

    1. Restitution. Released from alpha/2 in the x-z plane (planar: Housner's 2D block), no ground
       motion. Between impacts a rigid block rocks without loss, so the rocking energy at the
       peaks, E(theta) = M g R (cos(alpha - theta) - cos alpha), gives r = omega_after/omega_before
       = sqrt(E_{n+1}/E_n); r_mean over 5 impacts = (E_5/E_0)^(1/10). Band:
       * lower end Housner's r_H = 1 - 1.5 sin^2 alpha = 0.942: his impact is perfectly plastic at
         the new corner (it destroys that corner's whole relative velocity, the largest loss an
         impact there can have, Carnot's theorem); the model's contact springs are undamped and
         return their normal energy, and lose only what the unloading corner's shear springs hold
         when it lifts off (Coulomb release, booked as slip_dissipated) plus what stays in
         vibration. This holds for ks = kn (the paper's Table I; bench: ks = 0.3 kn gives r = r_H,
         ks = 0.1 kn r = 0.84). A damped or plastic contact law falls below it.
       * upper end from the ledger, not tuned: the run starts at rest (all its energy is rocking
         energy E_0) and has no source, so E_5 <= E_0 - (slip dissipated) - (contact_switch) +
         |balance error| over the same window (the rest is vibration energy, >= 0).
       * the loss must be resolved above the integration error (lost > 2 |balance error|):
         otherwise r would be a property of the step, not of the contact.
       Measured (2026-11-23): r_mean 0.987 (per impact 0.984-0.989), ledger bound 0.992, loss
       0.124 E_0 of which slip 0.099 and integration error 0.025; Housner loses 1 - r_H^10 = 0.45 E_0
       over 5 impacts.
    2. Threshold, Tp = 0.5 s (overturning after several impacts: it was the xfail, the solver
       overturning at 0.94x Housner's 0.440 g). Housner's equations with r_mean in place of r_H
       (R.one_sine_threshold, restitution patched) must predict the solver's threshold to the
       same +-5 % as Tp = 1 and 2 s above: stands at 0.95x, overturns at 1.05x (measured: 0.406 g
       predicted, the solver's bisected threshold 0.412 g). r = 0.975-0.99 moves that prediction
       by 1.2 % (0.413-0.404 g), so the 5 % bracket is the one used at Tp = 1 and 2 s, not room
       for the restitution's scatter."""
    b, H = 0.2, 2.0
    col = pcf.Column.single_block(2 * b, H, n_sides=4,
                                  joints=pcf.JointProperties(kn=1e11, ks=1e11, friction_deg=80.0))
    alpha, Rr = math.atan(b / (H / 2)), math.hypot(b, H / 2)
    r_h = R.housner_restitution(alpha)
    res = pcf.simulate(col, np.zeros(2), 0.01, history=True, history_dt=5e-4, tail_s=7.0, early_exit=False,
                       initial_tilt_rad=0.5 * alpha, planar=True)
    h = res.history
    q = h.block_quat[:, 0]
    th = 2 * np.arctan2(q[:, 2], q[:, 0])                  # rotation about y
    peaks, sgn, start = [], 1.0, 0                          # peak |theta| of each completed half-cycle
    for i in range(1, th.size):
        if np.sign(th[i]) == -sgn and abs(th[i]) > 0.01 * alpha:
            peaks.append(start + int(np.argmax(np.abs(th[start:i]))))
            sgn, start = -sgn, i
    assert len(peaks) >= 6, f"only {len(peaks)} half-cycles"
    i0, i5 = peaks[0], peaks[5]
    E = col.mass * G * Rr * (np.cos(alpha - np.abs(th[peaks])) - math.cos(alpha))   # J
    r_mean = (E[5] / E[0]) ** 0.1
    e = h.energy
    slip = e["slip_dissipated"][i5] - e["slip_dissipated"][i0]
    switch = e["contact_switch"][i5] - e["contact_switch"][i0]
    derr = e["balance_error"][i5] - e["balance_error"][i0]
    lost = E[0] - E[5]
    r_upper = ((E[0] - slip - switch + abs(derr)) / E[0]) ** 0.1
    print(f"\nsoft restitution: r per impact {np.round(np.sqrt(E[1:6] / E[:5]), 4)}, r_mean {r_mean:.4f} "
          f"(Housner {r_h:.4f}, ledger bound {r_upper:.4f}); loss {lost / E[0]:.3f} E0 = slip {slip / E[0]:.3f} "
          f"+ switch {switch / E[0]:.3f} + vibration - balance error {derr / E[0]:+.4f}")
    assert i0 == 0
    assert r_h < r_mean <= r_upper
    assert lost > 2 * abs(derr)

    Tp = 0.5
    thr_h = R.one_sine_threshold(b, H / 2, Tp, lo_g=0.2, hi_g=20.0)
    monkeypatch.setattr(R, "housner_restitution", lambda a: r_mean)
    thr = R.one_sine_threshold(b, H / 2, Tp, lo_g=0.2, hi_g=20.0)
    dt = 0.001
    t = np.arange(0.0, Tp + dt / 2, dt)
    pulse = np.sin(2 * np.pi * t / Tp)
    below = pcf.simulate(col, 0.95 * thr * pulse, dt, tail_s=4.0)
    above = pcf.simulate(col, 1.05 * thr * pulse, dt, tail_s=4.0)
    print(f"Tp=0.5: Housner threshold {thr_h / G:.4f} g with r_H, {thr / G:.4f} g with r_mean "
          f"({thr / thr_h:.3f}x)")
    assert thr < thr_h                                    # less loss per impact -> lower threshold
    assert not below.collapsed
    assert above.collapsed and above.collapse_block == 0


# ---- long, finely and coarsely sampled records ----------------------------------------------

def noise_record(duration, dt, pga_g, seed=0):
    rng = np.random.default_rng(seed)
    n = int(duration / dt)
    a = np.convolve(rng.normal(size=n), np.ones(max(1, int(0.05 / dt))), "same")
    return pga_g * G * a / np.abs(a).max()


def test_200s_record():
    """200 s of 0.08 g broadband motion (uplift starts near 0.15 g quasi-statically, but
    dynamic rocking can start below): finite, stands, energy balance below the warning level 0.05."""
    col = pcf.Column.parthenon()
    acc = noise_record(200.0, 0.01, 0.08, seed=3)
    r = pcf.simulate(col, acc, 0.01)
    assert finite(r) and not r.collapsed
    assert r.energy_error < 0.05
    assert r.t_end >= 200.0 or r.at_rest_exit


@pytest.mark.parametrize("dt_rec", [0.001, 0.02])
def test_record_sampling_intervals(dt_rec):
    """The same smooth 0.3 g, 1 s pulse sampled at 0.001 s and 0.02 s: the solver interpolates
    linearly to its own step, so u_top (reached before the first impact here, deterministic,
    bench/work_precision.py) agrees with the 0.005 s sampling within 2 % (the linear-interpolation
    error of a 1 Hz signal sampled at 0.02 s is (2 pi f dt)^2/8 = 0.2 %)."""
    col = pcf.Column.parthenon()

    def rec(dt):
        t = np.arange(0, 6, dt)
        x = t - 2.0
        env = np.where(np.abs(x) <= 1.0, 0.5 * (1 + np.cos(np.pi * x)), 0.0)
        return 0.3 * G * env * np.cos(2 * np.pi * x)
    ref = pcf.simulate(col, rec(0.005), 0.005)
    r = pcf.simulate(col, rec(dt_rec), dt_rec)
    assert finite(r)
    assert r.u_top == pytest.approx(ref.u_top, rel=0.02)


# ---- extreme geometry and stiffness: automatic step -------------------------------------------

@pytest.mark.parametrize("diam", [0.1, 5.0])
def test_extreme_drum_sizes(diam):
    """Drums 0.1 m and 5 m across (3 drums of height = diameter): the whole-stack step scales
    with sqrt(m/(k A)) ~ sqrt(h); the run stays finite and stands at rest; under a 2 Hz pulse of
    0.5 x the rigid threshold the max top displacement converges as the step halves (within 2 %)."""
    col = pcf.Column.from_drums([diam] * 3, diam)
    r0 = pcf.simulate(col, np.zeros(200), 0.005, tail_s=1.0)
    assert finite(r0) and not r0.collapsed and r0.u_top < 1e-3
    t = np.arange(0, 2, 0.001)
    acc = 0.5 * (1 / 3) * G * np.sin(2 * np.pi * 2 * t) * (t < 1)
    a = pcf.simulate(col, acc, 0.001, dt_factor=0.8)
    b = pcf.simulate(col, acc, 0.001, dt_factor=0.4)
    assert finite(a) and finite(b)
    assert a.dt == pytest.approx(0.8 * a.dt_crit)
    assert a.max_top_disp == pytest.approx(b.max_top_disp, rel=0.02, abs=1e-7 * diam)


@pytest.mark.parametrize("kn", [1e8, 1e9, 1e10])
def test_joint_stiffness_range(kn):
    """kn = ks from 0.1 to 10 GPa/m: the stability limit scales as 1/sqrt(kn) (within 10 % of it
    from 1e9), the run is finite, and u_top under a 0.1 g, 2 Hz, 1 s sine converges as the step
    halves (2 %). The amplitude keeps all three columns out of rocking impacts (largest joint opening
    0.5 mm at 0.1 GPa/m): at 0.25 g the 0.1 GPa/m column rocks with impacts (opening 39 mm) and single
    runs at dt 0.8/0.4/0.2/0.1 scatter chaotically (0.193, 0.189, 0.208, 0.195), which a two-run
    comparison cannot judge; at 0.1 g they agree to 3e-4 (measured 2026-11-23)."""
    col = pcf.Column.parthenon().with_joints(kn=kn, ks=kn)
    t = np.arange(0, 1.5, 0.005)
    acc = 0.1 * G * np.sin(2 * np.pi * 2 * t) * (t < 1.0)
    a = pcf.simulate(col, acc, 0.005, dt_factor=0.8, tail_s=1.0)
    b = pcf.simulate(col, acc, 0.005, dt_factor=0.4, tail_s=1.0)
    ref = pcf.simulate(pcf.Column.parthenon(), np.zeros(2), 0.01, tail_s=0.01).dt_crit
    assert a.dt_crit == pytest.approx(ref * math.sqrt(1e9 / kn), rel=0.10)
    assert finite(a) and finite(b)
    assert a.u_top == pytest.approx(b.u_top, rel=0.02)


# ---- collapse part-way: early exit -----------------------------------------------------------

def test_collapse_part_way_early_exit():
    """Default column under a 0.6 g one-sine pulse of 2 s period, then 20 s of silence (it
    collapses). Early exit: the run ends at the collapse time, well before the end of the
    record, with the block and reason reported, a finite u_top and u_d NaN (no residual after a
    collapse); the collapse time lies within the
    pulse or shortly after it (a free column topples within ~2 s once past its stability)."""
    col = pcf.Column.parthenon()
    dt = 0.01
    t = np.arange(0, 22, dt)
    acc = 0.6 * G * np.sin(2 * np.pi * t / 2.0) * (t < 2.0)
    r = pcf.simulate(col, acc, dt)
    assert r.collapsed and r.collapse_block is not None
    assert 0 <= r.collapse_block < col.n_blocks
    assert r.collapse_reason
    assert 0.5 < r.collapse_time < 6.0
    assert r.t_end == pytest.approx(r.collapse_time, abs=0.05)
    assert r.n_steps * r.dt < 8.0
    assert math.isfinite(r.u_top) and math.isnan(r.u_d)


def test_stiff_block_impacts_energy_error_falls_with_step():
    """Stiff (kn = 1e11) square block rocking with impacts after a one-sine pulse at 0.9x its
    Housner threshold (docs/accuracy.md, finding 4). Measured energy error with vertex contacts:
    0.06-0.14 at dt_factor 0.8 (flagged; it moves with the last digits of the amplitude), 0.02-0.026
    at 0.4, 0.005-0.006 at 0.1. Asserted: the flag matches the
    tolerance (0.05), and the error falls as the step shrinks (an integration error, not a model one)."""
    col = pcf.Column.single_block(0.4, 2.0, n_sides=4,
                                  joints=pcf.JointProperties(kn=1e11, ks=1e11, friction_deg=80.0))
    t = np.arange(0, 2.0005, 0.001)
    acc = 0.9 * 0.22852 * G * np.sin(np.pi * t)
    errs = {}
    for f in (0.8, 0.4, 0.1):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = pcf.simulate(col, acc, 0.001, tail_s=4.0, dt_factor=f)
        assert finite(r) and not r.collapsed
        assert r.energy_warning == (r.energy_error > 0.05)
        errs[f] = r.energy_error
    print(f"\nstiff block impacts, energy error by dt_factor: {errs}")
    assert errs[0.1] < errs[0.4] < errs[0.8]
    assert errs[0.1] < 0.05
