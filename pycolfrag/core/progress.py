"""Progress of a command's long loops (fits, risk levels, figures): one tqdm bar on stderr.

Library code marks its steps with :func:`advance` (nothing happens unless a bar is open) and the
command wraps its work in :func:`task` with the number of steps; bars are drawn only once a command
turned them on (:func:`enable`, which :func:`pycolfrag.cli.main.main` does for every command), so a
script that calls the library sees no bar. On a terminal the bar appears after
:data:`TERMINAL_DELAY_S` and updates twice a second; into a file or a pipe (a log) it appears only
when the work lasts longer than :data:`LOG_DELAY_S` and prints every :data:`LOG_INTERVAL_S`. One bar at
a time, counting its own unit: steps of another unit (a figure's fits in the ``figures`` bar) and a
task inside another are not counted. Without tqdm, no bar.
"""
from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Iterator

__all__ = ["enable", "enabled", "task", "advance", "steps", "TERMINAL_DELAY_S", "LOG_DELAY_S", "LOG_INTERVAL_S"]

#: Seconds before a bar appears on a terminal (a quick command shows none).
TERMINAL_DELAY_S = 1.0
#: Seconds before a bar appears in a log (stderr not a terminal), and between its lines there.
LOG_DELAY_S, LOG_INTERVAL_S = 5.0, 30.0

_state: dict = {"on": False, "bar": None, "unit": None}


def enable(on: bool = True) -> None:
    """Let :func:`task` draw bars (the commands), or not (the default: library use)."""
    _state["on"] = bool(on)


def enabled() -> bool:
    return bool(_state["on"])


@contextmanager
def task(desc: str, total: int | None, unit: str = "step") -> Iterator[None]:
    """A bar of ``total`` steps (None: a count without a total) for the block, when bars are enabled and
    no other is open; :func:`advance` moves it."""
    if not _state["on"] or _state["bar"] is not None or (total is not None and total <= 0):
        yield
        return
    try:
        from tqdm import tqdm
    except ImportError:
        yield
        return
    tty = sys.stderr.isatty()
    bar = tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True, leave=False,
               delay=TERMINAL_DELAY_S if tty else LOG_DELAY_S, mininterval=0.5 if tty else LOG_INTERVAL_S)
    if not tty and hasattr(bar, "last_print_t"):   # (a stand-in bar of the tests has none)
        # tqdm prints once mininterval has passed since its last print, which at the start is its creation:
        # the first line would come after LOG_INTERVAL_S, not LOG_DELAY_S (a 20 s command's log showed none)
        bar.last_print_t -= LOG_INTERVAL_S - LOG_DELAY_S
    _state["bar"], _state["unit"] = bar, unit
    try:
        yield
    finally:
        _state["bar"] = _state["unit"] = None
        bar.close()


def advance(n: int = 1, unit: str = "step") -> None:
    """``n`` steps of ``unit`` done: the open bar moves if it counts that unit (nothing otherwise)."""
    bar = _state["bar"]
    if bar is not None and _state["unit"] == unit:
        bar.update(n)


def steps(items, desc: str, unit: str = "step"):
    """``items`` one by one inside a :func:`task` of ``len(items)`` steps, each advancing it once done."""
    items = list(items)
    with task(desc, len(items), unit):
        for item in items:
            yield item
            advance(unit=unit)
