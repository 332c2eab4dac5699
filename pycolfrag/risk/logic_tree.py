"""Logic trees over the model and site choices of a site risk (docs/logic_tree.md).

A logic tree is a TOML table -- its own file, or a ``[logic_tree]`` table in the site file -- of
*branch sets*. Each set varies one *choice* (:data:`CHOICES`) over a list of alternatives (branches),
each with a weight; the weights of a set sum to 1 (within :data:`WEIGHT_TOL`). An *end branch* takes
one alternative of every set; its weight is the product of theirs (OpenQuake's full enumeration), or,
when the tree asks for ``samples = N`` (OpenQuake's ``number_of_logic_tree_samples``), N end branches
are drawn, each set's alternative by its weights, and each gets the weight 1/N.

A choice has a *scope*: ``"site"`` (source rates, b-values, Mmax, the pulse-occurrence model: the same
runs, re-weighted) or ``"runs"`` (the pulse amplitude and period, the contact model, the joints, the
connectors: other runs). Numerical settings (``dt_factor``, the record's time step, ...) are not model
choices and are refused as branches. Reading a tree checks its form (keys, types, weights, duplicate
alternatives); :mod:`pycolfrag.risk.tree_apply` checks every branch against the models' own
validation (the site loader, :class:`~pycolfrag.Column`, :class:`~pycolfrag.SolverOptions`) before any
run. Every refusal is a :class:`~pycolfrag.core.errors.ParameterError` naming the bad value.
"""
from __future__ import annotations

import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from typing import Callable

import numpy as np

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError

__all__ = ["SITE", "RUNS", "Choice", "CHOICES", "NUMERICAL_SETTINGS", "MAX_ENUMERATED", "WEIGHT_TOL", "MAX_SAMPLES",
           "MAX_TREE_BYTES", "Branch", "BranchSet", "EndBranch", "LogicTree", "tree_from_dict", "load_tree"]

#: Scopes of a choice: the site's rates (the same runs re-weighted) or the runs themselves.
SITE, RUNS = "site", "runs"
#: The most end branches a full enumeration gives; beyond, ``samples`` must be given.
MAX_ENUMERATED = 64
#: How far a set's weights may sum from 1.
WEIGHT_TOL = 1e-9
#: The most end branches ``samples`` may draw.
MAX_SAMPLES = 10000
#: The largest tree file read (as a site file).
MAX_TREE_BYTES = 16 << 20

_TREE_KEYS = ("description", "samples", "seed", "branch_sets")
_SET_KEYS = ("name", "choice", "sources", "branches")
_BRANCH_KEYS = ("name", "value", "weight")

#: Settings that are numerical, not model choices: refused as branches (a branch must change the model,
#: not the accuracy of its solution; docs/logic_tree.md).
NUMERICAL_SETTINGS = {
    "dt_factor": "the solver step's fraction of the stability limit",
    "dt_solver": "the solver step",
    "record_dt": "the record's time step", "record_dt_s": "the record's time step", "dt": "a time step",
    "history_dt": "the history's sampling", "tail_s": "the free response after the record",
    "residual_window_s": "the window of the residual dislocation", "max_record_s": "the record's length",
    "energy_tolerance": "the energy check's tolerance", "unstable_tolerance": "the energy check's tolerance",
    "contact_tolerance": "the contact search's tolerance", "early_exit": "when a run stops",
    "sleep": "the sleeping joints (results change by round-off only)", "sleep_margin": "the sleeping joints' margin",
    "draws": "the intervals' draws", "n_draws": "the intervals' draws", "seed": "the random streams",
}


def _where(where: str, key: str | None = None) -> str:
    return where if key is None else f"{where}.{key}"


def _number(v, where: str, lo: float = -math.inf, hi: float = math.inf, low_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ParameterError(f"{where} must be a finite number, got {v!r}")
    if v < lo or (low_open and v == lo) or v > hi:
        rng = f"{'(' if low_open else '['}{lo:g}, {hi:g}]"
        raise ParameterError(f"{where} must be in {rng}, got {v!r}")
    return float(v)


def _text(v, where: str) -> str:
    if not isinstance(v, str) or not v.strip():
        raise ParameterError(f"{where} must be a non-empty string, got {v!r}")
    return v


def _table(v, where: str) -> dict:
    if not isinstance(v, dict):
        raise ParameterError(f"{where} must be a table, got {v!r}")
    return v


def _contact(v, where: str):
    """A contact model: its name, or a table of ``contact`` and the options of that model alone
    (``points_per_edge`` of the perimeter model): the mesh is part of the model."""
    if isinstance(v, str):
        return _text(v, where)
    t = _table(v, where)
    unknown = sorted(set(t) - {"contact", "points_per_edge"})
    if unknown or "contact" not in t:
        raise ParameterError(f"{where} must be a contact model's name or a table of 'contact' and its "
                             f"'points_per_edge', got {v!r}" + (f" (unknown key(s) {unknown})" if unknown else ""))
    return dict(t)


def _connectors(v, where: str):
    """A list of a column file's ``[[connectors]]`` tables; an empty list is the free column."""
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise ParameterError(f"{where} must be a list of connector tables (a column file's [[connectors]]; [] for "
                             f"none), got {v!r}")
    return [dict(x) for x in v]


@dataclass(frozen=True)
class Choice:
    """One kind of choice a branch set may vary.

    ``read`` checks a value's form (the models check it again when the branch is applied); ``target``
    is what it changes (two sets changing one target of one source conflict); ``per_source``: it
    applies to the sources a set names (all of them by default)."""

    name: str
    scope: str
    meaning: str
    read: Callable
    target: str = ""
    per_source: bool = False

    @property
    def key(self) -> str:
        return self.target or self.name


def _c(name, scope, meaning, read, target="", per_source=False):
    return name, Choice(name, scope, meaning, read, target, per_source)


#: The choices a branch set may vary, by name.
CHOICES: dict = dict([
    _c("rate", SITE, "a source's annual rate (absolute), 1/yr",
       lambda v, w: _number(v, w, 0.0), "rate", True),
    _c("rate_factor", SITE, "a factor on a source's annual rate",
       lambda v, w: _number(v, w, 0.0, low_open=True), "rate", True),
    _c("b", SITE, "a Gutenberg-Richter source's b-value", lambda v, w: _number(v, w), "b", True),
    _c("m_max", SITE, "a Gutenberg-Richter source's largest magnitude", lambda v, w: _number(v, w), "m_max", True),
    _c("pulse_model", SITE, "the pulse-occurrence model (a site file's [pulse] table)", _table, "pulse", True),
    _c("vp_scale", RUNS, "the factor on the pulse amplitude of Eq. (6)", lambda v, w: _number(v, w)),
    _c("vp_model", RUNS, "the pulse-amplitude relation (Eq. (6) or another: docs/ground_motion.md)", _text),
    _c("tp_model", RUNS, "the pulse-period relation", _text),
    _c("contact", RUNS, "the contact model (and the perimeter model's points_per_edge)", _contact),
    _c("joint_kn", RUNS, "the joints' normal stiffness, Pa/m", lambda v, w: _number(v, w)),
    _c("joint_ks", RUNS, "the joints' shear stiffness, Pa/m", lambda v, w: _number(v, w)),
    _c("joint_friction_deg", RUNS, "the joints' friction angle, degrees", lambda v, w: _number(v, w)),
    _c("connectors", RUNS, "the dowels (a column file's [[connectors]] tables; [] for none)", _connectors),
])


def _canonical(value) -> str:
    """A value's identity (duplicates, the runs' key): its JSON with sorted keys, numbers as floats."""
    def norm(x):
        if isinstance(x, bool) or isinstance(x, str) or x is None:
            return x
        if isinstance(x, (int, float)):
            return float(x)
        if isinstance(x, dict):
            return {k: norm(x[k]) for k in sorted(x)}
        return [norm(y) for y in x]
    return json.dumps(norm(value), sort_keys=True)


@dataclass(frozen=True)
class Branch:
    """One alternative of a branch set."""

    name: str
    value: object
    weight: float


@dataclass(frozen=True)
class BranchSet:
    """A choice and its alternatives; ``sources``: the sources a per-source choice applies to (empty: all)."""

    name: str
    choice: Choice
    branches: tuple
    sources: tuple = ()

    @property
    def scope(self) -> str:
        return self.choice.scope


@dataclass(frozen=True)
class EndBranch:
    """One path through the tree: an alternative of every set (``index``: their positions), its weight."""

    index: tuple
    branches: tuple
    weight: float
    sets: tuple

    @property
    def path(self) -> str:
        return " / ".join(f"{s.name}={b.name}" for s, b in zip(self.sets, self.branches))

    @property
    def runs_key(self) -> tuple:
        """The alternatives of the run-changing sets: end branches with one key share their runs."""
        return tuple((s.name, _canonical(b.value)) for s, b in zip(self.sets, self.branches) if s.scope == RUNS)

    @property
    def changes_runs(self) -> bool:
        """Whether this branch needs runs of its own (a set of scope ``runs``), or only re-weights."""
        return any(s.scope == RUNS for s in self.sets)


class EndBranchArrays:
    """What a tree's result (on either route) derives from its ``ends`` (EndBranch tuple) and ``tree``: the end
    branches' weights, their branch indices per set, and the sets' names and sizes (the statistics' inputs)."""

    ends: tuple
    tree: "LogicTree"

    @property
    def weights(self) -> np.ndarray:
        return np.array([e.weight for e in self.ends])

    @property
    def index(self) -> np.ndarray:
        return np.array([e.index for e in self.ends], dtype=int).reshape(len(self.ends), -1)

    @property
    def sets(self) -> list:
        return [(s.name, len(s.branches)) for s in self.tree.branch_sets]


@dataclass(frozen=True)
class LogicTree:
    """Branch sets, and how end branches are formed: all of them (``samples`` 0) or ``samples`` drawn."""

    branch_sets: tuple
    samples: int = 0
    seed: int = 0
    description: str = ""
    origin: str = ""

    @property
    def n_paths(self) -> int:
        """The number of distinct end branches (the product of the sets' sizes)."""
        return math.prod(len(s.branches) for s in self.branch_sets)

    @property
    def site_only(self) -> bool:
        """True when every set changes only the site: the same runs serve every branch, re-weighted."""
        return all(s.scope == SITE for s in self.branch_sets)

    @property
    def run_sets(self) -> tuple:
        return tuple(s for s in self.branch_sets if s.scope == RUNS)

    def end_branches(self) -> tuple:
        """Every end branch with its product weight, or ``samples`` drawn with weight 1/samples each."""
        if self.samples:
            return self._sampled()
        return tuple(self._end(idx, math.prod(s.branches[i].weight for s, i in zip(self.branch_sets, idx)))
                     for idx in itertools.product(*(range(len(s.branches)) for s in self.branch_sets)))

    def _end(self, idx, weight) -> EndBranch:
        return EndBranch(tuple(idx), tuple(s.branches[i] for s, i in zip(self.branch_sets, idx)), weight,
                         self.branch_sets)

    def _sampled(self) -> tuple:
        """OpenQuake's sampling rule: each sample draws every set's alternative by its weights (inverse
        CDF of one uniform per set and sample, PCG64 of ``seed``), and every sample weighs 1/samples (a
        path drawn twice counts twice). The rule is OpenQuake's; the random numbers are not."""
        rng = np.random.Generator(np.random.PCG64(self.seed))
        u = rng.random((self.samples, len(self.branch_sets)))
        idx = np.empty(u.shape, dtype=int)
        for k, s in enumerate(self.branch_sets):
            cum = np.cumsum([b.weight for b in s.branches])
            idx[:, k] = np.minimum(np.searchsorted(cum / cum[-1], u[:, k], side="right"), len(s.branches) - 1)
        return tuple(self._end(tuple(int(i) for i in row), 1.0 / self.samples) for row in idx)

    def run_groups(self, ends=None) -> dict:
        """End branches (their positions in ``ends``) grouped by the runs they need (:attr:`EndBranch.runs_key`)."""
        groups: dict = {}
        for k, e in enumerate(self.end_branches() if ends is None else ends):
            groups.setdefault(e.runs_key, []).append(k)
        return groups


def _choice(t: dict, where: str) -> Choice:
    name = t.get("choice")
    if name in NUMERICAL_SETTINGS:
        raise ParameterError(f"{_where(where, 'choice')} = {name!r} is a numerical setting ({NUMERICAL_SETTINGS[name]}), "
                             "not a model choice: it is refused as a branch (set it for every branch on the command "
                             "line; docs/logic_tree.md)")
    if name not in CHOICES:
        from pycolfrag.solver.options import OPTIONS  # here: only this message needs the C library's option table
        hint = " (a solver setting that is not a model choice)" if name in OPTIONS else ""
        raise ParameterError(f"{_where(where, 'choice')} must be one of {', '.join(map(repr, CHOICES))}, "
                             f"got {name!r}{hint}")
    return CHOICES[name]


def _only(t: dict, allowed, where: str) -> None:
    unknown = sorted(set(t) - set(allowed))
    if unknown:
        raise ParameterError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
                             f"{', '.join(allowed)}")


def _branches(raw, choice: Choice, where: str) -> tuple:
    if not isinstance(raw, list) or not raw:
        raise ParameterError(f"{_where(where, 'branches')} must be a non-empty list of tables "
                             f"{{value = ..., weight = ...}}, got {raw!r}")
    out: list = []
    seen_value: dict = {}
    seen_name: set = set()
    for i, b in enumerate(raw):
        bw = f"{where}.branches[{i}]"
        _only(_table(b, bw), _BRANCH_KEYS, bw)
        if "value" not in b or "weight" not in b:
            raise ParameterError(f"{bw}: needs 'value' and 'weight', got {b!r}")
        value = choice.read(b["value"], _where(bw, "value"))
        weight = _number(b["weight"], _where(bw, "weight"), 0.0, 1.0, low_open=True)
        key = _canonical(value)
        if key in seen_value:
            raise ParameterError(f"{_where(bw, 'value')} = {b['value']!r} repeats branch {seen_value[key]} of the set: "
                                 "give each alternative once (its weight is the sum)")
        seen_value[key] = i
        name = _text(b["name"], _where(bw, "name")) if "name" in b else _short(value)
        if name in seen_name:
            raise ParameterError(f"{_where(bw, 'name')} {name!r} names an earlier branch of the set")
        seen_name.add(name)
        out.append(Branch(name, value, weight))
    total = math.fsum(br.weight for br in out)
    if abs(total - 1.0) > WEIGHT_TOL:
        raise ParameterError(f"{where}: the weights {[br.weight for br in out]} sum to {total!r}, not 1 (within "
                             f"{WEIGHT_TOL:g})")
    return tuple(out)


def _short(value) -> str:
    """A branch's default name: its value (a table as key=value pairs)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{value:g}"
    if isinstance(value, dict):
        return ",".join(f"{k}={_short(v)}" for k, v in value.items())
    return value if isinstance(value, str) else _canonical(value)


def _branch_set(t, i: int, where: str, names: set) -> BranchSet:
    sw = f"{where}.branch_sets[{i}]"
    _only(_table(t, sw), _SET_KEYS, sw)
    choice = _choice(t, sw)
    name = _text(t["name"], _where(sw, "name")) if "name" in t else choice.name
    if name in names:
        raise ParameterError(f"{_where(sw, 'name')} {name!r} names an earlier branch set: give every set its own name")
    sources = t.get("sources", [])
    if "sources" in t and not choice.per_source:
        raise ParameterError(f"{_where(sw, 'sources')}: {choice.name!r} is not a choice of the sources "
                             f"({choice.meaning}); drop 'sources'")
    if not isinstance(sources, list) or not all(isinstance(s, str) for s in sources) or len(set(sources)) != len(sources):
        raise ParameterError(f"{_where(sw, 'sources')} must be a list of distinct source names, got {sources!r}")
    if "sources" in t and not sources:
        raise ParameterError(f"{_where(sw, 'sources')} is empty: name the sources, or drop the key for all of them")
    return BranchSet(name, choice, _branches(t.get("branches"), choice, sw), tuple(sources))


def _conflicts(sets, where: str) -> None:
    """Two sets that change one thing (of one source) would each undo the other: refused."""
    for a, b in itertools.combinations(sets, 2):
        if a.choice.key != b.choice.key:
            continue
        if a.choice.per_source and a.sources and b.sources and not set(a.sources) & set(b.sources):
            continue
        both = sorted(set(a.sources) & set(b.sources)) if a.sources and b.sources else "every source"
        raise ParameterError(f"{where}: branch sets {a.name!r} ({a.choice.name}) and {b.name!r} ({b.choice.name}) both "
                             f"change {a.choice.key!r}" + (f" of {both}" if a.choice.per_source else "")
                             + ": merge them into one set")


def tree_from_dict(d: dict, origin: str = "") -> LogicTree:
    """A :class:`LogicTree` from a ``[logic_tree]`` table (or a tree file's top level); every bad value raises
    :class:`~pycolfrag.core.errors.ParameterError` naming the file, the key and the value."""
    where = f"{origin}: logic_tree" if origin else "logic_tree"
    _only(_table(d, where), _TREE_KEYS, where)
    raw = d.get("branch_sets")
    if not isinstance(raw, list) or not raw:
        raise ParameterError(f"{where}: at least one [[logic_tree.branch_sets]] table is needed, got {raw!r}")
    sets: list = []
    for i, t in enumerate(raw):
        sets.append(_branch_set(t, i, where, {s.name for s in sets}))
    _conflicts(sets, where)
    samples = d.get("samples", 0)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 0 <= samples <= MAX_SAMPLES:
        raise ParameterError(f"{_where(where, 'samples')} must be an integer in [0, {MAX_SAMPLES}] (0: every end branch), "
                             f"got {samples!r}")
    seed = d.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError(f"{_where(where, 'seed')} must be an integer >= 0, got {seed!r}")
    tree = LogicTree(tuple(sets), samples, seed, str(d.get("description", "")), origin)
    if not samples and tree.n_paths > MAX_ENUMERATED:
        raise ParameterError(f"{where}: {tree.n_paths} end branches ({' x '.join(str(len(s.branches)) for s in sets)}), "
                             f"more than the {MAX_ENUMERATED} a full enumeration takes: give samples = N (OpenQuake's "
                             "number_of_logic_tree_samples) to draw N end branches")
    return tree


def tree_table(d: dict):
    """The tree's table of a parsed file: its ``[logic_tree]`` table, else the top level; None for a site
    file without one."""
    if "logic_tree" in d:
        return d["logic_tree"]
    return None if "sources" in d else d


def load_tree(path) -> LogicTree:
    """Read a logic tree: a TOML file of its own (its top level, or a ``[logic_tree]`` table), or a site file
    with a ``[logic_tree]`` table."""
    text = input_files.read_text(path, "logic tree file", max_bytes=MAX_TREE_BYTES)
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    t = tree_table(d)
    if t is None:
        raise ParameterError(f"{path}: a site file without a [logic_tree] table")
    return tree_from_dict(t, str(path))
