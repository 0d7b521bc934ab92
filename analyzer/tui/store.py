"""The TUI's event store: a day of events in columns, not objects.

An ``Event`` object costs about 600 bytes; a day at 115200 baud is tens of
millions of them. The store keeps, per event, what the list, the filters, the
navigation keys and the statistics need, in typed arrays (stdlib ``array``),
and the event's raw bytes in one ``bytearray``: 56 bytes plus the raw
bytes an event. ``event(i)`` rebuilds the ``Event`` on demand, from the raw
bytes (the frame's header, its payload) and the columns, re-dissecting the
payload through the command table's memo (``dissectors.dissect``), so a row's
text and its detail tree are made only for rows on screen.

What re-dissection cannot give back is kept beside the columns, sparsely: an
event's problems (most events have none) and the fields of events that are not
commands or results (a rate change's). A command's fields are its payload's
decode and a result's its decode against the command it answers, as pairing
made them; tests/pure/test_tui_store.py checks that a rebuilt event equals the
stored one on the sample captures and on hostile lines.

Appends come from one thread (the screen's); readers in worker threads (a
filter scanning) read indices below the length they started with: arrays only
grow, so those stay valid.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterator, Sequence

from dissectors.dissect import dissect_command, dissect_result
from dissectors.event import (
    ACK, COMMAND, FRAME, NAK, NIC, NO_ACK, NO_FIELDS, NO_PROBLEMS, NO_RESULT, NOISE, OK, PENDING, RATE, RESULT, ST_NAK,
    ST_NIC, Event)

KINDS = (COMMAND, RESULT, ACK, NAK, NIC, NOISE, RATE, FRAME)
STATUSES = (None, OK, ST_NAK, ST_NIC, NO_ACK, NO_RESULT, PENDING)
_KIND_CODE = {k: i for i, k in enumerate(KINDS)}
_STATUS_CODE = {s: i for i, s in enumerate(STATUSES)}

# flag bits
UNTIMED = 1        # t and t_end are None; the t column holds the index (the timeline's order)
FRAMED = 2         # a frame: dst, src and payload are in its raw bytes (Table 1)
CHECKSUM_OK = 4
CHECKSUM_BAD = 8
RETRANSMISSION = 16
ERROR = 32         # a row the error keys stop at (``is_error``)
LINKED = 64        # has a pairing record (its ``transaction``)

_NAN = math.nan
# events after a command its answers are looked for in: pairing gives up on a
# result after its timeout (at most 90 s, IX), a minute and a half of a saturated
# 115200-baud line is about 100,000 events
ANSWER_WINDOW = 250_000
_CHECKSUM_FLAG = {None: 0, True: CHECKSUM_OK, False: CHECKSUM_BAD}
_ERROR_KINDS = frozenset((NAK, NOISE))
_ERROR_STATUS = frozenset((ST_NAK, ST_NIC, NO_ACK, NO_RESULT))
_DISSECTED = frozenset((COMMAND, RESULT))


def is_error(ev: Event) -> bool:
    """Rows the error keys jump between: anything with a problem, NAKs and noise,
    and commands that did not end ok."""
    return bool(ev.problems) or ev.kind in _ERROR_KINDS or ev.status in _ERROR_STATUS


_WIDER = {"H": "I", "I": "q"}


def _extend_wide(column: array, values: list[int]) -> array:
    """Extend a narrow column, or a wider copy of it once a value needs more (a
    line past 4 GB, garbled input naming 65,536 commands): bytes saved on every
    event of every capture that needs no more."""
    n = len(column)
    try:
        column.extend(values)
        return column
    except OverflowError:
        del column[n:]
        return _extend_wide(array(_WIDER[column.typecode], column), values)


class Link:
    """A rebuilt event's pairing record: the part of ``analyzer.analysis.pairing.Transaction``
    that readers of events use (the statistics, ``Event.device``)."""

    __slots__ = ("command", "device")

    def __init__(self, command: str | None, device: str | None) -> None:
        self.command = command
        self.device = device


class _Interned:
    """Values that repeat (lines, devices, command ids with their table entries)
    as small codes; code 0 is None. A value is found by its key: itself, or what
    ``codes_of`` is given (commands are keyed by the table entry's identity: an
    entry is a dataclass whose hash goes through every field)."""

    __slots__ = ("values", "codes")

    def __init__(self, none_key=None) -> None:
        self.values: list = [None]
        self.codes: dict = {none_key: 0}

    def code(self, key, value) -> int:
        c = self.codes.get(key)
        if c is None:
            c = self.codes[key] = len(self.values)
            self.values.append(value)
        return c

    def codes_of(self, keys: list, values=None) -> list[int]:
        """The codes of ``keys``, new ones made for their ``values()`` (default:
        the keys themselves). Every key known is the common case: one lookup each."""
        codes = self.codes
        try:
            return [codes[k] for k in keys]
        except KeyError:
            return [self.code(k, v) for k, v in zip(keys, keys if values is None else values())]


class EventStore:
    """Settled events in wire order; event number N is index N - 1."""

    def __init__(self) -> None:
        self.raw = bytearray()
        self.end = array("I")         # raw bytes of event i: raw[end[i-1]:end[i]] (64-bit past 4 GB)
        self.t = array("d")           # t, or the index when untimed
        self.t_end = array("d")
        self.offset = array("I")      # on its line (64-bit past 4 GB)
        self.kind = array("B")
        self.line = array("B")
        self.status = array("B")
        self.flags = array("B")
        self.command = array("H")     # (command id, table entry) code (wider when needed)
        self.device = array("H")
        self.latency = array("d")     # NaN: none
        self.request = array("i")     # 0: none
        self.txn = array("i")         # txn + 1; 0: none
        self.errors = array("i")      # numbers of error rows, ascending
        self.problems: dict[int, list] = {}     # index -> the event's problems
        self.fields: dict[int, dict] = {}       # index -> fields re-dissection does not give
        self._lines = _Interned()
        self._commands = _Interned(none_key=(None, id(None)))   # code -> (command id, table entry)
        self._devices = _Interned()

    def __len__(self) -> int:
        return len(self.kind)

    # --------------------------------------------------------------- input
    def append(self, batch: list[Event]) -> list[str | None]:
        """Store settled events, numbered consecutively from len(self) + 1; their
        devices (``Event.device``, worked out once here for the model's other parts).

        Column by column (a comprehension each): several times faster than one
        loop appending to every column, and loading a day's file is this loop."""
        if not batch:
            return []
        start = len(self.kind)
        raw = self.raw
        ends = []
        for ev in batch:
            raw += ev.raw
            ends.append(len(raw))
        self.end = _extend_wide(self.end, ends)
        t = [ev.t for ev in batch]
        if None in t:
            self.t.extend([float(i) if x is None else x for i, x in enumerate(t, start)])
            self.t_end.extend([_NAN if ev.t is None else ev.t_end for ev in batch])
        else:
            self.t.extend(t)
            self.t_end.extend([ev.t_end for ev in batch])
        self.offset = _extend_wide(self.offset, [ev.offset for ev in batch])
        kc = _KIND_CODE
        self.kind.extend([kc[ev.kind] for ev in batch])
        self.line.extend(self._lines.codes_of([ev.line for ev in batch]))
        sc = _STATUS_CODE
        self.status.extend([sc[ev.status] for ev in batch])
        # keyed by the table entry's identity: hashing the entry was a third of this loop
        self.command = _extend_wide(self.command, self._commands.codes_of(
            [(ev.command, id(ev.entry)) for ev in batch], lambda: [(ev.command, ev.entry) for ev in batch]))
        devices = [ev.device for ev in batch]
        self.device = _extend_wide(self.device, self._devices.codes_of(devices))
        self.latency.extend([_NAN if ev.latency is None else ev.latency for ev in batch])
        request = [ev.request or 0 for ev in batch]
        self.request.extend(request)
        self.txn.extend([0 if ev.txn is None else ev.txn + 1 for ev in batch])
        flags = [(UNTIMED if ev.t is None else 0) | (FRAMED if ev.dst is not None else 0)
                 | _CHECKSUM_FLAG[ev.checksum_ok] | (RETRANSMISSION if ev.retransmission else 0)
                 | (LINKED if ev.transaction is not None else 0) | (ERROR if is_error(ev) else 0)
                 for ev in batch]
        self.flags.extend(flags)
        errors = [i for i, f in enumerate(flags, start) if f & ERROR]   # events with problems among them
        self.errors.extend([i + 1 for i in errors])
        problems = self.problems
        for i in errors:
            ev = batch[i - start]
            if ev.problems:
                problems[i] = ev.problems
        # commands and results: their fields are their payload's decode (pairing
        # dissects every command, and a result against the command it answers);
        # other events' fields (a rate change's) are kept
        for i, ev in enumerate(batch, start):
            if ev.fields and ev.kind not in _DISSECTED:
                self.fields[i] = ev.fields
        return devices

    @staticmethod
    def _natural_fields(kind: str, payload: bytes | None, entry) -> dict:
        """The fields a re-dissection of the payload gives."""
        if payload is None:
            return NO_FIELDS
        if kind == COMMAND:
            return dissect_command(payload).fields
        if kind == RESULT:
            return dissect_result(entry, payload)[0] if entry is not None else NO_FIELDS
        return NO_FIELDS

    # --------------------------------------------------------------- reading
    def device_code(self, device: str) -> int | None:
        """The device column's code for ``device``; None if no event has it."""
        return self._devices.codes.get(device)

    def timed(self, i: int) -> bool:
        return not self.flags[i] & UNTIMED

    def answers_of(self, number: int, upto: int | None = None) -> list[int]:
        """The answers' numbers of command ``number`` in wire order (those up to
        ``upto`` only): the events after it whose ``request`` is ``number``,
        found by the request column's own search (C speed) within
        ``ANSWER_WINDOW`` events, farther than pairing ever waits."""
        out: list[int] = []
        request = self.request
        stop = min(len(request), number + ANSWER_WINDOW, len(request) if upto is None else upto)
        i = number   # the index after the command's
        while i < stop:
            try:
                i = request.index(number, i, stop)
            except ValueError:
                break
            i += 1
            out.append(i)   # index i - 1 is event number i
        return out

    def event(self, i: int) -> Event:
        """Event number i + 1, rebuilt."""
        a = self.end[i - 1] if i else 0
        raw = bytes(self.raw[a:self.end[i]])
        flags = self.flags[i]
        kind = KINDS[self.kind[i]]
        if flags & UNTIMED:
            ev = Event(self._lines.values[self.line[i]], self.offset[i], kind, raw)
        else:
            ev = Event(self._lines.values[self.line[i]], self.offset[i], kind, raw, self.t[i], self.t_end[i])
        ev.number = i + 1
        if flags & FRAMED:
            ev.dst = (raw[1], raw[2], raw[3])
            ev.src = raw[4]
            ev.payload = raw[6:-1]
        if flags & CHECKSUM_OK:
            ev.checksum_ok = True
        elif flags & CHECKSUM_BAD:
            ev.checksum_ok = False
        code = self.command[i]
        if code:
            ev.command, ev.entry = self._commands.values[code]
        fields = self.fields.get(i)
        if fields is None:
            fields = self._natural_fields(kind, ev.payload, ev.entry)
        ev.fields = fields
        ev.problems = self.problems.get(i, NO_PROBLEMS)
        ev.status = STATUSES[self.status[i]]
        lat = self.latency[i]
        if lat == lat:   # not NaN
            ev.latency = lat
        ev.retransmission = bool(flags & RETRANSMISSION)
        req = self.request[i]
        if req:
            ev.request = req
        txn = self.txn[i]
        if txn:
            ev.txn = txn - 1
        if flags & LINKED:
            device = self._devices.values[self.device[i]]
            if kind == COMMAND:
                command = ev.command
            elif req:
                c = self.command[req - 1]
                command = self._commands.values[c][0] if c else None
            else:
                command = ev.command
            ev.transaction = Link(command, device)
        return ev

    def events(self, start: int = 0, stop: int | None = None) -> Iterator[Event]:
        stop = len(self) if stop is None else stop
        for i in range(start, stop):
            yield self.event(i)


class EventsView(Sequence):
    """The first ``count()`` events of a store as a read-only sequence of
    rebuilt events (``model.events``)."""

    def __init__(self, store: EventStore, count) -> None:
        self._store = store
        self._count = count

    def __len__(self) -> int:
        return self._count()

    def __getitem__(self, k):
        n = self._count()
        if isinstance(k, slice):
            return [self._store.event(i) for i in range(*k.indices(n))]
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError("event index out of range")
        return self._store.event(k)

    def __iter__(self) -> Iterator[Event]:
        return self._store.events(0, self._count())
