"""Impact dissipation of the soft contacts: the coefficient of restitution of a rocking block.

Free rocking, no ground motion, no damping: the column is tilted rigidly by ``tilt`` about its +x
base edge/vertex (``simulate(initial_tilt_rad=...)``) and released. Between impacts a rigid block
rocks without loss, so the rocking energy at the n-th peak,

    E_n = M g (z_cm at the peak - z_cm at rest)  [= M g R (cos(alpha - theta_n) - cos(alpha)) for one body]

measures what survives the impacts, and the apparent coefficient of restitution of impact n is

    r_n = omega_after / omega_before = sqrt(E_{n+1} / E_n).

It is compared with Housner's (1963) instantaneous, plastic impact about the new corner with the
angular momentum about that corner conserved, r_H = 1 - (M R^2 / I_O) (1 - cos 2 alpha), which is
1 - 1.5 sin^2(alpha) for a rectangular block (I_O = 4/3 M R^2). I_O (about the rocking axis through
the pivot) is computed here from the segments: I_O = I_yy(cm) + M R^2, I_yy(cm) = rho * integral over
z of [c_n k_n r(z)^4 + k_n r(z)^2 (z - z_cm)^2] dz, k_n = (n/2) sin(2 pi/n), c_n = (2 + cos(2 pi/n))/12
(the second moment of a regular n-gon of circumradius r about any in-plane centroidal axis is
c_n k_n r^4), by Gauss-Legendre quadrature of each segment (exact for the degree-6 polynomial in z).

The energy ledger (History.energy) is read at the same peaks: E_mech = KE + gravity + spring,
relative to the column at rest, changes only by slip dissipation (including released shear-spring
energy), contact_switch and the integration error (balance_error), so the rocking energy lost
over the impacts = energy left in vibration (E_mech - E_rock at the peak: vertical bouncing and
the block's oscillation on its contact springs) + slip + switch - balance error.

    nice .venv/bin/python bench/restitution.py            # a few CPU-seconds; table to stdout,
                                                          # docs/restitution.png
    nice .venv/bin/python bench/restitution.py --no-plot
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import time
import warnings

import numpy as np

import pycolfrag as pcf

G = 9.81
HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.join(HERE, "..", "docs")
N_IMPACTS = 5  # impacts averaged in r_mean


# ---- geometry: mass, centre of mass, I_O about the pivot (independent of the C code) ----------

def _segments_z(col):
    """(z0, z1, r0, r1, n) of every segment, bottom up, stacked rigidly."""
    out, z = [], 0.0
    for b in col.blocks:
        for s in b.segments:
            out.append((z, z + s.height, s.r_bottom, s.r_top, s.n_sides))
            z += s.height
    return out


def rigid_properties(col):
    """Mass, z of the centre of mass, I_yy about the centre of mass of the whole column as one body."""
    xg, wg = np.polynomial.legendre.leggauss(8)
    M = Mz = 0.0
    slices = []
    for z0, z1, r0, r1, n in _segments_z(col):
        k = 0.5 * n * math.sin(2 * math.pi / n)
        c = (2 + math.cos(2 * math.pi / n)) / 12.0
        z = 0.5 * (z0 + z1) + 0.5 * (z1 - z0) * xg
        w = 0.5 * (z1 - z0) * wg
        r = r0 + (r1 - r0) * (z - z0) / (z1 - z0)
        slices.append((z, w, r, k, c))
        M += col.density * np.sum(w * k * r * r)
        Mz += col.density * np.sum(w * k * r * r * z)
    zc = Mz / M
    I = sum(col.density * np.sum(w * (c * k * r ** 4 + k * r * r * (z - zc) ** 2)) for z, w, r, k, c in slices)
    return M, zc, I


def pivot_halfwidth(col):
    """Horizontal distance from the axis to the +x pivot of the base face (the outermost +x vertex)."""
    s = col.blocks[0].segments[0]
    ang = s.phase_rad + 2 * math.pi * np.arange(s.n_sides) / s.n_sides
    return float(np.max(s.r_bottom * np.cos(ang)))


def housner(col):
    """(alpha, R, I_O / (M R^2), r_H) of the column as one rigid body rocking about its +x pivot."""
    M, zc, Icm = rigid_properties(col)
    b = pivot_halfwidth(col)
    R = math.hypot(b, zc)
    alpha = math.atan2(b, zc)
    IO = Icm + M * R * R
    return alpha, R, IO / (M * R * R), 1.0 - (M * R * R / IO) * (1.0 - math.cos(2 * alpha))


# ---- one free-rocking run --------------------------------------------------------------------

def free_rocking(col, tilt, tail_s, history_dt=5e-4, **kw):
    """Release ``col`` from a rigid tilt; return the rocking energy at each peak and the ledger there.

    Rocking half-cycles are delimited by the sign of the base block's rotation about y; a half-cycle
    counts once its peak exceeds 2 % of the tilt (so chatter around an impact does not split one),
    the last (unfinished) one is dropped."""
    rest = pcf.simulate(col, np.zeros(2), 0.01, history=True, history_dt=history_dt, tail_s=0.0,
                        early_exit=False, **kw).history
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        res = pcf.simulate(col, np.zeros(2), 0.01, history=True, history_dt=history_dt, tail_s=tail_s,
                           early_exit=False, initial_tilt_rad=tilt, **kw)
        wall = time.perf_counter() - t0
    h = res.history
    m = np.asarray(col.block_masses if not kw.get("monolithic") else [col.mass])
    zrest = rest.block_pos[0, :len(m), 2]
    e = h.energy
    # rocking energy above rest, from the centres of mass (rigid-body definition, any number of bodies)
    vg0 = float(np.sum(m * G * (h.block_pos[0, :len(m), 2] - zrest)))  # initial rocking energy
    erock_t = vg0 + e["gravity"]
    emech_t = erock_t + e["kinetic"] + e["spring"]
    q = h.block_quat[:, 0]
    th = 2 * np.arctan2(q[:, 2], q[:, 0])
    # half-cycles with hysteresis
    thr = 0.02 * abs(tilt)
    idx, sgn, start = [], np.sign(tilt), 0
    for i in range(1, th.size):
        if np.sign(th[i]) == -sgn and abs(th[i]) > thr:
            seg = slice(start, i)
            idx.append(start + int(np.argmax(erock_t[seg])))
            sgn, start = -sgn, i
    # peaks: rocking energy maximum of every completed half-cycle
    idx = np.array(idx, dtype=int)
    out = dict(res=res, wall=wall, t=h.t[idx], erock=erock_t[idx], emech=emech_t[idx],
               kinetic=e["kinetic"][idx], slip=e["slip_dissipated"][idx], switch=e["contact_switch"][idx],
               err=e["balance_error"][idx], theta=th[idx], e0=vg0)
    out["evib"] = out["emech"] - out["erock"]
    E = out["erock"]
    out["r"] = np.sqrt(np.maximum(E[1:], 0) / E[:-1]) if E.size > 1 else np.array([])
    return out


def summarise(name, col, tilt_frac, tail_s, **kw):
    alpha, R, io, rH = housner(col)
    d = free_rocking(col, tilt_frac * alpha, tail_s, **kw)
    n = min(N_IMPACTS, d["r"].size)
    if n == 0:
        raise RuntimeError(f"{name}: no complete rocking half-cycle (collapsed={d['res'].collapsed})")
    E0, En = d["erock"][0], d["erock"][n]
    row = dict(name=name, alpha=alpha, io=io, rH=rH, r1=d["r"][0],
               rmean=(En / E0) ** (0.5 / n), n=n, rmin=d["r"][:n].min(), rmax=d["r"][:n].max(),
               # the ledger over the first n impacts, as fractions of the rocking energy at the first peak
               lost=(E0 - En) / E0, vib=(d["evib"][n] - d["evib"][0]) / E0, slip=(d["slip"][n] - d["slip"][0]) / E0,
               switch=(d["switch"][n] - d["switch"][0]) / E0, err=(d["err"][n] - d["err"][0]) / E0,
               energy_error=d["res"].energy_error, dt=d["res"].dt, wall=d["wall"], rs=d["r"][:n])
    return row


def cases(quick=False):
    """(group, name, column, tilt as a fraction of alpha, tail_s, simulate keywords)."""
    def block(B, H, kn, n_sides=4, fr=80.0, flat=True):
        return pcf.Column.single_block(B, H, n_sides=n_sides, flat_side_along_x=flat,
                                       joints=pcf.JointProperties(kn=kn, ks=kn, friction_deg=fr))
    out = []
    # (a) stiffness, 0.4 x 0.4 x 2 m square block (the Tp = 0.5 s test's block), friction 80 deg (no
    # sliding), in 3D and in the x-z plane (planar: Housner's 2D block)
    for kn in (1e8, 1e9, 1e10, 1e11):
        out.append(("a stiffness", f"square 0.4x2 kn={kn:.0e}", block(0.4, 2.0, kn), 0.5, 8.0, {}))
        out.append(("a stiffness", f"square 0.4x2 kn={kn:.0e} planar", block(0.4, 2.0, kn), 0.5, 8.0,
                    dict(planar=True)))
    # (b) contact discretisation, same block, kn = 1e9 and 1e11
    for kn in (1e9, 1e11):
        for c, p in (("perimeter", 1), ("perimeter", 2), ("perimeter", 4), ("exact", 1)):
            nm = f"{c}{p if c == 'perimeter' else ''} kn={kn:.0e}"
            out.append(("b contact", nm, block(0.4, 2.0, kn), 0.5, 8.0, dict(contact=c, points_per_edge=p)))
    # (c) time step (dt_factor 0.8 is the default of (a))
    for kn, pl in ((1e9, False), (1e11, False), (1e11, True)):
        for f in (0.4, 0.2):
            out.append(("c step", f"vertex kn={kn:.0e}{' planar' if pl else ''} dt_factor {f}", block(0.4, 2.0, kn),
                        0.5, 8.0, dict(dt_factor=f, planar=pl)))
    # (d) slenderness, section, shear stiffness, friction, amplitude; kn = 1e11 (rigid limit), planar
    pl = dict(planar=True)
    for H in (1.0, 4.0):
        out.append(("d slenderness", f"square 0.4x{H:g} kn=1e+11 planar", block(0.4, H, 1e11), 0.5, 8.0, pl))
    out.append(("d slenderness", "square 0.4x2 kn=1e+11 planar tilt 0.9 alpha", block(0.4, 2.0, 1e11), 0.9, 8.0, pl))
    out.append(("d slenderness", "square 0.4x2 kn=1e+11 planar friction 37", block(0.4, 2.0, 1e11, fr=37.0), 0.5,
                8.0, pl))
    for ks in (3e10, 1e10):
        c = pcf.Column.single_block(0.4, 2.0, n_sides=4, joints=pcf.JointProperties(kn=1e11, ks=ks, friction_deg=80.0))
        out.append(("d slenderness", f"square 0.4x2 kn=1e+11 ks={ks:.0e} planar dt_factor 0.2", c, 0.5, 8.0,
                    dict(planar=True, dt_factor=0.2)))
    out.append(("d slenderness", "10-gon D0.4x2 vertex pivot kn=1e+11", block(0.4, 2.0, 1e11, 10, flat=False),
                0.5, 8.0, {}))
    out.append(("d slenderness", "10-gon D0.4x2 vertex pivot kn=1e+09", block(0.4, 2.0, 1e9, 10, flat=False),
                0.5, 8.0, {}))
    # (e) the default column (kn = 1 GPa/m, friction 37 deg)
    col = pcf.Column.parthenon()
    for tf in (0.5, 0.12):
        out.append(("e column", f"Parthenon monolithic tilt {tf} alpha", col, tf, 20.0, dict(monolithic=True)))
        out.append(("e column", f"Parthenon multidrum tilt {tf} alpha", col, tf, 20.0, {}))
    out.append(("e column", "Parthenon multidrum tilt 0.5 alpha dt_factor 0.4", col, 0.5, 20.0, dict(dt_factor=0.4)))
    out.append(("e column", "Parthenon monolithic kn=1e+10", col.with_joints(kn=1e10, ks=1e10), 0.5, 20.0,
                dict(monolithic=True)))
    out.append(("e column", "Parthenon multidrum kn=1e+10", col.with_joints(kn=1e10, ks=1e10), 0.5, 20.0, {}))
    # the vertex default for the stiffness group is also the reference of (b), (c)
    return out[:4] if quick else out


HEADER = ("| case | alpha | I_O/MR² | r_H | r₁ | r̄ (5) | r range | lost | → vibration | → slip | → switch "
          "| balance err | energy_error | dt ms |")


def fmt(row):
    return (f"| {row['name']} | {row['alpha']:.3f} | {row['io']:.3f} | {row['rH']:.3f} | {row['r1']:.3f} "
            f"| {row['rmean']:.3f} | {row['rmin']:.3f}–{row['rmax']:.3f} | {row['lost']:.3f} | {row['vib']:+.3f} "
            f"| {row['slip']:+.3f} | {row['switch']:+.3f} | {row['err']:+.3f} | {row['energy_error']:.3f} "
            f"| {row['dt'] * 1e3:.3f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-plot", action="store_true")
    a = ap.parse_args(argv)
    t0 = time.time()
    rows = []
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, pycolfrag {getattr(pcf, '__version__', '?')}")
    print("lost / vibration / slip / switch / balance err: change over the first n impacts as fractions of the "
          "rocking energy at the first peak; lost = vibration + slip + switch - balance err")
    print(HEADER)
    print("|" + "---|" * 14)
    for grp, name, col, tf, tail, kw in cases(a.quick):
        row = summarise(name, col, tf, tail, **kw)
        row["group"] = grp
        rows.append(row)
        print(fmt(row), flush=True)
    print(f"\n{time.time() - t0:.0f} s")
    if not a.no_plot:
        plot(rows, os.path.join(DOCS, "restitution.png"))
    return rows


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    st = [r for r in rows if r["group"] == "a stiffness"]
    for pl, mk in ((False, "o-"), (True, "s--")):
        sel = [r for r in st if r["name"].endswith("planar") == pl]
        ax[0].semilogx([float(r["name"].split("kn=")[1].split()[0]) for r in sel], [r["rmean"] for r in sel], mk,
                       label=f"vertex{' planar' if pl else ' 3D'}, r̄ over 5 impacts")
    colours = {}
    for r in rows:
        if r["group"] == "b contact":
            k = float(r["name"].split("kn=")[1])
            c = r["name"].split(" kn")[0]
            colours.setdefault(c, f"C{len(colours) + 2}")
            ax[0].semilogx([k], [r["rmean"]], "x", ms=8, color=colours[c], label=c if k == 1e9 else None)
    ax[0].axhline(st[0]["rH"], color="k", lw=1, label="Housner r_H")
    ax[0].axhline(1.0, color="0.6", lw=0.8)
    ax[0].set_xlabel("kn (Pa/m)")
    ax[0].set_ylabel("r = ω after / ω before")
    ax[0].set_title("0.4 × 0.4 × 2 m block (α = 0.197)")
    ax[0].legend(fontsize=7)
    oth = [r for r in rows if r["group"] in ("d slenderness", "e column", "a stiffness")]
    ax[1].plot([r["rH"] for r in oth], [r["rmean"] for r in oth], "o")
    for r in oth:
        ax[1].annotate(r["name"], (r["rH"], r["rmean"]), fontsize=5)
    lim = [min(r["rH"] for r in oth) - 0.02, 1.01]
    ax[1].plot(lim, lim, "k-", lw=1, label="r = r_H")
    ax[1].set_xlabel("Housner r_H")
    ax[1].set_ylabel("measured r̄")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print("wrote", path)


if __name__ == "__main__":
    main()
