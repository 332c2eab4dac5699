"""NRML 0.5 ``fragilityModel`` files read back (written by :mod:`pycolfrag.analysis.outputs`)."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from ...errors import HazardFileError
from .functions import ContinuousFragility, DiscreteFragility, FragilityModel


def _floats(text, what, path):
    try:
        vals = [float(v) for v in (text or "").split()]
    except ValueError:
        raise HazardFileError(f"{path}: {what} must be numbers, got {text!r}") from None
    return vals


def read_nrml(path) -> dict:
    """The fragility functions of an NRML 0.5 ``fragilityModel`` file: ``{taxonomy: FragilityModel}``
    (``logncdf`` continuous and discrete functions; bad or missing values raise
    :class:`~pycolfrag.errors.HazardFileError` naming them)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise HazardFileError(f"{path}: cannot read the NRML file: {exc}") from None
    ns = root.tag[1:root.tag.index("}")] if root.tag.startswith("{") else ""
    q = (lambda tag: f"{{{ns}}}{tag}") if ns else (lambda tag: tag)  # noqa: E731
    fm = root.find(q("fragilityModel"))
    if fm is None:
        raise HazardFileError(f"{path}: no fragilityModel element (NRML 0.5)")
    ls_el = fm.find(q("limitStates"))
    if ls_el is None or not (ls_el.text or "").split():
        raise HazardFileError(f"{path}: the fragilityModel has no limitStates")
    limit_states = tuple(ls_el.text.split())
    desc_el = fm.find(q("description"))
    out = {}
    for ff in fm.findall(q("fragilityFunction")):
        tax, fmt = ff.get("id", ""), ff.get("format")
        im_el = ff.find(q("imls"))
        if im_el is None or not im_el.get("imt"):
            raise HazardFileError(f"{path}: fragilityFunction {tax!r} has no imls element with an imt")
        ndl = im_el.get("noDamageLimit")
        ndl = None if ndl is None else _floats(ndl, "noDamageLimit", path)[0]
        funcs = {}
        try:
            if fmt == "continuous":
                lo, hi = (_floats(im_el.get(k), k, path)[0] if im_el.get(k) else math.nan
                          for k in ("minIML", "maxIML"))
                for p in ff.findall(q("params")):
                    funcs[p.get("ls")] = ContinuousFragility(float(p.get("mean")), float(p.get("stddev")), lo, hi,
                                                             ndl)
            elif fmt == "discrete":
                x = _floats(im_el.text, "imls", path)
                for p in ff.findall(q("poes")):
                    funcs[p.get("ls")] = DiscreteFragility(tuple(x), tuple(_floats(p.text, "poes", path)), ndl)
            else:
                raise HazardFileError(f"{path}: fragilityFunction {tax!r} has format {fmt!r} (continuous or discrete)")
        except (ValueError, TypeError) as exc:   # ParameterError is a ValueError
            raise HazardFileError(f"{path}: fragilityFunction {tax!r}: {exc}") from None
        missing = [ls for ls in limit_states if ls not in funcs]
        if missing:
            raise HazardFileError(f"{path}: fragilityFunction {tax!r} lacks limit state(s) {missing}")
        out[tax] = FragilityModel(im_el.get("imt"), limit_states, [funcs[ls] for ls in limit_states], taxonomy=tax,
                                  model_id=fm.get("id", "pycolfrag"),
                                  description=(desc_el.text or "").strip() if desc_el is not None else "",
                                  asset_category=fm.get("assetCategory", "buildings"),
                                  loss_category=fm.get("lossCategory", "structural"))
    if not out:
        raise HazardFileError(f"{path}: the fragilityModel has no fragilityFunction")
    return out

