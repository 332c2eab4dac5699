"""The queue of a run's rows and the one rule for how many of them a rank takes at a time.

The scheduler (:mod:`pycolfrag.grid.schedule`) hands out chunks by this rule and the replay model
(:mod:`pycolfrag.grid.replay`) replays the same code, so a prediction is of the policy that runs.

The rule is guided self-scheduling by *expected cost*: a chunk is the head of the queue (longest
expected first) up to a quarter of an equal share of the expected cost still queued,
``left / (4 ranks)``, at most ``chunk_max`` rows, rounded down to whole SIMD lanes and never fewer
than one batch of lanes (until fewer rows are left). Why each part:

* a share of what is left, not a fixed size: chunks shrink towards the end, so the ranks finish
  together (the tail of a Mw 7.5 row is four times a Mw 5.5 row: the share counts cost, not rows);
* whole lanes: a chunk's runs go side by side in SIMD lanes (8 with AVX-512, 4 with AVX2); a batch of
  fewer runs than lanes leaves lanes idle or drops to a narrower width, which costs 1.6x (4 lanes) to
  2.8x (one run) per run-step of the full width (measured on the default grid's rows), more than the
  longer tail a batch of full lanes adds;
* rows are never split or reordered by the rule, so a row is computed as it would be alone: the
  chunk changes which rank computes it, never its bits.

``expected_cost`` is what a kind of grid says a row will cost before it runs
(:meth:`pycolfrag.grid.protocol.RunSpec.expected_cost`): only ratios matter. For the synthetic grid it
is the nominal simulated seconds of the scenario's record plus the solver's tail
(:func:`synthetic_record_s`); the solver's steps, and with them the time, are proportional to it.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["ChunkQueue", "GUIDED_SHARE", "rank0_chunk_max", "synthetic_record_s"]

#: A chunk is at most 1/GUIDED_SHARE of an equal share of the expected cost still queued.
GUIDED_SHARE = 4


def rank0_chunk_max(chunk_max: int, lanes: int) -> int:
    """The largest chunk rank 0 takes for itself while it also serves: a quarter of a worker's, so that
    the workers' prefetched requests are answered within a short chunk, but at least one batch of lanes
    (a narrower batch would run its rows slower than the answers it speeds up save)."""
    return max(1, min(chunk_max, max(lanes, chunk_max // 4)))


class ChunkQueue:
    """The rows still to compute, in order, and :meth:`take`, the chunk rule (module docstring).

    Parameters
    ----------
    rows : sequence of int
        The rows in the order they are handed out (the spec's ``order``: longest expected first).
    cost : sequence of float
        Each row's expected cost (same order; any unit, >= 0).
    size : int
        Ranks that compute (the equal share is of ``size`` ranks).
    lanes : int
        SIMD lanes of a batch on this CPU (1: rows run one by one).
    """

    def __init__(self, rows: Sequence[int], cost: Sequence[float], size: int, lanes: int):
        self._rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        c = np.asarray(cost, dtype=np.float64).reshape(-1)
        if c.shape != self._rows.shape or not np.all(np.isfinite(c)) or np.any(c < 0):
            raise ValueError(f"expected costs must be {self._rows.size} finite values >= 0")
        self._cum = np.concatenate([[0.0], np.cumsum(c)])
        self._head = 0
        self.size, self.lanes = max(1, int(size)), max(1, int(lanes))
        self.draining = False

    def __len__(self) -> int:
        return 0 if self.draining else self._rows.size - self._head

    @property
    def rows_left(self) -> int:
        """Rows not handed out (also while draining)."""
        return self._rows.size - self._head

    def take(self, chunk_max: int) -> list[int]:
        """The next chunk (module docstring), at most ``chunk_max`` rows; [] when the queue is empty or
        draining."""
        n = len(self)
        if n == 0:
            return []
        h, cum = self._head, self._cum
        share = (cum[-1] - cum[h]) / (GUIDED_SHARE * self.size)
        # the head rows whose summed cost fits the share (at least one)
        k = int(np.searchsorted(cum, cum[h] + share, side="right")) - 1 - h
        k = min(max(k, 1), chunk_max)
        if k >= self.lanes:
            k -= k % self.lanes
        k = min(max(k, min(self.lanes, chunk_max)), n)
        self._head = h + k
        return self._rows[h:h + k].tolist()

    def drain(self) -> int:
        """Hand out nothing more (a run told to stop: its chunks in flight still come back); returns the
        rows left. Only sets a flag, so a signal handler may call it while :meth:`take` runs."""
        self.draining = True
        return self.rows_left


def synthetic_record_s(mw: float, dist_km: float) -> float:
    """The nominal length of the synthetic grid's record of a scenario, s: the stochastic record's
    Saragoni-Hart window (twice the Atkinson-Silva duration T_gm) and the generator's margins before
    and after it (``cf_stochastic_def``'s ``pre_s`` and ``tail_s``). A velocity pulse that reaches past
    the record pads it further; the estimate leaves that out (a few rows of Mw >= 6 are longer).
    ``tests/test_scheduling.py`` holds it to the generator's own lengths."""
    from pycolfrag.core.ffi import ffi, lib
    from pycolfrag.ground_motion import atkinson_silva_2000 as as00  # loads C: only rank 0 building its queue needs it
    df = ffi.new("cf_stochastic_def *")
    lib.cf_stochastic_def_default(df)
    return float(df.pre_s + 2.0 * as00.duration_s(mw, dist_km) + df.tail_s)
