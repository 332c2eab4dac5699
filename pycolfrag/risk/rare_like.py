"""Like with like: may an event-based site simulation be set beside a grid's results at all?

The simulation (``pycolfrag risk SITE --simulate OUT GRID.h5 [--no-pulse NOPULSE.h5]``) and the grid route
estimate the same rates only when their runs are runs of the same model: the same column or scene, the same
solver options, the same records (time step, cut, per-row function) and pulse model (shape, pulse-period
relation, amplitude scale), and seeds that mean the same thing (the grid's streams: a row's noise seed drawn
from its (Mw, R, sample); a version this code does not know is another noise). Two estimates of different
columns can "agree" by chance, and did (a two-drum simulation against a Parthenon grid printed "agree: yes").
:func:`check_like_with_like` refuses such a pair, naming each difference; the site, its pulse-occurrence model
and the levels are the same in both routes by construction (one site file, the same overrides).

Not compared: the grid's seed and sample counts (the two routes draw their own runs), its spectral periods and
damping (IMs, not the levels), the code (its digest is each file's own business: a resume refuses other code).
"""
from __future__ import annotations

import json

from pycolfrag import results as _results
from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, DEFAULT_VP_MODEL
from pycolfrag.risk.branches import declared_pulse, signature

__all__ = ["differences", "check_like_with_like", "grid_streams"]


def grid_streams() -> str:
    """What this code's synthetic grid signs as the meaning of its seeds (:meth:`GridSpec.signature`)."""
    from pycolfrag.grid.spec import GridSpec  # here: the grid package is heavy and only this check needs it
    return GridSpec(mw=(6.0,), dist_km=(10.0,), samples=1).signature()["streams"]


def _describe(column: dict) -> str:
    if not column:
        return "the default column (Column.parthenon())"
    from pycolfrag.structure.kinds import kind_of_dict
    if kind_of_dict(column).name == "colonnade":
        return f"the scene {column.get('name', '')!r} ({column['n_columns']} columns)"
    n = len(column.get("blocks", []))
    return f"the column {column.get('name', '')!r} ({n} blocks)"


def _column(d) -> dict:
    """A column dict as compared: the default column for an empty one (what :func:`model_from_dict` reads)."""
    if not d:
        from pycolfrag.structure.column import Column
        return Column.parthenon().to_dict()
    return d


def _value(v) -> str:
    return "none (the default)" if v is None else f"{v!r}"


def _attrs(path) -> dict:
    with _results.h5open(path) as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}


def _file_column(attrs: dict, sig: dict):
    col = sig.get("column")
    if col is None and attrs.get("column") is not None:
        try:
            col = json.loads(attrs["column"])
        except (TypeError, ValueError):
            col = None
    return col


def _shared(record, sig: dict, attrs: dict) -> list:
    out = []
    col = _file_column(attrs, sig)
    if col is None:
        out.append("column: the grid's file does not say which column it ran (no `column` in its signature)")
    elif json.dumps(_column(col), sort_keys=True) != json.dumps(_column(record.column), sort_keys=True):
        out.append(f"column: the simulation ran {_describe(record.column)}, the grid {_describe(col)}")
    solver = record.solver_options.to_dict()
    if "solver" in sig and sig["solver"] != solver:
        diff = sorted(k for k in set(solver) | set(sig["solver"]) if solver.get(k) != sig["solver"].get(k))
        out.append("solver options: " + "; ".join(f"{k} {solver.get(k)!r} in the simulation, {sig['solver'].get(k)!r} "
                                                   "in the grid" for k in diff[:6]))
    for key, mine, text in (("record_dt_s", float(record.record_dt_s), "record time step (--record-dt)"),
                            ("max_record_s", record.max_record_s, "records cut (--max-record-s)"),
                            ("sample_function", record.sample_function, "per-row function (--sample-function)")):
        if key in sig and sig[key] != mine:
            out.append(f"{text}: {_value(mine)} in the simulation, {_value(sig[key])} in the grid")
    streams = sig.get("streams")
    if streams is not None and streams != grid_streams():
        out.append(f"seeds: the grid's rows draw their noise as {streams!r}, which this code's records do not "
                   f"({grid_streams()!r}): another noise model")
    return out


def _pulse(record, branch: str, sig: dict, attrs: dict) -> list:
    declared = declared_pulse(attrs)
    if branch == "no-pulse":
        return [] if declared is not None and declared.lower() == "none" else [
            f"pulse model: given as the no-pulse branch, the grid declares pulse {declared!r}, not 'none'"]
    out = []
    shape = "mp03" if declared is None else declared
    if shape != record.pulse_shape:
        out.append(f"pulse model: the simulation's pulses are {record.pulse_shape!r}, the grid's {shape!r}")
    tp = sig.get("tp_model", DEFAULT_TP_MODEL)
    if tp != record.tp_model:
        out.append(f"pulse model: pulse-period relation {record.tp_model!r} in the simulation, {tp!r} in the grid")
    vpm = sig.get("vp_model", "")
    if vpm != record.vp_model:
        out.append(f"pulse model: pulse-amplitude relation {record.vp_model or DEFAULT_VP_MODEL!r} in the simulation, "
                   f"{vpm or DEFAULT_VP_MODEL!r} in the grid")
    vp = sig.get("vp_scale", attrs.get("vp_scale"))
    if vp is not None and float(vp) != float(record.vp_scale):
        out.append(f"pulse model: amplitude scale (--vp-scale) {float(record.vp_scale):g} in the simulation, "
                   f"{float(vp):g} in the grid")
    return out


def differences(record, files: dict) -> list:
    """What differs between the simulation's runs (its :class:`~pycolfrag.rare.evaluator.RecordSettings`)
    and those of the grid files ``{branch: path}`` (branch ``pulse`` or ``no-pulse``), one line each
    ("what: the simulation's, the grid's"); [] when they are like with like."""
    out = []
    for branch, path in files.items():
        attrs = _attrs(path)
        layout = attrs.get("layout")
        if layout not in (None, "synthetic"):
            out.append(f"{path}: a {layout!r} file, not a synthetic grid (Mw x R x samples): its runs are not the "
                       "site's synthetic events")
            continue
        sig = signature(attrs)
        out += [f"{path} ({branch} branch): {d}" for d in _shared(record, sig, attrs) + _pulse(record, branch, sig,
                                                                                               attrs)]
    return out


def check_like_with_like(record, files: dict) -> None:
    """ParameterError listing :func:`differences`, if any: the comparison would set unlike runs side by side."""
    diffs = differences(record, files)
    if diffs:
        raise ParameterError(
            "the grid's results are not runs of the simulated model, so the two routes are not compared:\n  - "
            + "\n  - ".join(diffs) + "\nGive the results of a grid made with the simulation's column, solver "
            "options, records and pulse model (pycolfrag grid --column/--scene, --solver, --record-dt, "
            "--max-record-s, --vp-scale, --tp-model), or simulate that grid's column with the same options.")
