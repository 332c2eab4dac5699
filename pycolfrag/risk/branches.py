"""The results files a site risk reads: are they complete, and are the two branches one pair?

* **Completeness.** A killed or running grid's file holds part of its rows; its cells then rest on
  fewer runs than the grid asked for, and the rates computed from it differ from the finished
  grid's (an interrupted file of 33 of 36 rows gave lambda 6.3e-4 against 4.2e-4). Such a file is
  refused unless the user asks for it (``allow_incomplete``), and then every output says so.
* **Pairing.** The no-pulse grid is the pulse grid's stochastic part, made from the same seeds, so
  its rows are paired with the pulse grid's by sample number. That holds only for the same seed and
  the same code: a no-pulse file made with another ``--seed``, or by another build of the code, is
  refused. The code is identified by the root attribute ``code_digest`` (a digest of the package's
  sources and the C build) where both files have it, else by the package ``version`` and the grid
  signature's ``result_hash``.
"""
from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np

from pycolfrag.analysis import completeness as _completeness
from pycolfrag.core.errors import ParameterError

__all__ = ["declared_pulse", "check_branches", "check_complete", "SHARED_SETTINGS"]

#: Grid settings the two branches must share (everything but the pulse and the scenarios' sample counts).
SHARED_SETTINGS = ("column", "solver", "damping", "record_dt_s", "max_record_s", "sample_function", "streams")


def declared_pulse(attrs) -> str | None:
    """What a results file says about its pulses: the root attribute or grid-signature entry ``pulse``
    (``"none"`` for the stochastic part alone), None when it says nothing (files made before the
    no-pulse grid existed; every one of their motions carries a pulse)."""
    v = attrs.get("pulse")
    if v is None:
        v = signature(attrs).get("pulse")
    if isinstance(v, bytes):
        v = v.decode()
    return None if v is None else str(v)


def signature(attrs) -> dict:
    """The grid signature of a file's attributes as a dict ({} when it has none or it is not JSON)."""
    try:
        v = json.loads(attrs.get("grid_signature", "{}") or "{}")
    except (TypeError, ValueError):
        return {}
    return v if isinstance(v, dict) else {}


def _text(v):
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, np.generic):
        v = v.item()
    return v


def _seed(attrs):
    v = attrs.get("seed")
    return _text(v) if v is not None else signature(attrs).get("seed")


def code_identity(attrs) -> tuple[str, object] | None:
    """("code_digest", digest) when the file has one, else ("version/result_hash", (version, hash)),
    None when it says neither."""
    if attrs.get("code_digest") is not None:
        return "code_digest", _text(attrs["code_digest"])
    build = signature(attrs).get("build") or {}
    version, result_hash = _text(attrs.get("version")) or build.get("version"), build.get("result_hash")
    if version is None and result_hash is None:
        return None
    return "version/result_hash", (version, result_hash)


def _check_pairing(pulse, no_pulse):
    sp, sn = _seed(pulse.attrs), _seed(no_pulse.attrs)
    if sp is not None and sn is not None and str(sp) != str(sn):
        raise ParameterError(f"{pulse.path} was made with seed {sp} and {no_pulse.path} with seed {sn}: the "
                             "branches' rows are paired by sample number, which holds only for the same seed; "
                             "make the no-pulse grid with the pulse grid's --seed")
    cp, cn = code_identity(pulse.attrs), code_identity(no_pulse.attrs)
    if cp is not None and cn is not None:
        if cp[0] != cn[0]:      # one file has a code digest, the other not: compare what both have
            cp, cn = (code_identity({k: v for k, v in d.attrs.items() if k != "code_digest"})
                      for d in (pulse, no_pulse))
        if cp is not None and cn is not None and cp != cn:
            raise ParameterError(f"{pulse.path} and {no_pulse.path} were made by different code ({cp[0]} "
                                 f"{cp[1]!r} against {cn[1]!r}): the no-pulse branch is the pulse branch's "
                                 "stochastic part only when both come from the same code; rerun one of them")


def check_branches(pulse, no_pulse) -> None:
    """Refuse branches that are not one pair: a pulse file that declares no pulses, a no-pulse file that
    does not declare ``pulse = "none"``, different columns or shared settings, another seed, other code."""
    dp = declared_pulse(pulse.attrs)
    if dp is not None and dp.lower() == "none":
        raise ParameterError(f"{pulse.path} declares pulse = 'none' (no velocity pulses) but was given as the "
                             "pulse branch; give it as the no-pulse branch (--no-pulse)")
    if no_pulse is None:
        return
    dn = declared_pulse(no_pulse.attrs)
    if dn is None or dn.lower() != "none":
        raise ParameterError(f"{no_pulse.path} was given as the no-pulse branch but does not declare pulse = "
                             f"'none' (it declares {dn!r}); make it with: {no_pulse_command(pulse)}")
    cp, cn = pulse.attrs.get("column"), no_pulse.attrs.get("column")
    if cp is not None and cn is not None and json.loads(cp) != json.loads(cn):
        raise ParameterError(f"{pulse.path} and {no_pulse.path} are grids of different columns; the two "
                             "branches must describe the same column")
    sp, sn = signature(pulse.attrs), signature(no_pulse.attrs)
    differ = [k for k in SHARED_SETTINGS if k in sp and k in sn and sp[k] != sn[k]]
    if differ:
        raise ParameterError(f"{pulse.path} and {no_pulse.path} differ in {', '.join(differ)} ("
                             + "; ".join(f"{k}: {sp[k]!r} against {sn[k]!r}" for k in differ)[:400]
                             + "); the two branches must be the same column, solver and records but for the pulse")
    _check_pairing(pulse, no_pulse)



def check_complete(branches: dict, allow_incomplete: bool) -> list:
    """The marks of the incomplete branch files (:func:`pycolfrag.analysis.completeness.check_complete`,
    the one judge: rows not computed yet); refused unless ``allow_incomplete``."""
    notes = [_completeness.check_complete(d, allow_incomplete, f"a site risk from {d.path}") for d in branches.values()]
    return [n for n in notes if n]


#: Options of a grid's recorded command that do not carry over to its no-pulse twin (with their value).
_NOT_CARRIED = ("--out", "--pulse", "--report", "--figures-dir")
#: ... and the flags of that one run (replacing or resuming its file) that a new file must not take.
_FLAGS_NOT_CARRIED = ("--overwrite", "--retry-failed", "--allow-code-change")


def no_pulse_command(pulse) -> str:
    """The one command that makes the no-pulse grid of the grid with pulses ``pulse`` (its data, with the
    ``command`` attribute the grid records): its own options with ``--pulse none`` and ``--out`` beside it
    (``<stem>_nopulse.h5``); the same options by name when the file records no command."""
    path = Path(str(pulse.path)) if getattr(pulse, "path", None) is not None else Path("grid.h5")
    out = path.with_name(f"{path.stem}_nopulse{path.suffix or '.h5'}")
    cmd = pulse.attrs.get("command") if hasattr(pulse, "attrs") else None
    cmd = cmd.decode() if isinstance(cmd, bytes) else cmd
    try:
        words = shlex.split(cmd) if isinstance(cmd, str) else []
    except ValueError:
        words = []
    start = next((i + 1 for i, w in enumerate(words) if w == "grid" or w.endswith("run_grid.py")), None)
    if start is None:
        return f"pycolfrag grid <the grid's own options> --pulse none --out {shlex.quote(str(out))}"
    kept, skip = [], False
    for w in words[start:]:
        if skip:
            skip = False
        elif w in _NOT_CARRIED:
            skip = True
        elif w not in _FLAGS_NOT_CARRIED and not w.startswith(tuple(f"{o}=" for o in _NOT_CARRIED)):
            kept.append(w)
    return shlex.join(["pycolfrag", "grid", *kept, "--pulse", "none", "--out", str(out)])
