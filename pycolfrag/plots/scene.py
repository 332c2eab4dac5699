"""The debug plots (:mod:`pycolfrag.plots.response`) of a scene and of dowels.

A :class:`~pycolfrag.structure.scene.Colonnade`'s history holds every block of its columns, column by column, then
its epistyles (``block_pos``, ``block_quat``); every joint of its columns, then the epistyles' bearings
(``joint_opening``, ``joint_slip``); and ``top_disp`` of its first column (:class:`pycolfrag.solver.run.History`).
So for a colonnade:

* the 3-D drawings (``plot_snapshot``, ``animate``, the page of ``plot_record_response``) draw every
  column at its place on the row and every epistyle as a box on the capitals;
* ``plot_top_displacement`` is that of the first column, normalised by its base diameter;
* ``plot_joint_slips`` with the model divides the columns' joints by their diameters (u_d's measure) and
  leaves the bearings out (an epistyle's slip at its bearings is ``res.epistyles``);
* ``plot_joint_openings`` names each joint by its column ("c2 joint 3") and each bearing.

:func:`plot_dowels`: the dowels' shear force and shear displacement over time, from ``history.dowels``
(a column with connectors or a scene with dowels, run with ``history=True``), each dowel's yield and
break marked from ``res.dowels``.
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.plots.base import _axes, _history, _mark_collapse

__all__ = ["is_scene", "first_column", "rest_faces", "limits", "joint_labels", "column_joint_diameters",
           "plot_dowels"]


def is_scene(model) -> bool:
    """A structure of a kind other than the column's (structure/kinds.py), whose parts the plots draw."""
    from pycolfrag.structure.kinds import BY_CLASS  # here: the structures only when a model is asked about
    kind = BY_CLASS[type(model)]
    return kind is not None and kind.name != "column"


def _columns(model) -> list:
    return [c for c, _, _ in model.scene_parts().columns]


def first_column(model):
    """The column whose top ``history.top_disp`` follows: the model itself, or a scene's first."""
    return _columns(model)[0] if is_scene(model) else model


def _box(x, y, z0, length, width, height):
    """The six faces of a box whose underside is centred at (x, y, z0)."""
    xs, ys = (x - length / 2, x + length / 2), (y - width / 2, y + width / 2)
    c = np.array([[xs[i], ys[j], z0 + height * k] for k in (0, 1) for j in (0, 1) for i in (0, 1)])
    quads = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))
    return [c[list(q)] for q in quads]


def rest_faces(model, column_faces):
    """Per block of a colonnade: (faces at rest, centre of mass at rest), every column's blocks shifted to
    its place (``column_faces``: the column's own, :func:`pycolfrag.plots.response._rest_faces`), then each
    epistyle's box on the capitals."""
    parts = model.scene_parts()
    out = []
    for col, x, y in parts.columns:
        shift = np.array([x, y, 0.0])
        out += [([f + shift for f in faces], com + shift) for faces, com in column_faces(col)]
    z0 = parts.columns[0][0].height   # the beams rest on the tops of the (equal) columns
    for b in parts.beams:
        out.append((_box(b.x, b.y, z0, b.length, b.width, b.height), np.array([b.x, b.y, z0 + b.height / 2])))
    return out


def limits(model, h, idx, column_faces):
    """Equal-scale 3-D limits (half-width, top) covering the colonnade at the samples ``idx``."""
    verts = np.concatenate([np.concatenate(f) for f, _ in rest_faces(model, column_faces)])
    com0 = np.array([c for _, c in rest_faces(model, column_faces)])
    pos = np.asarray(h.block_pos)[idx]
    moved = float(np.max(np.abs(pos[..., :2] - com0[None, :, :2]))) if pos.size else 0.0
    half = 1.1 * (float(np.max(np.abs(verts[:, :2]))) + moved)
    zmax = 1.05 * max(float(verts[:, 2].max()), float(np.max(pos[..., 2])) if pos.size else 0.0)
    return half, zmax


def joint_labels(model, nj):
    """Names of the ``nj`` joints of a history: a colonnade's by column ("c1 base", "c1 joint 2") then its
    bearings; a column's "base joint", "joint j"."""
    if not is_scene(model):
        return ["base joint" if j == 0 else f"joint {j}" for j in range(nj)]
    out = [f"c{i + 1} {'base' if j == 0 else f'joint {j}'}" for i, c in enumerate(_columns(model))
           for j in range(c.n_joints)]
    return (out + [f"bearing {k + 1}" for k in range(nj - len(out))])[:nj]


def column_joint_diameters(model) -> np.ndarray:
    """The diameter (m) of every column joint of the model, in the history's order (the bearings, which
    follow them in a colonnade's history, excluded)."""
    if is_scene(model):
        return np.concatenate([np.asarray(c.joint_diameters, dtype=float) for c in _columns(model)])
    return np.asarray(model.joint_diameters, dtype=float)


def _dowel_labels(res, nd):
    joints = (getattr(res, "dowels", None) or {}).get("joint")
    if joints is None or len(joints) != nd:
        return [f"dowel {k + 1}" for k in range(nd)]
    return [f"dowel {k + 1} (joint {int(j)})" for k, j in enumerate(joints)]


def plot_dowels(res, col=None, ax=None, max_lines: int = 16):
    """Shear force (kN) and shear displacement (mm) of every dowel over time.

    Parameters
    ----------
    res : Response
        Of ``simulate(..., history=True)`` of a column with connectors or a scene with dowels
        (``history.dowels``: (n, nd, 3), shear displacement |u| m, shear force |F| N, axial force N).
    col : Column or Colonnade, optional
        Accepted for symmetry with the other plots (not needed).
    ax : pair of Axes, optional
        Where to draw (force, displacement); default a new Figure.
    max_lines : int
        At most this many dowels drawn one by one (the most loaded, by peak force); with more, the
        envelope of all (max over the dowels) is drawn as well.

    A broken dowel's break time (``res.dowels["break_time"]``) is marked with a cross on its force.
    """
    import matplotlib  # here: the plotting stack, as in pycolfrag.plots.response

    h = _history(res)
    d = getattr(h, "dowels", None)
    if d is None or np.size(d) == 0:
        raise ParameterError("the run's history has no dowels: plot_dowels needs a column with connectors (or a "
                             "scene with dowels) run with simulate(..., history=True)")
    d = np.asarray(d, dtype=float)
    t = np.asarray(h.t)
    nd = d.shape[1]
    fig, (a1, a2) = _axes(ax, 2, figsize=(8.0, 5.0))
    order = np.argsort(-np.nanmax(d[:, :, 1], axis=0))[:max_lines]
    labels = _dowel_labels(res, nd)
    cmap = matplotlib.colormaps["viridis"]
    info = getattr(res, "dowels", None) or {}
    for rank, k in enumerate(order):
        c = cmap(rank / max(len(order) - 1, 1))
        a1.plot(t, d[:, k, 1] / 1000.0, color=c, lw=0.9, label=labels[k])
        a2.plot(t, 1000.0 * d[:, k, 0], color=c, lw=0.9)
        tb = info.get("break_time", [math.nan] * nd)[k] if len(info.get("break_time", ())) == nd else math.nan
        if math.isfinite(tb):
            a1.plot([tb], [np.interp(tb, t, d[:, k, 1]) / 1000.0], "x", color="C3", ms=8)
    if nd > len(order):
        a1.plot(t, np.nanmax(d[:, :, 1], axis=1) / 1000.0, "k--", lw=1.0, label=f"max over all {nd} dowels")
        a2.plot(t, 1000.0 * np.nanmax(d[:, :, 0], axis=1), "k--", lw=1.0)
    n_broken = int(np.sum(info.get("broken", []))) if "broken" in info else 0
    a1.set_ylabel("shear force |F| (kN)")
    a1.set_title(f"Dowel shear force ({nd} dowels{f', {n_broken} broken (x: break)' if n_broken else ''})")
    a1.legend(loc="upper right", fontsize="x-small", ncol=2)
    a2.set_ylabel("shear displacement |u| (mm)")
    a2.set_title("Dowel shear displacement across its joint")
    a2.set_xlabel("time (s)")
    for a in (a1, a2):
        _mark_collapse(a, res)
    return fig
