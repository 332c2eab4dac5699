"""The C side of a structure: its parts (the Structure contract, :mod:`pycolfrag.structure.kinds`) as the
solver's ``cf_solver_scene`` (``csrc/solver.h``), and what a run reports of its columns, epistyles and
dowels (``cf_solver_set_outputs``, ``cf_solver_set_history_connectors``).

:func:`pycolfrag.simulate` and :func:`pycolfrag.simulate_batch` set every structure up here: a plain
column is a one-column scene, which C sets up as the column's own stack (bit for bit the results of
``cf_solver_setup_joints``); only the runs of a scene (a column with connectors, a colonnade) report
its parts (:class:`Outputs`).
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import check, ffi, lib, ptr, segment_arrays
from pycolfrag.structure import as_built
from pycolfrag.structure.scene_parts import SceneParts

__all__ = ["parts_of", "setup", "setup_as_built", "Outputs", "EDP_DEFAULTS"]

#: The scene EDPs of a :class:`~pycolfrag.solver.run.Response` and their value where the scene has no
#: such part (no dowels, no epistyles): NaN, the quantity does not exist.
EDP_DEFAULTS = {"dowel_shear_kn": math.nan, "dowel_slip_mm": math.nan, "dowels_yielded": math.nan,
                "dowels_broken": math.nan,
                "epistyle_slip_mm": math.nan, "epistyle_unseat": math.nan}


def parts_of(model, monolithic: bool, caller: str) -> SceneParts:
    """The parts for C of a structure (its ``scene_parts()``, the Structure contract; a column is a
    one-column scene). A monolithic column keeps the dowels of its base joint only (its other joints
    do not exist: warned)."""
    parts = model.scene_parts()
    dowels = parts.dowels
    if monolithic and len(parts.columns) == 1 and any(j > 0 for j, _, _, _ in dowels):
        warnings.warn(f"{caller}: monolithic=True has the base joint only; the dowels of joints "
                      f"{sorted({j for j, _, _, _ in dowels if j > 0})} do not act", UserWarning, stacklevel=4)
        parts.dowels = [d for d in dowels if d[0] == 0]
    return parts


def setup(solver, d, parts: SceneParts, caller: str) -> list:
    """Set the solver up for ``parts`` with the definition ``d`` (``cf_solver_setup_scene``); returns
    the C objects that must outlive the call (none is kept by the solver: it copies what it needs)."""
    cols = ffi.new("cf_solver_scene_column[]", len(parts.columns))
    for c, (col, x, y) in zip(cols, parts.columns):
        c.x = x; c.y = y; c.n_blocks = col.n_blocks
    segs, nseg = segment_arrays([b for col, _, _ in parts.columns for b in col.blocks])
    props = [col.joint(i) for col, _, _ in parts.columns for i in range(col.n_blocks)]
    kn = np.array([p.kn for p in props]); ks = np.array([p.ks for p in props]); mu = np.array([p.mu for p in props])
    beams = ffi.new("cf_solver_scene_beam[]", max(len(parts.beams), 1))
    for c, b in zip(beams, parts.beams):
        c.x = b.x; c.y = b.y; c.length = b.length; c.width = b.width; c.height = b.height; c.density = b.density
    bears = ffi.new("cf_solver_scene_bearing[]", max(len(parts.bearings), 1))
    for c, g in zip(bears, parts.bearings):
        c.beam = g.beam; c.column = g.column; c.x = g.x; c.y = g.y; c.side = g.side
        c.kn = g.joints.kn * g.kn_factor; c.ks = g.joints.ks * g.kn_factor; c.mu = g.joints.mu
    conns = ffi.new("cf_solver_connector[]", max(len(parts.dowels), 1))
    for c, (j, x, y, law) in zip(conns, parts.dowels):
        law.fill(c)
        c.joint = j; c.x = x; c.y = y
    sc = ffi.new("cf_solver_scene *")
    sc.n_columns = len(parts.columns); sc.columns = cols
    sc.n_segments = nseg; sc.segments = segs; sc.density = parts.columns[0][0].density
    sc.kn = ptr(kn); sc.ks = ptr(ks); sc.mu = ptr(mu)
    sc.n_beams = len(parts.beams); sc.beams = beams
    sc.n_bearings = len(parts.bearings); sc.bearings = bears
    sc.n_connectors = len(parts.dowels); sc.connectors = conns
    densities = {col.density for col, _, _ in parts.columns}
    if len(densities) > 1:
        raise ParameterError(f"the columns of a scene share one density, got {sorted(densities)} kg/m^3")
    st = lib.cf_solver_setup_scene(solver, d, sc)
    check(st, lib.cf_solver_message(solver), caller)
    return [cols, segs, nseg, kn, ks, mu, beams, bears, conns, sc]


class Outputs:
    """One run's output buffers of a scene's columns, beams and dowels, and their histories, and what
    they report once the run has finished (:meth:`report`)."""

    def __init__(self, parts: SceneParts, cap: int):
        self.parts = parts
        self.col = np.full((len(parts.columns), lib.CF_SOLVER_COLUMN_OUT), np.nan)
        self.beam = np.full((max(len(parts.beams), 1), lib.CF_SOLVER_BEAM_OUT), np.nan)
        self.conn = np.full((max(len(parts.dowels), 1), lib.CF_SOLVER_CONNECTOR_OUT), np.nan)
        nd = len(parts.dowels)
        self.h_en = np.zeros((cap, 2)) if nd and cap else None
        self.h_dowel = np.zeros((cap, nd, 3)) if nd and cap else None

    def attach(self, solver) -> None:
        """Point the solver at these buffers (before a run)."""
        lib.cf_solver_set_outputs(solver, ptr(self.col), ptr(self.beam), ptr(self.conn))
        if self.h_en is not None:
            lib.cf_solver_set_history_connectors(solver, ptr(self.h_en), ptr(self.h_dowel))

    def fill(self, cj) -> None:
        """Point a cf_solver_batch_job at these buffers (a run in a batch's lane)."""
        cj.out_columns = ptr(self.col); cj.out_beams = ptr(self.beam); cj.out_connectors = ptr(self.conn)
        if self.h_en is not None:
            cj.h_conn_energy = ptr(self.h_en); cj.h_conn = ptr(self.h_dowel)

    def report(self, r) -> dict:
        """The Response's scene attributes after the run whose result is r: ``columns``,
        ``epistyles``, ``dowels`` (dicts of arrays, None where the scene has no such part), the scene
        EDPs (:data:`EDP_DEFAULTS`). A one-column scene (set up as its column) reports its column
        from the run's result."""
        p = self.parts
        out = dict(EDP_DEFAULTS)
        if len(p.columns) == 1 and not p.beams:
            self.col[0] = (r.u_top, r.u_d, r.max_top_disp, 1.0 if r.collapsed else 0.0)
        out["columns"] = {"u_top": self.col[:, 0].copy(), "u_d": self.col[:, 1].copy(),
                          "max_top_disp": self.col[:, 2].copy(), "collapsed": self.col[:, 3] > 0.5}
        out["epistyles"] = None
        out["dowels"] = None
        if p.beams:
            b = self.beam[:len(p.beams)]
            out["epistyles"] = {"slip": b[:, 0].copy(), "residual_slip": b[:, 1].copy(), "unseat": b[:, 2].copy(),
                                "collapsed": b[:, 3] > 0.5}
            out["epistyle_slip_mm"] = float(b[:, 0].max() * 1000.0)
            out["epistyle_unseat"] = float(b[:, 2].max())
        if p.dowels:
            c = self.conn[:len(p.dowels)]
            out["dowels"] = {"joint": np.array([j for j, _, _, _ in p.dowels]), "peak_shear": c[:, 0].copy(),
                             "peak_slip": c[:, 1].copy(), "peak_axial": c[:, 2].copy(), "yielded": c[:, 3] > 0.5,
                             "broken": c[:, 4] > 0.5, "break_time": c[:, 5].copy(), "dissipated": c[:, 6].copy()}
            out["dowel_shear_kn"] = float(c[:, 0].max() / 1000.0)
            out["dowel_slip_mm"] = float(c[:, 1].max() * 1000.0)
            out["dowels_yielded"] = float((c[:, 3] > 0.5).sum())
            out["dowels_broken"] = float((c[:, 4] > 0.5).sum())
        return out

    def history(self, n: int) -> dict:
        """The connectors' histories of the first n samples (empty without dowels)."""
        if self.h_en is None:
            return {}
        return {"connector_energy": {"connector_stored": self.h_en[:n, 0].copy(),
                                     "connector_dissipated": self.h_en[:n, 1].copy()},
                "dowels": self.h_dowel[:n].copy()}


def setup_as_built(solver, d, col, monolithic: bool, caller: str) -> None:
    """Set up the C solver for a plain column placed as built (``cf_solver_setup_as_built``: offsets, turns,
    chipped faces, missing parts; :mod:`pycolfrag.structure.as_built`): the one set-up beside :func:`setup`,
    which every other structure, an aligned plain column included, goes through."""
    if monolithic:
        as_built.refuse(col, caller, "are not for a monolithic run (one body)")
    segs, nseg = segment_arrays(col.blocks)
    props = [col.joint(i) for i in range(col.n_blocks)]
    kn, ks, mu = (np.array([getattr(p, k) for p in props]) for k in ("kn", "ks", "mu"))
    place = as_built.placement_array(col)
    st = lib.cf_solver_setup_as_built(solver, d, col.n_blocks, nseg, segs, col.density, ptr(kn), ptr(ks),
                                      ptr(mu), ptr(place))
    check(st, lib.cf_solver_message(solver), caller)
