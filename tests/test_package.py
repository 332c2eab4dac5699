"""Package-level properties: version agreement, exceptions, reproducible build flags."""
import numpy as np
import pytest

import pycolfrag as pcf
from pycolfrag.core import ffi as _ffi
from pycolfrag.core import validate as _validate


def test_c_library_version_matches_package():
    assert _ffi.ffi.string(_ffi.lib.cf_common_version()).decode() == pcf.__version__


def test_floating_point_contraction_is_off():
    # a = 1 + 2^-30: a*a = 1 + 2^-29 + 2^-60 exactly. Rounded to double the 2^-60 term is lost,
    # so (a*a) - (1 + 2^-29) is 0 without FMA and 2^-60 with a fused multiply-add.
    # Bitwise reproducibility across CPUs (docs/reproducibility.md) needs the unfused result.
    a = 1.0 + 2.0 ** -30
    c = -(1.0 + 2.0 ** -29)
    assert _ffi.lib.cf_common_fma_probe(a, a, c) == 0.0
    # the probe is sensitive: exact arithmetic (Python ints scaled by 2^60) gives 1, not 0
    exact = (2 ** 30 + 1) ** 2 - (2 ** 60 + 2 ** 31)
    assert exact == 1


def test_status_codes_map_to_exceptions():
    with pytest.raises(pcf.ParameterError, match="bad thing"):
        _ffi.check(_ffi.lib.CF_EINVAL, "bad thing")
    with pytest.raises(ValueError):  # ParameterError is a ValueError
        _ffi.check(_ffi.lib.CF_EINVAL, "x")
    with pytest.raises(pcf.ModelRangeError):
        _ffi.check(_ffi.lib.CF_ERANGE, "Mw")
    with pytest.raises(pcf.SolverError):
        _ffi.check(_ffi.lib.CF_EUNSTABLE, "NaN")
    _ffi.check(_ffi.lib.CF_OK, "ignored")


def test_array_checks_name_the_bad_value():
    with pytest.raises(pcf.ParameterError, match=r"acc_x has a non-finite value nan at index \(2,\)"):
        _validate.float_array([0.0, 1.0, np.nan], "acc_x")
    with pytest.raises(pcf.ParameterError, match="acc_x is empty"):
        _validate.float_array([], "acc_x")
    with pytest.raises(pcf.ParameterError, match="must be 1-D"):
        _validate.float_array(np.zeros((2, 2)), "acc_x")
    out = _validate.float_array(np.arange(4, dtype=np.float32), "acc_x")
    assert out.dtype == np.float64 and out.flags.c_contiguous
