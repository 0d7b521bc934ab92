"""What the TUI shows, without Textual: the events of a capture, the filtered
view of them, the pairing index ("answers #N", "ACK in #M after 4.2 ms"),
statistics, marks, follow mode and replay playback. The widgets only read it.

Events arrive in batches from the feed thread (``extend``), already paired and
settled; ``set_unsettled`` shows what pairing still holds, live, so a command
appears the moment it is on the wire and its status fills in when its answers
come. Event numbers are consecutive from 1, so event N is ``events[N - 1]``.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from dataclasses import dataclass, field
from typing import Callable

from dissectors.event import (
    ACK, COMMAND, NAK, NIC, NO_ACK, NO_RESULT, NOISE, RESULT, ST_NAK, ST_NIC, Event, format_address,
)

from ..filter import compile_filter
from ..output import device_address, fmt_seconds, summary
from ..stats import Stats

TIME_MODES = ("absolute", "relative", "delta")


def is_error(ev: Event) -> bool:
    """Rows the error keys jump between: anything with a problem, NAKs, and
    commands that did not end ok."""
    return bool(ev.problems) or ev.kind in (NAK, NOISE) or ev.status in (ST_NAK, ST_NIC, NO_ACK, NO_RESULT)


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


@dataclass
class DeviceInfo:
    """One device of the device map."""
    address: str
    lines: set[str] = field(default_factory=set)       # lines its answers came on
    commands: int = 0
    answered: int = 0
    nic: set[str] = field(default_factory=set)         # commands it answered with NIC


@dataclass
class DetailNode:
    """A line of the detail tree: a label, children, and where Enter goes."""
    label: str
    children: list["DetailNode"] = field(default_factory=list)
    jump: int | None = None                 # an event number
    span: tuple[int, int] | None = None     # bytes of the event this field covers
    expanded: bool = True


class CaptureModel:
    def __init__(self, *, follow: bool = True, slow: float = 0.1) -> None:
        self.events: list[Event] = []
        self.unsettled: list[Event] = []
        self.follow = follow
        self.away = False              # the user navigated away from the end (follow stopped)
        self.new_while_away = 0        # "+N new" since then
        self.slow = slow               # seconds: answers slower than this are coloured
        self.time_mode = "absolute"
        self.filter_text = ""
        self._pred: Callable[[Event], object] | None = None
        self._view: list[int] | None = None      # indices of matching settled events
        self._unsettled_view: list[Event] = []
        self.answers: dict[int, list[int]] = {}  # command number -> its answers' numbers
        self.errors: list[int] = []              # numbers of error events, ascending
        self.stats = Stats()
        self.devices: dict[str, DeviceInfo] = {}
        self.marks: set[int] = set()
        self.series: dict[str, dict[str, list[tuple[float, float]]]] = {}  # device -> name -> (t, deg)
        self._times: list[float] = []            # events' t (untimed: their index): timeline
        # Replays: the whole file is decoded into ``loaded`` ahead of the screen; the
        # playback position moves events from there into the model, so statistics,
        # plots and the device map describe what has been played so far.
        self.playback: Playback | None = None
        self.loaded: list[Event] = []
        self._loaded_times: list[float] = []
        self.filter_history: list[str] = []
        self.findings: list = []                 # the wiring doctor's, from the capture thread
        self.done = False                        # the capture has ended

    # --------------------------------------------------------------- input
    def add(self, batch: list[Event], unsettled: list[Event]) -> int:
        """A batch from the capture thread: shown at once, or (replay) loaded for
        the playback to reach. Returns how many rows became visible."""
        if self.playback is None:
            return self.extend(batch) + self.set_unsettled(unsettled)
        self.loaded.extend(batch)
        self._loaded_times.extend(ev.t if ev.t is not None else float(k)
                                  for k, ev in enumerate(batch, len(self._loaded_times)))
        return 0

    def extend(self, batch: list[Event]) -> int:
        """Add settled events (wire order). Returns how many rows became visible."""
        before = self.row_count
        events = self.events
        answers, errors, stats_add = self.answers, self.errors, self.stats.add
        times = self._times
        pred = self._pred
        view = self._view
        for ev in batch:
            idx = len(events)
            events.append(ev)
            times.append(ev.t if ev.t is not None else float(idx))
            req = ev.request
            if req is not None:
                answers.setdefault(req, []).append(ev.number)
            if is_error(ev):
                errors.append(ev.number)
            stats_add(ev)
            self._device(ev)
            if pred is not None and pred(ev):
                view.append(idx)
        return self._grew(before)

    def set_unsettled(self, held: list[Event]) -> int:
        before = self.row_count
        self.unsettled = held
        pred = self._pred
        self._unsettled_view = held if pred is None else [e for e in held if pred(e)]
        return self._grew(before)

    def _grew(self, before: int) -> int:
        added = max(0, self.row_count - before)
        if self.away:
            self.new_while_away += added
        return added

    def stop_following(self) -> None:
        """Any navigation: the view stays where the user put it."""
        if self.follow:
            self.follow = False
            self.away = True
            self.new_while_away = 0

    def resume_following(self) -> None:
        self.follow = True
        self.away = False
        self.new_while_away = 0

    def _device(self, ev: Event) -> None:
        kind = ev.kind
        if kind not in (COMMAND, RESULT, ACK, NAK, NIC):
            return
        if kind != COMMAND and ev.transaction is None:
            return   # an unpaired answer says nothing about where a device answers
        addr = ev.device
        if addr is None:
            return
        info = self.devices.get(addr)
        if info is None:
            info = self.devices[addr] = DeviceInfo(addr)
        if kind == COMMAND:
            info.commands += 1
            if ev.status == ST_NIC and ev.command:
                info.nic.add(ev.command)
            fields = ev.fields
            if ev.command == "P" and fields and "azimuth_deg" in fields:   # go to (Table 11)
                self._point(addr, "commanded", ev.t, fields)
            return
        info.lines.add(ev.line)
        if kind in (ACK, NAK):
            info.answered += 1
        elif kind == RESULT and ev.command == "P?" and ev.fields and "azimuth_deg" in ev.fields:
            self._point(addr, "reported", ev.t, ev.fields)

    def _point(self, addr: str, which: str, t: float | None, fields: dict) -> None:
        if t is None:
            return
        series = self.series.setdefault(addr, {})
        series.setdefault(f"{which} azimuth", []).append((t, fields["azimuth_deg"]))
        if "elevation_deg" in fields:
            series.setdefault(f"{which} elevation", []).append((t, fields["elevation_deg"]))

    # ------------------------------------------------------------- filter
    def set_filter(self, text: str) -> None:
        """Show only events matching ``text`` (the ``decode --filter`` language).
        Raises FilterError (with the column) for a bad expression; an empty text
        shows everything."""
        pred, upto, view = self.prepare_filter(text)
        self.apply_filter(text, pred, upto, view)

    def prepare_filter(self, text: str) -> tuple:
        """The slow half of ``set_filter``, safe in a worker thread (events are only
        appended): (predicate, events scanned, matching indices)."""
        text = text.strip()
        pred = compile_filter(text) if text else None
        events = self.events
        upto = len(events)
        if pred is None:
            return None, upto, None
        return pred, upto, [i for i in range(upto) if pred(events[i])]

    def apply_filter(self, text: str, pred, upto: int, view: list[int] | None) -> None:
        """The fast half, on the thread that extends the model: catch up with the
        events that arrived while the view was being computed."""
        text = text.strip()
        self._pred = pred
        self.filter_text = text
        if pred is None:
            self._view = None
            self._unsettled_view = self.unsettled
            return
        events = self.events
        view.extend(i for i in range(upto, len(events)) if pred(events[i]))
        self._view = view
        self._unsettled_view = [e for e in self.unsettled if pred(e)]
        if text in self.filter_history:
            self.filter_history.remove(text)
        self.filter_history.append(text)

    # --------------------------------------------------------------- rows
    @property
    def settled_visible(self) -> int:
        return len(self.events) if self._view is None else len(self._view)

    @property
    def row_count(self) -> int:
        return self.settled_visible + len(self._unsettled_view)

    def row(self, i: int) -> Event | None:
        s = self.settled_visible
        if 0 <= i < s:
            return self.events[i if self._view is None else self._view[i]]
        if 0 <= i - s < len(self._unsettled_view):
            return self._unsettled_view[i - s]
        return None

    def row_of(self, number: int) -> int | None:
        """The row showing event ``number``, or None (filtered out, not yet shown)."""
        idx = number - 1
        s = self.settled_visible
        if 0 <= idx < len(self.events):
            if self._view is None:
                return idx
            k = bisect_left(self._view, idx)
            return k if k < s and self._view[k] == idx else None
        for k, ev in enumerate(self._unsettled_view):
            if ev.number == number:
                return s + k
        return None

    def event(self, number: int) -> Event | None:
        if 1 <= number <= len(self.events):
            return self.events[number - 1]
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
            first = self.events[0].t if self.events and self.events[0].t is not None else 0.0
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
        errs = self.errors
        if forward:
            k = bisect_right(errs, number)
            rng = range(k, len(errs))
        else:
            k = bisect_left(errs, number)
            rng = range(k - 1, -1, -1)
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
            found = self.answers.get(number)
            if found:
                return found[0]
            for other in self.unsettled:   # still held: answers link to it already
                if other.request == number:
                    return other.number
            return None
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
        step = 1 if forward else -1
        r = row + step
        while 0 <= r < self.row_count:
            other = self.row(r)
            if other is not None and other.device == addr:
                return other.number
            r += step
        return None

    def toggle_mark(self, number: int) -> bool:
        if number in self.marks:
            self.marks.discard(number)
            return False
        self.marks.add(number)
        return True

    def next_mark(self, number: int) -> int | None:
        shown = sorted(m for m in self.marks if self.row_of(m) is not None)
        if not shown:
            return None
        k = bisect_right(shown, number)
        return shown[k % len(shown)]

    def search(self, text: str, after: int, forward: bool = True) -> int | None:
        """The next shown event whose row text contains ``text`` (case-insensitive)."""
        needle = text.lower()
        row = self.row_of(after)
        start = row if row is not None else -1
        n = self.row_count
        step = 1 if forward else -1
        for k in range(1, n + 1):
            r = (start + step * k) % n
            ev = self.row(r)
            if ev is not None and needle in " ".join(self.cells(ev, r)).lower():
                return ev.number
        return None

    def window(self, start: float, end: float, most: int = 4000) -> list[Event]:
        """Events on the wire between ``start`` and ``end`` (timeline), filter or not:
        the timeline shows the wire."""
        times = self._times
        i = bisect_left(times, start - 0.5)   # a long frame may start before the window
        j = bisect_right(times, end, i)
        out = [e for e in self.events[i:min(j, i + most)] if e.t_end is not None and e.t_end >= start]
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
        if pb.speed == 0:
            return self._play_to(len(self.loaded))
        if not self.events and self._loaded_times and pb.position == 0.0:
            pb.position = self._loaded_times[0]   # playing starts at the first event
        return self._play_to(bisect_right(self._loaded_times, pb.tick(wall)))

    def seek(self, seconds: float) -> None:
        """Move a replay's position by ``seconds`` of capture time (either way)."""
        pb = self.playback
        if pb is None or not self._loaded_times:
            return
        first, last = self._loaded_times[0], self._loaded_times[-1]
        pb.position = min(max(pb.position + seconds, first), last)
        self._play_to(bisect_right(self._loaded_times, pb.position))

    def _play_to(self, k: int) -> int:
        """Show the first ``k`` loaded events. Going back rebuilds the model's
        indexes from the start (about a second per 300k events)."""
        n = len(self.events)
        if k > n:
            return self.extend(self.loaded[n:k])
        if k < n:
            self._reset()
            self.extend(self.loaded[:k])
        return 0

    def _reset(self) -> None:
        """Forget the shown events (not the filter, marks or loaded ones)."""
        self.events = []
        self._times = []
        self.answers = {}
        self.errors = []
        self.stats = Stats()
        self.devices = {}
        self.series = {}
        if self._view is not None:
            self._view = []

    @property
    def position(self) -> float | None:
        return self.playback.position if self.playback is not None else None

    # -------------------------------------------------------------- detail
    def detail(self, ev: Event) -> list[DetailNode]:
        """The detail tree of one event: frame, fields, problems, pairing."""
        from dissectors.dissect import field_spans

        nodes: list[DetailNode] = []
        n = len(ev.raw)
        head = DetailNode(f"#{ev.number} {ev.kind} on line {ev.line}, bytes {ev.offset}–{ev.offset + n - 1}"
                          f" of the line ({n} byte{'' if n == 1 else 's'})")
        if ev.t is not None:
            head.children.append(DetailNode(f"time {ev.t:.6f} s → {ev.t_end:.6f} s"))
        if ev.dst is not None:
            head.children.append(DetailNode(f"address {format_address(ev.dst)} (group.port.device)", span=(1, 4)))
            head.children.append(DetailNode(f"source group {ev.src}", span=(4, 5)))
            head.children.append(DetailNode(f"length {len(ev.payload)}", span=(5, 6)))
            ok = "ok" if ev.checksum_ok else "BAD"
            head.children.append(DetailNode(f"checksum 0x{ev.raw[-1]:02x} {ok}", span=(len(ev.raw) - 1, len(ev.raw))))
        device = self._device_line(ev)
        if device is not None:
            head.children.append(device)
        nodes.append(head)
        if ev.command or ev.fields:
            entry = ev.entry
            title = f"{ev.command or '?'}"
            if entry is not None:
                title += f" — {entry.name} ({entry.ref})"
            cmd = DetailNode(title)
            spans = {name: (a, b) for name, a, b in field_spans(ev)}
            units = {f.name: f.unit for f in _fields_of(entry)} if entry is not None else {}
            for name, value in (ev.fields or {}).items():
                unit = units.get(name, "")
                span = spans.get(name)
                where = f"  [bytes {span[0]}–{span[1] - 1}]" if span else ""
                cmd.children.append(DetailNode(f"{name} = {value}{(' ' + unit) if unit else ''}{where}", span=span))
            nodes.append(cmd)
        if ev.problems:
            nodes.append(DetailNode("problems", [DetailNode(p) for p in ev.problems]))
        pairing = DetailNode("pairing")
        if ev.kind == COMMAND:
            pairing.children.append(DetailNode(f"status {ev.status or 'waiting'}"
                                               + (" (retransmission)" if ev.retransmission else "")))
            for num in self._answers_of(ev.number):
                ans = self.event(num)
                if ans is None:
                    continue
                what = {ACK: "ACK", NAK: "NAK", NIC: "NIC", RESULT: "result"}.get(ans.kind, ans.kind)
                after = f" after {fmt_seconds(ans.latency)}" if ans.latency is not None else ""
                pairing.children.append(DetailNode(f"{what} in #{num}{after}", jump=num))
        elif ev.request is not None:
            after = f", {fmt_seconds(ev.latency)} after it ended" if ev.latency is not None else ""
            pairing.children.append(DetailNode(f"answers #{ev.request}{after}", jump=ev.request))
        else:
            pairing.children.append(DetailNode("not paired"))
        nodes.append(pairing)
        return nodes

    @staticmethod
    def _device_line(ev: Event) -> DetailNode | None:
        """Where the device is not the header's destination as written: a result
        (its header addresses the controller) and an ACK/NAK/NIC (no header)."""
        device = ev.device
        if device is None or ev.kind == COMMAND:
            return None
        if ev.kind == RESULT:
            return DetailNode(f"device {device} (source group {ev.src}, port and device as addressed)", span=(2, 5))
        return DetailNode(f"device {device} (the command's, #{ev.request})", jump=ev.request)

    def _answers_of(self, number: int) -> list[int]:
        found = list(self.answers.get(number, ()))
        found += [e.number for e in self.unsettled if e.request == number and e.number not in found]
        return found


def _fields_of(entry) -> list:
    out = list(entry.layout.fields) if getattr(entry, "layout", None) is not None else []
    for layout in entry.result or ():
        out += list(layout.fields)
    return out


def hex_lines(raw: bytes, highlight: tuple[int, int] | None = None, width: int = 16) -> list[tuple[str, str, list[tuple[int, int]]]]:
    """Hex and ASCII of ``raw``, ``width`` bytes a line: (offset, hex, ascii) and,
    per line, the character ranges of the hex text to highlight."""
    out = []
    for start in range(0, len(raw), width):
        part = raw[start:start + width]
        hx = " ".join(f"{b:02x}" for b in part)
        asc = "".join(chr(b) if 0x20 <= b < 0x7F else "." for b in part)
        marks = []
        if highlight is not None:
            a, b = max(highlight[0], start), min(highlight[1], start + len(part))
            if a < b:   # half-open columns of the hex text: "0e 0f" without the space after
                marks.append(((a - start) * 3, (b - start) * 3 - 1))
        out.append((f"{start:04x}", hx, asc, marks))
    return out
