"""Moving between related events among the rows a model shows: the next
error, the paired request or answer, the next event of the same device, the
next mark, the next row holding a text or matching a filter expression
(``=EXPR``, as Wireshark's "find by display filter"). Each returns an event
number, or None when there is none (the screen rings the bell)."""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Iterator
from typing import TYPE_CHECKING, Protocol

from dissectors.event import COMMAND, Event

from ...formats.store import KIND_CODE, EventStore
from ...formats.sweep import IsCancelled, ReportProgress, first_match
from .filter import FilterView
from .follow import Marks
from .row_text import RowText

if TYPE_CHECKING:
    import numpy as np

COMMAND_CODE = KIND_CODE[COMMAND]
FIND_BY_FILTER = "="   # a search text that starts with it is a filter expression


class Browsed(Protocol):
    """What navigation reads of the model (capture.py)."""
    store: EventStore
    shown: int
    filter: FilterView
    marks: Marks
    text: RowText

    @property
    def row_count(self) -> int: ...

    def row(self, i: int) -> Event | None: ...

    def row_of(self, number: int) -> int | None: ...

    def event(self, number: int) -> Event | None: ...

    def answers_of(self, number: int) -> list[int]: ...


class Navigation:
    def __init__(self, model: Browsed) -> None:
        self.model = model
        # find by filter: (expression, shown, store indices it selects)
        self._hits: tuple[str, int, np.ndarray] | None = None

    @property
    def answers(self) -> dict[int, list[int]]:
        """Command number -> its answers' numbers, for the shown events."""
        store, shown = self.model.store, self.model.shown
        out: dict[int, list[int]] = {}
        for i in range(shown):
            if store.kind[i] == COMMAND_CODE:
                found = store.answers_of(i + 1, shown)
                if found:
                    out[i + 1] = found
        return out

    def next_error(self, number: int, forward: bool = True) -> int | None:
        """The next (or previous) error event after ``number`` that is shown."""
        m = self.model
        errs = m.store.errors
        last = bisect_right(errs, m.shown)
        if forward:
            rng = range(bisect_right(errs, number, 0, last), last)
        else:
            rng = range(bisect_left(errs, number, 0, last) - 1, -1, -1)
        if m.filter.view is None:
            for j in rng:
                return errs[j]
        else:
            for j in rng:
                if m.row_of(errs[j]) is not None:
                    return errs[j]
        return None

    def partner(self, number: int) -> int | None:
        """The paired event: an answer's request, a command's first answer."""
        ev = self.model.event(number)
        if ev is None:
            return None
        if ev.kind == COMMAND:
            found = self.model.answers_of(number)
            return found[0] if found else None
        return ev.request

    def next_mark(self, number: int) -> int | None:
        m = self.model
        return m.marks.next(number, lambda mark: m.row_of(mark) is not None)

    def same_device(self, number: int, forward: bool = True) -> int | None:
        """The next (previous) shown event concerning the same device."""
        m = self.model
        ev = m.event(number)
        if ev is None:
            return None
        addr = ev.device
        if not addr:
            return None
        row = m.row_of(number)
        if row is None:
            return None
        code = m.store.device_code(addr)
        settled = m.filter.settled(m.shown)
        if row < settled:
            found = self._same_device_settled(row, code, forward) if code is not None else None
            if found is not None or not forward:
                return found
            unsettled = range(settled, m.row_count)
        else:
            unsettled = range(row + 1, m.row_count) if forward else range(row - 1, settled - 1, -1)
        for r in unsettled:
            other = m.row(r)
            if other is not None and other.device == addr:
                return other.number
        if not forward and row >= settled and code is not None:
            return self._same_device_settled(settled, code, False)
        return None

    def _same_device_settled(self, row: int, code: int, forward: bool) -> int | None:
        """Among settled rows after (before) ``row``, the first whose device has ``code``."""
        dev = self.model.store.device
        view = self.model.filter.view
        if view is None:
            if forward:
                try:
                    return dev.index(code, row + 1, self.model.shown) + 1
                except ValueError:
                    return None
            b = row
            while b > 0:   # backwards, in reversed chunks searched at C speed
                a = max(0, b - 65536)
                chunk = dev[a:b]
                chunk.reverse()
                try:
                    return b - chunk.index(code)   # index b - 1 - k, as a number
                except ValueError:
                    b = a
            return None
        rng = range(row + 1, len(view)) if forward else range(row - 1, -1, -1)
        for r in rng:
            if dev[view[r]] == code:
                return view[r] + 1
        return None

    def search(self, text: str, after: int, forward: bool = True, *, progress: ReportProgress | None = None,
               cancelled: IsCancelled | None = None) -> int | None:
        """The next shown event whose row text contains ``text`` (case-insensitive),
        or, for ``=EXPR``, that the filter expression EXPR selects; wrapping round.
        Safe in a worker thread; raises Cancelled when ``cancelled()``, FilterError
        for a bad expression."""
        if text.startswith(FIND_BY_FILTER):
            return self.find_by_filter(text[len(FIND_BY_FILTER):], after, forward, progress=progress,
                                       cancelled=cancelled)
        m = self.model
        needle = text.lower()
        row = m.row_of(after)
        start = row if row is not None else -1
        cells = m.text.cells

        def test(r: int) -> bool:
            ev = m.row(r)
            return ev is not None and needle in " ".join(cells(ev, r)).lower()

        r = first_match(_Wrapped(start, 1 if forward else -1, m.row_count), test,
                        progress=progress, cancelled=cancelled)
        if r is None:
            return None
        ev = m.row(r)
        return ev.number if ev is not None else None

    def find_by_filter(self, expr: str, after: int, forward: bool = True, *,
                       progress: ReportProgress | None = None, cancelled: IsCancelled | None = None) -> int | None:
        """The next shown event after ``after`` that the filter expression selects,
        wrapping round: the stored events through the store's columns
        (``store_filter.matching``, as a filter), kept for the next ``n`` while no
        more events are shown; the unsettled ones by the expression itself."""
        import numpy as np

        from ...analysis.filter import compile_filter
        from ...formats.store_filter import matching

        m = self.model
        expr = expr.strip()
        pred = compile_filter(expr)
        shown = m.shown
        if self._hits is None or self._hits[:2] != (expr, shown):
            self._hits = (expr, shown, np.frombuffer(
                matching(pred, m.store, 0, shown, progress=progress, cancelled=cancelled).tobytes(), dtype=np.int32))
        hits = self._hits[2]
        view = m.filter.view
        if view is not None:   # the rows of the stored hits the filter shows
            shown_rows = np.frombuffer(view.tobytes(), dtype=np.int32)
            hits = np.flatnonzero(np.isin(shown_rows, hits))
        settled = m.filter.settled(shown)
        held = [settled + k for k, ev in enumerate(m.filter.unsettled) if pred(ev)]
        rows = np.concatenate([hits.astype(np.int64), np.array(held, dtype=np.int64)])
        if not len(rows):
            return None
        here = m.row_of(after)
        here = -1 if here is None else here
        if forward:
            k = int(np.searchsorted(rows, here, side="right"))
            r = int(rows[k if k < len(rows) else 0])
        else:
            k = int(np.searchsorted(rows, here, side="left")) - 1
            r = int(rows[k])   # -1: the last, round the end
        ev = m.row(r)
        return ev.number if ev is not None else None


class _Wrapped:
    """Rows ``start + step``, ``start + 2·step``, … round ``n`` rows, each once."""

    def __init__(self, start: int, step: int, n: int) -> None:
        self.start, self.step, self.n = start, step, n

    def __len__(self) -> int:
        return self.n

    def __iter__(self) -> Iterator[int]:
        start, step, n = self.start, self.step, self.n
        for k in range(1, n + 1):
            yield (start + step * k) % n
