"""Two-component motion (docs/accuracy.md, "Two-component motion"): symmetry, the quasi-static
level along a flat side, and the energy ledger when drums slide past the edge of the drum below.

The default column (``Column.parthenon()``) is a stack of regular 10-gons with a vertex along +x,
so its geometry is unchanged by a rotation of 36 degrees about z, and the loading direction 18 deg
points at the middle of a flat side. Everything here uses synthetic records built from seeded
numpy generators (no data files, no optional packages).
"""
import math

import numpy as np
import pytest

import pycolfrag as pcf

G = 9.81


def rotate(xy, deg):
    """Rotate (n, 2) horizontal vectors by deg about z."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.c_[c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]]


def along(col, acc, dt, deg, **kw):
    """simulate() with the one-direction record acc applied along deg (acc_x = a cos, acc_y = a sin)."""
    th = math.radians(deg)
    return pcf.simulate(col, acc * math.cos(th), dt, acc_y=acc * math.sin(th), **kw)


# ---- (a) symmetry: 0 deg against 36 deg -----------------------------------------------------

def first_impact_time(hist, lift=1e-5, closed=1e-7):
    """First time a joint that had lifted (some upper-face vertex more than `lift` above the lower
    face's plane) closes again (no vertex above `closed`): the first rocking impact."""
    op = hist.joint_opening
    times = []
    for j in range(op.shape[1]):
        up = np.nonzero(op[:, j] > lift)[0]
        if up.size:
            back = np.nonzero(op[up[0]:, j] <= closed)[0]
            if back.size:
                times.append(hist.t[up[0] + back[0]])
    return min(times)


def test_rotated_36_deg_same_response_before_first_impact():
    """A one-sine pulse (0.35 g, 0.6 s) along x and along 36 deg: the 36 deg response, rotated back
    by -36 deg, equals the x response to round-off until the first rocking impact (measured: the
    first impact, a joint that lifted closing again, at 0.28 s in both runs; up to it the difference
    is 3e-14 of the peak top displacement (0.22 m); after it the chaotic motion amplifies the
    round-off: 1e-12 at 0.53 s, 1e-8 at 0.73 s, 1e-3 at 1.4 s). The only difference between the two
    runs is the order in which the vertex forces are summed (the points sit at other vertices), so
    1e-11 of the peak is round-off with a margin of 300, while any physical anisotropy (a wrong
    component, an inertia that is not the 10-gon's, a face rotated by a fraction of a sector) is
    orders of magnitude larger. Also: the x run has no y motion (mirror symmetry about x)."""
    col = pcf.Column.parthenon()
    dt = 0.005
    t = np.arange(0.0, 3.0, dt)
    a = np.where(t < 0.6, 0.35 * G * np.sin(2 * np.pi * t / 0.6), 0.0)
    kw = dict(history=True, history_dt=0.001, early_exit=False, tail_s=2.0)
    rx = along(col, a, dt, 0.0, **kw)
    rr = along(col, a, dt, 36.0, **kw)
    hx, hr = rx.history, rr.history
    t_imp = first_impact_time(hx)
    assert 0.2 < t_imp < 0.6          # the pulse rocks the column: uplift at 0.1 s, first impact 0.28 s
    assert first_impact_time(hr) == pytest.approx(t_imp, abs=0.0015)
    peak = np.max(np.abs(hx.top_disp))
    assert peak > 0.05                # m: a real rocking response, not an elastic wobble
    assert np.max(np.abs(hr.top_disp[:, 1])) > 0.5 * math.sin(math.radians(36)) * peak  # truly 2D
    before = hx.t < t_imp
    diff = np.max(np.abs(rotate(hr.top_disp, -36.0) - hx.top_disp)[before])
    assert diff < 1e-11 * peak
    assert np.max(np.abs(hx.top_disp[before, 1])) < 1e-11 * peak


def test_rotated_36_deg_same_sliding():
    """The Coulomb law is isotropic in the joint plane: a squat 10-gon block (2 m across flats, 0.4 m
    tall, vertex along x) on the ground under a 1.2 g one-sine pulse (1 s) slides (peak 0.20 m,
    residual 3 mm) without rocking (no vertex lifts), so nothing is chaotic and the 36 deg run,
    rotated back, equals the x run to round-off over the whole record (measured 1.4e-13 of the peak;
    bound 1e-10). A cap on each shear component instead of on the shear vector (24 % more friction
    along 36 deg) fails it by orders of magnitude."""
    col = pcf.Column.single_block(2.0, 0.4, n_sides=10, flat_side_along_x=False)
    dt = 0.005
    t = np.arange(0.0, 2.0, dt)
    a = np.where(t < 1.0, 1.2 * G * np.sin(2 * np.pi * t), 0.0)
    kw = dict(history=True, history_dt=0.001, tail_s=1.0, early_exit=False)
    rx, rr = along(col, a, dt, 0.0, **kw), along(col, a, dt, 36.0, **kw)
    hx, hr = rx.history, rr.history
    assert np.max(hx.joint_opening) == 0.0                       # pure sliding, no rocking
    peak = np.max(np.abs(hx.top_disp))
    assert peak > 0.1
    assert np.max(np.abs(rotate(hr.top_disp, -36.0) - hx.top_disp)) < 1e-10 * peak
    assert rr.u_d == pytest.approx(rx.u_d, rel=1e-9)


def pulse_ensemble(n=16, seed=1, dt=0.01, dur=6.0):
    """n records: a one-sine pulse (0.25-0.45 g, 0.4-1.0 s) plus 0.1 g of decaying multi-sine noise
    (1-6 Hz): every run rocks with impacts (u_top 0.07-0.36) and none collapses."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, dur, dt)
    out = []
    for _ in range(n):
        amp, tp = rng.uniform(0.25, 0.45), rng.uniform(0.4, 1.0)
        a = np.where(t < tp, amp * G * np.sin(2 * np.pi * t / tp), 0.0)
        f, ph = rng.uniform(1.0, 6.0, 20), rng.uniform(0.0, 2 * np.pi, 20)
        noise = np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None]).sum(0)
        a = a + 0.1 * G * noise / math.sqrt(10) * np.exp(-t / 2)
        out.append(a)
    return out, dt


def test_rotated_36_deg_same_ensemble_statistics_after_impacts():
    """After the first impact single runs are chaotic, so the symmetry is checked on an ensemble of
    16 pulse records along 0 and 36 deg.

    * Means: the paired differences (36 minus 0, record by record) are chaotic noise with mean zero;
      measured u_top +0.0007 +- 0.0005 (SE), u_d -0.0032 +- 0.0013 on means of 0.208 and 0.014 (48 other
      records, seed 2: -0.0004 +- 0.0007 and -0.0013 +- 0.0008 at 36 deg, -0.0004 +- 0.0003 and
      -0.0004 +- 0.0009 at 72 deg). Bound: 4 SE of the paired mean.
    * Per record: u_top is mostly reached in the first large excursions, before the round-off has
      grown, so most records give the same u_top within 1 % (median 0.04 %) while u_d, a residual,
      differs by 30 % in the median. The count is itself chaotic: with the records scaled by
      1 + eps (eps = 0, 1e-13 ... 4e-12, eight harmless last-bit perturbations, measured after the
      solver moved to the library's own cos/sin) it was 11, 12, 15, 13, 11, 12, 12, 14 of 16;
      the mutants below give 2 to 6. Bound: at least 9 of 16, between the two populations.

    What it catches (tried): the y ground acceleration scaled by 0.9 (2 of 16 within 1 %), the body
    y torque scaled by 0.9 (6 of 16) or 0.5 (3 of 16); the means alone miss them (1.7 SE), which is why the
    per-record count is asserted. It does not catch a Coulomb cap on each shear component instead
    of on the vector (these records make the joints rock more than slide): test_rotated_36_deg_same_sliding
    does."""
    col = pcf.Column.parthenon()
    recs, dt = pulse_ensemble()
    res = {}
    for deg in (0.0, 36.0):
        res[deg] = np.array([[r.u_top, r.u_d, r.collapsed] for r in (along(col, a, dt, deg) for a in recs)], float)
    assert not res[0.0][:, 2].any() and not res[36.0][:, 2].any()
    n = len(recs)
    for i, name in ((0, "u_top"), (1, "u_d")):
        d = res[36.0][:, i] - res[0.0][:, i]
        se = d.std(ddof=1) / math.sqrt(n)
        assert abs(d.mean()) < 4 * se, (name, d.mean(), se)
    same = np.abs(res[36.0][:, 0] - res[0.0][:, 0]) < 0.01 * res[0.0][:, 0]
    assert same.sum() >= 9, same.sum()


# ---- (a) quasi-static level along a flat side -----------------------------------------------

def rigid_levels(col):
    """Rigid-block uplift/overturning levels (g) of every joint, loading towards a vertex and towards
    a flat side: the part above joint j tips about the joint's polygon (circumradius r, apothem
    r cos(pi/n)) when a/g = lever / (height of its centre of mass above the joint)."""
    zs, ms = col.joint_heights, col.block_masses
    out = []
    for j, b in enumerate(col.blocks):
        r = b.bottom.r_bottom if j == 0 else min(b.bottom.r_bottom, col.blocks[j - 1].top.r_top)
        n = b.bottom.n_sides
        m = sum(ms[j:])
        h = sum(mi * (z + bi.centroid_height) for z, bi, mi in zip(zs[j:], col.blocks[j:], ms[j:])) / m - zs[j]
        out.append((r / h, r * math.cos(math.pi / n) / h))
    return out


def ramp_level(col, deg, rate=0.0005, a0=0.14, amax=0.19, dt=0.01, u_level=0.05):
    """Ground acceleration ramped to a0 in 2 s, then slowly (rate g/s) along deg; returns the level
    (g) at which u_top first exceeds u_level (the column is then tipping over)."""
    t = np.arange(0.0, 2.0 + (amax - a0) / rate, dt)
    a = np.where(t < 2.0, a0 * t / 2.0, a0 + rate * (t - 2.0)) * G
    r = along(col, a, dt, deg, history=True, tail_s=0.0)
    u = np.hypot(r.history.top_disp[:, 0], r.history.top_disp[:, 1]) / col.base_diameter
    i = np.argmax(u > u_level)
    assert u[i] > u_level, "the ramp did not tip the column"
    return a0 + rate * (r.history.t[i] - 2.0)


def test_quasi_static_level_along_flat_side_follows_rigid_geometry():
    """Along 0 deg the column tips about a vertex of the base 10-gon, along 18 deg about a flat side.
    Rigid-block levels from the geometry (computed here): base joint r / h_cg = 0.825 / 4.81 = 0.1715 g
    towards a vertex, apothem / h_cg = 0.1631 g towards a flat side (rounded to 0.170 and 0.162 g in
    tests/test_solver_physics.py); the base joint governs (every joint above has a higher level).
    With stiff joints (kn = ks = 1e11 Pa/m) and a slow two-component ramp (0.0005 g/s) the measured
    levels are 0.1728 and 0.1646 g: within 0.003 g of rigid (the toe compliance lowers the level,
    the ramp's lag of a few tenths of a second raises it; both are about 0.001 g here), and their
    ratio 0.9525 is cos 18 deg = 0.9511 to 0.005."""
    col = pcf.Column.parthenon().with_joints(kn=1e11, ks=1e11)
    levels = rigid_levels(col)
    vertex, flat = levels[0]
    assert min(v for v, _ in levels) == vertex and min(f for _, f in levels) == flat
    assert vertex == pytest.approx(0.170, abs=0.002) and flat == pytest.approx(0.162, abs=0.002)
    assert flat / vertex == pytest.approx(math.cos(math.radians(18)), rel=1e-12)
    lv, lf = ramp_level(col, 0.0), ramp_level(col, 18.0)
    assert lv == pytest.approx(vertex, abs=0.003)
    assert lf == pytest.approx(flat, abs=0.003)
    assert lf / lv == pytest.approx(math.cos(math.radians(18)), abs=0.005)


# ---- (b) the energy ledger when drums slide past the edge of the drum below ------------------

def two_component_record(seed, pga_g, dur=15.0, dt=0.01, fmin=1.0, fmax=8.0):
    """Two independent horizontal components: 40 sines each (frequencies uniform in [fmin, fmax] Hz,
    amplitudes 1/f, random phases) under a 1 s ramp and an exponential decay from mid-record,
    scaled to pga_g."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, dur, dt)
    env = np.minimum(t / 1.0, 1.0) * np.exp(-np.maximum(t - 0.5 * dur, 0.0) / (0.2 * dur))
    out = []
    for _ in range(2):
        f, ph = rng.uniform(fmin, fmax, 40), rng.uniform(0.0, 2 * np.pi, 40)
        a = (np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None]) / f[:, None]).sum(0) * env
        out.append(a * pga_g * G / np.abs(a).max())
    return out[0], out[1], dt


@pytest.mark.parametrize("seed, pga_g, dt_factor", [(0, 0.5, 0.8), (6, 0.5, 0.4), (0, 0.6, 0.8)])
def test_ledger_closes_when_drums_slide_past_the_edge(seed, pga_g, dt_factor):
    """Two-component records under which upper drums slide past the edges of the drums below, tilt,
    and their overhanging corners dip below the lower drum's top plane and come back onto it.

    History of the ledger on such records: before the point states 3 and 4 (main c9942c1) a corner
    came back with its whole overlap as a compressed spring (seed 6, 0.5 g: 0.46 MJ created against
    18 kJ of ground work, SolverError with energy error 0.522); a point deeper than pmax = 0.1 rc was
    'open' and re-entered as a fresh contact, its spring energy booked nowhere (seed 0, 0.6 g: error
    0.545, SolverError). With the re-entry threshold of 0.01 rc that followed, shallow re-entries still
    brought their spring, booked as created energy (up to 33 % of the ground work on these records).
    Now (default ``reentry_depth`` 0) every re-entry is unstretched: measured energy error 0.0083,
    0.0013, 0.0058 for the three cases, maximum slip 0.074, 0.165, 0.266 m, and no energy created.
    Bounds: the solver's tolerance 0.05 halved (two-component runs of the FEMA P695 sets stay under
    0.015 with this rule, docs/accuracy.md), and exactly zero created energy (no term of the rule
    subtracts from contact_switch).

    Which drum slides past an edge is chaotic (the cases were re-chosen when the rule changed). Scan of
    seeds 0-9 at 0.5 and 0.6 g, dt_factor 0.8 and 0.4 (40 runs): every energy error <= 0.0123 and
    nothing created, so the bounds hold on all of them, not only on the cases chosen for sliding far."""
    col = pcf.Column.parthenon()
    ax, ay, dt = two_component_record(seed, pga_g)
    r = pcf.simulate(col, ax, dt, acc_y=ay, dt_factor=dt_factor, history=True)
    h = r.history
    # a drum did slide past the edge below: a dislocation far beyond the polygon test's 0.01 rc
    assert np.max(np.hypot(h.joint_slip[..., 0], h.joint_slip[..., 1])) > 0.05
    assert r.energy_error < 0.025
    e = h.energy
    assert reentry_created(e["contact_switch"]) == 0.0
    # the history's own ledger closes at every sample, not only at the solver's check
    assert np.max(np.abs(e["balance_error"])) <= r.energy_error * r.energy_scale * (1 + 1e-9)


# ---- (c) the re-entry rule: a point coming back onto a face brings no compressed spring ------------

def reentry_created(switch):
    """Spring energy created by re-entries, J: the negative increments of the cumulative contact_switch
    between history samples (the solver books a stretched re-entry as negative contact_switch)."""
    d = np.diff(np.concatenate([[0.0], switch]))
    return float(-d[d < 0].sum())


def test_default_reentry_creates_no_energy():
    """A sub-contact that was off the face (beside the lower drum, below its top plane) and slides back
    onto it takes contact with its spring unstretched at every depth (``reentry_depth`` 0, the default
    chosen in docs/accuracy.md, "The re-entry rule"): a passive contact cannot create energy, so the
    ledger's contact_switch (spring energy leaving with points that slide off, minus that brought by
    points that slide on) never decreases -- exactly, not within a tolerance: with the rule no term is
    ever subtracted. The former rule (re-entries up to 0.01 rc deep bring their compressed spring)
    creates, on this record, 25 % of the ground work (measured 0.251; bound 5 %: over seeds 0-9 at
    0.5 and 0.6 g the former rule created 2.5-33 %, so the record keeps exercising re-entries if it
    shifts chaotically); changing the default back, or the solver ignoring the option, fails the
    first two assertions."""
    col = pcf.Column.parthenon()
    ax, ay, dt = two_component_record(6, 0.5)
    r = pcf.simulate(col, ax, dt, acc_y=ay, history=True)
    assert pcf.SolverOptions().reentry_depth == 0.0
    e = r.history.energy
    assert reentry_created(e["contact_switch"]) == 0.0
    assert np.all(np.diff(e["contact_switch"]) >= 0.0)
    old = pcf.simulate(col, ax, dt, acc_y=ay, history=True, reentry_depth=0.01)
    assert reentry_created(old.history.energy["contact_switch"]) > 0.05 * float(old.history.energy["ground_work"][-1])


def test_collapse_time_of_a_drum_pushed_past_the_edge_converges_with_the_step():
    """A constructed case where the rule decides the outcome's timing (the fourth case of the table in
    docs/accuracy.md, "The re-entry rule"): two drums of 10-gon section (circumradius 0.8 m, lower
    0.8 m tall, upper 3.0 m tall, 25 deg friction between them, default stiffness), a 1.0 g one-sine
    pulse of 1.0 s along x then a 0.5 g one along y. The upper drum slides past the lower drum's edge
    and overturns. Measured collapse times with the default rule (every re-entry unstretched): 2.04,
    2.01, 2.01 s at dt_factor 0.8, 0.2, 0.05 -- it converges with the step; with the former rule
    (``reentry_depth`` 0.01): 2.94, 2.28, 2.65 s, it does not. (The refined mesh, perimeter 4 points
    per edge, gives 2.30, 2.21, 2.23 s and the exact interface 2.57, 2.56, 2.55 s: the contact models
    differ, each converges.) Bound: 0.1 s between 0.8 and 0.2, about three times the spread of the
    default rule and a third of the former rule's; and the collapse within 0.15 s of 2.01 s."""
    from pycolfrag.structure.column import Block, Column, JointProperties, Segment
    seg = lambda h: Segment(height=h, r_bottom=0.8, r_top=0.8, n_sides=10)
    j = JointProperties()
    col = Column(blocks=(Block((seg(0.8),)), Block((seg(3.0),))), joints=j,
                 joint_overrides={1: JointProperties(kn=j.kn, ks=j.ks, friction_deg=25.0)})
    dt = 0.002
    t = np.arange(0.0, 6.0, dt)
    ax = np.where(t < 1.0, 1.0 * G * np.sin(2 * np.pi * t), 0.0)
    ay = np.where((t >= 1.0) & (t < 2.0), 0.5 * G * np.sin(2 * np.pi * (t - 1.0)), 0.0)
    times = []
    for f in (0.8, 0.2):
        r = pcf.simulate(col, ax, dt, acc_y=ay, dt_factor=f, early_exit=False, tail_s=2.0)
        assert r.collapsed and r.collapse_reason == "overturning"
        times.append(r.collapse_time)
    assert abs(times[0] - times[1]) < 0.1, times
    assert times[1] == pytest.approx(2.01, abs=0.15)
