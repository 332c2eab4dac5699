"""Independent reference solutions for the hard-case tests (tests/test_hard_cases.py): closed forms and scipy
solve_ivp integrations that share no code with the solver.

* Housner (1963) rigid-block rocking with his restitution r = 1 - 1.5 sin^2(alpha).
* Newmark (1965) rigid sliding block (Coulomb friction, no rocking) under any base acceleration,
  integrated event by event (stick / slip phases); slip per cycle under harmonic motion.
* One-sine pulse overturning threshold of a rigid block by bisection over the Housner integration.
* Quasi-static overturning threshold b / h of a rigid block.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81


def quasi_static_threshold_g(b, h_cg):
    """Rigid block on a rigid base: uniform base acceleration overturns it at a/g = b / h_cg
    (b: distance from the centre of mass to the toe, horizontally; h_cg: height of the centre of mass)."""
    return b / h_cg


def housner_restitution(alpha):
    """Housner (1963): angular-velocity ratio across an impact, r = 1 - 1.5 sin^2(alpha)."""
    return 1.0 - 1.5 * math.sin(alpha) ** 2


def housner_overturns(ag, b, h_cg, t_end, t_start=0.0):
    """Integrate Housner's equation of a rigid block (half-width b, centre of mass at h_cg)
    theta'' = -p^2 [sin(alpha sgn(theta) - theta) + (a_g/g) cos(alpha sgn(theta) - theta)],
    p^2 = 3 g / (4 R) (prismatic block, R = hypot(b, h_cg)), with Housner's impact restitution.
    ``ag(t)`` is the base acceleration (m/s^2). Returns True when |theta| reaches pi/2."""
    alpha = math.atan(b / h_cg)
    p2 = 3 * G / (4 * math.hypot(b, h_cg))
    r = housner_restitution(alpha)
    ts = np.linspace(t_start, t_end, 40001)
    a = np.array([ag(x) for x in ts])
    over = np.abs(a) > G * math.tan(alpha)
    if not over.any():
        return False
    i0 = int(np.argmax(over))
    sgn0 = -np.sign(a[i0])

    def f(t, y):
        s = np.sign(y[0]) if y[0] != 0 else sgn0
        return [y[1], -p2 * (math.sin(alpha * s - y[0]) + ag(t) / G * math.cos(alpha * s - y[0]))]

    def impact(t, y):
        return y[0]
    impact.terminal = True

    def fall(t, y):
        return abs(y[0]) - math.pi / 2
    fall.terminal = True

    y, t = [sgn0 * 1e-12, 0.0], ts[i0]
    while t < t_end:
        sol = solve_ivp(f, (t, t_end), y, events=(impact, fall), rtol=1e-9, atol=1e-12, max_step=2e-3)
        if sol.t_events[1].size:
            return True
        if not sol.t_events[0].size:
            return False
        t = sol.t_events[0][0] + 1e-9
        w = sol.y_events[0][0][1] * r
        if abs(w) < 1e-7:
            # at rest on the base: restart when the base acceleration next exceeds the uplift level
            rest = np.where((ts > t) & over)[0]
            if not rest.size:
                return False
            t = ts[rest[0]]
            sg = -np.sign(a[rest[0]])
            y = [sg * 1e-12, 0.0]
            continue
        y = [math.copysign(1e-12, w), w]
    return False


def one_sine_threshold(b, h_cg, Tp, lo_g=0.1, hi_g=20.0, tol_rel=1e-3, tail=4.0):
    """Smallest one-sine pulse amplitude A (m/s^2) of period Tp, a_g = A sin(2 pi t/Tp) on [0, Tp],
    that overturns the rigid block, by bisection over :func:`housner_overturns` (assumes a single
    transition inside [lo_g, hi_g] g, true for the minimum-amplitude branch)."""
    def ov(A):
        return housner_overturns(lambda t: A * math.sin(2 * math.pi * t / Tp) if t < Tp else 0.0,
                                 b, h_cg, Tp + tail)
    lo, hi = lo_g * G, hi_g * G
    assert not ov(lo) and ov(hi)
    while hi - lo > tol_rel * hi:
        mid = 0.5 * (lo + hi)
        if ov(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def newmark_sliding(ag, mu, t_end, dt=1e-4):
    """Rigid block on a Coulomb base (no rocking): relative slip s(t) of the block w.r.t. the
    ground under base acceleration ``ag(t)`` (m/s^2). While sliding, s'' = -a_g - mu g sgn(s');
    it sticks when s' reaches 0 and |a_g| <= mu g, and starts to slip again when |a_g| > mu g.
    Integrated with solve_ivp from event to event. Returns (t, s, s')."""
    T, S, V = [0.0], [0.0], [0.0]
    t, s, v = 0.0, 0.0, 0.0
    lim = mu * G
    while t < t_end - 1e-12:
        if v == 0.0:  # stuck: march to the next instant |a_g| > mu g
            tt = t
            while tt < t_end and abs(ag(tt)) <= lim:
                tt += dt
            if tt >= t_end:
                T.append(t_end); S.append(s); V.append(0.0)
                break
            T.append(tt); S.append(s); V.append(0.0)
            t = tt
            d = -math.copysign(1.0, ag(t))

            def f(x, y, d=d):
                return [y[1], -ag(x) - lim * d]
        else:
            d = math.copysign(1.0, v)

            def f(x, y, d=d):
                return [y[1], -ag(x) - lim * d]

        def stop(x, y, d=d):
            return y[1] if x > t + 1e-9 else d  # noqa: B023 (solve_ivp calls it within this iteration)
        stop.terminal = True
        sol = solve_ivp(f, (t, t_end), [s, v if v else 0.0], events=stop, rtol=1e-10, atol=1e-13,
                        max_step=min(1e-3, 0.05 * t_end))
        T.extend(sol.t[1:]); S.extend(sol.y[0, 1:]); V.extend(sol.y[1, 1:])
        t, s = sol.t[-1], sol.y[0, -1]
        v = 0.0 if sol.status == 1 else sol.y[1, -1]
        if sol.status == 1:
            V[-1] = 0.0
            if abs(ag(t)) > lim and math.copysign(1.0, -ag(t)) == d:
                v = 1e-12 * d  # keeps sliding the same way (cannot happen with the stop at v = 0)
    return np.array(T), np.array(S), np.array(V)


def newmark_harmonic_slip_per_cycle(A, f_hz, mu, n_cycles=6):
    """Peak-to-peak relative slip over the last cycle of steady two-way sliding under
    a_g = A sin(2 pi f t) (reference for the stick-slip test)."""
    T = 1.0 / f_hz
    t, s, _ = newmark_sliding(lambda x: A * math.sin(2 * math.pi * f_hz * x), mu, n_cycles * T)
    m = t >= (n_cycles - 1) * T
    return float(s[m].max() - s[m].min())


def newmark_pulse_slip(A, t_p, mu):
    """Newmark (1965) closed form: slip of a rigid block under a rectangular pulse of A for t_p,
    V = A t_p: V^2/(2 mu g) (1 - mu g / A)."""
    V = A * t_p
    return V * V / (2 * mu * G) * (1 - mu * G / A)


def rocking_frame_first_excursion(ag, alpha, p, t_start, t_end):
    """The rocking frame of Makris & Vassiliou (2013): N equal rigid columns of slenderness alpha
    with a rigid cap beam that stays level move as one rigid column of the same slenderness with the
    frequency parameter p_hat = p sqrt((1 + 2 gamma) / (1 + 3 gamma)) (gamma: the beam's mass over the
    columns'). Their Lagrangian, with every column turning by theta about a base corner and the beam
    carried by the opposite top corners (a translation of 2R theta-rates): T = (1/2) (N (4/3) m R^2 +
    4 M R^2) theta'^2, V = (N m + 2 M) g R cos(alpha - theta), the ground's inertia forces (N m + 2 M)
    R cos(alpha - theta) a_g -- whence theta'' = -p_hat^2 (sin(alpha - theta) - (a_g / g) cos(alpha
    - theta)) with p^2 = 3 g / (4 R), the equation of one column of p_hat, tipping toward -x under
    a_g > 0. Integrated (solve_ivp, rtol 1e-10) from uplift at t_start until it falls back to theta = 0
    (its first impact) or t_end: returns (theta_max, t_impact)."""
    def rhs(t, y):
        return [y[1], -p * p * (math.sin(alpha - y[0]) - ag(t) / G * math.cos(alpha - y[0]))]

    def back(t, y):
        return y[0]
    back.terminal = True
    back.direction = -1
    sol = solve_ivp(rhs, (t_start, t_end), [1e-12, 0.0], events=back, max_step=1e-3, rtol=1e-10, atol=1e-14)
    t_imp = sol.t_events[0][0] if len(sol.t_events[0]) else math.nan
    return float(sol.y[0].max()), float(t_imp)
