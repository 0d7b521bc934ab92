"""Long scans over the shown rows (a search; a filter's rows the columns cannot
decide, analyzer/tui/store_filter.py), made to run in a worker thread: in steps,
reporting progress, and stoppable (Esc) between steps.

Pure: the screen passes ``progress(done, total)`` and a ``cancelled()`` test;
a cancelled scan returns None and changes nothing.
"""

from __future__ import annotations

from collections.abc import Callable

STEP = 20_000   # events between progress reports and cancel checks


class Cancelled(Exception):
    """The scan was stopped before it ended."""


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
