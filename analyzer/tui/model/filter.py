"""The filter's part of the model: its text and history, and which events it
lets through, as the store indices of the matching shown events (an
``array('i')``, four bytes a row) and the matching unsettled events.

Filtering a large capture is split in two: ``prepare`` finds the matching
events among those shown so far (safe in a worker thread: the store only
grows), ``apply`` catches up with what was shown meanwhile, on the thread that
extends the model. Both go through the store's columns (``store_filter``):
numpy decides what the columns can, the filter's closure the rest.
"""

from __future__ import annotations

from array import array
from bisect import bisect_left
from dataclasses import dataclass

from dissectors.event import Event

from ...analysis.filter import Predicate, compile_filter
from ...formats.store import ERROR, EventStore
from ...formats.store_filter import Columns, matching
from ...formats.sweep import IsCancelled, ReportProgress


@dataclass(frozen=True)
class PreparedFilter:
    """What ``FilterView.prepare`` found: the filter's text and predicate (None:
    no filter), how many events it went through, and the store indices of
    those it selects (None: no filter)."""
    text: str
    pred: Predicate | None
    upto: int
    view: array | None


class FilterView:
    def __init__(self) -> None:
        self.text = ""
        self.history: list[str] = []
        self.pred: Predicate | None = None
        self.view: array | None = None           # indices of matching shown events; None: every one
        self.unsettled: list[Event] = []         # the unsettled events that match
        self.errors = 0                          # error rows among ``view`` (the status line's count)

    def settled(self, shown: int) -> int:
        """How many settled rows there are, of ``shown`` settled events."""
        return shown if self.view is None else len(self.view)

    def learn(self, store: EventStore, start: int, stop: int) -> None:
        """The stored events ``start``..``stop`` are shown now: the columns
        decide which match (``store_filter``), as for ``prepare``."""
        if self.pred is None or self.view is None or stop <= start:
            return
        found = matching(self.pred, store, start, stop)
        flags = store.flags
        self.view.extend(found)
        self.errors += sum(1 for i in found if flags[i] & ERROR)

    def hold(self, unsettled: list[Event]) -> None:
        """What pairing still holds now."""
        pred = self.pred
        self.unsettled = unsettled if pred is None else [e for e in unsettled if pred(e)]

    def forget(self) -> None:
        """The shown events are shown again from the start (a replay went back)."""
        if self.view is not None:
            self.view = array("i")
            self.errors = 0

    @staticmethod
    def prepare(text: str, store: EventStore, shown: int, *, progress: ReportProgress | None = None,
                cancelled: IsCancelled | None = None) -> PreparedFilter:
        """The filter ``text`` over the first ``shown`` events of ``store``.
        Raises FilterError for a bad expression, Cancelled when ``cancelled()``."""
        text = text.strip()
        pred = compile_filter(text) if text else None
        if pred is None:
            return PreparedFilter(text, None, shown, None)
        return PreparedFilter(text, pred, shown,
                              matching(pred, store, 0, shown, progress=progress, cancelled=cancelled))

    def apply(self, prepared: PreparedFilter, store: EventStore, shown: int, unsettled: list[Event]) -> None:
        """Show what ``prepare`` found, caught up with the ``shown`` events now."""
        pred, upto, view = prepared.pred, prepared.upto, prepared.view
        self.pred = pred
        self.text = prepared.text
        if pred is None or view is None:
            self.view = None
            self.unsettled = unsettled
            self.errors = 0
            return
        if upto > shown:   # a replay went back meanwhile
            view = array("i", view[:bisect_left(view, shown)])
            upto = shown
        view.extend(matching(pred, store, upto, shown))
        self.view = view
        self.errors = error_rows(store, view, shown)
        self.unsettled = [e for e in unsettled if pred(e)]
        if self.text in self.history:
            self.history.remove(self.text)
        self.history.append(self.text)


def error_rows(store: EventStore, view: array, shown: int) -> int:
    """How many of the rows ``view`` (store indices below ``shown``) are errors,
    from the store's flags column (copies: the arrays go on growing)."""
    import numpy as np

    if not len(view):
        return 0
    errors = Columns(store, 0, shown).flag(ERROR)
    return int(np.count_nonzero(errors[np.array(view, dtype=np.int64)]))
