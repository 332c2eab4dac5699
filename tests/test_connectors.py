"""Connectors (dowels) across joints: the law against its closed forms (csrc/connector_law.h driven
through prescribed displacement histories by the C text the solver runs), the bad-input refusals,
the column file, the bits of a column whose dowels carry nothing, the monolithic limit of stiff
unbreakable dowels, and the energy ledger of dowelled runs."""
import math
from pathlib import Path

import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.structure.connectors import LAWS, Connectors, DowelLaw, law

G = 9.81


def path(*points, step=1e-5):
    """Shear along x through the given values (m), in steps of at most ``step``; every given point
    (yield, reversal, break) is a point of the path itself, so the law's corners fall on steps."""
    xs = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(math.ceil(abs(b - a) / step)))
        xs += list(np.linspace(a, b, n + 1)[1:])
    u = np.zeros((len(xs), 3))
    u[:, 0] = xs
    return u


# ---- the law ---------------------------------------------------------------------------

def test_elastoplastic_law_yield_unload_reverse_break():
    """k = 1e7 N/m, F_y = 1e4 N (u_y = 1 mm), u_ult = 5 mm. Closed forms (elastic-perfectly plastic):
    F = -k u up to u_y, then -F_y; unloading from u_max = 3 mm is elastic about the offset
    u_max - u_y = 2 mm and reaches +F_y exactly at 1 mm; reloading is elastic up to 3 mm, plastic to
    the break at 5 mm, nothing after. Dissipation: F_y (3 - 1) mm + F_y (5 - 3) mm + the energy stored
    at the break F_y^2 / (2 k) = 20 + 20 + 5 J, less half the plastic work of the step that breaks
    it (its force falls from F_y to 0 over that step, which the trapezoidal rule of the integrator's
    ledger books as half). Exact to rounding (rel 1e-9: the corners lie on steps)."""
    lw = DowelLaw("elastoplastic", k_shear=1e7, f_yield=1e4, u_ultimate=5e-3)
    u = path(0.0, 3e-3, 1e-3, 6e-3)
    out = lw.drive(u)
    x, f = u[:, 0], out["force"][:, 0]
    n1 = int(np.argmax(x >= 3e-3 - 1e-15))          # end of the first loading
    n2 = n1 + int(np.argmax(x[n1:] <= 1e-3 + 1e-15))  # end of the unloading
    load, unload, reload = slice(0, n1 + 1), slice(n1, n2 + 1), slice(n2, None)
    expect = np.empty_like(x)
    expect[load] = -np.minimum(1e7 * x[load], 1e4)
    expect[unload] = -1e7 * (x[unload] - 2e-3)
    expect[reload] = np.where(x[reload] < 5e-3, -np.minimum(1e7 * (x[reload] - 2e-3), 1e4), 0.0)
    np.testing.assert_allclose(f, expect, rtol=1e-9, atol=1e-6)
    nb = int(np.argmax(x >= 5e-3))
    assert out["dissipated"][-1] == pytest.approx(45.0 - 0.5 * 1e4 * (x[nb] - x[nb - 1]), rel=1e-9)
    states = out["state"]
    assert states[int(np.argmax(x > 1.0001e-3))] == 1 and states[0] == 0
    assert states[-1] == 2 and (out["force"][x >= 5e-3] == 0.0).all()
    # stored: |F|^2 / (2 k), nothing once broken
    np.testing.assert_allclose(out["stored"], f ** 2 / 2e7, rtol=1e-12, atol=1e-15)


def test_clearance_law_gap_crushing_slack_and_break():
    """c = 2 mm, k = 5e6 N/m, F_y = 1e4 N, u_ult = 8 mm. Closed forms: nothing inside 2 mm, k (u - c)
    beyond, the seat crushing from c + F_y/k = 4 mm on; loading to 6 mm leaves a clearance of
    6 - 2 = 4 mm in every direction: back through 0 to -5 mm the force is +k (5 - 4) mm = 5 kN;
    then to +9 mm it breaks at 8 mm. Dissipation F_y (6 - 4) mm = 20 J, then on the way to 8 mm
    F_y (8 - 6) mm = 20 J and the 10 J stored at the break (less half the breaking step's plastic
    work, as in the elastoplastic case)."""
    lw = DowelLaw("clearance", k_shear=5e6, f_yield=1e4, u_ultimate=8e-3, clearance=2e-3)
    u = path(0.0, 6e-3, -5e-3, 9e-3)
    out = lw.drive(u)
    x, f = u[:, 0], out["force"][:, 0]
    n1 = int(np.argmax(x >= 6e-3 - 1e-15))
    n2 = n1 + int(np.argmax(x[n1:] <= -5e-3 + 1e-15))
    first = -np.clip(5e6 * (x[:n1 + 1] - 2e-3), 0.0, 1e4)
    back = np.where(np.abs(x[n1:n2 + 1]) > 4e-3, -np.sign(x[n1:n2 + 1]) * 5e6 * (np.abs(x[n1:n2 + 1]) - 4e-3), 0.0)
    np.testing.assert_allclose(f[:n1 + 1], first, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(f[n1:n2 + 1], back, rtol=1e-9, atol=1e-6)
    assert f[n2] == pytest.approx(5e3, rel=1e-9)
    assert (f[x < 2e-3][: int(np.argmax(x >= 2e-3))] == 0.0).all()
    assert out["dissipated"][n2] == pytest.approx(20.0, rel=1e-9)
    nb = int(np.argmax(x >= 8e-3))
    assert out["dissipated"][-1] == pytest.approx(50.0 - 0.5 * 1e4 * (x[nb] - x[nb - 1]), rel=1e-9)
    assert out["state"][-1] == 2 and f[-1] == 0.0


def test_elastoplastic_law_turns_with_the_displacement_radially():
    """A circle of radius R = 3 u_y after a radial loading: the force keeps |F| = F_y. In the steady
    state the offset p runs on a circle of radius rho with u - p (|u - p| = u_y, the direction it
    moves in: radial return) tangent to it, so R^2 = rho^2 + u_y^2 and a revolution dissipates
    F_y 2 pi sqrt(R^2 - u_y^2) = 177.7 J (the second turn, to 0.1 %: 20 000 steps a turn)."""
    lw = DowelLaw("elastoplastic", k_shear=1e7, f_yield=1e4)
    uy = 1e-3
    r = np.linspace(0.0, 3 * uy, 301)
    phi = np.linspace(0.0, 4 * np.pi, 40001)
    u = np.zeros((r.size + phi.size, 3))
    u[:r.size, 0] = r
    u[r.size:, 0] = 3 * uy * np.cos(phi)
    u[r.size:, 1] = 3 * uy * np.sin(phi)
    out = lw.drive(u)
    fm = np.hypot(out["force"][:, 0], out["force"][:, 1])
    assert fm[r.size + 10:] == pytest.approx(1e4, rel=1e-9)
    second_turn = out["dissipated"][-1] - out["dissipated"][r.size + 20000]
    assert second_turn == pytest.approx(2 * np.pi * math.sqrt(8.0) * uy * 1e4, rel=1e-3)


def test_axial_part_tension_only_slip_and_pull_out():
    """ka = 1e8 N/m, N_y = 5e4 N (0.5 mm), d_ult = 2 mm: no force closing (uz < 0), -ka uz opening,
    capped at N_y with a slack that grows to 1.5 - 0.5 = 1 mm by 1.5 mm; closed again to 0.5 mm it
    carries nothing (slack), pulls out at 2 mm (every force 0 after)."""
    lw = DowelLaw("elastoplastic", k_shear=1e7, k_axial=1e8, n_yield=5e4, d_ultimate=2e-3)
    z = np.concatenate([np.linspace(0, -1e-3, 11), np.linspace(-1e-3, 1.5e-3, 26)[1:], np.linspace(1.5e-3, 0.5e-3, 11)[1:],
                        np.linspace(0.5e-3, 2.5e-3, 21)[1:]])
    u = np.zeros((z.size, 3))
    u[:, 2] = z
    out = lw.drive(u)
    fz = out["force"][:, 2]
    assert (fz[z <= 0] == 0.0).all()
    i15 = int(np.argmax(z >= 1.5e-3 - 1e-15))
    assert fz[i15] == pytest.approx(-5e4, rel=1e-12)
    back = i15 + 10
    assert z[back] == pytest.approx(0.5e-3) and fz[back] == 0.0
    assert out["state"][-1] == 2 and fz[-1] == 0.0
    assert out["dissipated"][i15] == pytest.approx(5e4 * 1e-3, rel=1e-9)
    # the pull-out is at d_ult itself (a point of the path): still whole, and at N_y, one step of
    # 0.1 mm before it (1.9 mm), broken from 2 mm on (a break at 0.9 d_ult passed every test)
    brk = int(np.argmax(out["state"] == 2))
    assert z[brk] == pytest.approx(2e-3, rel=1e-12) and z[brk - 1] == pytest.approx(1.9e-3, rel=1e-12)
    assert fz[brk - 1] == pytest.approx(-5e4, rel=1e-12)


@pytest.mark.parametrize("changes, text", [
    (dict(k_shear=-1.0), "k_shear must be finite and >= 0"),
    (dict(f_yield=float("nan")), "f_yield must be a number"),
    (dict(f_yield=0.0), "f_yield must be > 0"),
    (dict(u_ultimate=-0.01), "u_ultimate must be > 0"),
    (dict(clearance=0.001), "an elastoplastic connector has no clearance"),
    (dict(kind="steel"), "kind must be one of"),
    (dict(k_axial=float("inf")), "k_axial must be finite"),
])
def test_bad_laws_are_refused_naming_the_value(changes, text):
    with pytest.raises(pcf.ParameterError, match=text):
        DowelLaw(**{**dict(kind="elastoplastic", k_shear=1e7, f_yield=1e4), **changes})
    with pytest.raises(pcf.ParameterError, match="clearance 0.03 m must be below u_ultimate 0.02"):
        DowelLaw("clearance", k_shear=1e6, clearance=0.03, u_ultimate=0.02)


# ---- connectors on a column --------------------------------------------------------------

def test_dowels_off_the_face_and_bad_joints_are_refused():
    col = pcf.Column.parthenon()
    with pytest.raises(pcf.ParameterError, match=r"outside the face of joint 12"):
        col.with_connectors(Connectors.of("titanium", joints=(12,), count=3, radius=0.63))
    with pytest.raises(pcf.ParameterError, match="joint 13 does not exist"):
        col.with_connectors(Connectors.of("titanium", joints=(13,)))
    with pytest.raises(pcf.ParameterError, match="need a radius > 0"):
        Connectors.of("titanium", count=3)
    with pytest.raises(pcf.ParameterError, match="unknown dowel law 'bronze'"):
        Connectors.of("bronze")


def test_column_file_takes_connectors(tmp_path):
    text = ("[shaft]\ndrum_heights = [1.0, 1.0]\ndiameter_bottom = 1.0\n\n"
            "[[connectors]]\njoints = [1]\nlaw = \"titanium\"\n\n"
            "[[connectors]]\njoints = \"all\"\ncount = 3\nradius = 0.2\n"
            "law = {kind = \"clearance\", k_shear = 1e6, clearance = 0.001, u_ultimate = 0.01}\n")
    p = tmp_path / "c.toml"
    p.write_text(text)
    col = pcf.Column.from_file(p)
    assert [(j, round(x, 12), round(y, 12), lw.kind) for j, x, y, lw in col.dowels()][:2] == \
        [(1, 0.0, 0.0, "elastoplastic"), (0, 0.2, 0.0, "clearance")]
    assert len(col.dowels()) == 1 + 2 * 3
    again = pcf.Column.from_dict(col.to_dict())
    assert again.dowels() == col.dowels()
    assert "connectors" not in pcf.Column.parthenon().to_dict()   # a column without them: as before
    p.write_text(text.replace("count = 3", "count = 3\ncolour = 1"))
    with pytest.raises(pcf.ParameterError, match=r"unknown keys \['colour'\]"):
        pcf.Column.from_file(p)


def _burst(amp_g=0.25, f_hz=2.0, dur=3.0, dt=0.005):
    t = np.arange(0.0, dur, dt)
    return amp_g * G * np.sin(2 * np.pi * f_hz * t), dt


def test_dowels_that_carry_nothing_give_the_free_columns_bits():
    """Zero shear and axial stiffness: every force of the dowels is +0.0, so the run is bitwise the
    free column's (the set-up through the scene, the connectors in the step and the ledger)."""
    col = pcf.Column.parthenon()
    nothing = col.with_connectors(Connectors(DowelLaw("elastoplastic", k_shear=0.0), "all", count=3, radius=0.3))
    acc, dt = _burst()
    a = pcf.simulate(col, acc, dt, history=True, acc_z=0.3 * acc)
    b = pcf.simulate(nothing, acc, dt, history=True, acc_z=0.3 * acc)
    for name in ("u_top", "u_d", "energy_error", "n_steps", "dt", "dt_crit", "max_top_disp"):
        assert getattr(a, name) == getattr(b, name), name
    np.testing.assert_array_equal(a.residual_dislocation, b.residual_dislocation)
    for name in ("t", "top_disp", "block_pos", "block_quat", "joint_opening", "joint_slip", "joint_normal_force"):
        np.testing.assert_array_equal(getattr(a.history, name), getattr(b.history, name), err_msg=name)
    for k in a.history.energy:
        np.testing.assert_array_equal(a.history.energy[k], b.history.energy[k], err_msg=k)
    assert b.dowels_broken == 0 and b.dowel_shear_kn == 0.0 and math.isnan(a.dowels_broken)
    assert b.dowels_yielded == 0 and math.isnan(a.dowels_yielded)


def _static_threshold(col, lo=0.8, hi=1.0, iters=7, **kw):
    """Largest steady acceleration (a fraction of g r / h_cg, held after a 4 s raised-cosine ramp for
    8 s) under which the column stands, by bisection to (hi - lo) / 2^iters."""
    thr = G * col.blocks[0].bottom.r_bottom / col.com_height
    t = np.arange(0.0, 12.0, 0.01)
    ramp = np.where(t < 4.0, 0.5 * (1.0 - np.cos(np.pi * t / 4.0)), 1.0)
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if pcf.simulate(col, mid * thr * ramp, 0.01, tail_s=0.0, planar=True, **kw).collapsed:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def test_stiff_unbreakable_dowels_make_the_monolithic_column():
    """Four dowels at 0.45 m in every joint above the base, 1e10 N/m in shear and axially, never
    yielding: the column overturns quasi-statically where the monolithic column does (the same soft
    base joint, default kn): within 1 %. Measured (bisection to 0.16 %): monolithic 0.901, dowelled
    0.896, free 0.870 of the rigid threshold g r / h_cg = 0.1715 g (the soft joints' compliance keeps
    both below it; with kn = 1e10 they are 0.978 and 0.976). The free column, whose joints open
    above the base, stands 3.5 % lower: the check tells the dowels' work from the base's."""
    col = pcf.Column.parthenon()
    stiff = col.with_connectors(Connectors(DowelLaw("elastoplastic", k_shear=1e10, k_axial=1e10),
                                           tuple(range(1, col.n_blocks)), count=4, radius=0.45))
    mono = _static_threshold(col, monolithic=True)
    dowelled = _static_threshold(stiff)
    free = _static_threshold(col)
    assert dowelled == pytest.approx(mono, rel=0.01)
    assert free < 0.98 * mono


# ---- runs: ledger, reports ------------------------------------------------------------------

@pytest.mark.parametrize("name", ["titanium", "wood"])
def test_dowelled_runs_close_the_ledger_and_report_their_dowels(name):
    """A 0.35 g 1.5 Hz burst yields the dowels: the balance error stays within the tolerance a free
    column's run keeps (0.05 of the energy scale), the connectors' dissipation in the history's ledger
    is the sum of what each dowel reports, and the EDPs are the reports' maxima."""
    col = pcf.Column.parthenon().with_connectors(Connectors.of(name, "all"))
    acc, dt = _burst(0.35, 1.5, 4.0)
    r = pcf.simulate(col, acc, dt, history=True, early_exit=False)
    assert r.energy_error < 0.05
    d = r.dowels
    assert d["yielded"].any()
    assert r.history.energy["connector_dissipated"][-1] == pytest.approx(d["dissipated"].sum(), rel=1e-9, abs=1e-9)
    assert r.dowel_shear_kn == pytest.approx(d["peak_shear"].max() / 1e3)
    assert r.dowel_slip_mm == pytest.approx(d["peak_slip"].max() * 1e3)
    assert r.dowels_broken == d["broken"].sum() and r.dowels_yielded == d["yielded"].sum() >= r.dowels_broken
    assert (d["peak_shear"] <= LAWS[name].f_yield * (1 + 1e-12)).all()
    assert r.history.dowels.shape == (r.history.t.size, col.n_blocks, 3)


def test_ledger_converges_with_the_step_on_a_hard_case():
    """Titanium dowels that yield and break under a 0.5 g 1 Hz burst (the column rocks and its dowels
    break): the balance error falls as the step is shortened (dt_factor 0.8 -> 0.2; measured 5.3e-3,
    3.9e-3, 1.1e-3; before the dowels' pair of forces was made the gradient of their energy the
    error stayed at 5e-3 at every step)."""
    col = pcf.Column.parthenon().with_connectors(Connectors.of("titanium", "all"))
    acc, dt = _burst(0.5, 1.0, 3.0)
    errs = [pcf.simulate(col, acc, dt, dt_factor=f, early_exit=False, tail_s=1.0).energy_error for f in (0.8, 0.4, 0.2)]
    assert errs[2] < errs[1] < errs[0]
    assert errs[2] < 0.5 * errs[0]


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _same(a, b, what):
    """Two Responses bitwise equal (NaN == NaN): EDPs, residuals, dowel outputs, histories (the dowels' too)."""
    for key in ("u_top", "u_d", "n_steps", "t_end", "collapsed", "collapse_time", "energy_error", "energy_scale",
                "max_top_disp", "message", "dowel_shear_kn", "dowel_slip_mm", "dowels_yielded", "dowels_broken"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=f"{what}: {key}")
    np.testing.assert_array_equal(a.residual_dislocation, b.residual_dislocation, err_msg=f"{what}: residuals")
    for key in a.dowels:
        np.testing.assert_array_equal(a.dowels[key], b.dowels[key], err_msg=f"{what}: dowels {key}")
    for key in ("t", "top_disp", "block_pos", "block_quat", "joint_opening", "joint_slip", "joint_normal_force",
                "dowels"):
        np.testing.assert_array_equal(getattr(a.history, key), getattr(b.history, key), err_msg=f"{what}: {key}")
    assert a.history.energy.keys() == b.history.energy.keys()
    for key in a.history.energy:
        np.testing.assert_array_equal(a.history.energy[key], b.history.energy[key], err_msg=f"{what}: {key}")


@pytest.mark.parametrize("name", ["column_parthenon_titanium.toml", "column_parthenon_wood.toml"])
def test_batch_of_a_dowelled_column_is_its_single_runs(name):
    """A dowelled column (the examples: titanium, the elastoplastic law; wood, the clearance law) runs in
    lanes as wide as the free column's, each lane's dowels stepped by the single run's code after its
    contacts (csrc/solver_batch_lanes.h); every run of a batch at every width is bitwise its single
    run (tolerance zero: the lanes do the single run's operations in its order), its dowels' outputs
    and histories included. Records of different lengths: lanes are refilled, their dowels reset."""
    col = pcf.Column.from_file(EXAMPLES / name)
    recs = [_burst(a, 2.0, d) for a, d in ((0.3, 1.2), (0.45, 0.8), (0.2, 0.4), (0.4, 1.0), (0.35, 0.6))]
    widest = pcf.solver.run.batch_width(col, tail_s=0.5)
    assert widest == pcf.solver.run.batch_width(pcf.Column.parthenon(), tail_s=0.5)
    singles = [pcf.simulate(col, acc, dt, history=True, tail_s=0.5) for acc, dt in recs]
    assert max(s.dowel_shear_kn for s in singles) > 0.0   # the dowels carry force: the equality is not vacuous
    for width in (w for w in (1, 2, 4, 8) if w <= widest):
        batch = pcf.simulate_batch(col, recs, history=True, width=width, tail_s=0.5)
        for i, (s, b) in enumerate(zip(singles, batch)):
            _same(s, b, f"{name} width {width} run {i}")


def test_monolithic_keeps_the_base_dowels_only():
    col = pcf.Column.parthenon().with_connectors(Connectors.of("titanium", "all"))
    acc, dt = _burst(0.2, 2.0, 1.0)
    with pytest.warns(UserWarning, match="dowels of joints"):
        r = pcf.simulate(col, acc, dt, monolithic=True)
    assert r.dowels["joint"].tolist() == [0]


def test_named_laws_have_their_provenance():
    for name, lw in LAWS.items():
        assert lw.name == name and law(name) is lw
    assert LAWS["titanium"].u_yield == pytest.approx(1e-3)
    assert LAWS["wood"].kind == "clearance" and LAWS["wood"].u_yield == pytest.approx(2e-3 + 2e-3)


def test_a_broken_dowels_slip_is_frozen_at_its_break():
    """One weak dowel (12 mm ultimate slip) at the centre of the base joint of a column on joints of
    8 degrees' friction, under a 0.3 g 1 Hz burst: the dowel breaks at 0.33 s and the base then slides
    on to 56 mm (the history's displacement across the joint at the dowel). The dowel's ``peak_slip``
    (and the EDP ``dowel_slip_mm``) is the slip at which it broke: the law's break criterion
    |u| >= u_ultimate = 12 mm, overshot by at most one step's slide (measured 12.099 mm: dt 0.8 ms at a
    slide of about 0.12 m/s; bound 2 % of u_ultimate). Before the slip was frozen at the break it kept
    counting the joint's slide: 55.6 mm."""
    lw = DowelLaw("elastoplastic", k_shear=2e6, f_yield=2e3, u_ultimate=0.012)
    col = pcf.Column.parthenon().with_joints(friction_deg=8.0).with_connectors(Connectors(lw, (0,)))
    t = np.arange(0.0, 3.0, 0.005)
    r = pcf.simulate(col, 0.3 * G * np.sin(2 * np.pi * t), 0.005, history=True, early_exit=False, tail_s=0.5)
    d = r.dowels
    assert d["broken"][0]
    assert r.history.dowels[:, 0, 0].max() > 3 * lw.u_ultimate      # the joint slid on well past the break
    assert lw.u_ultimate <= d["peak_slip"][0] <= 1.02 * lw.u_ultimate
    assert r.dowel_slip_mm == pytest.approx(d["peak_slip"][0] * 1e3)
