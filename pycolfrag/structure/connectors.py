"""Connectors between drums: dowels across the joints of a column (docs/column_format.md,
"Connectors"; the law: ``csrc/connector_law.h``, docs/solver.md "Connectors").

A :class:`DowelLaw` is the law of one dowel: an elastic-perfectly plastic shear law that breaks at
an ultimate shear displacement (``kind="elastoplastic"``: a titanium dowel), or a clearance then a
low stiffness, the seat crushing beyond a force and the pin breaking at an ultimate displacement
(``kind="clearance"``: the ancient wooden empolion and polos); optionally an axial part that resists
the joint's opening at the dowel. :data:`LAWS` holds the named laws (``"titanium"``, ``"wood"``) with
their provenance (``pycolfrag/data/connector_laws.json``).

:class:`Connectors` places dowels of one law at some joints: ``count`` dowels on a circle of
``radius`` around the joint's centre (one dowel at the centre when the radius is 0). A
:class:`~pycolfrag.Column` carries a tuple of them (``Column(..., connectors=...)``,
``Column.with_connectors``, or ``[[connectors]]`` tables in a column file).

Units: N/m, N, m. The law's checks are the C library's (``cf_solver_connectors_check``): one text
for the ranges and their messages.
"""
from __future__ import annotations

import json
import math
import numbers
from dataclasses import dataclass, replace
from importlib import resources
from typing import Any

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib
from pycolfrag.core.validate import integer, real
from pycolfrag.structure.connector_laws import COMMON, LAW_KINDS

__all__ = ["DowelLaw", "Connectors", "LAWS", "KINDS", "law", "dowel_positions"]

#: The kinds of shear law, by name: their index in the C library's registry (:mod:`pycolfrag.structure.connector_laws`).
KINDS = {name: k.index for name, k in LAW_KINDS.items()}

_LAW_NUMBERS = tuple(COMMON)
_OWN = tuple(sorted({v.name for k in LAW_KINDS.values() for v in k.values}))   # every kind's own values
_LAW_KEYS = ("kind", *_LAW_NUMBERS, *_OWN, "name", "provenance")
_SET_KEYS = ("joints", "law", "count", "radius", "phase_deg")


@dataclass(frozen=True, init=False)
class DowelLaw:
    """The law of one dowel (``csrc/connector_law.h``; its kinds: :data:`KINDS`, read from C).

    Parameters
    ----------
    kind : str
        A kind of :data:`KINDS`: ``"elastoplastic"`` (a metal dowel), ``"clearance"`` (a clearance then
        linear with a crushing seat: a wooden empolion and polos), or any kind the C registry adds.
    k_shear : float
        Shear stiffness once engaged, N/m (>= 0).
    f_yield : float
        Shear force at yield, or at which the seat crushes, N (> 0; ``inf``: never).
    u_ultimate : float
        Shear displacement |u| at which the dowel breaks, m (> 0; ``inf``: never).
    k_axial, n_yield, d_ultimate : float
        The axial part: stiffness against the joint's opening at the dowel (N/m, 0: none), the force at
        which it slips out (N) and the opening at which it pulls out and breaks (m).
    name : str
        A label (the key of :data:`LAWS` for a named law).
    **values
        The kind's own values by name (``LAW_KINDS[kind].values``; the clearance kind's ``clearance``,
        its initial clearance in m), read as attributes (``law.clearance``); missing ones take their
        defaults. ``own`` gives them all at once, in the kind's order (what ``dataclasses.replace`` passes).
    """

    kind: str
    k_shear: float
    f_yield: float
    u_ultimate: float
    k_axial: float
    n_yield: float
    d_ultimate: float
    name: str
    own: tuple   # the kind's own values, in the order of its C table

    def __init__(self, kind: str = "elastoplastic", k_shear=0.0, f_yield=math.inf, u_ultimate=math.inf, *,
                 k_axial=0.0, n_yield=math.inf, d_ultimate=math.inf, name: str = "", own: tuple | None = None,
                 **values):
        if kind not in KINDS:
            raise ParameterError(f"dowel law: kind must be one of {sorted(KINDS)}, got {kind!r}")
        spec = LAW_KINDS[kind].values
        label = f" {name}" if name else ""
        unknown = sorted(set(values) - {v.name for v in spec})
        if unknown:
            article = "an" if kind[0] in "aeiou" else "a"
            raise ParameterError(f"dowel law{label}: {article} {kind} connector has no {', '.join(unknown)} (its own "
                                 f"values: {', '.join(v.name for v in spec) or 'none'}; use another kind)")
        mine = dict(zip((v.name for v in spec), own)) if own is not None else {}
        mine.update(values)
        given = {"k_shear": k_shear, "f_yield": f_yield, "u_ultimate": u_ultimate, "k_axial": k_axial,
                 "n_yield": n_yield, "d_ultimate": d_ultimate, **{v.name: mine.get(v.name, v.default) for v in spec}}
        for key, x in given.items():
            v = real(x, f"dowel law {key}")
            if math.isnan(v):
                raise ParameterError(f"dowel law {key} must be a number, got {x!r}")
            given[key] = v
        object.__setattr__(self, "kind", kind)
        object.__setattr__(self, "name", name)
        for key in _LAW_NUMBERS:
            object.__setattr__(self, key, given[key])
        object.__setattr__(self, "own", tuple(given[v.name] for v in spec))
        msg = ffi.new("char[]", 256)
        c = ffi.new("cf_solver_connector *")
        self.fill(c)
        if lib.cf_solver_connectors_check(c, msg) != lib.CF_OK:
            raise ParameterError(f"dowel law{label}: {ffi.string(msg).decode(errors='replace')}")

    def __getattr__(self, key: str) -> float:
        """A kind's own value by its name (``law.clearance``)."""
        if key.startswith("__") or "own" not in self.__dict__:
            raise AttributeError(key)
        for v, x in zip(LAW_KINDS[self.kind].values, self.own):
            if v.name == key:
                return x
        raise AttributeError(f"a {self.kind} dowel law has no value {key!r}")

    def fill(self, c) -> None:
        """Write the law into a ``cf_solver_connector`` (its place is the caller's)."""
        c.kind = KINDS[self.kind]
        for key in _LAW_NUMBERS:
            setattr(c, key, getattr(self, key))
        for k, x in enumerate(self.own):
            c.law[k] = x

    @property
    def u_yield(self) -> float:
        """Shear displacement at yield (elastoplastic) or at crushing (clearance included), m: the kind's
        own (``cf_solver_connector_law_u_yield``)."""
        c = ffi.new("cf_solver_connector *")
        self.fill(c)
        return float(lib.cf_solver_connector_law_u_yield(c))

    def drive(self, u) -> dict:
        """The law along a prescribed displacement history ``u`` ((n, 3) m: shear x, y and the
        opening, from the rest state), by the C text the solver runs: ``force`` (n, 3) N on the upper
        block, ``stored`` (n,) J, ``dissipated`` (n,) J so far, ``state`` (n,) 0 elastic, 1 yielded,
        2 broken."""
        u = np.ascontiguousarray(u, dtype=np.float64)
        if u.ndim != 2 or u.shape[1] != 3 or not np.isfinite(u).all():
            raise ParameterError(f"u must be a finite (n, 3) array of displacements (m), got shape {u.shape}")
        n = u.shape[0]
        force, stored, diss = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
        state = ffi.new("int[]", max(n, 1))
        c = ffi.new("cf_solver_connector *")
        self.fill(c)
        msg = ffi.new("char[]", 256)
        st = lib.cf_solver_connectors_drive(c, n, ffi.from_buffer("double[]", u), ffi.from_buffer("double[]", force),
                                            ffi.from_buffer("double[]", stored), ffi.from_buffer("double[]", diss),
                                            state, msg)
        if st != lib.CF_OK:
            raise ParameterError(ffi.string(msg).decode(errors="replace"))
        return {"force": force, "stored": stored, "dissipated": diss, "state": np.array(list(state)[:n])}

    def to_dict(self) -> dict:
        """Its keys, the infinite ones (``never``) and the zero axial part left out."""
        d: dict[str, Any] = {"kind": self.kind}
        own = [(v.name, x, v.default) for v, x in zip(LAW_KINDS[self.kind].values, self.own)]
        shear = [(key, getattr(self, key), None) for key in ("k_shear", "f_yield", "u_ultimate")]
        axial = [(key, getattr(self, key), 0.0 if key == "k_axial" else None) for key in ("k_axial", "n_yield", "d_ultimate")]
        for key, v, default in shear + own + axial:   # the order of a file's table
            if math.isinf(v) or v == default:
                continue
            d[key] = v
        if self.name:
            d["name"] = self.name
        return d

    @classmethod
    def from_dict(cls, d, where: str = "law") -> "DowelLaw":
        """A law from a mapping of its keys (missing: the defaults; ``provenance`` ignored), or the
        name of a law of :data:`LAWS`."""
        if isinstance(d, str):
            return law(d)
        if not isinstance(d, dict):
            raise ParameterError(f"{where} must be the name of a law ({', '.join(LAWS)}) or a table of its keys, "
                                 f"got {type(d).__name__}: {d!r}")
        unknown = set(d) - set(_LAW_KEYS)
        if unknown:
            raise ParameterError(f"{where}: unknown keys {sorted(unknown)} (known: {sorted(_LAW_KEYS)})")
        args = {k: v for k, v in d.items() if k != "provenance"}
        return cls(**args)


def _load_laws() -> dict:
    text = resources.files("pycolfrag").joinpath("data/connector_laws.json").read_text("utf-8")
    table = json.loads(text)
    return {name: replace(DowelLaw.from_dict({k: v for k, v in d.items()}), name=name)
            for name, d in table.items() if isinstance(d, dict)}


#: The named laws, with their provenance in ``pycolfrag/data/connector_laws.json``.
LAWS: dict[str, DowelLaw] = _load_laws()


def law(name: str, **changes) -> DowelLaw:
    """The named law (``"titanium"``, ``"wood"``), with ``changes`` to its values."""
    if name not in LAWS:
        raise ParameterError(f"unknown dowel law {name!r}; known: {', '.join(LAWS)}")
    return replace(LAWS[name], **changes) if changes else LAWS[name]


def dowel_positions(count: int, radius: float, phase_deg: float) -> list[tuple[float, float]]:
    """Places of ``count`` dowels on a circle of ``radius`` (m) about the joint's centre, the first at
    ``phase_deg`` from +x; one dowel at the centre when the radius is 0."""
    if radius == 0.0:
        return [(0.0, 0.0)]
    a0 = math.radians(phase_deg)
    return [(radius * math.cos(a0 + 2.0 * math.pi * k / count), radius * math.sin(a0 + 2.0 * math.pi * k / count))
            for k in range(count)]


@dataclass(frozen=True)
class Connectors:
    """Dowels of one law at some joints: at each joint of ``joints``, ``count`` dowels on a circle
    of ``radius`` m about its centre (the first at ``phase_deg`` from +x), or one dowel at the centre
    (``radius`` 0, ``count`` 1).

    ``joints`` is a tuple of joint indices (joint j under block j; 0 the base joint) or ``"all"``,
    resolved against the column it is given to.
    """

    law: DowelLaw
    joints: str | tuple[int, ...] = "all"   # given as any iterable of indices (or one index): a tuple after checks
    count: int = 1
    radius: float = 0.0
    phase_deg: float = 0.0

    def __post_init__(self):
        if not isinstance(self.law, DowelLaw):
            raise ParameterError(f"connectors: law must be a DowelLaw (or give a name to Connectors.of), got "
                                 f"{type(self.law).__name__}")
        if isinstance(self.joints, str):
            if self.joints != "all":
                raise ParameterError(f"connectors: joints must be 'all' or a list of joint indices, got {self.joints!r}")
        else:
            js = self.joints
            if isinstance(js, numbers.Integral) and not isinstance(js, bool):
                js = (js,)
            if not hasattr(js, "__iter__"):
                raise ParameterError(f"connectors: joints must be 'all' or a list of joint indices, got {self.joints!r}")
            js = tuple(integer(j, "connectors joint index", minimum=0) for j in js)
            if not js or len(set(js)) != len(js):
                raise ParameterError(f"connectors: joints must be a non-empty list of distinct indices, got {self.joints!r}")
            object.__setattr__(self, "joints", js)
        object.__setattr__(self, "count", integer(self.count, "connectors count", minimum=1, maximum=64))
        r = real(self.radius, "connectors radius (m)")
        if not (math.isfinite(r) and r >= 0.0):
            raise ParameterError(f"connectors radius must be finite and >= 0 m, got {self.radius!r}")
        if r == 0.0 and self.count != 1:
            raise ParameterError(f"connectors: {self.count} dowels need a radius > 0 (one dowel sits at the centre)")
        object.__setattr__(self, "radius", r)
        ph = real(self.phase_deg, "connectors phase_deg")
        if not math.isfinite(ph):
            raise ParameterError(f"connectors phase_deg must be finite, got {self.phase_deg!r}")
        object.__setattr__(self, "phase_deg", ph)

    @classmethod
    def of(cls, law_name: str, joints="all", **kwargs) -> "Connectors":
        """Connectors of a named law: ``Connectors.of("titanium", (1, 2), count=3, radius=0.3)``."""
        return cls(law(law_name), joints, **kwargs)

    def joint_list(self, n_joints: int) -> tuple:
        """The joints it names on a column of ``n_joints`` joints (ParameterError for one outside)."""
        if isinstance(self.joints, str):   # "all", the one string the checks let through
            return tuple(range(n_joints))
        for j in self.joints:
            if j >= n_joints:
                raise ParameterError(f"connectors: joint {j} does not exist (the column has joints 0 to {n_joints - 1})")
        return self.joints

    def positions(self) -> list[tuple[float, float]]:
        """The dowels' places at each joint, m from its centre."""
        return dowel_positions(self.count, self.radius, self.phase_deg)

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"joints": self.joints if self.joints == "all" else list(self.joints), "count": self.count,
             "radius": self.radius, "phase_deg": self.phase_deg}
        d["law"] = self.law.name if self.law.name in LAWS and LAWS[self.law.name] == self.law else self.law.to_dict()
        return d

    @classmethod
    def from_dict(cls, d, where: str = "connectors") -> "Connectors":
        if not isinstance(d, dict):
            raise ParameterError(f"{where} must be a table (joints, law, count, radius, phase_deg), got {d!r}")
        unknown = set(d) - set(_SET_KEYS)
        if unknown:
            raise ParameterError(f"{where}: unknown keys {sorted(unknown)} (known: {sorted(_SET_KEYS)})")
        if "law" not in d:
            raise ParameterError(f"{where}: missing key 'law' (a name: {', '.join(LAWS)}, or a table of its keys)")
        return cls(DowelLaw.from_dict(d["law"], f"{where}.law"), joints=d.get("joints", "all"),
                   count=d.get("count", 1), radius=d.get("radius", 0.0), phase_deg=d.get("phase_deg", 0.0))


def connectors_on(column, connectors) -> tuple:
    """``connectors`` (a Connectors or a sequence of them) as a tuple, each checked on ``column``:
    its joints exist and every dowel lies on both faces of its joint (the ground's face under the
    base joint is the block's own)."""
    if isinstance(connectors, Connectors):
        connectors = (connectors,)
    if isinstance(connectors, (str, bytes)) or not hasattr(connectors, "__iter__"):
        raise ParameterError(f"connectors must be a sequence of Connectors, got {type(connectors).__name__}")
    out = tuple(connectors)
    for c in out:
        if not isinstance(c, Connectors):
            raise ParameterError(f"connectors must be Connectors, got {type(c).__name__}")
        for j in c.joint_list(column.n_blocks):
            faces = [(column.blocks[j].bottom, False)]
            if j > 0:
                faces.append((column.blocks[j - 1].top, True))
            for x, y in c.positions():
                for seg, top in faces:
                    if not seg.inside(x, y, top):
                        raise ParameterError(f"connectors: a dowel at ({x:.4g}, {y:.4g}) m lies outside the face of "
                                             f"joint {j} (circumradius {seg.circumradius(top):.4g} m, "
                                             f"{seg.n_sides} sides)")
    return out
