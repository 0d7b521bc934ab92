"""What the TUI shows, without Textual: the rows of a capture, the filtered
view of them, navigation, follow mode and marks, statistics, the device map and
plots, and replay playback. The widgets only read it.

The events themselves are in an ``EventStore`` (columns, ``store.py``); the
parts here read it: ``Follow`` and ``Marks`` (follow.py), the filter's view
(an array of indices), ``Stats`` (analyzer/analysis/stats.py), ``DeviceMap``
(devices.py). Rows are rebuilt events, made when a row is drawn.

Events arrive in batches from the feed thread (``extend``), already paired and
settled; ``set_unsettled`` shows what pairing still holds, live, so a command
appears the moment it is on the wire and its status fills in when its answers
come. Event numbers are consecutive from 1, so event N is stored at index N - 1.

A replay stores the whole file as it loads; ``shown`` is how many of those
events the playback has reached. Statistics, plots and the device map describe
what has been shown.
"""

from __future__ import annotations

from array import array
from bisect import bisect_left, bisect_right
from dataclasses import dataclass
from typing import Callable

from dissectors.event import COMMAND, Event

from ..analysis.filter import compile_filter
from ..analysis.stats import Stats
from ..output import device_address, fmt_seconds, summary
from .detail import DetailNode, hex_lines
from .detail import detail as detail_tree
from .devices import DeviceInfo, DeviceMap
from .follow import Follow, Marks
from .scan import Cancelled, scan_first, scan_matching
from .store import KINDS, EventStore, EventsView, is_error

__all__ = ["CaptureModel", "Cancelled", "DetailNode", "DeviceInfo", "Playback", "hex_lines", "is_error"]

TIME_MODES = ("absolute", "relative", "delta")
COMMAND_CODE = KINDS.index(COMMAND)
_CACHE_MAX = 512   # rebuilt events kept: the rows on screen and their neighbours


@dataclass
class Playback:
    """Replay pace: the capture time shown so far advances with the wall clock,
    ``speed`` times as fast, while playing. ``speed`` 0 shows everything at once."""
    speed: float = 1.0
    playing: bool = True
    position: float = 0.0       # capture time (s) shown up to
    _anchor: float | None = None  # wall clock at the last update

    def tick(self, wall: float) -> float:
        if self.playing and self._anchor is not None:
            self.position += (wall - self._anchor) * self.speed
        self._anchor = wall
        return self.position


class CaptureModel:
    def __init__(self, *, follow: bool = True, slow: float = 0.1) -> None:
        self.store = EventStore()
        self.shown = 0                            # settled events shown (a replay: played)
        self.unsettled: list[Event] = []
        self._follow = Follow(follow)
        self.slow = slow               # seconds: answers slower than this are coloured
        self.time_mode = "absolute"
        self.filter_text = ""
        self.filter_history: list[str] = []
        self._pred: Callable[[Event], object] | None = None
        self._view: array | None = None           # indices of matching shown events
        self._unsettled_view: list[Event] = []
        self.stats = Stats()
        self._devices = DeviceMap()
        self._marks = Marks()
        self.playback: Playback | None = None
        self.findings: list = []                  # the wiring doctor's, from the capture thread
        self.done = False                         # the capture has ended
        self._cache: dict[int, Event] = {}

    # ------------------------------------------------------------ parts
    @property
    def events(self) -> EventsView:
        """The shown settled events (rebuilt when read)."""
        return EventsView(self.store, lambda: self.shown)

    @property
    def devices(self) -> dict[str, DeviceInfo]:
        return self._devices.devices

    @property
    def series(self):
        return self._devices.series

    @property
    def marks(self) -> Marks:
        return self._marks

    @property
    def error_count(self) -> int:
        return bisect_right(self.store.errors, self.shown)

    @property
    def answers(self) -> dict[int, list[int]]:
        """Command number -> its answers' numbers, for the shown events."""
        store, shown = self.store, self.shown
        out = {}
        for i in range(shown):
            if store.kind[i] == COMMAND_CODE:
                found = store.answers_of(i + 1, shown)
                if found:
                    out[i + 1] = found
        return out

    # follow mode (follow.py)
    @property
    def follow(self) -> bool:
        return self._follow.on

    @follow.setter
    def follow(self, on: bool) -> None:
        self._follow.on = on

    @property
    def away(self) -> bool:
        return self._follow.away

    @property
    def new_while_away(self) -> int:
        return self._follow.new_while_away

    def stop_following(self) -> None:
        """Any navigation: the view stays where the user put it."""
        self._follow.stop()

    def resume_following(self) -> None:
        self._follow.resume()

    # --------------------------------------------------------------- input
    def add(self, batch: list[Event], unsettled: list[Event]) -> int:
        """A batch from the capture thread: shown at once, or (a paced replay)
        stored for the playback to reach. Returns how many rows became visible."""
        pb = self.playback
        if pb is None or pb.speed == 0 and self.shown == len(self.store):
            return self.extend(batch) + self.set_unsettled(unsettled)
        self.store.append(batch)
        return 0

    def extend(self, batch: list[Event]) -> int:
        """Store and show settled events (wire order). Returns how many rows became visible."""
        before = self.row_count
        start = len(self.store)
        self.store.append(batch)
        self._show(batch, start)
        return self._grew(before)

    def _show(self, events: list[Event], start: int) -> None:
        """``events`` (stored from index ``start`` on) are shown now: the parts learn of them."""
        self.shown = start + len(events)
        add = self.stats.add
        for ev in events:
            add(ev)
        self._devices.add(events)
        pred = self._pred
        if pred is not None:
            self._view.extend([i for i, ev in enumerate(events, start) if pred(ev)])

    def set_unsettled(self, held: list[Event]) -> int:
        before = self.row_count
        self.unsettled = held
        pred = self._pred
        self._unsettled_view = held if pred is None else [e for e in held if pred(e)]
        return self._grew(before)

    def _grew(self, before: int) -> int:
        added = max(0, self.row_count - before)
        self._follow.grew(added)
        return added

    # ------------------------------------------------------------- filter
    def set_filter(self, text: str) -> None:
        """Show only events matching ``text`` (the ``decode --filter`` language).
        Raises FilterError (with the column) for a bad expression; an empty text
        shows everything."""
        pred, upto, view = self.prepare_filter(text)
        self.apply_filter(text, pred, upto, view)

    def prepare_filter(self, text: str, *, progress=None, cancelled=None) -> tuple:
        """The slow half of ``set_filter``, safe in a worker thread (the store only
        grows): (predicate, events scanned, matching indices). ``progress(done,
        total)`` is called as it goes; raises Cancelled when ``cancelled()``."""
        text = text.strip()
        pred = compile_filter(text) if text else None
        upto = self.shown
        if pred is None:
            return None, upto, None
        return pred, upto, scan_matching(self.store.event, 0, upto, pred, progress=progress, cancelled=cancelled)

    def apply_filter(self, text: str, pred, upto: int, view) -> None:
        """The fast half, on the thread that extends the model: catch up with the
        events shown while the view was being computed."""
        text = text.strip()
        self._pred = pred
        self.filter_text = text
        if pred is None:
            self._view = None
            self._unsettled_view = self.unsettled
            return
        if upto > self.shown:   # a replay went back meanwhile
            view = array("i", view[:bisect_left(view, self.shown)])
            upto = self.shown
        view.extend(scan_matching(self.store.event, upto, self.shown, pred))
        self._view = view
        self._unsettled_view = [e for e in self.unsettled if pred(e)]
        if text in self.filter_history:
            self.filter_history.remove(text)
        self.filter_history.append(text)

    # --------------------------------------------------------------- rows
    @property
    def settled_visible(self) -> int:
        return self.shown if self._view is None else len(self._view)

    @property
    def row_count(self) -> int:
        return self.settled_visible + len(self._unsettled_view)

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
        s = self.settled_visible
        if 0 <= i < s:
            return self._stored(i if self._view is None else self._view[i])
        if 0 <= i - s < len(self._unsettled_view):
            return self._unsettled_view[i - s]
        return None

    def row_of(self, number: int) -> int | None:
        """The row showing event ``number``, or None (filtered out, not yet shown)."""
        idx = number - 1
        s = self.settled_visible
        if 0 <= idx < self.shown:
            if self._view is None:
                return idx
            k = bisect_left(self._view, idx)
            return k if k < s and self._view[k] == idx else None
        for k, ev in enumerate(self._unsettled_view):
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
        if self._view is not None:
            k = bisect_left(self._view, idx)
            return max(0, min(k, self.row_count - 1))
        return max(0, min(idx, self.row_count - 1))

    # --------------------------------------------------------------- cells
    def time_text(self, ev: Event, row: int) -> str:
        t = ev.t
        if t is None:
            return "-"
        mode = self.time_mode
        if mode == "relative":
            store = self.store
            first = store.t[0] if len(store) and store.timed(0) else 0.0
            return f"+{t - first:.6f}"
        if mode == "delta":
            prev = self.row(row - 1) if row > 0 else None
            if prev is None or prev.t is None:
                return "+0.000000"
            return f"+{t - prev.t:.6f}"
        return f"{t:.6f}"

    def cells(self, ev: Event, row: int) -> tuple[str, ...]:
        """No., time, lane, address, kind, command, summary, status, latency."""
        if ev.kind == COMMAND:
            status = ev.status or "…"
            if ev.retransmission:
                status += " retx"
        elif ev.request is not None:
            status = f"#{ev.request}"
        else:
            status = ""
        lane = "→ A" if ev.line == "A" else "← B" if ev.line == "B" else ("→" if ev.kind == COMMAND else "←")
        text = summary(ev)
        if ev.problems:
            text += "  ! " + "; ".join(ev.problems)
        return (str(ev.number), self.time_text(ev, row), lane, device_address(ev), ev.kind,
                ev.command or "", text, status, fmt_seconds(ev.latency))

    def cycle_time_mode(self) -> str:
        self.time_mode = TIME_MODES[(TIME_MODES.index(self.time_mode) + 1) % len(TIME_MODES)]
        return self.time_mode

    # ---------------------------------------------------------- navigation
    def next_error(self, number: int, forward: bool = True) -> int | None:
        """The next (or previous) error event after ``number`` that is shown."""
        errs = self.store.errors
        last = bisect_right(errs, self.shown)
        if forward:
            rng = range(bisect_right(errs, number, 0, last), last)
        else:
            rng = range(bisect_left(errs, number, 0, last) - 1, -1, -1)
        if self._view is None:
            for j in rng:
                return errs[j]
        else:
            for j in rng:
                if self.row_of(errs[j]) is not None:
                    return errs[j]
        return None

    def partner(self, number: int) -> int | None:
        """The paired event: an answer's request, a command's first answer."""
        ev = self.event(number)
        if ev is None:
            return None
        if ev.kind == COMMAND:
            found = self._answers_of(number)
            return found[0] if found else None
        return ev.request

    def same_device(self, number: int, forward: bool = True) -> int | None:
        """The next (previous) shown event concerning the same device."""
        ev = self.event(number)
        if ev is None:
            return None
        addr = ev.device
        if not addr:
            return None
        row = self.row_of(number)
        if row is None:
            return None
        code = self.store.device_code(addr)
        settled = self.settled_visible
        if row < settled:
            found = self._same_device_settled(row, code, forward) if code is not None else None
            if found is not None or not forward:
                return found
            unsettled = range(settled, self.row_count)
        else:
            unsettled = range(row + 1, self.row_count) if forward else range(row - 1, settled - 1, -1)
        for r in unsettled:
            other = self.row(r)
            if other is not None and other.device == addr:
                return other.number
        if not forward and row >= settled and code is not None:
            return self._same_device_settled(settled, code, False)
        return None

    def _same_device_settled(self, row: int, code: int, forward: bool) -> int | None:
        """Among settled rows after (before) ``row``, the first whose device has ``code``."""
        dev = self.store.device
        view = self._view
        if view is None:
            if forward:
                try:
                    return dev.index(code, row + 1, self.shown) + 1
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

    def toggle_mark(self, number: int) -> bool:
        return self._marks.toggle(number)

    def next_mark(self, number: int) -> int | None:
        return self._marks.next(number, lambda m: self.row_of(m) is not None)

    def search(self, text: str, after: int, forward: bool = True, *, progress=None, cancelled=None) -> int | None:
        """The next shown event whose row text contains ``text`` (case-insensitive),
        wrapping round. Safe in a worker thread; raises Cancelled when ``cancelled()``."""
        needle = text.lower()
        row = self.row_of(after)
        start = row if row is not None else -1
        n = self.row_count
        step = 1 if forward else -1

        def test(r: int) -> bool:
            ev = self.row(r)
            return ev is not None and needle in " ".join(self.cells(ev, r)).lower()

        order = _Wrapped(start, step, n)
        r = scan_first(order, test, progress=progress, cancelled=cancelled)
        if r is None:
            return None
        ev = self.row(r)
        return ev.number if ev is not None else None

    def window(self, start: float, end: float, most: int = 4000) -> list[Event]:
        """Events on the wire between ``start`` and ``end`` (timeline), filter or not:
        the timeline shows the wire."""
        times = self.store.t
        i = bisect_left(times, start - 0.5, 0, self.shown)   # a long frame may start before the window
        j = bisect_right(times, end, i, self.shown)
        out = [e for e in map(self._stored, range(i, min(j, i + most))) if e.t_end is not None and e.t_end >= start]
        out += [e for e in self.unsettled if e.t is not None and e.t <= end and e.t_end >= start]
        return out

    # -------------------------------------------------------------- replay
    def start_playback(self, speed: float) -> None:
        self.playback = Playback(speed=speed)

    def advance_playback(self, wall: float) -> int:
        """Move a replay on to ``wall`` clock time; returns rows newly shown."""
        pb = self.playback
        if pb is None:
            return 0
        store = self.store
        if pb.speed == 0:
            return self._play_to(len(store))
        if not self.shown and len(store) and pb.position == 0.0:
            pb.position = store.t[0]   # playing starts at the first event
        return self._play_to(bisect_right(store.t, pb.tick(wall)))

    def seek(self, seconds: float) -> None:
        """Move a replay's position by ``seconds`` of capture time (either way)."""
        pb = self.playback
        store = self.store
        if pb is None or not len(store):
            return
        first, last = store.t[0], store.t[len(store) - 1]
        pb.position = min(max(pb.position + seconds, first), last)
        self._play_to(bisect_right(store.t, pb.position))

    def _play_to(self, k: int) -> int:
        """Show the first ``k`` stored events. Going back rebuilds the parts from
        the start (a few seconds per million events)."""
        n = self.shown
        if k > n:
            before = self.row_count
            self._show(list(self.store.events(n, k)), n)
            return self._grew(before)
        if k < n:
            self._reset()
            self._show(list(self.store.events(0, k)), 0)
        return 0

    def _reset(self) -> None:
        """Forget what the parts learnt of the shown events (not the filter,
        marks or stored events)."""
        self.shown = 0
        self.stats = Stats()
        self._devices = DeviceMap()
        self._cache.clear()
        if self._view is not None:
            self._view = array("i")

    @property
    def position(self) -> float | None:
        return self.playback.position if self.playback is not None else None

    # -------------------------------------------------------------- detail
    def detail(self, ev: Event) -> list[DetailNode]:
        """The detail tree of one event: frame, fields, problems, pairing."""
        return detail_tree(ev, self._answers_of, self.event)

    def _answers_of(self, number: int) -> list[int]:
        found = self.store.answers_of(number, self.shown) if number <= self.shown else []
        found += [e.number for e in self.unsettled if e.request == number and e.number not in found]
        return found


class _Wrapped:
    """Rows ``start + step``, ``start + 2·step``, … round ``n`` rows, each once."""

    def __init__(self, start: int, step: int, n: int) -> None:
        self.start, self.step, self.n = start, step, n

    def __len__(self) -> int:
        return self.n

    def __iter__(self):
        start, step, n = self.start, self.step, self.n
        for k in range(1, n + 1):
            yield (start + step * k) % n
