"""A logic tree's end branches applied to a site and to a model, and checked by the models' own validation
before any run (docs/logic_tree.md).

* :func:`site_of` -- the site of an end branch: the site file's table with the branch's site choices set,
  read again by the site loader (:func:`pycolfrag.site.sources.site_from_dict`), so every range and rule of a site
  file holds for every branch (a b-value out of range, an Mmax below m_min are refused by the loader's
  own messages, prefixed with the branch);
* :func:`model_of` -- the run settings of an end branch (:class:`ModelSettings`: vp_scale, the
  pulse-period relation, the solver options, the column's dict), checked by :func:`check_model`
  (:class:`~pycolfrag.Column`, :class:`~pycolfrag.SolverOptions`, the pulse model's own parameter check,
  and with ``probe`` the grid's check of a column with its options, a few solver steps);
* :func:`check_tree` -- all of it for every end branch, before any run.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace

from pycolfrag.core.errors import ParameterError
from pycolfrag.risk.logic_tree import RUNS, SITE, BranchSet, EndBranch, LogicTree

__all__ = ["ModelSettings", "site_of", "model_of", "check_model", "check_sources", "check_tree", "CheckedTree"]

_GR = "gutenberg-richter"


def _source_names(site_dict: dict) -> list:
    raw = site_dict.get("sources")
    if not isinstance(raw, list):
        return []
    return [str(s.get("name", f"source {i + 1}")) if isinstance(s, dict) else f"source {i + 1}"
            for i, s in enumerate(raw)]


def _targets(site_dict: dict, bs: BranchSet, origin: str) -> list:
    """The indices of the sources a per-source set changes: those it names (each must exist and, for b and
    m_max, have Gutenberg-Richter magnitudes), else every source it applies to."""
    names = _source_names(site_dict)
    raw = site_dict.get("sources") or []
    gr = [i for i, s in enumerate(raw) if isinstance(s, dict) and isinstance(s.get("magnitude"), dict)
          and s["magnitude"].get("type") == _GR]
    where = f"{origin}: logic tree set {bs.name!r}" if origin else f"logic tree set {bs.name!r}"
    if bs.sources:
        unknown = [s for s in bs.sources if s not in names]
        if unknown:
            raise ParameterError(f"{where}: sources {unknown} are not sources of the site (its sources: {names})")
        idx = [names.index(s) for s in bs.sources]
    elif bs.choice.name == "rate" and len(names) > 1:
        raise ParameterError(f"{where}: an absolute rate for every one of the site's {len(names)} sources "
                             f"({names}): name the source(s) with sources = [...], or vary rate_factor")
    else:
        idx = gr if bs.choice.key in ("b", "m_max") else list(range(len(names)))
    if bs.choice.key in ("b", "m_max"):
        other = [names[i] for i in idx if i not in gr]
        if other or not idx:
            raise ParameterError(f"{where}: {bs.choice.name!r} applies to Gutenberg-Richter sources; "
                                 f"{other or 'none of the site sources'} {'have' if other else 'has'} other magnitudes")
    return idx


def check_sources(tree: LogicTree, site_dict: dict, origin: str = "") -> None:
    """Every per-source set names sources of the site that its choice applies to (before any branch)."""
    for bs in tree.branch_sets:
        if bs.choice.per_source:
            _targets(site_dict, bs, origin)


def _set_site_value(site_dict: dict, bs: BranchSet, value, origin: str) -> None:
    for i in _targets(site_dict, bs, origin):
        src = site_dict["sources"][i]
        key = bs.choice.name
        if key == "rate":
            src["rate"] = value
        elif key == "rate_factor":
            r = src.get("rate")
            if isinstance(r, bool) or not isinstance(r, (int, float)):
                raise ParameterError(f"{origin}: sources[{i}].rate = {r!r} cannot be multiplied by the branch's "
                                     f"rate_factor {value!r}")
            src["rate"] = r * value
        elif key in ("b", "m_max"):
            src["magnitude"] = {**src["magnitude"], key: value}
        elif key == "pulse_model":
            src["pulse"] = dict(value)
        else:                                        # a new per-source choice must say how it applies
            raise AssertionError(f"no site rule for the choice {key!r}")


def _refused(end: EndBranch, exc: ParameterError) -> ParameterError:
    return ParameterError(f"logic tree branch {end.path!r}: {exc}")


def site_of(site_dict: dict, end: EndBranch, origin: str = ""):
    """The :class:`~pycolfrag.site.sources.Site` of an end branch: the site file's table (``[logic_tree]`` left out)
    with its site choices set, read by the site loader; a value it refuses is refused naming the branch."""
    from pycolfrag.site.sources import site_from_dict
    d = copy.deepcopy({k: v for k, v in site_dict.items() if k != "logic_tree"})
    try:
        for bs, br in zip(end.sets, end.branches):
            if bs.scope == SITE:
                _set_site_value(d, bs, copy.deepcopy(br.value), origin)
        return site_from_dict(d, origin)
    except ParameterError as exc:
        raise _refused(end, exc) from None


@dataclass(frozen=True)
class ModelSettings:
    """What a run-changing branch changes: the pulse amplitude's factor and relation (``vp_model``, empty:
    Eq. (6)) and the period relation, solver options
    (the contact model), the column (a column file's dict: joints, connectors). The defaults are the
    paper's model (``column`` None: :meth:`pycolfrag.Column.parthenon`)."""

    vp_scale: float = 1.0
    tp_model: str = ""
    vp_model: str = ""
    solver_options: dict = field(default_factory=dict)
    column: dict | None = None

    def column_dict(self) -> dict:
        if self.column is not None:
            return copy.deepcopy(self.column)
        from pycolfrag.structure.column import Column
        return Column.parthenon().to_dict()


def _set_model_value(m: ModelSettings, name: str, value) -> ModelSettings:
    if name == "vp_scale":
        return replace(m, vp_scale=value)
    if name == "tp_model":
        return replace(m, tp_model=value)
    if name == "vp_model":
        return replace(m, vp_model=value)
    if name == "contact":
        opts = {k: v for k, v in m.solver_options.items() if k not in ("contact", "points_per_edge")}
        return replace(m, solver_options={**opts, **({"contact": value} if isinstance(value, str) else value)})
    col = m.column_dict()
    if name.startswith("joint_"):
        key = {"joint_kn": "kn", "joint_ks": "ks", "joint_friction_deg": "friction_angle_deg"}[name]
        joints = dict(col.get("joints") or {})
        for alias in ("friction_angle", "friction_deg") if key == "friction_angle_deg" else ():
            joints.pop(alias, None)
        col["joints"] = {**joints, key: value}
        if col.get("joint_overrides"):
            raise ParameterError(f"{name}: the column has joint_overrides, which a branch of every joint's "
                                 f"{key} would leave as they are; vary the column file instead")
        return replace(m, column=col)
    if name == "connectors":
        col.pop("connectors", None)
        if value:
            col["connectors"] = copy.deepcopy(value)
        return replace(m, column=col)
    raise AssertionError(f"no model rule for the choice {name!r}")


def model_of(end: EndBranch, base: ModelSettings | None = None) -> ModelSettings:
    """The run settings of an end branch: ``base`` with its run choices set."""
    m = base or ModelSettings()
    for bs, br in zip(end.sets, end.branches):
        if bs.scope == RUNS:
            m = _set_model_value(m, bs.choice.name, copy.deepcopy(br.value))
    return m


def check_model(m: ModelSettings, *, probe: bool = False, record_dt_s: float | None = None):
    """The column and solver options of ``m``, each checked by its own class, the pulse amplitude and period by
    the pulse model's checks, and options that belong to another contact model refused; with ``probe`` the
    grid's check of the column with its options (:func:`pycolfrag.grid.probes.check_solver_options`: a
    few solver steps). Returns (Column, SolverOptions)."""
    from pycolfrag.grid.spec import DEFAULT_RECORD_DT_S, resolve_solver_options
    from pycolfrag.ground_motion import rupakhety_2011
    from pycolfrag.ground_motion.registry import DEFAULT_TP_MODEL, tp_model_of, vp_model_key
    from pycolfrag.solver.options import OPTIONS
    from pycolfrag.structure.column import Column
    rupakhety_2011.PARAMETERS[2].check(m.vp_scale, "vp_scale", error=ParameterError)
    tp_model_of(m.tp_model or DEFAULT_TP_MODEL)
    vp_model_key(m.vp_model)   # ParameterError naming an unknown vp_model
    opts = resolve_solver_options(dict(m.solver_options))
    for k in m.solver_options:
        models = OPTIONS[k].models if k in OPTIONS else ()
        if models and opts.contact not in models:
            raise ParameterError(f"solver option {k} = {m.solver_options[k]!r} belongs to the contact model(s) "
                                 f"{', '.join(models)}, not to {opts.contact!r}")
    col = Column.from_dict(m.column_dict())
    if probe:
        from pycolfrag.grid.probes import check_solver_options
        check_solver_options(col, opts, DEFAULT_RECORD_DT_S if record_dt_s is None else record_dt_s)
    return col, opts


@dataclass(frozen=True)
class CheckedTree:
    """A tree whose end branches all passed the checks: each with its site and its run settings."""

    tree: LogicTree
    ends: tuple
    sites: tuple
    models: tuple


def check_tree(tree: LogicTree, site_dict: dict, origin: str = "", base: ModelSettings | None = None, *,
               probe: bool = False, record_dt_s: float | None = None) -> CheckedTree:
    """Every end branch applied to the site and the model and checked by their own validation, before any run;
    the first refusal is raised naming the branch. Run settings shared by several end branches are checked
    once."""
    check_sources(tree, site_dict, origin)
    ends = tree.end_branches()
    sites, models, seen = [], [], set()
    for end in ends:
        sites.append(site_of(site_dict, end, origin))
        try:
            m = model_of(end, base)
            if end.runs_key not in seen:
                check_model(m, probe=probe, record_dt_s=record_dt_s)
                seen.add(end.runs_key)
        except ParameterError as exc:
            raise _refused(end, exc) from None
        models.append(m)
    return CheckedTree(tree, ends, tuple(sites), tuple(models))
