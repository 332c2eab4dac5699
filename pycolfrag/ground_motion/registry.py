"""The ground-motion models that declare their parameters, one line each, and what is built from them.

Every module listed in :data:`MODELS` declares, as data at its top, ``NAME``, ``KIND`` and
``PARAMETERS`` (:class:`pycolfrag.core.names.Parameter` rows: name, unit, accepted range, description,
``Record.meta`` key, sample-row field). From them, and from nowhere else:

* :data:`PULSE_SHAPES` -- the velocity-pulse shapes (kind ``"pulse"``, the interface of
  :mod:`~pycolfrag.ground_motion.pulse_shape`) by their short name: the choices of
  ``synthesize(shape=...)``, ``sample_pulse_parameters(shape=...)`` and, with "none" (the stochastic
  record alone), of the grid's ``--pulse``;
* :data:`PULSE_FIELDS` -- the pulse fields of a synthetic sample row and of ``/samples``
  (:mod:`pycolfrag.solver.sample` fills them from a record's ``meta``, :mod:`pycolfrag.results` lays them out):
  the parameters with a row field of the pulse shapes, each field once (a shape that has no value for a
  field leaves it NaN in its rows);
* :data:`TP_MODELS` -- the pulse-period relations (kind ``"pulse_period"``), the choices of
  ``run_grid.py --tp-model`` and of ``sample_pulse_parameters(tp_model=...)``;
* :data:`VP_MODELS` -- the pulse-amplitude relations (Eq. (6) and those of kind ``"pulse_amplitude"``), the
  choices of a run's ``vp_model`` (``--vp-model``, ``sample_pulse_parameters(vp_model=...)``, a logic tree's
  ``vp_model`` set), a setting of its own beside ``tp_model``: empty is Eq. (6) (:func:`vp_model_key`);
* the parameter tables of docs/ground_motion.md (:func:`docs_section`; a test keeps them equal;
  ``python -c "from pycolfrag.ground_motion import registry; print(registry.docs_section())"`` prints them).

A new model is its module plus its line in :data:`MODELS`. Importing this module loads no C: the
model modules load the C library on first use of a function that needs it, so the results layout
and the statistics that read it do not need a built library. (The Atkinson & Silva (2000) module is
not listed: its accepted scenario range is the C generator's, read from ``csrc/stochastic.h`` when it
loads, and it adds no row field; it declares its ``PARAMETERS`` all the same.)
"""
from __future__ import annotations

from pycolfrag.core.errors import ParameterError
from pycolfrag.ground_motion import (
    baker_2007,
    bray_rodriguez_marek_2004,
    mavroeidis_papageorgiou_2003,
    pulse_shape,
    record,
    rupakhety_2011,
    shahi_baker_2014,
    shahi_baker_earlier,
)

__all__ = ["MODELS", "KINDS", "PULSE_SHAPES", "DEFAULT_PULSE_SHAPE", "NO_PULSE", "pulse_shape_of", "PULSE_FIELDS",
           "TP_MODELS", "DEFAULT_TP_MODEL", "tp_model_of", "VP_MODELS", "DEFAULT_VP_MODEL", "vp_model_key",
           "vp_model_of", "markdown_table", "docs_section"]

_LISTED = (
    record,
    mavroeidis_papageorgiou_2003,
    rupakhety_2011,
    baker_2007,
    bray_rodriguez_marek_2004,
    shahi_baker_2014,
    shahi_baker_earlier,
)
#: Every declared model, one line each above (name -> module).
MODELS = {m.NAME: m for m in _LISTED}
if len(MODELS) != len(_LISTED):   # a second model of one NAME would silently replace the first
    raise ImportError("ground-motion registry: two models share a NAME: "
                      + ", ".join(sorted(m.NAME for m in _LISTED if sum(o.NAME == m.NAME for o in _LISTED) > 1)))

#: What each kind of model is for.
KINDS = {
    "high_frequency": "the stochastic high-frequency record (Atkinson & Silva 2000, not listed in MODELS)",
    "record": "the keys of a synthetic record's meta (scenario and seeds)",
    "pulse": "a velocity-pulse shape (synthesize(shape=...), --pulse): its parameters are the pulse fields of a sample row",
    "pulse_period": "a pulse-period relation: log10_fp_mean(Mw), SIGMA_LOG10_FP (--tp-model)",
    "pulse_amplitude": "a pulse-amplitude relation in place of Eq. (6): mean_vp_cm_s(Mw, R, vp_scale) (--vp-model)",
    "pulse_occurrence": "the probability that a near-fault motion carries a pulse (site risk)",
}
for _m in MODELS.values():
    if _m.KIND not in KINDS:
        raise ValueError(f"ground-motion model {_m.NAME!r} declares an unknown kind {_m.KIND!r}")

#: The grid's choice of no pulse (the stochastic record alone); no shape may take the name.
NO_PULSE = "none"


def _pulse_shapes(models) -> dict:
    """The pulse shapes among ``models`` (modules) by SHAPE; ImportError for a shape that lacks part of
    the interface, takes the no-pulse name or another shape's."""
    shapes = {}
    for m in models:
        if m.KIND != "pulse":
            continue
        lacking = pulse_shape.missing(m)
        if lacking:
            raise ImportError(f"pulse shape {m.NAME!r} lacks {', '.join(lacking)} (pycolfrag.ground_motion.pulse_shape)")
        if m.SHAPE == NO_PULSE or m.SHAPE in shapes:
            raise ImportError(f"pulse shape {m.NAME!r}: its SHAPE {m.SHAPE!r} is "
                              + ("the grid's no-pulse choice" if m.SHAPE == NO_PULSE else "another shape's"))
        shapes[m.SHAPE] = m
    return shapes


#: Velocity-pulse shapes (short name -> module of the interface of :mod:`.pulse_shape`), in MODELS' order.
PULSE_SHAPES = _pulse_shapes(MODELS.values())
#: The paper's pulse (Mavroeidis & Papageorgiou 2003).
DEFAULT_PULSE_SHAPE = mavroeidis_papageorgiou_2003.SHAPE


def pulse_shape_of(name):
    """The module of a pulse shape of :data:`PULSE_SHAPES`, or ParameterError naming ``name``."""
    try:
        return PULSE_SHAPES[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown pulse shape {name!r} (known: {', '.join(PULSE_SHAPES)})") from None


def _pulse_fields(shapes) -> tuple:
    """The row fields of the shapes (modules), each once, in order of first appearance; a field two
    shapes declare must mean the same in both (meta key, unit, description), else ImportError."""
    fields: dict = {}
    for m in shapes:
        for p in m.PARAMETERS:
            if not p.row_field:
                continue
            first = fields.setdefault(p.row_field, p)
            if (first.meta_key, first.unit, first.field_description) != (p.meta_key, p.unit, p.field_description):
                raise ImportError(f"pulse shape {m.NAME!r} declares row field {p.row_field!r} unlike another shape "
                                  f"(meta key, unit, description: {(p.meta_key, p.unit, p.field_description)} "
                                  f"against {(first.meta_key, first.unit, first.field_description)})")
    return tuple(fields.values())


#: The pulse fields of a sample row (:class:`~pycolfrag.core.names.Parameter` rows), in layout order.
PULSE_FIELDS = _pulse_fields(PULSE_SHAPES.values())

#: Pulse-period relations (name -> module with ``log10_fp_mean(Mw)`` and ``SIGMA_LOG10_FP``).
TP_MODELS = {name: m for name, m in MODELS.items() if m.KIND == "pulse_period"}
#: The paper's Eq. (7).
DEFAULT_TP_MODEL = rupakhety_2011.NAME


#: Pulse-amplitude relations (name -> module with ``mean_vp_cm_s(Mw, dist_km, vp_scale)``): the paper's
#: Eq. (6) (:mod:`.rupakhety_2011`) and the relations of kind ``"pulse_amplitude"``.
VP_MODELS = {rupakhety_2011.NAME: rupakhety_2011,
             **{name: m for name, m in MODELS.items() if m.KIND == "pulse_amplitude"}}
#: The paper's Eq. (6): a run's ``vp_model`` left empty (the one way a run's settings say it, so that every
#: folder made before the setting existed keeps its identity).
DEFAULT_VP_MODEL = rupakhety_2011.NAME


def vp_model_key(name) -> str:
    """The ``vp_model`` a run's settings carry for the pulse-amplitude relation ``name``: ``""`` for Eq. (6)
    (``""``, None or :data:`DEFAULT_VP_MODEL`), else the relation's name; ParameterError naming an unknown one."""
    if name is None or name == "" or name == DEFAULT_VP_MODEL:
        return ""
    if not isinstance(name, str) or name not in VP_MODELS:
        raise ParameterError(f"unknown pulse-amplitude model {name!r} (vp_model; known: {', '.join(VP_MODELS)}; "
                             f"empty: Eq. (6), {DEFAULT_VP_MODEL})")
    return name


def vp_model_of(name):
    """The module of the pulse-amplitude relation ``name`` (``""`` or None: Eq. (6)), or ParameterError naming it."""
    return VP_MODELS[vp_model_key(name) or DEFAULT_VP_MODEL]


def tp_model_of(name):
    """The module of a pulse-period relation of :data:`TP_MODELS`, or ParameterError naming ``name``."""
    try:
        return TP_MODELS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown pulse-period model {name!r} (known: {', '.join(TP_MODELS)})") from None


def markdown_table(module) -> str:
    """The parameter table of a model module, as docs/ground_motion.md prints it."""
    lines = ["| parameter | unit | accepted | meta key | row field | meaning |", "|---|---|---|---|---|---|"]
    for p in module.PARAMETERS:
        lines.append(f"| {p.name} | {p.unit or '-'} | {p.range_text()} | {f'`{p.meta_key}`' if p.meta_key else '-'} "
                     f"| {f'`{p.row_field}`' if p.row_field else '-'} | {p.description} |")
    return "\n".join(lines)


def docs_section() -> str:
    """The declared parameters of every model, as docs/ground_motion.md prints them: the high-frequency
    model (loads C: its ranges are the generator's) and then :data:`MODELS` in their order."""
    from pycolfrag.ground_motion import atkinson_silva_2000  # loads C (see the module docstring); docs only
    parts = []
    for m in (atkinson_silva_2000, *MODELS.values()):
        parts += [f"**`{m.NAME}`** ({m.KIND}: {KINDS[m.KIND]})", "", markdown_table(m), ""]
    return "\n".join(parts).rstrip() + "\n"
