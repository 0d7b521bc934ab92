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
filter sweeping the rows) read indices below the length they started with:
arrays only grow, so those stay valid.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable, Hashable, Iterator, Sequence
from dataclasses import dataclass
from itertools import accumulate
from typing import Any, cast, overload

from dissectors.commands import COMMANDS, Command
from dissectors.dissect import dissect_command, dissect_result
from dissectors.event import (
    ACK,
    COMMAND,
    FRAME,
    NAK,
    NIC,
    NO_ACK,
    NO_FIELDS,
    NO_PROBLEMS,
    NO_RESULT,
    NOISE,
    OK,
    PENDING,
    RATE,
    RESULT,
    ST_NAK,
    ST_NIC,
    Event,
)
from dissectors.problems import Problem

KINDS = (COMMAND, RESULT, ACK, NAK, NIC, NOISE, RATE, FRAME)
STATUSES = (None, OK, ST_NAK, ST_NIC, NO_ACK, NO_RESULT, PENDING)
KIND_CODE = {k: i for i, k in enumerate(KINDS)}       # a kind's code in the kind column
STATUS_CODE = {s: i for i, s in enumerate(STATUSES)}  # a status's code in the status column

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


def _extend_array(column: array, more: array) -> array:
    """Extend ``column`` by ``more``, both of the widening typecodes (``_WIDER``)
    or both the same: the narrower made as wide as the other first."""
    if more.itemsize > column.itemsize:
        column = array(more.typecode, column)
    elif more.typecode != column.typecode:
        more = array(column.typecode, more)
    column.extend(more)
    return column


def natural_fields(kind: str, payload: bytes | None, entry: Command | None) -> dict[str, Any]:
    """The fields a re-dissection of an event's payload gives: a command's, and a
    result's against the table entry of the command it answers (which is why the
    store keeps only other events' fields)."""
    if payload is None:
        return NO_FIELDS
    if kind == COMMAND:
        return dissect_command(payload).fields
    if kind == RESULT:
        return dissect_result(entry, payload)[0] if entry is not None else NO_FIELDS
    return NO_FIELDS


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

    __slots__ = ("codes", "taken", "values")

    def __init__(self, none_key: Hashable = None) -> None:
        self.values: list[Any] = [None]
        self.codes: dict[Hashable, int] = {none_key: 0}
        self.taken = 1      # values handed on by ``take`` (the None code needs no handing)

    def code(self, key: Hashable, value: Any) -> int:
        c = self.codes.get(key)
        if c is None:
            c = self.codes[key] = len(self.values)
            self.values.append(value)
        return c

    def codes_of(self, keys: list[Any], values: Callable[[], list[Any]] | None = None) -> list[int]:
        """The codes of ``keys``, new ones made for their ``values()`` (default:
        the keys themselves). Every key known is the common case: one lookup each."""
        codes = self.codes
        try:
            return [codes[k] for k in keys]
        except KeyError:   # code the new keys only (garbled traffic brings new ones in many batches)
            valued = dict(zip(keys, keys if values is None else values()))
            for k, v in valued.items():
                if k not in codes:
                    self.code(k, v)
            return [codes[k] for k in keys]

    def take(self) -> list[Any]:
        """The values coded since the last take, in code order."""
        new = self.values[self.taken:]
        self.taken = len(self.values)
        return new

    def learn(self, keys: list[Any], values: list[Any]) -> None:
        """Values another table coded (``take``), given the next codes here."""
        for k, v in zip(keys, values):
            self.codes[k] = len(self.values)
            self.values.append(v)


# the per-event columns (and the error rows' numbers), as a StoreChunk carries them
COLUMNS = ("end", "t", "t_end", "offset", "kind", "line", "status", "flags", "command", "device", "latency",
           "request", "txn", "errors")
_ENTRY_PLACE = {id(c): k for k, c in enumerate(COMMANDS)}


@dataclass
class StoreChunk:
    """Events stored by one process's store, handed to another's: a file viewed
    is decoded in a process of its own (decode_process.py) and the screen's store
    takes its columns, a copy of arrays rather than a million objects.

    ``start`` is the index of its first event; ``columns`` the arrays of
    ``COLUMNS`` (``end`` counted from the start of the capture's raw bytes, so
    appending is copying); ``problems`` and ``fields`` keyed by index; the lists,
    values the sending store's interned tables coded since its last chunk (a
    command's table entry as its place in ``COMMANDS``: the receiving process
    has its own table, whose entries are the ones that must be found)."""
    start: int
    columns: dict[str, array]
    raw: bytes
    problems: dict[int, Sequence[Problem]]
    fields: dict[int, dict[str, Any]]
    lines: list[str | None]
    devices: list[str | None]
    commands: list[tuple[str | None, int | Command | None]]   # (command id, place in COMMANDS, or the entry itself)


class EventStore:
    """Settled events in wire order; event number N is index N - 1.

    A store that hands its events on (``take``) keeps only those since the
    last take: ``base`` events (``raw_base`` raw bytes) were handed on."""

    def __init__(self) -> None:
        self.base = 0
        self.raw_base = 0
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
        self.problems: dict[int, Sequence[Problem]] = {}   # index -> the event's problems
        self.fields: dict[int, dict[str, Any]] = {}        # index -> fields re-dissection does not give
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
        start = self.base + len(self.kind)
        raws = [ev.raw for ev in batch]
        ends = list(accumulate(map(len, raws), initial=self.raw_base + len(self.raw)))
        del ends[0]
        self.raw += b"".join(raws)
        self.end = _extend_wide(self.end, ends)
        t = [ev.t for ev in batch]
        # an event with a time has an end time (readers give both), and rows without
        # one are told apart first: the casts say so at no cost a row
        if None in t:
            self.t.extend([float(i) if x is None else x for i, x in enumerate(t, start)])
            self.t_end.extend(cast("list[float]", [_NAN if ev.t is None else ev.t_end for ev in batch]))
        else:
            self.t.extend(cast("list[float]", t))
            self.t_end.extend(cast("list[float]", [ev.t_end for ev in batch]))
        self.offset = _extend_wide(self.offset, [ev.offset for ev in batch])
        kc = KIND_CODE
        self.kind.extend([kc[ev.kind] for ev in batch])
        self.line.extend(self._lines.codes_of([ev.line for ev in batch]))
        sc = STATUS_CODE
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
        error_kinds, error_status = _ERROR_KINDS, _ERROR_STATUS
        flags = [(UNTIMED if ev.t is None else 0) | (FRAMED if ev.dst is not None else 0)
                 | _CHECKSUM_FLAG[ev.checksum_ok] | (RETRANSMISSION if ev.retransmission else 0)
                 | (LINKED if ev.transaction is not None else 0)
                 # is_error(ev), inline: a call per event was a tenth of this loop
                 | (ERROR if ev.problems or ev.kind in error_kinds or ev.status in error_status else 0)
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
        self.fields.update([(i, ev.fields) for i, ev in enumerate(batch, start)
                            if ev.fields and ev.kind not in _DISSECTED])
        return devices

    def take(self) -> StoreChunk:
        """The events appended since the last take, handed on (``append_chunk``
        of another process's store); this store forgets them but not its codes."""
        chunk = StoreChunk(self.base, {name: getattr(self, name) for name in COLUMNS}, bytes(self.raw),
                           self.problems, self.fields, self._lines.take(), self._devices.take(),
                           [(command, _ENTRY_PLACE.get(id(entry), entry))
                            for command, entry in self._commands.take()])
        self.base += len(self.kind)
        self.raw_base += len(self.raw)
        for name in COLUMNS:
            setattr(self, name, array(getattr(self, name).typecode))
        self.raw = bytearray()
        self.problems = {}
        self.fields = {}
        return chunk

    def append_chunk(self, chunk: StoreChunk) -> None:
        """Store the events another store handed on (``take``); they follow this
        store's last event."""
        if chunk.start != len(self):
            raise ValueError(f"a chunk from event {chunk.start + 1} does not follow event {len(self)}")
        self._lines.learn(chunk.lines, chunk.lines)
        self._devices.learn(chunk.devices, chunk.devices)
        commands = [(command, COMMANDS[place] if isinstance(place, int) else place)
                    for command, place in chunk.commands]
        self._commands.learn([(command, id(entry)) for command, entry in commands], commands)
        self.raw += chunk.raw
        for name in COLUMNS:
            setattr(self, name, _extend_array(getattr(self, name), chunk.columns[name]))
        self.problems.update(chunk.problems)
        self.fields.update(chunk.fields)

    # --------------------------------------------------------------- reading
    def column(self, name: str) -> array:
        """The column ``name`` (one of ``COLUMNS``): row i is event i's."""
        if name not in COLUMNS:
            raise KeyError(name)
        return getattr(self, name)

    @property
    def line_values(self) -> list[str | None]:
        """The line each code of the ``line`` column stands for (code 0: None)."""
        return list(self._lines.values)

    @property
    def device_values(self) -> list[str | None]:
        """The device each code of the ``device`` column stands for (code 0: None)."""
        return list(self._devices.values)

    @property
    def command_ids(self) -> list[str | None]:
        """The command id each code of the ``command`` column stands for (code 0:
        None; several codes can have one id, each with its own table entry)."""
        return [None if v is None else v[0] for v in list(self._commands.values)]

    @property
    def command_places(self) -> list[list[Any] | None]:
        """Each code of the ``command`` column as [command id, the table entry's
        place in ``COMMANDS``] (code 0: None; an entry not in the table: None,
        which only a hand-made event can have)."""
        return [None if v is None else [v[0], _ENTRY_PLACE.get(id(v[1]))] for v in list(self._commands.values)]

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
            fields = natural_fields(kind, ev.payload, ev.entry)
        ev.fields = fields
        ev.problems = self.problems.get(i, NO_PROBLEMS)
        ev.status = STATUSES[self.status[i]]
        lat = self.latency[i]
        if lat == lat:   # noqa: PLR0124 - not NaN: the test without a call, for every row rebuilt
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


class EventsView(Sequence[Event]):
    """The first ``count()`` events of a store as a read-only sequence of
    rebuilt events (``model.events``)."""

    def __init__(self, store: EventStore, count: Callable[[], int]) -> None:
        self._store = store
        self._count = count

    def __len__(self) -> int:
        return self._count()

    @overload
    def __getitem__(self, k: int) -> Event: ...

    @overload
    def __getitem__(self, k: slice) -> list[Event]: ...

    def __getitem__(self, k: int | slice) -> Event | list[Event]:
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
