"""A column's blocks placed as built (docs/sequences.md, "As-built geometry: offset and turned drums" and
"chipped joints"; the column file's block keys ``offset``, ``rotation_deg``, ``bottom_annulus``,
docs/column_format.md).

Each block's axis may stand off the column's by ``offset = (dx, dy)`` (m, in the column's axes) and
the block may be turned about its axis by ``rotation_deg`` (degrees, counter-clockwise seen from
above: its polygons' phases grow by it), at rest. The solver places the bodies there and a joint whose
two faces are offset or turned against each other carries their overlap (``cf_solver_setup_as_built``,
csrc/solver_as_built.c) in every contact model. A block's bottom face may be chipped to an annulus,
``bottom_annulus = (inner, outer)`` circumradii in m (outer 0: the face's own): the joint under it bears
only there, and may miss a sector, ``bottom_missing_sector = (start, end)`` (degrees from +x counter-clockwise
seen from above, in the column's axes): the face (or its annulus) bears nowhere in the wedge of the angles
[start, end) about its centre (:func:`bearing`). A block may miss a part, ``missing_part = (volume, x, y, z)`` (m^3; its centroid in the
block's frame, m): its mass, centre of mass and inertia move (:func:`mass_props`).

Refused when the column is made (ParameterError naming the value), for every joint j (under block j):

* a joint whose faces do not overlap; an annulus with no area or beyond its face (when the block is
  made), a chipped face reaching beyond the face below or on an offset or turned joint;
* the centre of the upper face (block j's axis) outside the lower face: more than half of the joint
  overhangs, the run's off-footprint criterion at rest;
* the centre of mass of the blocks above the joint (block j included) outside its support (the overlap
  of its two faces; on the ground, block j's own bottom face): the column would not stand.

Not for a monolithic run (one body), a column with connectors or in a scene, or on a tilted
foundation: refused when run or made, naming why.
"""
from __future__ import annotations

import math

import numpy as np

from pycolfrag.core.errors import ParameterError
from pycolfrag.core.ffi import ffi, lib, segment_arrays
from pycolfrag.core.validate import real

#: the column file's block keys this module reads
KEYS: tuple[str, ...] = ("offset", "rotation_deg", "bottom_annulus", "missing_part", "bottom_missing_sector")


def placement(offset, rotation_deg, where: str = "block") -> tuple[tuple[float, float], float]:
    """A block's offset (dx, dy) in m and rotation in degrees as floats, or ParameterError."""
    if isinstance(offset, (str, bytes)) or not hasattr(offset, "__len__") or len(offset) != 2:
        raise ParameterError(f"{where}: offset must be two numbers (dx, dy) in m, got {offset!r}")
    dx, dy = (real(v, f"{where}: offset (m)") for v in offset)
    rot = real(rotation_deg, f"{where}: rotation_deg")
    if not all(math.isfinite(v) for v in (dx, dy, rot)):
        raise ParameterError(f"{where}: offset and rotation_deg must be finite, got offset = {offset!r}, "
                             f"rotation_deg = {rotation_deg!r}")
    return (dx, dy), rot


def annulus(value, r_face: float, where: str = "block") -> tuple[float, float]:
    """A bottom face's annulus (inner, outer) circumradii in m as floats (outer 0: the face's own), or
    ParameterError: not two finite numbers >= 0, an outer beyond the face, or no area (inner >= outer)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ParameterError(f"{where}: bottom_annulus must be two numbers (inner, outer radius) in m, got {value!r}")
    inner, outer = (real(v, f"{where}: bottom_annulus (m)") for v in value)
    if not all(math.isfinite(v) and v >= 0.0 for v in (inner, outer)):
        raise ParameterError(f"{where}: bottom_annulus radii must be finite and >= 0, got {value!r}")
    if (inner, outer) != (0.0, 0.0):
        if outer > r_face:
            raise ParameterError(f"{where}: bottom_annulus outer radius {outer:g} m is beyond its face's "
                                 f"circumradius {r_face:g} m")
        if inner >= (outer or r_face):
            raise ParameterError(f"{where}: bottom_annulus {value!r} has no area: its inner radius {inner:g} m must be "
                                 f"below its outer radius {outer or r_face:g} m (a reduced face with no area)")
    return inner, outer


def sector(value, where: str = "block") -> tuple:
    """A bottom face's missing sector as (start, end) in degrees (floats), or () for none; ParameterError: not
    two finite numbers, or a range [start, end) that is empty or the whole face (end - start a multiple of 360)."""
    if value is None or (hasattr(value, "__len__") and len(value) == 0):
        return ()
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ParameterError(f"{where}: bottom_missing_sector must be two angles (start, end) in degrees, got {value!r}")
    a, b = (real(v, f"{where}: bottom_missing_sector (deg)") for v in value)
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ParameterError(f"{where}: bottom_missing_sector angles must be finite, got {value!r}")
    if (b - a) % 360.0 == 0.0:
        raise ParameterError(f"{where}: bottom_missing_sector [{a:g}, {b:g}) deg is "
                             f"{'empty' if a == b else 'the whole face'}: a reduced face with no area or no sector")
    return a, b


def missing(value, block, where: str = "block") -> tuple:
    """A block's missing part as (volume m^3, x, y, z m: its centroid in the block's frame, from its axis and
    its bottom face), or () for none; ParameterError: not four finite numbers, a volume not in (0, the
    block's), a centroid outside the block's height or beyond its widest radius."""
    if value is None or (hasattr(value, "__len__") and len(value) == 0):
        return ()
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 4:
        raise ParameterError(f"{where}: missing_part must be (volume m^3, x, y, z m of its centroid), got {value!r}")
    v, x, y, z = (real(u, f"{where}: missing_part") for u in value)
    whole = sum(s.volume for s in block.segments)
    r_max = max(max(s.r_bottom, s.r_top) for s in block.segments)
    if not all(math.isfinite(u) for u in (v, x, y, z)) or not 0.0 < v < whole:
        raise ParameterError(f"{where}: missing_part volume must be finite and in (0, {whole:.4g}) m^3 (the "
                             f"block's), its centroid finite; got {value!r}")
    if not (0.0 <= z <= block.height and math.hypot(x, y) <= r_max):
        raise ParameterError(f"{where}: missing_part centroid ({x:g}, {y:g}, {z:g}) m lies outside the block "
                             f"(height {block.height:g} m, widest radius {r_max:g} m)")
    return v, x, y, z


def mass_props(block, density: float) -> tuple:
    """A block missing a part: its mass (kg), centre of mass (x, y from its axis, z above its bottom face; m,
    in its own frame) and moments of inertia about it along x, y, z (kg m^2), the part taken away as a point
    mass at its centroid (its own inertia about its centroid neglected) and the products of inertia the
    off-axis centre brings neglected (the body keeps the column's axes; docs/sequences.md)."""
    segs, nseg = segment_arrays([block])
    bp = ffi.new("cf_geometry_massprops *")
    lib.cf_geometry_block_props(segs, len(block.segments), density, bp)
    v, x, y, z = block.missing_part
    mp = density * v
    m = bp.mass - mp
    c = (-mp * x / m, -mp * y / m, (bp.mass * bp.com_z - mp * z) / m)
    d = (c[0], c[1], c[2] - bp.com_z)             # the old centre from the new one is -d
    e = (x - c[0], y - c[1], z - c[2])            # the part from the new centre
    own = (bp.ixx, bp.ixx, bp.izz)
    inertia = tuple(own[k] + bp.mass * (sum(u * u for u in d) - d[k] ** 2) - mp * (sum(u * u for u in e) - e[k] ** 2)
                    for k in range(3))
    return m, c, inertia


def place(block) -> None:
    """Block's offset, rotation_deg, bottom_annulus and missing_part checked and stored as floats (its
    ``__post_init__``)."""
    object.__setattr__(block, "missing_part", missing(block.missing_part, block, f"block {block.name!r}"))
    offset, rot = placement(block.offset, block.rotation_deg, f"block {block.name!r}")
    object.__setattr__(block, "offset", offset)
    object.__setattr__(block, "rotation_deg", rot)
    object.__setattr__(block, "bottom_annulus", annulus(block.bottom_annulus, block.bottom.r_bottom,
                                                        f"block {block.name!r}"))
    object.__setattr__(block, "bottom_missing_sector", sector(block.bottom_missing_sector, f"block {block.name!r}"))


def block_kw(block) -> dict:
    """A block's placement as the column file's keys: only what differs from an aligned block."""
    out: dict = {}
    if block.offset != (0.0, 0.0):
        out["offset"] = list(block.offset)
    if block.rotation_deg != 0.0:
        out["rotation_deg"] = block.rotation_deg
    if block.bottom_annulus != (0.0, 0.0):
        out["bottom_annulus"] = list(block.bottom_annulus)
    if block.bottom_missing_sector:
        out["bottom_missing_sector"] = list(block.bottom_missing_sector)
    if block.missing_part:
        out["missing_part"] = {"volume": block.missing_part[0], "centroid": list(block.missing_part[1:])}
    return out


def file_kw(bd: dict) -> dict:
    """The placement keys of a column file's block mapping as Block's keyword arguments (``missing_part``
    a table {volume, centroid = [x, y, z]})."""
    out = {k: bd[k] for k in KEYS if k in bd}
    if "missing_part" in out:
        mp = out["missing_part"]
        if not isinstance(mp, dict) or set(mp) != {"volume", "centroid"} or not isinstance(mp["centroid"], list):
            raise ParameterError(f"missing_part must be a table with volume (m^3) and centroid = [x, y, z] (m), got {mp!r}")
        out["missing_part"] = (mp["volume"], *mp["centroid"])
    return out


def placed(col) -> bool:
    """Is any block of col offset, turned or chipped?"""
    return any(_placed(b) for b in col.blocks)


def _placed(b) -> bool:
    return (b.offset != (0.0, 0.0) or b.rotation_deg != 0.0 or b.bottom_annulus != (0.0, 0.0) or bool(b.missing_part)
            or bool(b.bottom_missing_sector))


def centre_of_mass(block, density: float) -> tuple[float, float, float]:
    """A block missing a part: its centre of mass from its axis (x, y turned by its rotation into the column's
    axes) and above its bottom face (z), m -- where the solver's body is (cf_solver_setup_as_built)."""
    _, (cx, cy, cz), _ = mass_props(block, density)
    a = math.radians(block.rotation_deg)
    return cx * math.cos(a) - cy * math.sin(a), cx * math.sin(a) + cy * math.cos(a), cz


def _own(block, density: float) -> list[float]:
    """A block missing a part: mass, centre of mass (:func:`centre_of_mass`), inertia, as
    cf_solver_setup_as_built reads them; zeros for a whole block."""
    if not block.missing_part:
        return [0.0] * 7
    m, _, inertia = mass_props(block, density)
    return [m, *centre_of_mass(block, density), *inertia]


def placement_array(col) -> np.ndarray:
    """(n_blocks x CF_SOLVER_AS_BUILT) per block dx, dy (m), rotation (rad), its bottom face's annulus (inner,
    outer radius, m), its own mass properties (:func:`_own`), its bottom face's missing sector (start, end, rad;
    0, 0: none): what cf_solver_setup_as_built reads."""
    return np.array([[b.offset[0], b.offset[1], math.radians(b.rotation_deg), *b.bottom_annulus, *_own(b, col.density),
                      *(math.radians(a) for a in (b.bottom_missing_sector or (0.0, 0.0)))]
                     for b in col.blocks], dtype=np.float64)


def face(col, i: int, top: bool, bearing: bool = False) -> list[tuple[float, float]]:
    """Block i's bottom (or top) polygon at rest, counter-clockwise, in the column's axes (m); bearing: a
    chipped bottom face at the outer radius of its annulus."""
    b = col.blocks[i]
    seg = b.top if top else b.bottom
    r = seg.r_top if top else (b.bottom_annulus[1] if bearing and b.bottom_annulus[1] else seg.r_bottom)
    ph = seg.phase_rad + math.radians(b.rotation_deg)
    return [(b.offset[0] + r * math.cos(ph + 2.0 * math.pi * k / seg.n_sides),
             b.offset[1] + r * math.sin(ph + 2.0 * math.pi * k / seg.n_sides)) for k in range(seg.n_sides)]


def _margin(poly, x: float, y: float) -> float:
    """The signed distance (m) of (x, y) inside the convex counter-clockwise polygon (< 0: outside)."""
    out = math.inf
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]):
        ex, ey = x1 - x0, y1 - y0
        if ex or ey:   # a vertex given twice makes an edge of no length
            out = min(out, (ex * (y - y0) - ey * (x - x0)) / math.hypot(ex, ey))
    return out


def overlap(a, b) -> list[tuple[float, float]]:
    """The intersection of two convex counter-clockwise polygons (Sutherland-Hodgman; [] when disjoint)."""
    out = list(a)
    for (x0, y0), (x1, y1) in zip(b, b[1:] + b[:1]):
        src, out = out, []
        side = [(x1 - x0) * (y - y0) - (y1 - y0) * (x - x0) for x, y in src]
        for k, p in enumerate(src):
            q, fp, fq = src[(k + 1) % len(src)], side[k], side[(k + 1) % len(src)]
            if fp >= 0.0:
                out.append(p)
            if (fp >= 0.0) != (fq >= 0.0):
                t = fp / (fp - fq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        if not out:
            return []
    return out


def area(poly) -> float:
    """The area of a counter-clockwise polygon, m^2."""
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]))


def _ray_exit(poly, cx: float, cy: float, a: float) -> tuple[float, float]:
    """Where the ray from (cx, cy) at angle a (rad) leaves the convex counter-clockwise polygon about it."""
    d = (math.cos(a), math.sin(a))
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]):
        ca = d[0] * (y0 - cy) - d[1] * (x0 - cx)
        cb = d[0] * (y1 - cy) - d[1] * (x1 - cx)
        if ca <= 0.0 < cb:
            u = ca / (ca - cb)
            return x0 + u * (x1 - x0), y0 + u * (y1 - y0)
    raise AssertionError("the centre lies inside its polygon")


def _chain(poly, cx: float, cy: float, a0: float, w: float) -> list[tuple[float, float]]:
    """The boundary of the polygon about (cx, cy) from angle a0 counter-clockwise over w (rad, in (0, 2 pi)):
    where the ray at a0 leaves it, the vertices passed, where the ray at a0 + w leaves it."""
    tol = 1e-12 * max(math.hypot(x - cx, y - cy) for x, y in poly)
    rel = sorted(((math.atan2(y - cy, x - cx) - a0) % (2.0 * math.pi), (x, y)) for x, y in poly)
    out = [_ray_exit(poly, cx, cy, a0)]
    for r, p in rel + [(w, _ray_exit(poly, cx, cy, a0 + w))]:
        if 0.0 < r <= w and math.dist(p, out[-1]) > tol:
            out.append(p)
    return out


def bearing(col, i: int) -> list[tuple[float, float]]:
    """Block i's chipped bottom face missing a sector: the outline of what bears at rest, counter-clockwise in
    the column's axes (m): the outer boundary from the sector's end round to its start, then the hole's back
    (an annulus) or the face's centre. [] for a face missing no sector."""
    b = col.blocks[i]
    if not b.bottom_missing_sector:
        return []
    start, end = (math.radians(a) for a in b.bottom_missing_sector)
    w = 2.0 * math.pi - (end - start) % (2.0 * math.pi)
    (cx, cy), outer = b.offset, face(col, i, False, True)
    out = _chain(outer, cx, cy, end, w)
    h = b.bottom_annulus[0] / (b.bottom_annulus[1] or b.bottom.r_bottom)
    inner = [(cx + h * (x - cx), cy + h * (y - cy)) for x, y in reversed(out)] if h > 0.0 else [(cx, cy)]
    return out + inner


def _hull(points) -> list[tuple[float, float]]:
    """The convex hull of the points, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(set(points))

    def half(seq):
        out: list = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0.0:
                out.pop()
            out.append(p)
        return out
    lower, upper = half(pts), half(reversed(pts))
    return lower[:-1] + upper[:-1]


def support(col, j: int) -> list[tuple[float, float]]:
    """The support polygon of joint j at rest (column axes): the overlap of its two faces (a chipped
    face at its annulus's outer radius, or missing a sector the convex hull of what bears: :func:`bearing`); on
    the ground, block j's own bottom face."""
    if col.blocks[j].bottom_missing_sector:
        return _hull(bearing(col, j))
    lower = face(col, j - 1, True) if j > 0 else None
    return face(col, j, False, True) if lower is None else overlap(lower, face(col, j, False, True))


def _offsets(col, j0: int) -> str:
    """The placements of blocks j0.. that are not aligned, as the message names them."""
    return ", ".join(f"blocks[{i}] offset = ({b.offset[0]:g}, {b.offset[1]:g}) m, rotation_deg = {b.rotation_deg:g}"
                     + (f", bottom_annulus = ({b.bottom_annulus[0]:g}, {b.bottom_annulus[1]:g}) m"
                        if b.bottom_annulus != (0.0, 0.0) else "")
                     + (f", bottom_missing_sector = [{b.bottom_missing_sector[0]:g}, {b.bottom_missing_sector[1]:g}) deg"
                        if b.bottom_missing_sector else "")
                     for i, b in enumerate(col.blocks) if i >= j0 and _placed(b))


def check(col) -> None:
    """ParameterError naming the value when col's placement cannot stand (the module's list)."""
    if not placed(col):
        return
    for i, b in enumerate(col.blocks):
        if any(s.aspect != 1.0 for s in b.segments):
            raise ParameterError(f"blocks[{i}]: as-built values ({_offsets(col, 0)}) are for "
                                 f"regular sections; a segment here has aspect "
                                 f"{next(s.aspect for s in b.segments if s.aspect != 1.0):g}")
    if col.foundation_tilt_deg:
        raise ParameterError(f"as-built offsets or rotations ({_offsets(col, 0)}) on a tilted foundation "
                             f"(foundation_tilt_deg = {col.foundation_tilt_deg:g}) are not supported: its static "
                             "threshold (pycolfrag/structure/foundation.py) is that of an aligned stack")
    masses = col.block_masses
    for j in range(col.n_blocks):
        sup = support(col, j)
        if j > 0 and (len(sup) < 3 or area(sup) <= 1e-12 * area(face(col, j, False))):
            raise ParameterError(f"joint {j}: the faces of blocks[{j - 1}] and blocks[{j}] do not overlap "
                                 f"({_offsets(col, j - 1)})")
        _chipped(col, j)
        if j > 0 and _margin(face(col, j - 1, True), *col.blocks[j].offset) < 0.0:
            raise ParameterError(f"joint {j}: the axis of blocks[{j}] lies outside the top face of blocks[{j - 1}] "
                                 f"(more than half of the joint overhangs; {_offsets(col, j - 1)})")
        m = sum(masses[j:])
        cxy = [_own(b, col.density)[1:3] for b in col.blocks]   # a missing part's centre of mass off the axis
        gx = sum(mk * (col.blocks[k].offset[0] + cxy[k][0]) for k, mk in enumerate(masses) if k >= j) / m
        gy = sum(mk * (col.blocks[k].offset[1] + cxy[k][1]) for k, mk in enumerate(masses) if k >= j) / m
        inside = _margin(sup, gx, gy)
        if not inside > 0.0:
            raise ParameterError(f"joint {j}: the centre of mass of blocks[{j}:] lies at ({gx:.4g}, {gy:.4g}) m, "
                                 f"{-inside:.4g} m outside the joint's support (the overlap of its faces): the "
                                 f"column would not stand ({_offsets(col, max(j - 1, 0))})")


def _chipped(col, j: int) -> None:
    """A chipped joint j: its faces aligned, its annulus on the face below (ParameterError otherwise)."""
    b = col.blocks[j]
    if b.bottom_missing_sector and not area(bearing(col, j)) > 1e-9 * area(face(col, j, False)):
        raise ParameterError(f"joint {j}: what is left of the chipped face of blocks[{j}] (bottom_missing_sector = "
                             f"{list(b.bottom_missing_sector)} deg, bottom_annulus = {list(b.bottom_annulus)} m) has no "
                             "area: a reduced face with no area")
    if (b.bottom_annulus == (0.0, 0.0) and not b.bottom_missing_sector) or j == 0:
        return
    a = col.blocks[j - 1]
    if a.offset != b.offset or a.rotation_deg != b.rotation_deg:
        raise ParameterError(f"joint {j}: a chipped face (blocks[{j}] bottom_annulus or bottom_missing_sector) is for a joint whose faces are "
                             f"aligned, not offset or turned against each other ({_offsets(col, j - 1)})")
    lower = face(col, j - 1, True)
    if any(_margin(lower, x, y) < -1e-9 * b.bottom.r_bottom for x, y in face(col, j, False, True)):
        raise ParameterError(f"joint {j}: the chipped face of blocks[{j}] (outer radius "
                             f"{b.bottom_annulus[1] or b.bottom.r_bottom:g} m) reaches beyond the top face of "
                             f"blocks[{j - 1}]: give a smaller outer radius")


def refuse(col, caller: str, why: str) -> None:
    """ParameterError when col is placed as built and a run cannot honour it (why)."""
    if placed(col):
        raise ParameterError(f"{caller}: as-built offsets or rotations of blocks ({_offsets(col, 0)}) {why}")
