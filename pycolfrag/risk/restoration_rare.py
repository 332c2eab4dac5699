"""Restoration alternatives compared on the same events through the rare-event estimator (docs/restoration.md,
"On the same events"):

    python -m pycolfrag.risk.restoration_rare SITE.toml --alternative free=COLUMN.toml \\
        --alternative titanium=COLUMN_TI.toml --alternative portal=SCENE.toml --simulate OUTDIR [--max-runs N]

Every alternative is a structure -- a column file (free, with dowels: ``[[connectors]]``) or a scene file (a
portal) -- simulated into ``OUTDIR/<key>`` by :func:`pycolfrag.rare.paired.simulate_paired`: one seed, one site,
one design (the cross-entropy shift from the first alternative's pilot) and one allocation for all, so that
every alternative runs the same events (Mw, R, pulse occurrence, the pulse's normals, the record's noise seed)
and their differences are measured paired (:mod:`pycolfrag.risk.paired_difference`). The first alternative is
the reference: every other one's difference from it, per level, with its own interval. Outputs
(:mod:`pycolfrag.risk.restoration_rare_report`): ``OUTDIR/restoration.md``, ``restoration.json`` and
``restoration_rare.png``; ``--docs PAGE`` replaces the page's block between ``<!-- restoration-rare:begin -->``
and ``<!-- restoration-rare:end -->`` and writes the figure into ``--figures``.

The other options are the site simulation's (:func:`pycolfrag.risk.simulate.add_arguments`; ``--column`` is
refused: the alternatives give the structures) and apply to every alternative. ``OUTDIR/restoration_runs.json``
records the alternatives (key, file, structure) before any run; a resume with other alternatives is refused
listing the differences. Exit codes as the site simulation's (75 on SIGTERM: rerun the same command).
Under MPI: ``mpirun -n N python -m mpi4py -m pycolfrag.risk.restoration_rare ...``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

from pycolfrag.core.errors import ParameterError, PycolfragError, ResultsFileError
from pycolfrag.core.help import HelpFormatter
from pycolfrag.grid import get_comm
from pycolfrag.grid.probes import check_solver_options
from pycolfrag.rare.paired import GroupEvaluator, serve_groups
from pycolfrag.risk import simulate as _sim
from pycolfrag.risk.paired_difference import paired_differences

__all__ = ["Alternative", "parse_alternative", "load_structure", "load_alternatives", "check_folder", "compare",
           "build_parser", "main", "FOLDER_FILE"]

#: The folder's record of its alternatives.
FOLDER_FILE = "restoration_runs.json"
_KIND = "pycolfrag-restoration-runs"
_KEY = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*$")


@dataclass(frozen=True)
class Alternative:
    """One restoration alternative: its key (its folder and its name in the tables), file and structure."""

    key: str
    path: str
    model: object

    @property
    def name(self) -> str:
        return str(getattr(self.model, "name", "") or self.key)


def parse_alternative(text: str) -> tuple:
    """(key, file) of ``KEY=FILE``; ParameterError naming the text."""
    key, sep, path = str(text).partition("=")
    key, path = key.strip(), path.strip()
    if not sep or not path:
        raise ParameterError(f"--alternative expects KEY=FILE (a column or scene file), got {text!r}")
    if not _KEY.match(key):
        raise ParameterError(f"--alternative {text!r}: the key {key!r} names a folder: letters, digits, '_' and '-' "
                             "only, not starting with '_' or '-'")
    return key, path


def load_structure(path: str):
    """The column or scene of a file: a scene file (a ``column`` or ``n_columns`` key: docs/scene_format.md) by
    :func:`pycolfrag.structure.kinds.scene_from_file`, any other by :meth:`Column.from_file`."""
    from pycolfrag.structure.column import Column
    from pycolfrag.structure.kinds import scene_from_file
    p = Path(path)
    if not p.is_file():
        raise ParameterError(f"{path!r} is not a file (a column or scene file)")
    if p.suffix.lower() == ".toml":
        try:
            table = tomllib.loads(p.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ParameterError(f"{path}: not a TOML file ({exc})") from None
        if "column" in table or "n_columns" in table:
            return scene_from_file(p)
    return Column.from_file(p)


def load_alternatives(items) -> list:
    """The :class:`Alternative` of every ``KEY=FILE`` (the first is the reference); ParameterError naming the
    value for fewer than two, a repeated key, a file that is no column or scene, or two alternatives that are
    the same structure."""
    items = list(items or [])
    if len(items) < 2:
        raise ParameterError(f"give at least two --alternative KEY=FILE (the first is the reference), got {items!r}")
    out: list = []
    for text in items:
        key, path = parse_alternative(text)
        if any(a.key == key for a in out):
            raise ParameterError(f"--alternative {text!r}: the key {key!r} is given twice")
        try:
            model = load_structure(path)
        except (PycolfragError, OSError) as exc:
            raise ParameterError(f"--alternative {text!r}: {exc}") from None
        twin = next((a for a in out if a.model.to_dict() == model.to_dict()), None)
        if twin is not None:
            raise ParameterError(f"--alternative {text!r} is the same structure as {twin.key!r} ({twin.path}): an "
                                 "alternative twice compares nothing")
        out.append(Alternative(key, path, model))
    return out


def _record(alternatives) -> dict:
    return json.loads(json.dumps({"kind": _KIND, "version": 1, "alternatives": [
        {"key": a.key, "file": os.fspath(a.path), "structure": a.model.to_dict()} for a in alternatives]},
        sort_keys=True, default=str))


def check_folder(outdir, alternatives) -> None:
    """Record the alternatives in ``OUTDIR/restoration_runs.json`` (a new folder), or refuse a folder begun with
    other alternatives (ResultsFileError naming what differs). A file's path may change, its structure not."""
    path = Path(outdir) / FOLDER_FILE
    now = _record(alternatives)
    if path.exists():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ResultsFileError(f"{path}: the folder's record of its alternatives cannot be read ({exc})") from None
        was = {a["key"]: a["structure"] for a in old.get("alternatives", [])} if old.get("kind") == _KIND else {}
        new = {a["key"]: a["structure"] for a in now["alternatives"]}
        diffs = [f"{k}: {'not in the folder' if k not in was else 'missing now' if k not in new else 'another structure'}"
                 for k in sorted(set(was) | set(new)) if was.get(k) != new.get(k)]
        order = [a["key"] for a in old.get("alternatives", [])] != [a["key"] for a in now["alternatives"]]
        if diffs or order:
            what = ", ".join(diffs) or "another order: the first is the reference whose pilot sets the design"
            raise ResultsFileError(f"{outdir} was begun with other alternatives ({what}): rerun with the alternatives "
                                   "it began with, or use another folder")
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(now, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(path)


def compare(alternatives, runs, confidence: float = 0.90) -> dict:
    """Every alternative's estimate and every other one's paired difference from the first, per level."""
    ref = runs[0]
    return {"alternatives": alternatives, "runs": runs,
            "differences": {a.key: paired_differences(ref, r, confidence=confidence,
                                                      names=(alternatives[0].key, a.key))
                            for a, r in zip(alternatives[1:], runs[1:])}}


def build_parser(prog: str = "pycolfrag restoration") -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog=prog, formatter_class=HelpFormatter, description=__doc__.split("\n\n")[0])
    ap.add_argument("site", help="site file (TOML)")
    ap.add_argument("--alternative", action="append", default=[], metavar="KEY=FILE",
                    help="a restoration alternative: a column or scene file (repeat; the first is the reference)")
    ap.add_argument("--years", type=float, nargs="*", default=[], help="more horizons (50 always)")
    ap.add_argument("--no-figures", action="store_true")
    ap.add_argument("--docs", type=Path, default=None, help="replace this page's restoration-rare block")
    ap.add_argument("--figures", type=Path, default=None, help="folder of the docs' figure (default: the page's figures/)")
    _sim.add_arguments(ap)
    return ap


def _prepare(a) -> dict:
    if a.column is not None:
        raise ParameterError(f"--column {a.column!r}: the alternatives give the structures (--alternative KEY=FILE)")
    alts = load_alternatives(a.alternative)
    site, settings, stop, record = _sim.settings_from_args(a)
    records = []
    for alt in alts:
        rec = replace(record, column=alt.model.to_dict())
        try:
            check_solver_options(alt.model, rec.solver_options, rec.record_dt_s)
        except ParameterError as exc:
            raise ParameterError(f"alternative {alt.key!r}: {exc}") from None
        records.append(rec)
    return {"alternatives": alts, "site": site, "settings": settings, "stop": stop, "records": records}


def _simulate(a, p, comm, size, log, command):
    evs = [GroupEvaluator(g, Path(a.simulate) / alt.key, rec, comm, allow_code_change=a.allow_code_change,
                          progress=a.progress, chunk_max=a.chunk_max, log=log, command=command)
           for g, (alt, rec) in enumerate(zip(p["alternatives"], p["records"]))]
    if not evs[0].is_root:
        serve_groups(evs)
        return _sim.EXIT_OK, None
    names = [alt.key for alt in p["alternatives"]]
    from pycolfrag.risk.grid_route import QUANTITIES
    code, runs = _sim.run_paired(p, evs, QUANTITIES, comm, size, log, "restoration", a.simulate, names)
    if code is not None:
        return code, None
    return _sim.paired_exit_code(runs, names, log), runs


def main(argv=None) -> int:
    """The command on every rank; the exit code (module docstring)."""
    from pycolfrag.risk import restoration_rare_report as report
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = build_parser()
    a = ap.parse_args(argv)
    comm = get_comm(a.mpi)
    rank = comm.Get_rank() if comm is not None else 0
    size = comm.Get_size() if comm is not None else 1
    log = (lambda s: print(s, flush=True)) if rank == 0 else (lambda s: None)
    try:
        p = _prepare(a)
        _sim._on_rank0(lambda: check_folder(a.simulate, p["alternatives"]), comm)
    except (PycolfragError, OSError) as exc:
        log(f"restoration: {exc}")
        return _sim.EXIT_ARGS
    log("restoration: " + "; ".join(f"{x.key} = {x.path} ({x.name})" for x in p["alternatives"])
        + f"; every alternative on the same events, the reference {p['alternatives'][0].key}")
    code, runs = _simulate(a, p, comm, size, log, " ".join([sys.argv[0], *argv]))
    if runs is None:
        return code
    try:
        result = compare(p["alternatives"], runs)
        years = sorted({50.0, *a.years})
        paths = report.write_outputs(result, a.simulate, years, figures=not a.no_figures, docs=a.docs,
                                     docs_figures=a.figures)
    except (PycolfragError, OSError) as exc:
        print(f"{ap.prog}: error: {exc}", file=sys.stderr)
        return _sim.EXIT_ARGS
    print(report.summary(result))
    print(paths["markdown"])
    return code


if __name__ == "__main__":
    sys.exit(main())
