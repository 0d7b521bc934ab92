"""Sweeps: walks over the shown rows too long for the screen's thread (a
search; a filter's rows the columns cannot decide, analyzer/formats/store_filter.py),
made to run in a worker thread: in steps, reporting progress, and stoppable
(Esc) between steps.

Pure: the screen passes ``progress(done, total)`` and a ``cancelled()`` test;
a sweep stopped that way raises ``Cancelled`` and changes nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Protocol

STEP = 20_000   # events between progress reports and cancel checks

ReportProgress = Callable[[int, int], None]   # (done, total): how far a sweep has got
IsCancelled = Callable[[], bool]              # the sweep is to stop


class Order(Protocol):
    """Row numbers in the order a sweep goes through them, as many as ``len``."""

    def __len__(self) -> int: ...

    def __iter__(self) -> Iterator[int]: ...


class Cancelled(Exception):
    """The sweep was stopped before it ended."""


def first_match(order: Order, test: Callable[[int], bool], *, progress: ReportProgress | None = None,
                cancelled: IsCancelled | None = None) -> int | None:
    """The first row of ``order`` (row numbers, of known length ``len(order)``)
    for which ``test(row)`` holds, or None."""
    total = len(order)
    for done, r in enumerate(order, 1):
        if test(r):
            return r
        if done % STEP == 0:
            if cancelled is not None and cancelled():
                raise Cancelled
            if progress is not None:
                progress(done, total)
    return None
