"""The grid's scheduling (pycolfrag/grid/chunks.py, serve.py) and the replay model that predicts it
(pycolfrag/grid/replay.py, replay_sim.py), without MPI: the chunk rule, the cost model, Open MPI's
probe, the batch width the replay assumes, and the replay's clock on cases worked out by hand.
"""
import math
from collections import deque

import numpy as np
import pytest

from pycolfrag import Column
from pycolfrag.grid import GridSpec, chunks, replay, serve
from pycolfrag.grid.chunks import ChunkQueue, rank0_chunk_max, synthetic_record_s
from pycolfrag.grid.replay_sim import batch_width_rule
from pycolfrag.ground_motion import atkinson_silva_2000 as as00
from pycolfrag.solver import run as solver


def _b2afe10_chunk(queue: deque, size: int, chunk_max: int) -> list:
    """b2afe10's rule, as it was written in its grid.py (the reference the new rule must keep for unit
    costs and one lane): a quarter of an equal share of the rows left, between 1 and chunk_max."""
    n = len(queue)
    k = max(1, min(chunk_max, n // (4 * size)))
    return [queue.popleft() for _ in range(min(k, n))]


@pytest.mark.parametrize("n_rows, size, chunk_max", [(3500, 2, 32), (3500, 16, 32), (3500, 128, 32),
                                                      (24, 4, 32), (1000, 3, 7), (5, 8, 32)])
def test_unit_costs_and_one_lane_are_the_old_guided_rule(n_rows, size, chunk_max):
    """With every row's cost 1 and no lanes the queue hands out b2afe10's chunks, chunk for chunk (the
    replay's 'b2afe10' policy is this), rank 0's quarter chunks included."""
    old, new = deque(range(n_rows)), ChunkQueue(range(n_rows), np.ones(n_rows), size, 1)
    own = rank0_chunk_max(chunk_max, 1)
    assert own == max(1, chunk_max // 4)
    k = 0
    while old:
        cm = own if k % 3 == 2 else chunk_max
        assert new.take(cm) == _b2afe10_chunk(old, size, cm)
        k += 1
    assert new.take(chunk_max) == [] and len(new) == 0


@pytest.mark.parametrize("size, chunk_max", [(2, 30), (16, 32), (128, 32)])
def test_chunks_are_whole_lanes_and_at_least_one_batch(size, chunk_max):
    """8 lanes: every chunk but the last is a multiple of 8 rows (the narrow batches of the old rule ran
    1.6-2.8x slower per run-step) between 8 and chunk_max rounded down (30 -> 24); only the last may be
    shorter."""
    q = ChunkQueue(range(3500), np.ones(3500), size, 8)
    sizes = []
    while len(q):
        sizes.append(len(q.take(chunk_max)))
    assert sum(sizes) == 3500
    assert all(s % 8 == 0 and 8 <= s <= chunk_max for s in sizes[:-1]) and 0 < sizes[-1] <= chunk_max
    assert max(sizes) == 8 * (chunk_max // 8) if size < 128 else max(sizes) == 8


def test_chunks_share_expected_cost_not_rows():
    """Two ranks, one lane, 8 rows of cost 10 then 80 of cost 1 (total 160), worked by hand: each chunk is
    the head rows whose cost fits a quarter of half the cost left -- 160 / 8 = 20 -> two rows of 10; then
    17.5, 16.25, 15, 13.75, 12.5 -> one row each; 11.25 -> the last row of 10 and one of 1; 79 / 8 = 9.875
    -> 9 rows of 1. Counting rows instead (b2afe10) the first chunk would be 88 // 8 = 11 rows, 110 of
    the 160."""
    q = ChunkQueue(range(88), np.r_[np.full(8, 10.0), np.ones(80)], 2, 1)
    assert [len(q.take(32)) for _ in range(8)] == [2, 1, 1, 1, 1, 1, 2, 9]
    # with 4 lanes the same costs give whole batches: 20 -> 2 rows, raised to one batch of 4
    q4 = ChunkQueue(range(88), np.r_[np.full(8, 10.0), np.ones(80)], 2, 4)
    assert q4.take(32) == [0, 1, 2, 3]


def test_a_drained_queue_hands_out_nothing_and_says_what_is_left():
    q = ChunkQueue(range(100), np.ones(100), 2, 8)
    q.take(32)
    left = q.rows_left
    assert q.drain() == left and len(q) == 0 and q.take(32) == [] and q.rows_left == left


def test_bad_costs_are_refused():
    with pytest.raises(ValueError, match="finite values >= 0"):
        ChunkQueue(range(3), [1.0, math.nan, 1.0], 1, 8)
    with pytest.raises(ValueError):
        ChunkQueue(range(3), [1.0, 1.0], 1, 8)


def test_rank0s_chunk_is_a_quarter_but_at_least_one_batch():
    assert rank0_chunk_max(32, 8) == 8 and rank0_chunk_max(64, 8) == 16 and rank0_chunk_max(32, 1) == 8
    assert rank0_chunk_max(4, 8) == 4 and rank0_chunk_max(1, 8) == 1


def test_the_cost_model_is_the_generators_record_length():
    """synthetic_record_s against the stochastic generator's own record (n_out samples of dt = 0.005 s)
    over Mw 4-8 and R 1-100 km: within one sample (the generator rounds its margins to whole samples)."""
    for mw in (4.0, 5.5, 6.5, 7.5, 8.0):
        for r in (1.0, 5.0, 12.5, 20.0, 100.0):
            n_out = as00._generator(mw, r, 0.005).info["n_out"]
            assert abs(synthetic_record_s(mw, r) - n_out * 0.005) <= 0.005, (mw, r)


def test_the_grids_expected_cost_is_its_records_plus_the_tail():
    spec = GridSpec(mw=(5.5, 7.5), dist_km=(5.0,), samples=2, max_record_s=30.0)
    cost = spec.expected_cost([0, 1, 2, 3])
    tail = spec.solver_options.tail_s
    assert cost[0] == cost[1] == pytest.approx(synthetic_record_s(5.5, 5.0) + tail, abs=0)
    assert cost[2] == cost[3] == 30.0 + tail       # Mw 7.5's 40 s record cut to 30 s
    assert list(spec.order(range(4))) == [2, 3, 0, 1]   # longest expected first, as the costs rank them


def test_the_replays_batch_width_is_the_c_librarys():
    col = Column.parthenon()
    lanes = solver.batch_width(col)
    for n in range(1, 41):
        assert batch_width_rule(n, lanes) == solver.batch_width(col, n_runs=n), n


class _Comm:
    """Iprobe as Open MPI's ob1 answers it: a request that arrived during rank 0's chunk is moved into
    the queue of unexpected messages by the first probe, which still says no; the second sees it."""

    def __init__(self):
        self.calls, self.moved = 0, False

    def Iprobe(self, source=None, tag=None, status=None):
        self.calls += 1
        seen, self.moved = self.moved, True
        return seen


def test_rank0_probes_twice_before_it_takes_its_own_chunk(monkeypatch):
    comm = _Comm()
    assert serve._waiting(comm, None) is True and comm.calls == 2


def _rows(costs_by_row, samples=1):
    n = len(costs_by_row)
    return replay.Rows(scenario=np.arange(n), steps=np.asarray(costs_by_row, dtype=float), sigma=np.ones(n),
                       prep=np.zeros(n), expected=np.asarray(costs_by_row, dtype=float), order=list(range(n)),
                       samples=samples)


def _zero_costs(**kw):
    """Every fixed cost 0, one lane, width factor 1: a chunk costs its rows' steps (sigma 1 s per step)."""
    fields = {k: 0.0 for k, v in replay.Costs().__dict__.items() if isinstance(v, float)}
    fields.update(lanes=1, width_factor={1: 1.0, 4: 1.0, 8: 1.0}, sigma_scale=1.0, lhs_cache=8)
    fields.update(kw)
    return replay.Costs(**fields)


def test_one_rank_takes_the_sum_of_its_rows():
    rows = _rows([3.0, 2.0, 1.0, 1.0])
    r = replay.simulate(rows, 1, replay.CURRENT, _zero_costs(), replay.Machine(latency=0.0))
    assert r["t_job"] == pytest.approx(7.0, abs=1e-9) and r["chunk_cpu"] == pytest.approx(7.0, abs=1e-9)


def test_two_ranks_split_by_the_chunk_rule_and_share_one_core():
    """Four rows of 1 s, two ranks, one lane, no fixed costs or latency, worked by hand: the worker's first
    request gets a quarter of half the cost (0.5 s -> one row, row 0); its prefetched request has not
    arrived when rank 0 probes, so rank 0 takes row 1 itself (3 / 8 -> one row). At 1 s rank 0's second
    probe sees the prefetched request (row 2 to the worker) and rank 0 takes row 3: both end at 2 s. On
    one core shared by both (processor sharing) the 4 s of work end at 4 s."""
    rows = _rows([1.0] * 4)
    r = replay.simulate(rows, 2, replay.CURRENT, _zero_costs(), replay.Machine(latency=0.0, spin=0.0))
    assert r["n_chunks"] == 4 and r["t_final"] == pytest.approx(2.0, abs=3e-3)
    r1 = replay.simulate(rows, 2, replay.CURRENT, _zero_costs(), replay.Machine(cores=1.0, latency=0.0, spin=0.0))
    assert r1["t_final"] == pytest.approx(4.0, abs=4e-3)


def test_the_replay_cuts_chunks_with_the_schedulers_queue(monkeypatch):
    """The replay's chunks are ChunkQueue.take's: a queue whose rule is changed changes the replay."""
    rows = _rows([1.0] * 64)
    base = replay.simulate(rows, 1, replay.CURRENT, _zero_costs())["n_chunks"]
    monkeypatch.setattr(chunks.ChunkQueue, "take", lambda self, cm: _one(self))
    assert replay.simulate(rows, 1, replay.CURRENT, _zero_costs())["n_chunks"] == 64 != base


def _one(q):
    if q.rows_left == 0:
        return []
    q._head += 1
    return [int(q._rows[q._head - 1])]


def test_one_probe_leaves_the_worker_waiting_through_a_chunk_of_rank_0():
    """The case above with b2afe10's single probe: at 1 s the probe only moves the prefetched request into
    Open MPI's queue and says no, so rank 0 computes row 2 itself while the worker, its prefetch
    unanswered, waits; the worker gets row 3 at 2 s and ends at 3 s (the measured worker waits of 34-48 %
    of a 2-rank session had this cause)."""
    from dataclasses import replace
    rows = _rows([1.0] * 4)
    once = replace(replay.CURRENT, probe_twice=False)
    r = replay.simulate(rows, 2, once, _zero_costs(), replay.Machine(latency=0.0, spin=0.0))
    assert r["t_final"] == pytest.approx(3.0, abs=4e-3)
