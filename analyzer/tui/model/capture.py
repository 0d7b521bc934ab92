"""``CaptureModel``: the rows of a capture as the TUI shows them, made of the
parts of this package (filter, follow and marks, navigation, row text,
replay, totals: the counts, statistics and device map; plots). The widgets
only read it.

The events themselves are in an ``EventStore`` (columns, ``store.py``); rows
are rebuilt events, made when a row is drawn. Events arrive in batches from
the feed thread (``extend``), already paired and settled; ``set_unsettled``
shows what pairing still holds, live, so a command appears the moment it is
on the wire and its status fills in when its answers come. Event numbers are
consecutive from 1, so event N is stored at index N - 1.

A replay stores the whole file as it loads; ``shown`` is how many of those
events the playback has reached. The totals and the plots describe what has
been shown.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right

from dissectors.event import Event

from ...analysis.findings import Finding
from ...formats.marks import Mark, marked_text
from ...formats.store import EventStore, EventsView
from ...formats.sweep import IsCancelled, ReportProgress
from ..detail import DetailNode
from ..detail import detail as detail_tree
from .chunks import ModelChunk
from .filter import FilterView, PreparedFilter
from .follow import Follow, Marks
from .navigation import Navigation
from .plots import PositionPlots, Series
from .replay import Replay
from .row_text import RowText
from .totals import Totals

_CACHE_MAX = 512   # rebuilt events kept: the rows on screen and their neighbours


class CaptureModel:
    def __init__(self, *, follow: bool = True, slow: float = 0.1) -> None:
        self.store = EventStore()
        self.shown = 0                            # settled events shown (a replay: played)
        self.unsettled: list[Event] = []
        self.slow = slow               # seconds: answers slower than this are coloured
        self.findings: list[Finding] = []         # the wiring doctor's, from the capture thread
        self.findings_known = False               # the doctor has had its say (``findings`` may be empty)
        self.doctor_error: str | None = None      # the doctor's process failed: why
        self.done = False                         # the capture has ended
        # the parts
        self.following = Follow(follow)
        self.marks = Marks()
        self.filter = FilterView()
        self.nav = Navigation(self)
        self.text = RowText(self)
        self.replay = Replay(self)
        self.totals = Totals(self)
        self.plots = PositionPlots()
        self._cache: dict[int, Event] = {}

    # ------------------------------------------------------------ parts
    @property
    def events(self) -> EventsView:
        """The shown settled events (rebuilt when read)."""
        return EventsView(self.store, lambda: self.shown)

    @property
    def series(self) -> dict[str, dict[str, Series]]:
        return self.plots.series

    @property
    def follow(self) -> bool:
        return self.following.on

    @follow.setter
    def follow(self, on: bool) -> None:
        self.following.on = on

    @property
    def new_while_away(self) -> int:
        return self.following.new_while_away

    # --------------------------------------------------------------- input
    def add(self, batch: list[Event], unsettled: list[Event]) -> int:
        """A batch from the capture thread: shown at once, or (a paced replay)
        stored for the playback to reach. Returns how many rows became visible."""
        if self._shown_as_they_come():
            return self.extend(batch) + self.set_unsettled(unsettled)
        self.store.append(batch)
        return 0

    def add_chunk(self, chunk: ModelChunk) -> int:
        """Events as columns from a process decoding the file (``chunks.py``):
        ``add`` without event objects. Returns how many rows became visible."""
        if not self._shown_as_they_come():
            self.store.append_chunk(chunk.stored)   # ``show_first`` rebuilds them when the playback is there
            return 0
        before = self.row_count
        start = len(self.store)
        self.store.append_chunk(chunk.stored)
        self.shown = len(self.store)
        self.totals.checksum_errors += chunk.checksum_errors
        self.plots.merge(chunk.points)
        self.filter.learn(self.store, start, self.shown)
        # a decoding process holds its unsettled events until they settle
        return self._grew(before) + self.set_unsettled([])

    def _shown_as_they_come(self) -> bool:
        """New events are shown as they arrive: not a paced replay's, which are
        stored for the playback to reach."""
        pb = self.replay.playback
        return pb is None or pb.speed == 0 and self.shown == len(self.store)

    def extend(self, batch: list[Event]) -> int:
        """Store and show settled events (wire order). Returns how many rows became visible."""
        before = self.row_count
        start = len(self.store)
        devices = self.store.append(batch)
        self._show(batch, start, devices)
        return self._grew(before)

    def _show(self, events: list[Event], start: int, devices: list[str | None] | None = None) -> None:
        """``events`` (stored from index ``start`` on; ``devices``, their devices) are
        shown now: the parts learn of them."""
        self.shown = start + len(events)
        if devices is None:
            devices = [ev.device for ev in events]
        self.totals.learn(events)
        self.plots.add(events, devices)
        self.filter.learn(self.store, start, self.shown)

    def set_unsettled(self, held: list[Event]) -> int:
        before = self.row_count
        self.unsettled = held
        self.filter.hold(held)
        return self._grew(before)

    def _grew(self, before: int) -> int:
        added = max(0, self.row_count - before)
        self.following.grew(added)
        return added

    def show_first(self, k: int) -> int:
        """Show the first ``k`` stored events (a replay's position); returns rows
        newly shown. Going back forgets what the parts learnt (not the filter,
        marks or stored events) and shows them again from the start (a few
        seconds per million events)."""
        n = self.shown
        if k > n:
            before = self.row_count
            self._show(list(self.store.events(n, k)), n)
            return self._grew(before)
        if k < n:
            self.shown = 0
            self.totals.forget()
            self.plots = PositionPlots()
            self._cache.clear()
            self.filter.forget()
            self._show(list(self.store.events(0, k)), 0)
        return 0

    # ------------------------------------------------------------- filter
    def set_filter(self, text: str) -> None:
        """Show only events matching ``text`` (the ``decode --filter`` language).
        Raises FilterError (with the column) for a bad expression; an empty text
        shows everything."""
        self.apply_filter(self.prepare_filter(text))

    def prepare_filter(self, text: str, *, progress: ReportProgress | None = None,
                       cancelled: IsCancelled | None = None) -> PreparedFilter:
        """The slow half of ``set_filter``, safe in a worker thread (the store only
        grows): the events shown so far that ``text`` selects. ``progress(done,
        total)`` is called as it goes; raises Cancelled when ``cancelled()``."""
        return FilterView.prepare(text, self.store, self.shown, progress=progress, cancelled=cancelled)

    def apply_filter(self, prepared: PreparedFilter) -> None:
        """The fast half, on the thread that extends the model: catch up with the
        events shown while the view was being computed."""
        self.filter.apply(prepared, self.store, self.shown, self.unsettled)

    @property
    def filter_text(self) -> str:
        return self.filter.text

    # --------------------------------------------------------------- rows
    @property
    def row_count(self) -> int:
        return self.filter.settled(self.shown) + len(self.filter.unsettled)

    @property
    def largest_number(self) -> int:
        """The largest event number a row can show (the number column's width)."""
        last = self.unsettled[-1].number if self.unsettled else 0
        return max(self.shown, last)

    def _stored(self, i: int) -> Event:
        cache = self._cache
        ev = cache.get(i)
        if ev is None:
            if len(cache) >= _CACHE_MAX:
                cache.clear()
            ev = cache[i] = self.store.event(i)
        return ev

    def row(self, i: int) -> Event | None:
        view = self.filter.view
        s = self.shown if view is None else len(view)
        if 0 <= i < s:
            return self._stored(i if view is None else view[i])
        unsettled = self.filter.unsettled
        if 0 <= i - s < len(unsettled):
            return unsettled[i - s]
        return None

    def row_of(self, number: int) -> int | None:
        """The row showing event ``number``, or None (filtered out, not yet shown)."""
        idx = number - 1
        view = self.filter.view
        s = self.filter.settled(self.shown)
        if 0 <= idx < self.shown:
            if view is None:
                return idx
            k = bisect_left(view, idx)
            return k if k < s and view[k] == idx else None
        for k, ev in enumerate(self.filter.unsettled):
            if ev.number == number:
                return s + k
        return None

    def event(self, number: int) -> Event | None:
        if 1 <= number <= self.shown:
            return self._stored(number - 1)
        for ev in self.unsettled:
            if ev.number == number:
                return ev
        return None

    def nearest_row(self, number: int) -> int:
        """The row of ``number``, or of the closest shown event after it (before it at the end)."""
        r = self.row_of(number)
        if r is not None:
            return r
        idx = number - 1
        if self.filter.view is not None:
            k = bisect_left(self.filter.view, idx)
            return max(0, min(k, self.row_count - 1))
        return max(0, min(idx, self.row_count - 1))

    def window(self, start: float, end: float, most: int = 4000) -> list[Event]:
        """Events on the wire between ``start`` and ``end`` (timeline), filter or not:
        the timeline shows the wire."""
        times = self.store.t
        i = bisect_left(times, start - 0.5, 0, self.shown)   # a long frame may start before the window
        j = bisect_right(times, end, i, self.shown)
        out = [e for e in map(self._stored, range(i, min(j, i + most))) if e.t_end is not None and e.t_end >= start]
        out += [e for e in self.unsettled if e.t is not None and e.t <= end and e.t_end is not None and e.t_end >= start]
        return out

    # -------------------------------------------------------------- detail
    def as_mark(self, number: int, note: str | None) -> Mark:
        """Event ``number``'s mark with ``note`` (None: the mark taken off), at the event's time."""
        ev = self.event(number)
        return Mark(number, note or "", ev.t if ev is not None else None, removed=note is None)

    def detail(self, ev: Event) -> list[DetailNode]:
        """The detail tree of one event: its mark and note first, then frame,
        fields, problems, pairing."""
        nodes = detail_tree(ev, self.answers_of, self.event)
        note = self.marks.note(ev.number) if ev.number is not None else None
        if note is not None:
            nodes.insert(0, DetailNode(marked_text(note)))
        return nodes

    def answers_of(self, number: int) -> list[int]:
        found = self.store.answers_of(number, self.shown) if number <= self.shown else []
        found += [e.number for e in self.unsettled if e.request == number and e.number not in found]
        return found
