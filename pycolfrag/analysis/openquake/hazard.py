"""OpenQuake hazard-curve CSV files in: the IMT names, the file's metadata and curves, annual rates and
OpenQuake's rates of occurrence."""
from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pycolfrag.core.errors import HazardFileError, ParameterError
from pycolfrag.core.input_files import read_text

#: pycolfrag IM name -> OpenQuake IMT (spectral ones take a period: ``SA(1.0)``); units agree.
_IMT = {"pga_g": "PGA", "pgv_cm_s": "PGV", "sa_g": "SA"}


def imt_of(im: str, period_s: float | None = None) -> str:
    """OpenQuake IMT string of a pycolfrag IM: ``pga_g`` -> ``PGA``, ``pgv_cm_s`` -> ``PGV``,
    ``sa_g`` at ``period_s`` -> ``SA(1.0)``."""
    if im not in _IMT:
        raise ParameterError(f"IM {im!r} has no OpenQuake intensity measure type (known: {', '.join(_IMT)})")
    if im == "sa_g":
        if period_s is None or not (math.isfinite(float(period_s)) and float(period_s) > 0):
            raise ParameterError(f"sa_g needs a period > 0 s for its OpenQuake IMT, got {period_s!r}")
        return f"SA({float(period_s)!r})"
    return _IMT[im]


def im_of_imt(imt: str) -> tuple[str, float | None]:
    """(pycolfrag IM name, period in s or None) of an OpenQuake IMT string (``PGA``, ``PGV``, ``SA(0.3)``)."""
    m = re.fullmatch(r"\s*SA\(\s*([0-9.eE+-]+)\s*\)\s*", imt)
    if m:
        return "sa_g", float(m.group(1))
    for k, v in _IMT.items():
        if imt.strip() == v and k != "sa_g":
            return k, None
    raise ParameterError(f"OpenQuake IMT {imt!r} has no pycolfrag IM (known: PGA, PGV, SA(T))")


# --------------------------------------------------------------------------- hazard curves

@dataclass
class HazardCurves:
    """Hazard curves of one IMT at N sites (an OpenQuake hazard-curve CSV).

    Attributes
    ----------
    imt : str
        OpenQuake intensity measure type (``PGA``, ``PGV``, ``SA(1.0)``).
    imls : ndarray (L,)
        Intensity measure levels, increasing (g for PGA/SA, cm/s for PGV).
    poes : ndarray (N, L)
        Probabilities of exceedance of each level in ``investigation_time``.
    investigation_time : float
        Years.
    lon, lat, depth : ndarray (N,)
        Site coordinates (``depth`` NaN when the file has no depth column).
    path : str
    site_ids : list of str
        OpenQuake's ``custom_site_id`` of each site (empty strings when the file has none).
    """

    imt: str
    imls: np.ndarray
    poes: np.ndarray
    investigation_time: float
    lon: np.ndarray
    lat: np.ndarray
    depth: np.ndarray
    path: str = ""
    site_ids: list = field(default_factory=list)

    def annual_rates(self) -> np.ndarray:
        """Annual rates of exceedance of every level at every site, 1/yr (:func:`annual_rates`)."""
        return annual_rates(self.poes, self.investigation_time)


#: Columns of a hazard-curve CSV besides ``poe-<IML>`` (OpenQuake writes ``custom_site_id`` first when
#: the site model has one).
_SITE_COLUMNS = ("custom_site_id", "lon", "lat", "depth")


def _metadata(comment: str) -> dict:
    """``key=value`` pairs of an OpenQuake CSV comment line, both spellings: the current one
    (``#,,,,"generated_by='...', investigation_time=50.0, imt='PGA'"``) and the older one
    (``# ..., investigation_time=50.0, imt="PGA"``). Values are kept as text."""
    text = comment.lstrip("#, ").rstrip(", \r\n")
    out = {}
    for m in re.finditer(r"(\w+)\s*=\s*('[^']*'|\"[^\"]*\"|\[[^\]]*\]|[^,]*)", text):
        v = m.group(2).strip()
        if len(v) >= 2 and v[0] == v[-1] and v[0] in "'\"":
            v = v[1:-1]
        out[m.group(1)] = v
    return out


def _same(a: str, b: str) -> bool:
    """Two metadata values that say the same: equal text, or equal numbers (``50`` and ``50.0``)."""
    if a == b:
        return True
    try:
        return float(a) == float(b)
    except ValueError:
        return False


def _comments(path, lines: list) -> dict:
    """The metadata of the comment lines at the top of ``lines`` (removed from it). A key given twice
    with different values (two comment lines that disagree, e.g. on ``investigation_time``) is
    refused: which one the curves belong to cannot be told."""
    meta = {}
    while lines and lines[0].lstrip().startswith("#"):
        for k, v in _metadata(lines.pop(0)).items():
            if k in meta and not _same(meta[k], v):
                raise HazardFileError(f"{path}: the comment lines disagree on {k}: {meta[k]!r} and {v!r}")
            meta.setdefault(k, v)
    return meta


def _lines(path, text: str) -> list:
    """The non-blank lines of a hazard-curve file's text; a NUL byte (a binary file) is refused."""
    if "\0" in text:
        line = text[:text.index("\0")].count("\n") + 1
        raise HazardFileError(f"{path}: line {line} holds a NUL byte: not a text CSV file (a binary file?)")
    return [ln for ln in text.splitlines() if ln.strip()]


def _fast_rows(header: list, lines: list):
    """(numbers of the site rows, ``custom_site_id`` of each or None) read by numpy's parser, or (None, None)
    when a row is not plain numbers (the caller then reads row by row to name the problem): a value that is
    not a finite number, a quote, a row of another length. ``custom_site_id`` is NaN in the numbers, as in
    :func:`_site_rows`. (The row-by-row reader's lists of fields took 13 times the file's size.)"""
    num = [j for j, h in enumerate(header) if h != "custom_site_id"]
    if not lines or any('"' in r or r.count(",") != len(header) - 1 for r in lines):
        return None, None
    try:
        vals = np.loadtxt(lines, delimiter=",", dtype=float, ndmin=2, comments=None,
                          usecols=num if len(num) < len(header) else None)
    except ValueError:
        return None, None
    if vals.shape != (len(lines), len(num)) or not np.all(np.isfinite(vals)):
        return None, None
    if len(num) == len(header):
        return vals, None
    j = header.index("custom_site_id")
    data = np.empty((len(lines), len(header)))
    data[:, num] = vals
    data[:, j] = np.nan
    return data, [r.split(",", j + 1)[j].strip() for r in lines]


def _header(path, row: list) -> tuple[list, list, np.ndarray]:
    """The header's column names, the indices of its ``poe-<IML>`` columns and their levels (at least
    two, increasing); refused with :class:`HazardFileError` naming the problem."""
    header = [h.strip() for h in row]
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise HazardFileError(f"{path}: the header names column(s) {dup} more than once (header: {','.join(header)})")
    for name in ("lon", "lat"):
        if name not in header:
            raise HazardFileError(f"{path}: the header has no {name!r} column (header: {','.join(header)})")
    poe_cols = [j for j, h in enumerate(header) if h.startswith("poe-")]
    if not poe_cols:
        raise HazardFileError(f"{path}: the header has no poe-<IML> column (header: {','.join(header)})")
    unknown = [h for j, h in enumerate(header) if j not in poe_cols and h not in _SITE_COLUMNS]
    if unknown:
        raise HazardFileError(f"{path}: unknown column(s) {unknown} (expected {', '.join(_SITE_COLUMNS)}, "
                              "poe-<IML>)")
    imls = np.array([_level(path, header[j]) for j in poe_cols])
    if np.any(np.diff(imls) <= 0):
        raise HazardFileError(f"{path}: the poe-<IML> columns must have increasing levels, got {imls.tolist()}")
    if imls.size < 2:
        # OpenQuake's rate of occurrence of a level is the difference of the exceedance rates around it
        # (occurrence_rates): with one level that difference is 0 and every damage rate would be 0
        raise HazardFileError(f"{path}: the hazard curve has one level ({header[poe_cols[0]]!r}); at least two "
                              "are needed (the rate of occurrence of a level is the difference of the rates around it)")
    return header, poe_cols, imls


def _level(path, name: str) -> float:
    try:
        x = float(name[4:])
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        raise HazardFileError(f"{path}: column {name!r} does not name a positive intensity level")
    return x


def _site_rows(path, header: list, rows: list) -> np.ndarray:
    """The numbers of the site rows (``custom_site_id`` as NaN), each checked to be finite."""
    data = []
    for i, r in enumerate(rows, start=1):
        if len(r) != len(header):
            raise HazardFileError(f"{path}: data row {i} has {len(r)} values, the header {len(header)} columns")
        vals = []
        for h, v in zip(header, r):
            if h == "custom_site_id":
                vals.append(math.nan)
                continue
            try:
                x = float(v)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                raise HazardFileError(f"{path}: data row {i}, column {h!r}: {v!r} is not a finite number")
            vals.append(x)
        data.append(vals)
    if not data:
        raise HazardFileError(f"{path}: no site rows below the header")
    return np.array(data)


def _check_poes(path, header: list, poe_cols: list, poes: np.ndarray) -> None:
    bad = np.argwhere((poes < 0) | (poes >= 1))
    if bad.size:
        i, j = bad[0]
        raise HazardFileError(f"{path}: data row {i + 1}, column {header[poe_cols[j]]!r}: probability "
                              f"{poes[i, j]!r} outside [0, 1) (1 would be an infinite annual rate)")
    inc = np.argwhere(np.diff(poes, axis=1) > 0)
    if inc.size:
        i, j = inc[0]
        raise HazardFileError(f"{path}: data row {i + 1}: the probability of exceedance increases from "
                              f"{header[poe_cols[j]]!r} ({poes[i, j]!r}) to {header[poe_cols[j + 1]]!r} "
                              f"({poes[i, j + 1]!r}); a hazard curve decreases with the level")


def _investigation_time(path, meta: dict, given) -> float:
    t_file = meta.get("investigation_time")
    if t_file is not None:
        try:
            t_file = float(t_file)
        except ValueError:
            raise HazardFileError(f"{path}: investigation_time={meta['investigation_time']!r} "
                                  "is not a number") from None
    t = _agree(path, "investigation_time", t_file, None if given is None else float(given))
    if not (math.isfinite(t) and t > 0):
        raise HazardFileError(f"{path}: investigation_time must be > 0 years, got {t!r}")
    return t


def read_hazard_curves(path, *, investigation_time: float | None = None, imt: str | None = None) -> HazardCurves:
    """Read an OpenQuake hazard-curve CSV file.

    The investigation time and the IMT come from the file's comment lines; ``investigation_time`` and
    ``imt`` supply them for a file without them (and must agree with it when both are given).
    The file is read by the project's policy for files a user names (:mod:`pycolfrag.core.input_files`:
    a regular file of at most ``LIMITS["hazard-curve file"]`` bytes, UTF-8 text).
    Refused with :class:`~pycolfrag.core.errors.HazardFileError` naming the file and the problem: not a
    regular file, too big, not UTF-8 or binary (a NUL byte); comment lines that disagree on a key; a
    column named twice; no ``lon``/``lat`` or no ``poe-<IML>`` column; fewer than two levels; an IML
    that is not a positive number or not increasing; a value that is not a number; a probability outside
    [0, 1) (1 would be an infinite annual rate); a curve that increases with the level; a missing
    investigation time or IMT.
    """
    text = read_text(path, "hazard-curve file", error=HazardFileError)
    path = Path(path)
    lines = _lines(path, text)
    del text
    meta = _comments(path, lines)
    if not lines:
        raise HazardFileError(f"{path}: no header line (lon,lat,poe-<IML>,...) in the hazard-curve file")
    header, poe_cols, imls = _header(path, next(csv.reader(lines[:1])))
    del lines[0]
    data, ids = _fast_rows(header, lines)
    if data is None:     # a row the fast reader cannot take: the row-by-row reader names the problem
        rows = list(csv.reader(lines))
        data = _site_rows(path, header, rows)
        ids = [r[header.index("custom_site_id")].strip() for r in rows] if "custom_site_id" in header else None
    del lines
    poes = data[:, poe_cols]
    _check_poes(path, header, poe_cols, poes)
    t = _investigation_time(path, meta, investigation_time)
    imt_ = _agree(path, "imt", meta.get("imt"), imt)
    im_of_imt(imt_)   # a known IMT, or ParameterError naming it
    col = {h: j for j, h in enumerate(header)}
    depth = data[:, col["depth"]] if "depth" in col else np.full(len(data), np.nan)
    return HazardCurves(imt_, imls, np.ascontiguousarray(poes), t, data[:, col["lon"]], data[:, col["lat"]], depth,
                        str(path), [""] * len(data) if ids is None else ids)


def _agree(path, name, in_file, given):
    if in_file is None and given is None:
        raise HazardFileError(f"{path}: no {name} in the file's comment line; give it ({name}=...)")
    if in_file is not None and given is not None and in_file != given:
        raise HazardFileError(f"{path}: the file says {name}={in_file!r}, the call {given!r}")
    return in_file if in_file is not None else given


def annual_rates(poes, investigation_time) -> np.ndarray:
    """Annual rates of exceedance from probabilities in ``investigation_time`` years (Poisson):
    ``-ln(1 - poe) / T``."""
    poes = np.asarray(poes, dtype=float)
    return -np.log1p(-poes) / float(investigation_time)


def occurrence_rates(rates) -> np.ndarray:
    """OpenQuake's rate of occurrence attributed to each level from the exceedance rates along the
    last axis: the rate between the midpoints around the level, ``(rate[i-1] - rate[i+1]) / 2``, with
    ``(rate[0] - rate[1]) / 2`` and ``(rate[-2] - rate[-1]) / 2`` at the ends (their sum is
    ``rate[0] - rate[-1]``: the rate above the highest level is not counted)."""
    r = np.asarray(rates, dtype=float)
    mid = np.concatenate([r[..., :1], 0.5 * (r[..., :-1] + r[..., 1:]), r[..., -1:]], axis=-1)
    return mid[..., :-1] - mid[..., 1:]

