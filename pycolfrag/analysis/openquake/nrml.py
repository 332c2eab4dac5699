"""NRML 0.5 ``fragilityModel`` files read back (written by :mod:`pycolfrag.analysis.outputs`)."""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from pycolfrag.analysis.completeness import MARK
from pycolfrag.analysis.openquake.export import DEGENERATE_MARK
from pycolfrag.analysis.openquake.functions import MIN_IML, ContinuousFragility, DiscreteFragility, FragilityModel
from pycolfrag.core.errors import HazardFileError
from pycolfrag.core.input_files import read_text


def _floats(text, what, path):
    try:
        vals = [float(v) for v in (text or "").split()]
    except ValueError:
        raise HazardFileError(f"{path}: {what} must be numbers, got {text!r}") from None
    return vals


def _continuous(ff, im_el, q, path, ndl) -> dict:
    """The ``params`` of a continuous function by limit state. A minIML of 0 becomes :data:`MIN_IML`, as
    OpenQuake's reader does (``ffconvert`` in ``openquake/risklib/read_nrml.py``: "Found minIML=0 ...,
    using 1e-10 instead"): no lower clip for any positive level."""
    lo, hi = (_floats(im_el.get(k), k, path)[0] if im_el.get(k) else math.nan for k in ("minIML", "maxIML"))
    lo = MIN_IML if lo == 0 else lo
    return {p.get("ls"): ContinuousFragility(float(p.get("mean")), float(p.get("stddev")), lo, hi, ndl)
            for p in ff.findall(q("params"))}


def _discrete(ff, im_el, q, path, ndl) -> dict:
    x = _floats(im_el.text, "imls", path)
    return {p.get("ls"): DiscreteFragility(tuple(x), tuple(_floats(p.text, "poes", path)), ndl)
            for p in ff.findall(q("poes"))}


def _function(ff, fm, q, path, limit_states, description) -> FragilityModel:
    """One ``fragilityFunction`` element as a :class:`FragilityModel`."""
    tax, fmt = ff.get("id", ""), ff.get("format")
    im_el = ff.find(q("imls"))
    if im_el is None or not im_el.get("imt"):
        raise HazardFileError(f"{path}: fragilityFunction {tax!r} has no imls element with an imt")
    if fmt not in ("continuous", "discrete"):
        raise HazardFileError(f"{path}: fragilityFunction {tax!r} has format {fmt!r} (continuous or discrete)")
    ndl = im_el.get("noDamageLimit")
    ndl = None if ndl is None else _floats(ndl, "noDamageLimit", path)[0]
    try:
        funcs = (_continuous if fmt == "continuous" else _discrete)(ff, im_el, q, path, ndl)
        missing = [ls for ls in limit_states if ls not in funcs]
        if missing:
            raise HazardFileError(f"{path}: fragilityFunction {tax!r} lacks limit state(s) {missing}")
        return FragilityModel(im_el.get("imt"), limit_states, [funcs[ls] for ls in limit_states], taxonomy=tax,
                              model_id=fm.get("id", "pycolfrag"), description=description, notes=_marks(description),
                              asset_category=fm.get("assetCategory", "buildings"),
                              loss_category=fm.get("lossCategory", "structural"))
    except HazardFileError:
        raise
    except (ValueError, TypeError) as exc:   # ParameterError is a ValueError
        raise HazardFileError(f"{path}: fragilityFunction {tax!r}: {exc}") from None


def _marks(description: str) -> tuple:
    """The sentences of a pycolfrag export's description that its printouts repeat: degenerate fits and an
    incomplete results file (a decimal point is not a sentence's end: it is followed by a digit)."""
    sentences = re.split(r"\.(?:\s+|$)", description)
    return tuple(x.strip() for x in sentences if x.strip().startswith((DEGENERATE_MARK + " ", MARK + ":")))


def read_nrml(path) -> dict:
    """The fragility functions of an NRML 0.5 ``fragilityModel`` file: ``{taxonomy: FragilityModel}``
    (``logncdf`` continuous and discrete functions; a pycolfrag export's marks of degenerate fits and of an
    incomplete results file, in its description, become the model's ``notes``). The file is read by the project's policy for files
    a user names (:mod:`pycolfrag.core.input_files`: a regular file of at most ``LIMITS["fragility model
    file"]`` bytes, UTF-8); bad or missing values, and a taxonomy given twice, raise
    :class:`~pycolfrag.core.errors.HazardFileError` naming them."""
    text = read_text(path, "fragility model file", error=HazardFileError)
    path = Path(path)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
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
    description = (desc_el.text or "").strip() if desc_el is not None else ""
    out = {}
    for ff in fm.findall(q("fragilityFunction")):
        model = _function(ff, fm, q, path, limit_states, description)
        if model.taxonomy in out:
            raise HazardFileError(f"{path}: fragilityFunction {model.taxonomy!r} is given twice")
        out[model.taxonomy] = model
    if not out:
        raise HazardFileError(f"{path}: the fragilityModel has no fragilityFunction")
    return out
