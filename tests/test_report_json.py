"""The reports' JSON is strict JSON (RFC 8259 has no NaN or Infinity; JavaScript's JSON.parse and jq refuse
them): pycolfrag.core.report_json writes an undefined number as null."""
import json

import numpy as np
import pytest

from pycolfrag.core import report_json


def strict_loads(text: str):
    """json.loads that fails on NaN, Infinity and -Infinity (Python's reader accepts them by default)."""
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"not JSON: {c} in the report"))


def test_undefined_numbers_are_null_and_the_rest_unchanged():
    obj = {"cov": float("nan"), "ratio": float("inf"), "low": -np.inf, "p": np.float64(0.25), "n": np.int64(3),
           "q": np.array([1.0, np.nan]), "t": (0.5, float("nan")), "s": "NaN", "ok": True, "none": None}
    text = report_json.dumps(obj, indent=1)
    assert strict_loads(text) == {"cov": None, "ratio": None, "low": None, "p": 0.25, "n": 3, "q": [1.0, None],
                                  "t": [0.5, None], "s": "NaN", "ok": True, "none": None}


def test_default_is_applied_before_the_check():
    """An object json cannot write is turned by ``default`` (here float), and a NaN it gives becomes null."""
    class Undefined:
        def __float__(self):
            return float("nan")
    assert strict_loads(report_json.dumps({"x": Undefined(), "y": 2}, default=float)) == {"x": None, "y": 2}


def test_python_json_alone_would_write_nan():
    """The reason for the module: json.dumps writes NaN, which the strict reader refuses."""
    with pytest.raises(pytest.fail.Exception, match="not JSON: NaN"):
        strict_loads(json.dumps({"cov": float("nan")}))
