"""The JSON text of every report a user reads (risk.json, logic_tree.json, restoration.json, the sequences'
summaries; the subset command's output writes its own "nan"/"inf" strings, which pass unchanged): strict JSON
(RFC 8259), which has no NaN or Infinity.

Python's :func:`json.dumps` writes ``NaN`` and ``Infinity`` by default, which JavaScript, ``jq`` and most
other readers refuse. An undefined number of a report (a CoV without runs, a quantile of no sample, an
unbounded ratio) is written ``null`` here, the way OpenQuake's and pandas' JSON writers say "no value";
numpy scalars and arrays are written as their numbers.
"""
import json
import math

__all__ = ["dumps", "plain"]


def plain(x):
    """``x`` with every float that is not finite replaced by ``None`` and numpy scalars and arrays by their
    Python numbers and lists, inside dicts, lists and tuples (anything else returned as it is)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if hasattr(x, "tolist") and type(x).__module__ == "numpy":
        return plain(x.tolist())
    return x


def dumps(obj, *, default=None, **kw) -> str:
    """Strict JSON text of ``obj`` (:func:`plain`: not-finite numbers as ``null``); ``default`` as for
    :func:`json.dumps`, applied before the check (a value it turns into NaN becomes ``null`` too)."""
    if default is not None:
        obj = json.loads(json.dumps(obj, default=default))
    return json.dumps(plain(obj), allow_nan=False, **kw)
