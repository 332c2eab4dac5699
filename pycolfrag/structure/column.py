"""Column geometry: stacks of rigid blocks made of regular-polygon frustum segments.

A :class:`Column` is a list of :class:`Block` objects from the bottom up, resting
on the ground (the base block, which moves with the ground motion). Each block is
one rigid body made of one or more :class:`Segment` objects stacked vertically
(a shaft drum is one segment; the Doric capital is an echinus frustum plus a
square abacus slab). Only a block's bottom face (its first segment's bottom) and
top face (its last segment's top) touch other blocks. Joint ``i`` is the
interface under block ``i`` (joint 0 is the base joint on the ground).

Diameters are those of the circle through the polygon's vertices (circumscribed),
as in the paper's reference geometry; ``phase`` is the angle of the first vertex
from the +x axis (the direction of ``acc_x``). All lengths in m, density in
kg/m^3, joint stiffness in Pa/m (N/m per m^2 of joint), angles in degrees unless
the name says ``_rad``.

Columns come from :meth:`Column.parthenon` (the paper's default scene),
:meth:`Column.from_drums`, :meth:`Column.single_block`, the constructor, or a JSON
or TOML file (:meth:`Column.from_file`, format in ``docs/column_format.md``).
"""
from __future__ import annotations

import itertools
import json
import math
import numbers
import os
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from typing import Iterable, Sequence

from pycolfrag.core import input_files
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import lib as _lib
from pycolfrag.core.validate import positive_float, real
from pycolfrag.structure import as_built, foundation
from pycolfrag.structure.connectors import Connectors, connectors_on
from pycolfrag.structure.scene_parts import SceneParts
from pycolfrag.structure.segment import MAX_SIDES, Segment, _check_keys, _n_sides  # noqa: F401  (re-exported)

__all__ = ["Segment", "Block", "JointProperties", "Column"]

_BLOCK_KEYS = ("name", "segments", *as_built.KEYS)
_SHAFT_KEYS = ("drum_heights", "diameter_bottom", "diameter_top", "n_sides", "phase_deg", "provenance")
_CAPITAL_KEYS = ("echinus_height", "echinus_diameter_bottom", "echinus_diameter_top", "abacus_height",
                 "abacus_side", "n_sides", "provenance")
_COLUMN_KEYS = ("name", "provenance", "description", "units", "density", "n_sides", "phase_deg", "shaft",
                "capital", "joints", "joint_overrides", "blocks", "connectors", "foundation_tilt_deg",
                "foundation_tilt_azimuth_deg")


@dataclass(frozen=True)
class Block:
    """One rigid body: segments stacked from the bottom up (at least one), as built (:mod:`pycolfrag.structure.as_built`)."""

    segments: tuple
    name: str = ""
    offset: tuple = (0.0, 0.0); rotation_deg: float = 0.0; bottom_annulus: tuple = (0.0, 0.0); missing_part: tuple = ()
    bottom_missing_sector: tuple = ()

    def __post_init__(self):
        segs = tuple(self.segments)
        if not segs:
            raise ParameterError(f"block {self.name!r} has no segments")
        for s in segs:
            if not isinstance(s, Segment):
                raise ParameterError(f"block {self.name!r}: segments must be Segment objects, got {type(s).__name__}")
        object.__setattr__(self, "segments", segs); as_built.place(self)

    @property
    def height(self) -> float:
        return sum(s.height for s in self.segments)

    @property
    def volume(self) -> float:
        return sum(s.volume for s in self.segments) - (self.missing_part[0] if self.missing_part else 0.0)

    @property
    def centroid_height(self) -> float:
        """Centroid height above the block's bottom face, m."""
        z0, acc = 0.0, 0.0
        for s in self.segments:
            acc += s.volume * (z0 + s.centroid_height)
            z0 += s.height
        return (acc - (self.missing_part[0] * self.missing_part[3] if self.missing_part else 0.0)) / self.volume

    @property
    def bottom(self) -> Segment:
        return self.segments[0]

    @property
    def top(self) -> Segment:
        return self.segments[-1]

    def to_dict(self) -> dict:
        return {"name": self.name, "segments": [s.to_dict() for s in self.segments], **as_built.block_kw(self)}


@dataclass(frozen=True)
class JointProperties:
    """Joint constitutive parameters (paper Table I), uniform over the column.

    Parameters
    ----------
    kn, ks : float
        Normal and shear stiffness per unit area, Pa/m. Default 1e9 (1 GPa/m).
    friction_deg : float
        Coulomb friction angle, degrees, in (0, 90). Default 37.
    cohesion, tensile_strength : float
        Pa. Only 0 is supported (paper Table I; dry joints): a non-zero value is
        refused rather than silently ignored.
    """

    kn: float = 1.0e9
    ks: float = 1.0e9
    friction_deg: float = 37.0
    cohesion: float = 0.0
    tensile_strength: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "kn", positive_float(self.kn, "joint normal stiffness kn (Pa/m)"))
        object.__setattr__(self, "ks", positive_float(self.ks, "joint shear stiffness ks (Pa/m)"))
        f = real(self.friction_deg, "friction angle (degrees)")
        if not math.isfinite(f) or not (0.0 < f < 90.0):
            raise ParameterError(f"friction angle must be in (0, 90) degrees, got {self.friction_deg!r}")
        object.__setattr__(self, "friction_deg", f)
        for name in ("cohesion", "tensile_strength"):
            v = real(getattr(self, name), f"joint {name} (Pa)")
            object.__setattr__(self, name, v)
            if v != 0.0:
                raise ParameterError(f"joint {name} = {v!r} is not supported: dry joints have 0 (paper Table I)")

    @property
    def mu(self) -> float:
        # tan as sin / cos of the library's own portable functions (csrc/cf_math.c): mu feeds the
        # solver, and libm's tan differs in its last bit between CPUs (docs/reproducibility.md)
        a = math.radians(self.friction_deg)
        return _lib.cf_math_sin(a) / _lib.cf_math_cos(a)

    def to_dict(self) -> dict:
        return {
            "kn": self.kn,
            "ks": self.ks,
            "friction_angle_deg": self.friction_deg,
            "cohesion": self.cohesion,
            "tensile_strength": self.tensile_strength,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "JointProperties":
        if not isinstance(d, dict):
            raise ParameterError(f"joints must be a mapping (JSON object / TOML table), got {type(d).__name__}: {d!r}")
        known = {"kn", "ks", "friction_angle_deg", "friction_angle", "friction_deg", "cohesion", "tensile_strength", "provenance"}
        unknown = set(d) - known
        if unknown:
            raise ParameterError(f"joints: unknown keys {sorted(unknown)}")
        fr = d.get("friction_angle_deg", d.get("friction_angle", d.get("friction_deg", 37.0)))
        return cls(
            kn=d.get("kn", 1.0e9),
            ks=d.get("ks", 1.0e9),
            friction_deg=fr,
            cohesion=d.get("cohesion", 0.0),
            tensile_strength=d.get("tensile_strength", 0.0),
        )


class Column:
    """A free-standing stack of rigid blocks on a moving ground.

    Parameters
    ----------
    blocks : sequence of Block
        From the bottom up (at least one).
    density : float
        kg/m^3 (> 0). Default 2700 (marble).
    joints : JointProperties
        Joint properties for every joint, including the base joint.
    name : str
        A label stored with results.
    joint_overrides : mapping {joint index: JointProperties}, optional
        Other properties for some joints (joint j lies under block j; 0 is the base joint on the
        ground), e.g. a mortar bed at the base or a weathered joint. Other joints take ``joints``.
    connectors : sequence of Connectors, optional
        Dowels across joints (:mod:`pycolfrag.structure.connectors`); each must lie on both faces of its joint.
    foundation_tilt_deg, foundation_tilt_azimuth_deg : float
        The foundation descends by this angle (>= 0) towards this azimuth: :mod:`pycolfrag.structure.foundation`.
    """

    def __init__(self, blocks: Sequence[Block], density: float = 2700.0,
                 joints: JointProperties | None = None, name: str = "custom", joint_overrides=None,
                 connectors=(), foundation_tilt_deg=0.0, foundation_tilt_azimuth_deg=0.0):
        if isinstance(blocks, (str, bytes)) or not isinstance(blocks, Iterable):
            raise ParameterError(f"blocks must be a sequence of Block (from the bottom up), got "
                                 f"{type(blocks).__name__} {blocks!r}")
        blocks = tuple(blocks)
        if not blocks:
            raise ParameterError("a column needs at least one block")
        for i, b in enumerate(blocks):
            if not isinstance(b, Block):
                raise ParameterError(f"blocks[{i}] must be a Block, got {type(b).__name__}")
        self.blocks = blocks
        self.density = positive_float(density, "density (kg/m^3)")
        self.joints = joints if joints is not None else JointProperties()
        if not isinstance(self.joints, JointProperties):
            raise ParameterError(f"joints must be JointProperties, got {type(self.joints).__name__}")
        over = {}
        if joint_overrides is not None:
            if not hasattr(joint_overrides, "items"):
                raise ParameterError(f"joint_overrides must be a mapping {{joint index: JointProperties}}, got "
                                     f"{type(joint_overrides).__name__}")
            for j, p in joint_overrides.items():
                if (isinstance(j, bool) or not isinstance(j, numbers.Integral)
                        or not 0 <= j < len(blocks)):  # type: ignore[operator]  # typeshed: Integral has no int <=
                    raise ParameterError(f"joint_overrides: joint index must be an integer in [0, {len(blocks) - 1}], "
                                         f"got {j!r}")
                if not isinstance(p, JointProperties):
                    raise ParameterError(f"joint_overrides[{j}] must be JointProperties, got {type(p).__name__}")
                over[int(j)] = p
        self.joint_overrides = dict(sorted(over.items()))
        self.name = str(name)
        self.connectors = connectors_on(self, connectors) if connectors else ()
        self.foundation_tilt_deg, self.foundation_tilt_azimuth_deg = foundation.check(
            self, foundation_tilt_deg, foundation_tilt_azimuth_deg)
        as_built.check(self)

    def dowels(self) -> list[tuple]:
        """Every dowel as (joint, x, y, law): the connectors expanded, in their order."""
        return [(j, x, y, c.law) for c in self.connectors for j in c.joint_list(self.n_blocks) for x, y in c.positions()]

    def scene_parts(self) -> SceneParts:   # the Structure contract (structure/kinds.py): a one-column scene
        return SceneParts([(self, 0.0, 0.0)], dowels=self.dowels())

    def with_connectors(self, *connectors) -> "Column":
        """A copy with these connectors (none: without connectors); the rest is kept."""
        return Column(self.blocks, density=self.density, joints=self.joints, name=self.name,
                      joint_overrides=self.joint_overrides, connectors=connectors, **foundation.kw(self))

    # ---- constructors -------------------------------------------------------------
    @classmethod
    def from_drums(cls, drum_heights: Iterable[float], diameter_bottom: float, diameter_top: float | None = None,
                   n_sides: int = 10, capital: Block | None = None, density: float = 2700.0,
                   joints: JointProperties | None = None, phase_deg: float = 0.0, name: str = "custom") -> "Column":
        """A shaft of drums with linear taper from ``diameter_bottom`` to ``diameter_top`` (m)
        over the total shaft height, optionally topped by ``capital``."""
        if isinstance(drum_heights, (str, bytes)) or not isinstance(drum_heights, Iterable):
            raise ParameterError(f"drum_heights must be a list of numbers, got {drum_heights!r}")
        heights = [positive_float(h, f"drum_heights[{i}] (m)") for i, h in enumerate(drum_heights)]
        if not heights:
            raise ParameterError("drum_heights is empty")
        d0 = positive_float(diameter_bottom, "diameter_bottom (m)")
        d1 = d0 if diameter_top is None else positive_float(diameter_top, "diameter_top (m)")
        total = sum(heights)
        phase = math.radians(real(phase_deg, "phase_deg"))
        blocks, z = [], 0.0
        for i, h in enumerate(heights):
            rb = 0.5 * (d0 + (d1 - d0) * z / total)
            rt = 0.5 * (d0 + (d1 - d0) * (z + h) / total)
            blocks.append(Block((Segment(h, rb, rt, n_sides, phase),), name=f"drum {i + 1}"))
            z += h
        if capital is not None:
            blocks.append(capital)
        return cls(blocks, density=density, joints=joints, name=name)

    @staticmethod
    def doric_capital(echinus_height: float, echinus_diameter_bottom: float, echinus_diameter_top: float,
                      abacus_height: float, abacus_side: float, n_sides: int = 10, phase_deg: float = 0.0) -> Block:
        """A Doric capital as one rigid block: polygonal echinus frustum + square abacus slab (m)."""
        ech = Segment(echinus_height, 0.5 * real(echinus_diameter_bottom, "echinus_diameter_bottom (m)"),
                      0.5 * real(echinus_diameter_top, "echinus_diameter_top (m)"),
                      n_sides, math.radians(phase_deg))
        r_ab = positive_float(abacus_side, "abacus_side (m)") / math.sqrt(2.0)  # circumradius of the square; sides parallel to x and y
        ab = Segment(abacus_height, r_ab, r_ab, 4, math.pi / 4.0)
        return Block((ech, ab), name="capital")

    @classmethod
    def single_block(cls, width: float, height: float, n_sides: int = 4, density: float = 2700.0,
                     joints: JointProperties | None = None, flat_side_along_x: bool = True) -> "Column":
        """One prismatic block of ``width`` (m, across flats for even ``n_sides``) and ``height`` (m).

        With ``n_sides=4`` and ``flat_side_along_x`` this is a square block of side
        ``width`` whose faces are normal to x and y: the 2D rocking block of Housner
        (1963) when excited along x (half-width b = width/2).
        """
        w = positive_float(width, "width (m)")
        positive_float(height, "height (m)")
        n_sides = _n_sides(n_sides, "single_block")
        r = 0.5 * w / _lib.cf_math_cos(math.pi / n_sides)  # circumradius from the inradius w/2 (portable cos)
        phase = math.pi / n_sides if flat_side_along_x else 0.0
        seg = Segment(height, r, r, n_sides, phase)
        return cls((Block((seg,), name="block"),), density=density, joints=joints, name="single block")

    @classmethod
    def parthenon(cls, **overrides) -> "Column":
        """The paper's default scene: Parthenon Pronaos column (12 drums + capital).

        Keyword overrides are applied to the file's values: ``density``, ``joints``
        (a :class:`JointProperties`), ``n_sides``, ``phase_deg``.
        """
        with resources.files("pycolfrag").joinpath("data/column_parthenon.json").open("r", encoding="utf-8") as fh:
            d = json.load(fh)
        for key in ("density", "n_sides", "phase_deg"):
            if key in overrides:
                d[key] = overrides.pop(key)
        joints = overrides.pop("joints", None)
        if overrides:
            raise ParameterError(f"Column.parthenon: unknown overrides {sorted(overrides)}")
        col = cls.from_dict(d)
        if joints is not None:
            col = col.with_joints(joints)
        return col

    @classmethod
    def from_dict(cls, d: dict) -> "Column":
        """Build from the file format of ``docs/column_format.md`` (``shaft``+``capital`` or ``blocks``)."""
        if not isinstance(d, dict):
            raise ParameterError(f"column description must be a mapping, got {type(d).__name__}")
        _check_keys(d, _COLUMN_KEYS, "column description")
        try:
            return cls._from_dict(d)
        except ParameterError:
            raise
        except (TypeError, ValueError, AttributeError) as exc:  # a wrong type deep inside: name it, never a raw error
            raise ParameterError(f"bad column description: {exc}") from None

    @classmethod
    def _from_dict(cls, d: dict) -> "Column":
        density = d.get("density", 2700.0)
        joints = JointProperties.from_dict(d.get("joints", {}))
        name = d.get("name", "custom")
        col = cls._from_dict_blocks(d, density, joints, name)
        conn = d.get("connectors", [])
        if not isinstance(conn, list):
            raise ParameterError(f"connectors must be a list of tables ([[connectors]]), got {type(conn).__name__}")
        if conn:
            col = col.with_connectors(*(Connectors.from_dict(c, f"connectors[{i}]") for i, c in enumerate(conn)))
        over = d.get("joint_overrides")
        if over is None:
            return foundation.tilted(col, d)
        if not isinstance(over, dict):
            raise ParameterError(f"joint_overrides must be a mapping (JSON object / TOML table) of joint index -> "
                                 f"joint properties, got {type(over).__name__}")
        parsed = {}
        for k, v in over.items():
            try:
                j = int(k)
            except (TypeError, ValueError):
                raise ParameterError(f"joint_overrides: joint index must be an integer, got {k!r}") from None
            if str(j) != str(k).strip():
                raise ParameterError(f"joint_overrides: joint index must be an integer, got {k!r}")
            if not isinstance(v, dict):
                raise ParameterError(f"joint_overrides.{k} must be a mapping of joint properties, got {v!r}")
            # keys not given keep the column's own [joints] values (not the library defaults)
            parsed[j] = JointProperties.from_dict({**joints.to_dict(), **v})
        return Column(col.blocks, density=col.density, joints=col.joints, name=col.name, joint_overrides=parsed,
                      connectors=col.connectors, **foundation.file_kw(d))

    @classmethod
    def _from_dict_blocks(cls, d: dict, density, joints, name) -> "Column":
        if "blocks" in d:
            if "shaft" in d or "capital" in d:
                raise ParameterError("column description has both 'blocks' and 'shaft'/'capital': use one form")
            if not isinstance(d["blocks"], list):
                raise ParameterError(f"blocks must be a list, got {type(d['blocks']).__name__}: {d['blocks']!r}")
            blocks = []
            for i, bd in enumerate(d["blocks"]):
                _check_keys(bd, _BLOCK_KEYS, f"blocks[{i}]")
                segs = bd.get("segments")
                if not segs:
                    raise ParameterError(f"blocks[{i}]: needs a non-empty 'segments' list")
                blocks.append(Block(tuple(Segment.from_dict(s, f"blocks[{i}].segments[{j}]") for j, s in enumerate(segs)),
                                    name=bd.get("name", f"block {i + 1}"), **as_built.file_kw(bd)))
            return cls(blocks, density=density, joints=joints, name=name)
        if "shaft" not in d:
            raise ParameterError("column description needs 'shaft' (with optional 'capital') or 'blocks'")
        sh = _check_keys(d["shaft"], _SHAFT_KEYS, "shaft")
        n_sides = _n_sides(d.get("n_sides", sh.get("n_sides", 10)), "column")
        phase = real(d.get("phase_deg", sh.get("phase_deg", 0.0)), "phase_deg")
        try:
            heights = sh["drum_heights"]
            d0 = sh["diameter_bottom"]
        except KeyError as exc:
            raise ParameterError(f"shaft: missing key {exc}") from None
        capital = None
        if "capital" in d:  # present but empty is an error, never a column without its capital
            c = _check_keys(d["capital"], _CAPITAL_KEYS, "capital")
            if not c:
                raise ParameterError("capital is empty: give its keys (docs/column_format.md) or remove the "
                                     "[capital] table for a column without a capital")
            try:
                capital = cls.doric_capital(c["echinus_height"],
                                            real(c["echinus_diameter_bottom"], "capital echinus_diameter_bottom (m)"),
                                            real(c["echinus_diameter_top"], "capital echinus_diameter_top (m)"),
                                            c["abacus_height"],
                                            positive_float(c["abacus_side"], "capital abacus_side (m)"),
                                            n_sides=_n_sides(c.get("n_sides", n_sides), "capital"), phase_deg=phase)
            except KeyError as exc:
                raise ParameterError(f"capital: missing key {exc}") from None
        return cls.from_drums(heights, d0, sh.get("diameter_top", d0), n_sides=n_sides, capital=capital,
                              density=density, joints=joints, phase_deg=phase, name=name)

    @classmethod
    def from_file(cls, path: str | os.PathLike) -> "Column":
        """Read a column from a ``.json`` or ``.toml`` file (format: ``docs/column_format.md``).

        The file is read by the one policy for files a user names (:mod:`pycolfrag.core.input_files`): a
        path (``str`` or ``os.PathLike``), a regular file (a folder, FIFO or device is refused before
        it is read), at most ``input_files.LIMITS["column file"]`` bytes (16 MiB), UTF-8 text. Every
        refusal is a ParameterError naming the path; a missing file is also a FileNotFoundError."""
        text = input_files.read_text(path, "column file")
        name = os.fspath(path)
        try:
            d = tomllib.loads(text) if name.lower().endswith(".toml") else input_files.json_loads(text)
        except ValueError as exc:  # JSONDecodeError and TOMLDecodeError are ValueErrors
            raise ParameterError(f"cannot parse column file {name}: {exc}") from None
        return cls.from_dict(d)

    def to_dict(self) -> dict:
        """Lossless description in the generic ``blocks`` form (what results files store)."""
        d = {"name": self.name, "density": self.density, "joints": self.joints.to_dict(),
             "blocks": [b.to_dict() for b in self.blocks]}
        if self.joint_overrides:   # only when used: the default layout (and results signatures) unchanged
            d["joint_overrides"] = {str(j): p.to_dict() for j, p in self.joint_overrides.items()}
        if self.connectors:        # the same
            d["connectors"] = [c.to_dict() for c in self.connectors]
        d.update(foundation.kw(self) if self.foundation_tilt_deg else {})   # the same
        return d

    def joint(self, j: int) -> JointProperties:
        """The properties of joint ``j`` (under block ``j``; 0 is the base joint)."""
        if isinstance(j, bool) or not isinstance(j, numbers.Integral) or not 0 <= j < self.n_blocks:
            raise ParameterError(f"joint index must be an integer in [0, {self.n_blocks - 1}], got {j!r}")
        return self.joint_overrides.get(int(j), self.joints)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    def with_joints(self, joints: JointProperties | None = None, **changes) -> "Column":
        """A copy with other default joint properties (``joints`` or field changes such as ``kn=1e10``);
        ``joint_overrides`` are kept."""
        j = joints if joints is not None else replace(self.joints, **changes)
        return Column(self.blocks, density=self.density, joints=j, name=self.name,
                      joint_overrides=self.joint_overrides, connectors=self.connectors, **foundation.kw(self))

    # ---- derived quantities ----------------------------------------------------------
    @property
    def n_blocks(self) -> int:
        """Number of rigid blocks (drums + capital)."""
        return len(self.blocks)

    @property
    def n_joints(self) -> int:
        """Number of joints, the base joint included (= n_blocks)."""
        return len(self.blocks)

    @property
    def height(self) -> float:
        """Total height, m."""
        return sum(b.height for b in self.blocks)

    @property
    def base_diameter(self) -> float:
        """The diameter of the bottom face of block 1, m, the one C normalises u_top by
        (``cf_geometry_section_diameter``: 2 r min(1, aspect), the circumscribed diameter of a regular face)."""
        seg = self.blocks[0].bottom
        return float(_lib.cf_geometry_section_diameter(seg.r_bottom, seg.aspect))

    @property
    def joint_diameters(self) -> list[float]:
        """Diameter at each joint (bottom face of the block above), m, the one C normalises u_d by
        (``cf_geometry_section_diameter``)."""
        return [float(_lib.cf_geometry_section_diameter(b.bottom.r_bottom, b.bottom.aspect)) for b in self.blocks]

    @property
    def joint_heights(self) -> list[float]:
        """Height of each joint above the ground at rest, m (the running sum of the heights below)."""
        return [0.0, *itertools.accumulate(b.height for b in self.blocks[:-1])]

    @property
    def block_masses(self) -> list[float]:
        """Mass of each block, kg."""
        return [self.density * b.volume for b in self.blocks]

    @property
    def mass(self) -> float:
        """Total mass, kg."""
        return sum(self.block_masses)

    @property
    def com_height(self) -> float:
        """Height of the centre of mass above the ground at rest, m."""
        acc = 0.0
        for z, b, m in zip(self.joint_heights, self.blocks, self.block_masses):
            acc += m * (z + b.centroid_height)
        return acc / self.mass

    def __repr__(self) -> str:
        return (f"Column({self.name!r}, n_blocks={self.n_blocks}, height={self.height:.3f} m, "
                f"base_diameter={self.base_diameter:.3f} m, mass={self.mass:.0f} kg)")
