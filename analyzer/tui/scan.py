"""Long scans over the shown rows (a filter, a search), made to run in a worker
thread: in steps, reporting progress, and stoppable (Esc) between steps.

Pure: the screen passes ``progress(done, total)`` and a ``cancelled()`` test;
a cancelled scan returns None and changes nothing.
"""

from __future__ import annotations

from array import array
from typing import Callable

STEP = 20_000   # events between progress reports and cancel checks


class Cancelled(Exception):
    """The scan was stopped before it ended."""


def scan_matching(get, start: int, stop: int, pred, *, progress: Callable[[int, int], None] | None = None,
                  cancelled: Callable[[], bool] | None = None) -> array:
    """Indices ``i`` in [start, stop) with ``pred(get(i))``, ascending (``array('i')``).
    Raises Cancelled when ``cancelled()`` says so between steps."""
    out = array("i")
    total = stop - start
    for a in range(start, stop, STEP):
        if cancelled is not None and cancelled():
            raise Cancelled
        b = min(stop, a + STEP)
        out.extend([i for i in range(a, b) if pred(get(i))])
        if progress is not None:
            progress(b - start, total)
    return out


def scan_first(order, test, *, progress: Callable[[int, int], None] | None = None,
               cancelled: Callable[[], bool] | None = None):
    """The first row of ``order`` (an iterable of row numbers, of known length
    ``len(order)``) for which ``test(row)`` holds, or None."""
    total = len(order)
    done = 0
    for r in order:
        if test(r):
            return r
        done += 1
        if done % STEP == 0:
            if cancelled is not None and cancelled():
                raise Cancelled
            if progress is not None:
                progress(done, total)
    return None
