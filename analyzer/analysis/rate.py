"""Following the link's rate (docs/time.md, "Rate changes"): a pure observer of
deframed events, in arrival order, that says when the link's rate changed.

The controller sets the rate with ``C0``…``C7`` (spec Table 4: 1200…115200 bit/s).
The device ACKs at the old rate (§1.4.2) and both ends use the new one after the
ACK, so the change takes effect at the end of the ACK byte. What is not a change:

- a rate-set command that is NAKed, or that gets no ACK before the next command;
- ``C8``…``CF`` (reserved; a device answers ACK then NIC);
- an ACK followed at once by NIC: the device does not implement it, so the change
  that the ACK started is taken back.

Wildcard addresses (255 at any level): the rate belongs to the wire, not to one
device, and the spec gives no exception for broadcasts, so a wildcard rate-set is
followed like any other once it is ACKed. One that gets no ACK leaves the rate as
it was; ``RateFollower.unconfirmed`` says so, since the devices may have switched.

Acting on a change (the lines' settings, the event in the output, the warnings)
is the capture's: analyzer/capture/rates.py.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from dissectors.commands import BAUD_CODES
from dissectors.event import ACK, COMMAND, FRAME, NAK, NIC, RATE, Event
from dissectors.wire import WILDCARD

_C = 0x43   # "C"
# What a rate-set frame looks like in the bytes: a start byte, four header bytes,
# length 2, "C" (payloads are ASCII, so a start byte begins a frame). A capture
# looks for it in the bytes it reads and watches the events only when it is there:
# most captures never change rate, and every event would cost a look.
RATE_MARK = re.compile(rb"\xf8[\x00-\xff]{4}\x02C")
_HEX = {ord(c): int(c, 16) for c in "0123456789ABCDEF"}


def rate_set(ev: Event) -> int | None:
    """The rate a command frame sets (``C0``…``C7``), else None."""
    payload = ev.payload
    if payload is None or len(payload) != 2 or payload[0] != _C or not ev.checksum_ok:
        return None
    return BAUD_CODES.get(_HEX.get(payload[1], -1))


@dataclass(frozen=True)
class RateChange:
    """The link's rate changed at ``t`` (the end of the ACK), or was taken back."""
    baud: int
    previous: int
    command: Event      # the rate-set command
    answer: Event       # the ACK that confirmed it (or the NIC that took it back)
    taken_back: bool = False

    @property
    def t(self) -> float | None:
        return self.answer.t_end

    def event(self) -> Event:
        """The rate event in the output: on the answer's line, right after it."""
        a = self.answer
        ev = Event(a.line, a.offset + len(a.raw), RATE, b"", a.t_end, a.t_end)
        ev.fields = {"baud": self.baud, "previous_baud": self.previous}
        return ev


class RateFollower:
    """Feed it every event as deframed (``observe``); it returns a ``RateChange``
    when the link's rate changes."""

    def __init__(self, baud: int) -> None:
        self.baud = baud
        self.changes = 0
        self._asked: tuple[Event, int] | None = None     # a rate-set waiting for its ACK
        self._done: RateChange | None = None              # the change an ACK just made
        self.unconfirmed: list[tuple[Event, int]] = []   # wildcard rate-sets that got no ACK
        # frames with a two-byte payload starting "C" looked at: what a ``RATE_MARK`` in
        # the bytes turned out to be (a rate-set, or CN, CX, a B? result "C7"...)
        self.marked = 0

    @property
    def busy(self) -> bool:
        """A rate-set waits for its answer, or an ACK for a NIC that would take it back."""
        return self._asked is not None or self._done is not None

    def scan(self, events: list[Event]) -> list[RateChange]:
        """``observe`` each of ``events`` that can matter, in order. Called for
        every batch a capture deframes, so it passes over the rest cheaply: while
        no rate-set waits, only a two-byte payload starting with ``C`` is looked at."""
        changes: list[RateChange] = []
        for ev in events:
            kind = ev.kind
            if kind == COMMAND or kind == FRAME:
                p = ev.payload
                if p is not None and len(p) == 2 and p[0] == _C:
                    self.marked += 1
                elif not self.busy:
                    continue
            elif not self.busy:
                continue
            change = self.observe(ev)
            if change is not None:
                changes.append(change)
        return changes

    def observe(self, ev: Event) -> RateChange | None:
        kind = ev.kind
        if kind == COMMAND or kind == FRAME:
            self._done = None
            asked = self._asked
            if asked is not None and _wildcard(asked[0]):
                self.unconfirmed.append(asked)
            baud = rate_set(ev) if ev.line != "B" else None
            self._asked = (ev, baud) if baud is not None else None
            return None
        if kind == ACK:
            self._done = None
            asked, self._asked = self._asked, None
            if asked is None or asked[1] == self.baud:
                return None
            change = RateChange(asked[1], self.baud, asked[0], ev)
            self.baud = asked[1]
            self.changes += 1
            self._done = change
            return change
        if kind == NIC:
            done, self._done = self._done, None
            if done is None:
                return None
            self.baud = done.previous
            return RateChange(done.previous, done.baud, done.command, ev, taken_back=True)
        if kind == NAK:
            self._asked = self._done = None
        return None


def _wildcard(ev: Event) -> bool:
    dst = ev.dst
    return dst is not None and WILDCARD in dst
