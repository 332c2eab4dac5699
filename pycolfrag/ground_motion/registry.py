"""The ground-motion models that declare their parameters, one line each, and what is built from them.

Every module listed in :data:`MODELS` declares, as data at its top, ``NAME``, ``KIND`` and
``PARAMETERS`` (:class:`pycolfrag.names.Parameter` rows: name, unit, accepted range, description,
``Record.meta`` key, sample-row field). From them, and from nowhere else:

* :data:`PULSE_FIELDS` -- the pulse fields of a synthetic sample row and of ``/samples``
  (:mod:`pycolfrag.sample` fills them from a record's ``meta``, :mod:`pycolfrag.results` lays them out):
  the parameters with a row field of the models of kind ``"pulse"``;
* :data:`TP_MODELS` -- the pulse-period relations (kind ``"pulse_period"``), the choices of
  ``run_grid.py --tp-model`` and of ``sample_pulse_parameters(tp_model=...)``;
* the parameter tables of docs/ground_motion.md (:func:`docs_section`; a test keeps them equal;
  ``python -c "from pycolfrag.ground_motion import registry; print(registry.docs_section())"`` prints them).

A new model is its module plus its line in :data:`MODELS`. Importing this module loads no C: the
model modules load the C library on first use of a function that needs it, so the results layout
and the statistics that read it do not need a built library. (The Atkinson & Silva (2000) module is
not listed: its accepted scenario range is the C generator's, read from ``csrc/stochastic.h`` when it
loads, and it adds no row field; it declares its ``PARAMETERS`` all the same.)
"""
from __future__ import annotations

from ..errors import ParameterError
from . import baker_2007, mavroeidis_papageorgiou_2003, record, rupakhety_2011, shahi_baker_2014, shahi_baker_earlier

__all__ = ["MODELS", "KINDS", "PULSE_FIELDS", "TP_MODELS", "DEFAULT_TP_MODEL", "tp_model_of", "markdown_table",
           "docs_section"]

_LISTED = (
    record,
    mavroeidis_papageorgiou_2003,
    rupakhety_2011,
    baker_2007,
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
    "pulse": "a velocity pulse: its parameters are the pulse fields of a sample row",
    "pulse_period": "a pulse-period relation: log10_fp_mean(Mw), SIGMA_LOG10_FP (--tp-model)",
    "pulse_occurrence": "the probability that a near-fault motion carries a pulse (site risk)",
}
for _m in MODELS.values():
    if _m.KIND not in KINDS:
        raise ValueError(f"ground-motion model {_m.NAME!r} declares an unknown kind {_m.KIND!r}")

#: The pulse fields of a sample row (:class:`~pycolfrag.names.Parameter` rows), in layout order.
PULSE_FIELDS = tuple(p for m in MODELS.values() if m.KIND == "pulse" for p in m.PARAMETERS if p.row_field)

#: Pulse-period relations (name -> module with ``log10_fp_mean(Mw)`` and ``SIGMA_LOG10_FP``).
TP_MODELS = {name: m for name, m in MODELS.items() if m.KIND == "pulse_period"}
#: The paper's Eq. (7).
DEFAULT_TP_MODEL = rupakhety_2011.NAME


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
    from . import atkinson_silva_2000  # loads C (see the module docstring); docs only
    parts = []
    for m in (atkinson_silva_2000, *MODELS.values()):
        parts += [f"**`{m.NAME}`** ({m.KIND}: {KINDS[m.KIND]})", "", markdown_table(m), ""]
    return "\n".join(parts).rstrip() + "\n"
