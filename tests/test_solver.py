"""simulate(): statics, energy balance, Newmark sliding, collapse of the default column,
determinism and bad input. The physics benchmarks that need stiff joints are in
tests/test_solver_physics.py."""
import math

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.solver.run import EnergyWarning

G = 9.81


@pytest.fixture(scope="module")
def col():
    return pcf.Column.parthenon()


def sine(amp_g, f_hz, dur_s, dt=0.005):
    t = np.arange(0.0, dur_s, dt)
    return amp_g * G * np.sin(2 * np.pi * f_hz * t), dt


# ---- statics --------------------------------------------------------------------------

def test_statics_rest_normal_forces_and_settlement(col):
    """Zero ground motion: the stack starts in exact equilibrium and stays there.

    Expected numbers: the normal force of joint i equals the weight of the blocks above
    (g * sum of block masses from Column geometry) -- 0.1 % would be an engineering tolerance; the
    start is exact equilibrium so we hold it to 1e-6. Settlement of joint i is
    W_i / (kn A_i) with A_i the area of the upper block's bottom polygon (same as the
    lower's top here), so the centre of mass of block 0 sits that much below its
    unloaded height; positions must not drift (1e-9 m, round-off scale x 1e5).
    """
    res = pcf.simulate(col, np.zeros(301), 0.01, history=True, tail_s=0.0, early_exit=False)
    h = res.history
    weights = G * np.cumsum(np.array(col.block_masses)[::-1])[::-1]
    np.testing.assert_allclose(h.joint_normal_force[-1], weights, rtol=1e-6)
    np.testing.assert_allclose(h.joint_normal_force[0], weights, rtol=1e-6)
    assert np.abs(h.block_pos - h.block_pos[0]).max() < 1e-9
    b0 = col.blocks[0]
    area0 = 0.5 * b0.bottom.n_sides * math.sin(2 * math.pi / b0.bottom.n_sides) * b0.bottom.r_bottom ** 2
    settle0 = weights[0] / (col.joints.kn * area0)
    assert h.block_pos[-1, 0, 2] == pytest.approx(b0.centroid_height - settle0, abs=1e-12)
    assert res.u_top < 1e-12 and res.u_d < 1e-12 and not res.collapsed
    assert res.n_steps > 0 and res.t_end == pytest.approx(3.0, abs=res.dt)


# ---- energy balance --------------------------------------------------------------------

def test_energy_balance_elastic_20s(col):
    """Elastic motion without impacts (0.01 g: no uplift, no slip) over 20 s.

    The leapfrog conserves the energy with the kinetic term m v(n-1/2).v(n+1/2)/2 and
    trapezoidal work exactly for linear springs, so the balance error is round-off
    plus the tiny geometric non-linearity: asserted below 1e-6 of the energy scale
    (docs/solver.md, "Energy balance"), measured about 3e-10.
    """
    a, dt = sine(0.01, 2.0, 3.0)
    res = pcf.simulate(col, a, dt, history=True, tail_s=17.0)
    assert res.t_end == pytest.approx(20.0, abs=0.01)
    assert res.history.energy["slip_dissipated"].max() == 0.0
    assert res.energy_error < 1e-6


def test_energy_balance_with_impacts_converges(col):
    """Rocking with impacts (0.25 g, 2 Hz, 3 s + 2 s): the balance error falls as the
    step shrinks. Measured 1.6e-2, 9.1e-3, 4.7e-3, 2.7e-3, 1.6e-3, 3.6e-4, 1.1e-4 at
    dt_factor 0.8, 0.6, 0.4, 0.3, 0.2, 0.1, 0.05: order about 1.8 (the kink of the contact
    force at zero overlap limits it below 2). The energy of compressed sub-contacts sliding
    off / onto a face polygon is booked separately (energy["contact_switch"]), not as
    error. Asserted: decreasing over 0.8 -> 0.4 -> 0.2 -> 0.1, and at 0.1 at least 10x
    below 0.8 (order > 1.1)."""
    a, dt = sine(0.25, 2.0, 3.0)
    errs = [pcf.simulate(col, a, dt, tail_s=2.0, dt_factor=f).energy_error for f in (0.8, 0.4, 0.2, 0.1)]
    assert errs[0] < 0.05
    assert all(e2 < e1 for e1, e2 in zip(errs, errs[1:]))
    assert errs[-1] < errs[0] / 10.0


def test_unstable_step_is_detected_not_hidden(col):
    """A step 30 % above the whole-stack limit must fail (SolverError), not be hidden by
    friction dissipating the runaway energy."""
    a, dt = sine(0.25, 2.0, 3.0)
    crit = pcf.simulate(col, a[:10], dt, tail_s=0.0).dt_crit
    with pytest.raises(pcf.SolverError, match="unstable"):
        pcf.simulate(col, a, dt, tail_s=2.0, dt_solver=1.3 * crit)


def test_energy_warning_is_raised_and_flagged(col):
    """With a tiny tolerance, a normal rocking run warns and sets energy_warning."""
    a, dt = sine(0.25, 2.0, 2.0)
    with pytest.warns(EnergyWarning):
        res = pcf.simulate(col, a, dt, tail_s=0.0, energy_tolerance=1e-9)
    assert res.energy_warning and res.energy_error > 1e-9


# ---- Newmark (1965) sliding block -----------------------------------------------------

def test_newmark_sliding_block():
    """Squat block (2 m x 2 m x 0.5 m: rocking needs A > g b/h = 4 g) on joints with
    mu = tan 37 deg under a rectangular pulse of A = 1 g for t0 = 0.5 s.
    Newmark (1965): slip = V^2 / (2 mu g) (1 - mu g / A) with V = A t0 = 0.401 m here.
    Tolerance 2 %: the elastic shear displacement (mu W / (ks A) ~ 1e-5 m)
    and the 1-sample ramp at the end of the sampled pulse are far below it."""
    col = pcf.Column.single_block(2.0, 0.5, n_sides=4, joints=pcf.JointProperties(friction_deg=37.0))
    dt = 0.001
    a = np.full(501, G)
    a[-1] = 0.0
    res = pcf.simulate(col, a, dt, history=True, tail_s=1.5, early_exit=False)
    mu = math.tan(math.radians(37.0))
    V = G * 0.5
    expected = V ** 2 / (2 * mu * G) * (1 - mu * G / G)
    slip = -(res.history.block_pos[-1, 0, 0] - res.history.block_pos[0, 0, 0])
    assert slip == pytest.approx(expected, rel=0.02)
    # stopped: only elastic shear vibration (tens of micrometres) remains
    assert np.ptp(res.history.block_pos[-50:, 0, 0]) < 1e-4
    assert not res.collapsed


# ---- collapse --------------------------------------------------------------------------

def test_default_column_collapses_under_strong_pulse(col):
    """0.6 g one-sine pulse of 2 s period: far above the ~0.15 g quasi-static
    threshold and long enough to tip the whole column: it collapses, and says which
    block and when (within the pulse + a few seconds)."""
    t = np.arange(0.0, 2.0, 0.005)
    res = pcf.simulate(col, 0.6 * G * np.sin(2 * np.pi * t / 2.0), 0.005)
    assert res.collapsed
    assert res.collapse_reason in ("overturning", "off_footprint", "falling")
    assert isinstance(res.collapse_block, int) and 0 <= res.collapse_block < col.n_blocks
    assert 0.0 < res.collapse_time < 5.0
    assert res.t_end == pytest.approx(res.collapse_time, abs=res.dt)  # early exit
    assert np.isfinite(res.u_top) and np.isfinite(res.energy_error)


def test_no_collapse_response_fields(col):
    a, dt = sine(0.25, 2.0, 3.0)
    res = pcf.simulate(col, a, dt, tail_s=3.0, history=True, history_dt=0.05)
    assert not res.collapsed and res.collapse_block is None and math.isnan(res.collapse_time)
    assert res.collapse_reason == ""
    assert 0 < res.u_top < 1 and 0 <= res.u_d < 1
    assert res.residual_dislocation.shape == (col.n_blocks,)
    assert res.u_d == pytest.approx(max(res.residual_dislocation / np.array(col.joint_diameters)))
    assert res.dt == pytest.approx(0.8 * res.dt_crit)
    assert res.t_end == pytest.approx(len(a) * dt - dt + 3.0, abs=res.dt)
    h = res.history
    n = h.t.size
    assert h.top_disp.shape == (n, 2) and h.block_pos.shape == (n, 13, 3) and h.block_quat.shape == (n, 13, 4)
    assert h.joint_opening.shape == (n, 13) and h.joint_slip.shape == (n, 13, 2)
    assert set(h.energy) == {"kinetic", "gravity", "spring", "slip_dissipated", "damping_dissipated",
                             "ground_work", "balance_error", "contact_switch"}
    e = h.energy
    np.testing.assert_allclose(e["kinetic"] + e["gravity"] + e["spring"] + e["slip_dissipated"]
                               + e["damping_dissipated"] + e["contact_switch"] - e["ground_work"],
                               e["balance_error"], atol=1e-9 * res.energy_scale)
    np.testing.assert_allclose(np.linalg.norm(h.block_quat, axis=2), 1.0, atol=1e-12)
    assert np.max(np.linalg.norm(h.top_disp, axis=1)) / col.base_diameter <= res.u_top + 1e-12
    assert (h.joint_opening >= 0).all() and h.joint_opening.max() > 0
    import json
    json.dumps(res.options)


@pytest.mark.parametrize("opts", [dict(contact="exact"), dict(contact="perimeter", points_per_edge=2),
                                  dict(planar=True), dict(monolithic=True)])
def test_fidelity_options_run(col, opts):
    """Every fidelity option runs the default case with a small energy error."""
    a, dt = sine(0.25, 2.0, 3.0)
    res = pcf.simulate(col, a, dt, tail_s=1.0, **opts)
    assert not res.collapsed
    assert 0 < res.u_top < 0.5
    assert res.energy_error < 0.05
    for k, v in opts.items():
        assert res.options[k] == v


def test_damping_dissipates(col):
    a, dt = sine(0.25, 2.0, 3.0)
    res = pcf.simulate(col, a, dt, tail_s=2.0, history=True, damping_alpha=2.0, damping_start_s=3.0)
    e = res.history.energy
    assert e["damping_dissipated"][res.history.t < 3.0 - 0.02].max() == 0.0
    assert e["damping_dissipated"][-1] > 0.0
    assert res.energy_error < 0.05


# ---- determinism -----------------------------------------------------------------------

def test_determinism_bitwise(col):
    """Same input twice in one process: bitwise-identical EDPs and histories (no state
    survives between runs; -ffp-contract=off is tested in test_package.py)."""
    a, dt = sine(0.3, 2.0, 3.0)
    r1 = pcf.simulate(col, a, dt, history=True, tail_s=1.0)
    r2 = pcf.simulate(col, a, dt, history=True, tail_s=1.0)
    assert r1.u_top == r2.u_top and r1.u_d == r2.u_d and r1.n_steps == r2.n_steps
    for name in ("t", "top_disp", "block_pos", "block_quat", "joint_opening", "joint_slip"):
        assert np.array_equal(getattr(r1.history, name), getattr(r2.history, name)), name
    for k in r1.history.energy:
        assert np.array_equal(r1.history.energy[k], r2.history.energy[k])


# ---- bad input: each a clear ValueError subclass naming the value -----------------------

@pytest.mark.parametrize("acc, dt, kw, match", [
    (np.array([0.0, np.nan, 0.0]), 0.01, {}, "non-finite"),
    (np.array([0.0, np.inf]), 0.01, {}, "non-finite"),
    (np.zeros(10), 0.0, {}, "dt"),
    (np.zeros(10), -0.01, {}, "dt"),
    (np.zeros(10), float("nan"), {}, "dt"),
    (np.zeros(0), 0.01, {}, "empty"),
    (np.zeros((3, 3)), 0.01, {}, "1-D"),
    (np.zeros(10), 0.01, dict(acc_y=np.zeros(9)), "samples"),
    (np.zeros(10), 0.01, dict(acc_z=np.zeros(11)), "samples"),
    (np.full(10, 981.0), 0.01, {}, "981"),
    (np.zeros(10), 0.01, dict(contact="vertices"), "contact"),
    (np.zeros(10), 0.01, dict(points_per_edge=0), "points_per_edge"),
    (np.zeros(10), 0.01, dict(points_per_edge=1.5), "points_per_edge"),
    (np.zeros(10), 0.01, dict(dt_factor=-0.5), "dt_factor"),
    (np.zeros(10), 0.01, dict(dt_factor=10.0), "dt_factor"),
    (np.zeros(10), 0.01, dict(dt_solver=0.0), "dt_solver"),
    (np.zeros(10), 0.01, dict(tail_s=-1.0), "tail_s"),
    (np.zeros(10), 0.01, dict(history_dt=0.0), "history_dt"),
    (np.zeros(10), 0.01, dict(damping_alpha=-1.0), "damping_alpha"),
    (np.zeros(10), 0.01, dict(planar=True, acc_y=np.zeros(10)), "planar"),
    (np.zeros(10), 0.01, dict(planar="yes"), "planar"),
    (np.zeros(10), 0.01, dict(g=0.0), "g"),
])
def test_bad_input(col, acc, dt, kw, match):
    with pytest.raises(pcf.ParameterError, match=match):
        pcf.simulate(col, acc, dt, **kw)


def test_bad_input_is_valueerror_and_column_checked(col):
    with pytest.raises(ValueError):
        pcf.simulate(col, [0.0, float("nan")], 0.01)
    with pytest.raises(pcf.ParameterError, match="Column"):
        pcf.simulate("not a column", np.zeros(10), 0.01)
    with pytest.raises(pcf.ParameterError):   # impossible geometry is refused by the Column itself
        pcf.Column.from_drums([1.0, -0.5], 1.6)
    with pytest.raises(pcf.ParameterError, match="n_sides"):  # beyond the C solver's 64 sides: refused
        pcf.Column.single_block(1.0, 2.0, n_sides=100)        # where it enters, not at simulate time


@pytest.mark.parametrize("contact", ["vertex", "exact"])
def test_collapse_without_early_exit_runs_to_the_end(col, contact):
    """With early_exit=False a collapsing column is followed to the end of the record plus
    tail: tumbling blocks must not produce NaN or a spurious instability (a hard case of docs/accuracy.md)."""
    t = np.arange(0.0, 6.0, 0.005)
    res = pcf.simulate(col, 0.8 * G * np.sin(2 * np.pi * t), 0.005, early_exit=False, tail_s=1.0,
                       contact=contact)
    assert res.collapsed and res.t_end == pytest.approx(t[-1] + 1.0, abs=res.dt)
    # the state stays finite (u_top is the largest top displacement reached); a residual
    # dislocation has no meaning after a collapse: u_d and every joint's residual are NaN
    assert np.isfinite(res.u_top) and np.isnan(res.u_d) and np.isnan(res.residual_dislocation).all()
