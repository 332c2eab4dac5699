"""Fragility output formats: one writer per format, in one registry (:data:`WRITERS`).

A writer takes a fitted fragility model -- a :class:`~pycolfrag.analysis.openquake.FragilityModel`
(``imt``, ``limit_states``, ``functions``, ``format``, ``fits``) or a list of them, one per
taxonomy -- and a path, writes the file and returns the path. ``python -m
pycolfrag.analysis.openquake export RESULTS OUT --to NAME`` offers every registered format
(its ``--to`` choices and help are read from the registry), and :func:`write_fragility` writes any
of them from Python. A new format is one function here with the :func:`writer` decorator
(docs/architecture.md walks through one).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pycolfrag.core.errors import ParameterError

__all__ = ["Writer", "WRITERS", "writer", "write_fragility", "write_nrml", "NRML_NS"]

#: Namespace of NRML 0.5, OpenQuake's exchange format.
NRML_NS = "http://openquake.org/xmlns/nrml/0.5"


@dataclass(frozen=True)
class Writer:
    """One output format: its name (the ``--to`` choice), the file suffix it usually has, one line
    saying what it is, and the function that writes it."""

    name: str
    suffix: str
    description: str
    write: Callable


#: Every output format, by name.
WRITERS: dict = {}


def writer(name: str, suffix: str, description: str):
    """Register the decorated ``write(models, path) -> str`` as the output format ``name``."""
    def register(fn):
        if name in WRITERS:
            raise ValueError(f"output format {name!r} is registered twice")
        WRITERS[name] = Writer(name, suffix, description, fn)
        return fn
    return register


def write_fragility(models, path, fmt: str = "nrml") -> str:
    """Write a fitted fragility model (or a list of them) in the output format ``fmt``; return the path."""
    try:
        w = WRITERS[fmt]
    except KeyError:
        raise ParameterError(f"output format {fmt!r} is not one of {sorted(WRITERS)}") from None
    return w.write(models, path)


# --------------------------------------------------------------------------- NRML 0.5

def _num(v: float) -> str:
    return repr(float(v))


@writer("nrml", ".xml", "NRML 0.5 fragilityModel, read by OpenQuake")
def write_nrml(models, path) -> str:
    """Write one or more :class:`~pycolfrag.analysis.openquake.FragilityModel` (one ``fragilityFunction``
    each, sharing limit states, id and description of the first) as an NRML 0.5 ``fragilityModel``;
    return the path. Read back by :func:`pycolfrag.analysis.openquake.read_nrml`."""
    models = [models] if hasattr(models, "limit_states") else list(models)
    if not models:
        raise ParameterError("write_nrml: no fragility model given")
    m0 = models[0]
    if any(m.limit_states != m0.limit_states for m in models):
        raise ParameterError("write_nrml: every fragility function of a model must have the same limit states")
    ET.register_namespace("", NRML_NS)
    q = lambda tag: f"{{{NRML_NS}}}{tag}"  # noqa: E731
    root = ET.Element(q("nrml"))
    fm = ET.SubElement(root, q("fragilityModel"), id=m0.model_id, assetCategory=m0.asset_category,
                       lossCategory=m0.loss_category)
    ET.SubElement(fm, q("description")).text = m0.description or m0.model_id
    ET.SubElement(fm, q("limitStates")).text = " ".join(m0.limit_states)
    for m in models:
        ff = ET.SubElement(fm, q("fragilityFunction"), id=m.taxonomy, format=m.format, shape="logncdf")
        f0 = m.functions[0]
        if m.format == "continuous":
            attrs = {"imt": m.imt, "minIML": _num(f0.min_iml), "maxIML": _num(f0.max_iml)}
            if f0.no_damage_limit:
                attrs["noDamageLimit"] = _num(f0.no_damage_limit)
            ET.SubElement(ff, q("imls"), **attrs)
            for ls, f in zip(m.limit_states, m.functions):
                ET.SubElement(ff, q("params"), ls=ls, mean=_num(f.mean), stddev=_num(f.stddev))
        else:
            attrs = {"imt": m.imt}
            if f0.no_damage_limit:
                attrs["noDamageLimit"] = _num(f0.no_damage_limit)
            ET.SubElement(ff, q("imls"), **attrs).text = " ".join(_num(v) for v in f0.imls)
            for ls, f in zip(m.limit_states, m.functions):
                ET.SubElement(ff, q("poes"), ls=ls).text = " ".join(_num(v) for v in f.poes)
    ET.indent(root)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return str(path)
