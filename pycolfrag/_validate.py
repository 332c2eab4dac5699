"""Scalar argument checks shared by every module: a bad value raises ParameterError naming it."""
import math

from .errors import ParameterError


def _number(value, name: str) -> float:
    if isinstance(value, bool):  # True would silently become 1.0
        raise ParameterError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None


def finite_float(value, name: str) -> float:
    """``value`` as a finite float, else :class:`ParameterError` naming it."""
    v = _number(value, name)
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return v


def positive_float(value, name: str, allow_zero: bool = False) -> float:
    """``value`` as a finite float > 0 (or >= 0 with ``allow_zero``), else :class:`ParameterError`."""
    v = _number(value, name)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ParameterError(f"{name} must be finite and {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return v
