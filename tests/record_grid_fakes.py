"""Sample functions for the record-suite grid tests (``--sample-function record_grid_fakes:NAME``;
the tests put this folder on PYTHONPATH).

* ``slow``: the real record row (:func:`pycolfrag.grid.run_record_row`: record, IMs, solver) after
  sleeping ``PCF_FAKE_SLEEP_S`` seconds, so a run can be killed part-way; the numbers are the real
  ones, so a resumed run can be compared with an uninterrupted one.
"""
import os
import time

from pycolfrag.grid import run_record_row


def slow(ctx, row):
    time.sleep(float(os.environ.get("PCF_FAKE_SLEEP_S", "0")))
    return run_record_row(ctx, row)
