"""Debug plots of one run: top displacement, joint openings and slips, energy, 3D drums, GIF.

Every function takes the :class:`~pycolfrag.solver.run.Response` of ``simulate(..., history=True)``
(only its ``history`` and a few scalars are read, so any object with the same fields works) and
returns a matplotlib ``Figure`` built with the object-oriented API (no pyplot state, no display
needed); pass ``ax`` to draw into an existing figure instead. Units on the axes: time in s,
displacements in mm, ground acceleration in g, energy in J; ``u_top``-like ratios are dimensionless.

Typical use while debugging one record::

    import pycolfrag as pcf
    from pycolfrag import plots
    col = pcf.Column.parthenon()
    res = pcf.simulate(col, acc, dt, history=True, history_dt=0.01)
    plots.plot_record_response(col, acc, dt, res).savefig("debug.png")
    plots.plot_snapshot(col, res, times=[2.0, 4.0, 6.0]).savefig("drums.png")
    plots.animate(col, res, "rocking.gif", fps=20)

The 3D drawings place each block's rest geometry (``Column`` segments as polygon frusta) by its
history sample: vertex = ``block_pos`` + R(``block_quat``) (vertex at rest - centre of mass at rest),
in the frame moving with the ground (the ground plate is drawn at z = 0).

A collapsed run has no residual state: its ``u_d`` is NaN, shown as "n/a (collapsed)" in titles.
"""
from __future__ import annotations

import math
import os

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.names import G as _G  # m/s^2, only to show accelerations in g
from pycolfrag.core.validate import finite_float, integer, positive_float, real
from pycolfrag.plots import scene as plots_scene
from pycolfrag.plots.base import _axes, _history, _mark_collapse
from pycolfrag.solver import run as _solver
from pycolfrag.structure import as_built

__all__ = [
    "U_TOP_LEVELS", "U_D_LEVELS", "plot_top_displacement", "plot_joint_openings", "plot_joint_slips",
    "plot_energy", "plot_ground_motion", "plot_snapshot", "animate", "plot_record_response",
    "block_faces", "quat_to_matrix", "plot_dowels",
]

#: Performance levels of u_top (paper Table III), dimensionless.
U_TOP_LEVELS = (0.15, 0.35, 1.0)
#: Performance levels of u_d (paper Table IV), dimensionless.
U_D_LEVELS = (0.005, 0.01, 0.02)


# --------------------------------------------------------------------------- helpers
def _edp_text(value) -> str:
    """An EDP for a title: ``0.0123``, or ``n/a (collapsed)`` for the NaN of a collapsed run."""
    if value is None or not math.isfinite(float(value)):
        return "n/a (collapsed)"
    return f"{float(value):.3g}"


def _base_diameter(res, col):
    """Base diameter (m) from the column, else from u_top = max|u| / D of the response, else None."""
    if col is not None:
        return plots_scene.first_column(col).base_diameter   # a colonnade's top_disp is its first column's
    u, umax = getattr(res, "u_top", None), getattr(res, "max_top_disp", None)
    if u and umax and u > 0 and umax > 0 and math.isfinite(u) and math.isfinite(umax):
        return umax / u
    return None


def _joint_labels(nj):
    return ["base joint" if j == 0 else f"joint {j}" for j in range(nj)]


# --------------------------------------------------------------------------- time histories
def plot_top_displacement(res, col=None, ax=None):
    """Top displacement history: x and y in mm, and |u| / D_base with the Table III levels.

    Parameters
    ----------
    res : Response
        With ``history`` (``top_disp`` (n, 2) m of the top block's top-face centre, relative to
        the ground).
    col : Column, optional
        For the base diameter D_base (m); without it D_base = ``res.max_top_disp / res.u_top``.
    ax : pair of Axes, optional
        Where to draw (displacements, normalised displacement); default a new Figure.

    Returns
    -------
    Figure
    """
    h = _history(res)
    fig, (a1, a2) = _axes(ax, 2, figsize=(8.0, 5.0))
    t, u = np.asarray(h.t), np.asarray(h.top_disp)
    a1.plot(t, 1e3 * u[:, 0], label="x")
    a1.plot(t, 1e3 * u[:, 1], label="y")
    a1.set_ylabel("top displacement (mm)")
    a1.set_title("Top displacement relative to the ground")
    _mark_collapse(a1, res)
    a1.legend(loc="upper right", fontsize="small")
    mag = np.hypot(u[:, 0], u[:, 1])
    d = _base_diameter(res, col)
    if d is not None:
        ratio = mag / d
        a2.plot(t, ratio, color="C2", label="|u| / D_base")
        colors = ("tab:green", "tab:orange", "tab:red")
        for lev, c in zip(U_TOP_LEVELS, colors):
            a2.axhline(lev, color=c, ls=":", lw=1.0, label=f"u_top = {lev:g} (Table III)")
        peak = float(np.nanmax(ratio)) if ratio.size else 0.0
        a2.set_ylim(0.0, max(1.1 * peak, 0.2) if math.isfinite(peak) else 1.1)
        a2.set_ylabel(f"|u| / D_base (-), D_base = {d:.3f} m")
        first = " of the first column" if col is not None and plots_scene.is_scene(col) else ""
        a2.set_title(f"Normalised top displacement{first} (u_top = {peak:.3g})")
    else:
        a2.plot(t, 1e3 * mag, color="C2", label="|u|")
        a2.set_ylabel("|u| (mm)")
        a2.set_title("Magnitude of the top displacement (base diameter unknown)")
    _mark_collapse(a2, res)
    a2.set_xlabel("time (s)")
    a2.legend(loc="upper left", fontsize="small")
    return fig


def _per_joint(res, values, ax, kind, title, label, names=None):
    h = _history(res)
    t = np.asarray(h.t)
    v = np.asarray(values)
    nj = v.shape[1]
    if kind not in ("heatmap", "lines"):
        raise ParameterError(f"kind must be 'heatmap' or 'lines', got {kind!r}")
    fig, (a,) = _axes(ax, 1, figsize=(8.0, 4.0))
    if kind == "lines":
        for j, name in enumerate(names or _joint_labels(nj)):
            a.plot(t, v[:, j], label=name, color=_joint_color(j, nj))
        a.set_ylabel(label)
        if nj <= 16:
            a.legend(loc="upper right", fontsize="x-small", ncol=2)
    else:
        dt = t[1] - t[0] if t.size > 1 else 1.0
        edges_t = np.concatenate([t - 0.5 * dt, [t[-1] + 0.5 * dt]])
        edges_j = np.arange(nj + 1) - 0.5
        mesh = a.pcolormesh(edges_t, edges_j, v.T, cmap="viridis", shading="flat")
        cb = fig.colorbar(mesh, ax=a)
        cb.set_label(label)
        a.set_ylabel("joint (0 = base)")
        a.set_ylim(-0.5, nj - 0.5)
        a.yaxis.set_major_locator(MaxNLocator(integer=True))
    a.set_xlabel("time (s)")
    a.set_title(title)
    _mark_collapse(a, res)
    return fig


def _joint_color(j, nj):
    return matplotlib.colormaps["viridis"](j / max(nj - 1, 1))


def plot_joint_openings(res, col=None, ax=None, kind="heatmap"):
    """Opening of every joint over time, mm (max normal gap of the upper face; 0 = closed).

    ``kind="heatmap"`` (time x joint, colour = opening) or ``"lines"`` (one line per joint).
    ``col`` is accepted for symmetry with the other functions (not needed).
    """
    h = _history(res)
    v = 1e3 * np.asarray(h.joint_opening)
    names = plots_scene.joint_labels(col, v.shape[1]) if col is not None else None
    return _per_joint(res, v, ax, kind, "Joint opening (max gap of the upper face over the joint)", "opening (mm)",
                      names)


def plot_joint_slips(res, col=None, ax=None, kind="lines"):
    """Dislocation of every joint over time (magnitude of the upper-minus-lower face-centre vector).

    In mm; with ``col`` the dislocation is divided by the joint's diameter and drawn with the u_d
    levels of the paper's Table IV. ``kind`` as in :func:`plot_joint_openings`.
    """
    h = _history(res)
    s = np.asarray(h.joint_slip)
    mag = np.hypot(s[..., 0], s[..., 1])
    if col is None:
        return _per_joint(res, 1e3 * mag, ax, kind, "Joint dislocation (upper minus lower face centre)",
                          "dislocation (mm)")
    d = plots_scene.column_joint_diameters(col)
    scene = plots_scene.is_scene(col)
    if d.size != mag.shape[1] and not (scene and col.n_joints == mag.shape[1]):
        raise ParameterError(f"the model has {d.size if not scene else col.n_joints} joints but the history has "
                             f"{mag.shape[1]}")
    mag = mag[:, :d.size]   # a colonnade's bearings follow its columns' joints: res.epistyles has their slip
    fig = _per_joint(res, mag / d, ax, kind, "Joint dislocation / joint diameter"
                     + (" (columns' joints; bearings left out)" if scene else ""),
                     "dislocation / joint diameter (-)", plots_scene.joint_labels(col, d.size))
    if kind == "lines":
        a = fig.axes[0] if ax is None else (ax[0] if isinstance(ax, (list, tuple)) else ax)
        for lev, c in zip(U_D_LEVELS, ("tab:green", "tab:orange", "tab:red")):
            a.axhline(lev, color=c, ls=":", lw=1.0)
        u_d = getattr(res, "u_d", None)
        if u_d is not None:
            a.set_title(f"Joint dislocation / joint diameter (residual u_d = {_edp_text(u_d)}; "
                        f"dotted: Table IV levels {', '.join(f'{x:g}' for x in U_D_LEVELS)})")
    return fig


def plot_energy(res, ax=None):
    """Energy terms (J) and the balance error relative to ``res.energy_scale`` over time."""
    h = _history(res)
    fig, (a1, a2) = _axes(ax, 2, figsize=(8.0, 5.0))
    t = np.asarray(h.t)
    e = h.energy
    for k in ("kinetic", "gravity", "spring", "slip_dissipated", "damping_dissipated", "contact_switch",
              "ground_work"):
        if k in e and np.any(np.asarray(e[k]) != 0.0):
            a1.plot(t, e[k], label=k.replace("_", " "), ls="--" if k == "ground_work" else "-")
    a1.set_ylabel("energy (J)")
    a1.set_title("Energy terms (changes since the static start)")
    a1.legend(loc="upper left", fontsize="x-small", ncol=2)
    bal = np.asarray(e.get("balance_error", np.zeros_like(t)))
    scale = getattr(res, "energy_scale", None)
    if scale and scale > 0:
        a2.plot(t, bal / scale, color="k")
        a2.set_ylabel("balance error / energy scale (-)")
    else:
        a2.plot(t, bal, color="k")
        a2.set_ylabel("balance error (J)")
    err = getattr(res, "energy_error", None)
    a2.set_title("Energy balance error" + (f" (max {err:.2e})" if err is not None else ""))
    a2.set_xlabel("time (s)")
    for a in (a1, a2):
        _mark_collapse(a, res)
    return fig


def _record(rec_or_acc, dt):
    acc = getattr(rec_or_acc, "acc", rec_or_acc)
    if dt is None:
        dt = getattr(rec_or_acc, "dt", None)
    if dt is None:
        raise ParameterError("dt (s) is needed when the record is a plain array")
    acc = np.asarray(acc, dtype=float)
    dt = float(dt)
    if acc.ndim != 1 or acc.size == 0:
        raise ParameterError(f"the record must be a non-empty 1-D array, got shape {acc.shape}")
    if not (math.isfinite(dt) and dt > 0):
        raise ParameterError(f"dt must be finite and > 0, got {dt!r}")
    return acc, dt


def plot_ground_motion(rec_or_acc, dt=None, ax=None):
    """Ground acceleration (g) of a record (a ``Record`` or an m/s^2 array with ``dt`` in s)."""
    acc, dt = _record(rec_or_acc, dt)
    fig, (a,) = _axes(ax, 1, figsize=(8.0, 2.5))
    t = dt * np.arange(acc.size)
    a.plot(t, acc / _G, color="0.3", lw=0.8)
    pga = float(np.max(np.abs(acc))) / _G
    a.set_xlabel("time (s)")
    a.set_ylabel("ground acceleration (g)")
    a.set_title(f"Ground motion along x (PGA = {pga:.3g} g)")
    return fig


# --------------------------------------------------------------------------- 3D drums
def quat_to_matrix(q):
    """Rotation matrix (3, 3) of a unit quaternion (w, x, y, z); rotates body vectors to the world."""
    w, x, y, z = (float(c) for c in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not n > 0:
        raise ParameterError(f"quaternion must be non-zero and finite, got {q!r}")
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _rest_faces(col):
    """Per block: (list of (k, 3) face polygons at rest in the ground frame, centre of mass at rest); a
    colonnade's columns at their places and its epistyles (:mod:`pycolfrag.plots.scene`)."""
    if plots_scene.is_scene(col):
        return plots_scene.rest_faces(col, _rest_faces)
    out = []
    for z0, blk in zip(col.joint_heights, col.blocks):
        faces, z = [], z0
        (dx, dy), turn = blk.offset, math.radians(blk.rotation_deg)   # as built (pycolfrag/structure/as_built.py)
        for s in blk.segments:
            ang = s.phase_rad + turn + 2.0 * math.pi * np.arange(s.n_sides) / s.n_sides
            c, sn = np.cos(ang), np.sin(ang)
            sn = sn * s.aspect   # a section scaled along y (pycolfrag/structure/segment.py)
            bot = np.column_stack([dx + s.r_bottom * c, dy + s.r_bottom * sn, np.full(s.n_sides, z)])
            top = np.column_stack([dx + s.r_top * c, dy + s.r_top * sn, np.full(s.n_sides, z + s.height)])
            faces.append(bot)
            faces.append(top)
            for k in range(s.n_sides):
                k1 = (k + 1) % s.n_sides
                faces.append(np.array([bot[k], bot[k1], top[k1], top[k]]))
            z += s.height
        com = np.array([dx, dy, z0 + blk.centroid_height])
        if blk.missing_part:   # the centre of mass the solver's body has
            cx, cy, cz = as_built.centre_of_mass(blk, col.density)
            com = np.array([dx + cx, dy + cy, z0 + cz])
        out.append((faces, com))
    return out


def block_faces(col, block_pos=None, block_quat=None):
    """Polygon faces of every block, placed by centre-of-mass positions and quaternions.

    Parameters
    ----------
    col : Column
    block_pos : (nb, 3) m, optional
        Centres of mass in the ground frame (default: at rest).
    block_quat : (nb, 4), optional
        Orientations (w, x, y, z) (default: identity).

    Returns
    -------
    list (one per block) of lists of (k, 3) arrays, m
    """
    rest = _rest_faces(col)
    nb = len(rest)
    if block_pos is not None and np.shape(block_pos) != (nb, 3):
        raise ParameterError(f"block_pos must have shape ({nb}, 3), got {np.shape(block_pos)}")
    if block_quat is not None and np.shape(block_quat) != (nb, 4):
        raise ParameterError(f"block_quat must have shape ({nb}, 4), got {np.shape(block_quat)}")
    out = []
    for i, (faces, com) in enumerate(rest):
        pos = com if block_pos is None else np.asarray(block_pos[i], dtype=float)
        rot = np.eye(3) if block_quat is None else quat_to_matrix(block_quat[i])
        out.append([pos + (f - com) @ rot.T for f in faces])
    return out


def _sample_index(h, time):
    t = np.asarray(h.t)
    tt = real(time, "snapshot time (s)")
    step = t[1] - t[0] if t.size > 1 else 0.0
    if not math.isfinite(tt) or tt < t[0] - step or tt > t[-1] + step:
        raise ParameterError(f"snapshot time {time!r} s is outside the history ({t[0]:g} to {t[-1]:g} s)")
    return int(np.argmin(np.abs(t - tt)))


def _draw_column(ax, col, pos, quat, alpha=0.9, collapse_block=None):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # here: the 3D toolkit only for 3D panels
    nb = col.n_blocks
    for i, faces in enumerate(block_faces(col, pos, quat)):
        face_col = "tab:red" if collapse_block == i else _block_color(i, nb)
        pc = Poly3DCollection(faces, facecolors=face_col, edgecolors="0.25", linewidths=0.3, alpha=alpha)
        _add3d(ax, pc)


def _block_color(i, nb):
    shades = (0.93, 0.85)
    g = shades[i % 2]
    return (g, g * 0.97, g * 0.88)  # marble, alternating so drums stand apart


def _ground(ax, half):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # here: the 3D toolkit only for 3D panels
    sq = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    _add3d(ax, Poly3DCollection([sq], facecolors="0.6", edgecolors="0.4", alpha=0.5))


def _add3d(ax, coll):
    """Add without autoscaling (limits are set once for all panels; autoscaling a flat plate overflows)."""
    try:
        ax.add_collection3d(coll, autolim=False)
    except TypeError:  # matplotlib < 3.9 has no autolim and does not autoscale here
        ax.add_collection3d(coll)


def _limits(col, h, idx):
    """Equal-scale 3D limits covering the column (or colonnade) at the given samples."""
    if plots_scene.is_scene(col):
        return plots_scene.limits(col, h, idx, _rest_faces)
    r = max(max(s.r_bottom, s.r_top) for b in col.blocks for s in b.segments)
    pos = np.asarray(h.block_pos)[idx]
    xy = np.abs(pos[..., :2]).max() if pos.size else 0.0
    half = max(1.2 * (r + xy), 0.2 * col.height)
    zmax = max(col.height, float(np.max(pos[..., 2])) + r if pos.size else col.height) * 1.05
    return half, zmax


def _setup_3d(ax, half, zmax, title):
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_zlim(0.0, zmax)
    ax.set_box_aspect((2 * half, 2 * half, zmax))
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(MaxNLocator(3))
    ax.tick_params(labelsize="x-small")
    ax.set_xlabel("x (m)", fontsize="small")
    ax.set_ylabel("y (m)", fontsize="small")
    ax.set_zlabel("z (m)", fontsize="small")
    ax.set_title(title)
    ax.view_init(elev=12.0, azim=-65.0)


def plot_snapshot(col, res, times, ax=None):
    """3D drawing of the blocks at the history samples nearest to ``times`` (s).

    Each block is drawn as its polygon frusta (one ``Poly3DCollection`` per block, plus one for the
    ground plate), placed by ``history.block_pos`` and ``history.block_quat``. All panels share one
    equal-scale box. The block that collapsed, if any, is red.

    Parameters
    ----------
    col : Column
        The simulated column (the history must have ``col.n_blocks`` blocks).
    res : Response
        With ``history``.
    times : float or sequence of float
        Times in s (each within the history; the nearest sample is drawn, its time in the title).
    ax : Axes3D or sequence of Axes3D, optional
        One per time; default a new Figure with the panels side by side.

    Returns
    -------
    Figure
    """
    h = _history(res)
    if np.shape(h.block_pos)[1] != col.n_blocks:
        raise ParameterError(f"the history has {np.shape(h.block_pos)[1]} blocks but the column has {col.n_blocks}")
    times = [times] if np.ndim(times) == 0 else list(times)
    if not times:
        raise ParameterError("times is empty: give at least one time (s)")
    idx = [_sample_index(h, tm) for tm in times]
    if ax is None:
        n = len(times)
        fig = Figure(figsize=(3.2 * n + 0.5, 6.0), layout="constrained")
        axes = [fig.add_subplot(1, n, i + 1, projection="3d") for i in range(n)]
    else:
        fig, axes = _axes(ax, len(times))
    half, zmax = _limits(col, h, idx)
    cb = getattr(res, "collapse_block", None) if getattr(res, "collapsed", False) else None
    for a, i in zip(axes, idx):
        _ground(a, half)
        _draw_column(a, col, h.block_pos[i], h.block_quat[i], collapse_block=cb)
        _setup_3d(a, half, zmax, f"t = {h.t[i]:.2f} s")
    return fig


def animate(col, res, path, fps=20, t_start=None, t_end=None, max_frames=300, dpi=72):
    """Write a GIF of the drums moving (matplotlib's ``PillowWriter``).

    Frames are history samples between ``t_start`` and ``t_end`` (s, default the whole history),
    thinned evenly to at most ``max_frames``; ``fps`` frames per second of GIF. Returns the path.
    """
    from matplotlib.animation import PillowWriter  # here: Pillow only for a GIF

    h = _history(res)
    if np.shape(h.block_pos)[1] != col.n_blocks:
        raise ParameterError(f"the history has {np.shape(h.block_pos)[1]} blocks but the column has {col.n_blocks}")
    fps = positive_float(fps, "fps")
    max_frames = integer(max_frames, "max_frames", 1)
    t = np.asarray(h.t)
    lo = t[0] if t_start is None else finite_float(t_start, "t_start (s)")
    hi = t[-1] if t_end is None else finite_float(t_end, "t_end (s)")
    frames = np.flatnonzero((t >= lo - 1e-12) & (t <= hi + 1e-12))
    if frames.size == 0:
        raise ParameterError(f"no history samples between t_start = {lo!r} s and t_end = {hi!r} s")
    if frames.size > max_frames:
        frames = frames[np.round(np.linspace(0, frames.size - 1, int(max_frames))).astype(int)]
    path = os.fspath(path)
    fig = Figure(figsize=(4.0, 6.0))
    FigureCanvasAgg(fig)
    a = fig.add_subplot(1, 1, 1, projection="3d")
    half, zmax = _limits(col, h, frames)
    cb = getattr(res, "collapse_block", None) if getattr(res, "collapsed", False) else None
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, path, dpi):
        for i in frames:
            a.cla()
            _ground(a, half)
            _draw_column(a, col, h.block_pos[i], h.block_quat[i], collapse_block=cb)
            _setup_3d(a, half, zmax, f"t = {t[i]:.2f} s")
            writer.grab_frame()
    return path


def plot_dowels(res, col=None, ax=None, max_lines=16):
    """Dowels' shear force (kN) and shear displacement (mm) over time: :func:`pycolfrag.plots.scene.plot_dowels`."""
    return plots_scene.plot_dowels(res, col, ax, max_lines)


# --------------------------------------------------------------------------- one page
def plot_record_response(col, rec_or_acc, dt=None, res=None, **simulate_options):
    """One-page debug figure of one record: ground motion, top displacement, joints, energy, drums.

    Parameters
    ----------
    col : Column
    rec_or_acc : Record or array
        The record (``.acc`` m/s^2 and ``.dt`` s) or its acceleration along x, m/s^2.
    dt : float, optional
        Sampling interval, s (needed for a plain array).
    res : Response, optional
        The run to show; default ``simulate(col, acc, dt, history=True, **simulate_options)``.

    Returns
    -------
    Figure
    """
    acc, dt = _record(rec_or_acc, dt)
    if res is None:
        simulate_options.setdefault("history", True)
        res = _solver.simulate(col, acc, dt, **simulate_options)
    elif simulate_options:
        raise ParameterError(f"simulate options {sorted(simulate_options)} given with a finished res")
    h = _history(res)
    fig = Figure(figsize=(14.0, 15.0), layout="constrained")
    gs = fig.add_gridspec(6, 3, width_ratios=(1.0, 1.0, 0.6))
    a_acc = fig.add_subplot(gs[0, :2])
    a_u = fig.add_subplot(gs[1, :2], sharex=a_acc)
    a_r = fig.add_subplot(gs[2, :2], sharex=a_acc)
    a_open = fig.add_subplot(gs[3, :2], sharex=a_acc)
    a_slip = fig.add_subplot(gs[4, :2], sharex=a_acc)
    a_e1 = fig.add_subplot(gs[5, 0])
    a_e2 = fig.add_subplot(gs[5, 1])
    a_s1 = fig.add_subplot(gs[0:3, 2], projection="3d")
    a_s2 = fig.add_subplot(gs[3:6, 2], projection="3d")
    plot_ground_motion(acc, dt, ax=a_acc)
    plot_top_displacement(res, col, ax=(a_u, a_r))
    plot_joint_openings(res, col, ax=a_open, kind="heatmap")
    plot_joint_slips(res, col, ax=a_slip, kind="lines")
    plot_energy(res, ax=(a_e1, a_e2))
    mag = np.hypot(h.top_disp[:, 0], h.top_disp[:, 1])
    t_peak = float(h.t[int(np.nanargmax(mag))]) if np.any(np.isfinite(mag)) else float(h.t[0])
    plot_snapshot(col, res, [t_peak, float(h.t[-1])], ax=[a_s1, a_s2])
    a_s1.set_title(f"peak |u|, t = {t_peak:.2f} s", fontsize="small")
    a_s2.set_title(f"end, t = {float(h.t[-1]):.2f} s", fontsize="small")
    status = "collapsed" if getattr(res, "collapsed", False) else "standing"
    if getattr(res, "collapsed", False):
        status += (f" at t = {getattr(res, 'collapse_time', float('nan')):.2f} s "
                   f"(block {getattr(res, 'collapse_block', None)}, {getattr(res, 'collapse_reason', '')})")
    fig.suptitle(f"{getattr(col, 'name', 'column')}: u_top = {res.u_top:.3g}, u_d = {_edp_text(res.u_d)}, {status}")
    return fig
