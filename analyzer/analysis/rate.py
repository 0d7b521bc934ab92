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

Which rate a line runs at, when a tap read it at another (the wiring doctor's
``wrong_baud``): ``rate_scores`` re-simulates a UART at the tap's rate reading
this protocol's traffic sent at each standard rate, and says how like each the
bytes are (below, "which rate the bytes were sent at").
"""

from __future__ import annotations

import math
import random
import re
from bisect import bisect_left
from collections import Counter
from dataclasses import dataclass
from functools import cache

from dissectors.commands import BAUD_CODES
from dissectors.event import ACK, COMMAND, FRAME, NAK, NIC, RATE, Event
from dissectors.wire import ACK as ACK_BYTE
from dissectors.wire import NAK as NAK_BYTE
from dissectors.wire import NIC as NIC_BYTE
from dissectors.wire import WILDCARD, build_frame

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

    def follow(self, events: list[Event]) -> list[RateChange]:
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


# ------------------------------------------------------------ which rate the bytes were sent at
# A byte capture (a socat log, a raw dump, a recording of a serial tap) holds what
# the tap's UART read at its own rate R. Traffic sent at another rate R' is misread
# in a way that depends on R'/R alone: the reader starts a character at every
# falling edge it sees while idle and samples the line in the middle of each of
# its own bits, so start and stop bits land on fixed bits of what it reads (at
# R' = R/2 every byte read has bit 0 clear and bits 1-2, 3-4, 5-6 equal; at
# R' = 2R bit 3 is the sender's stop bit, set). Which rate the line runs at is
# tested by re-simulating it: protocol traffic sent at each standard rate R' and
# read by a UART at R gives the bytes a tap at R would see; the rate whose bytes
# are most like the capture's (per byte, log-likelihood against random bytes)
# is the line's. Docs: docs/doctor.md, "Wrong rate or not this protocol".

PROTOCOL_RATES = tuple(sorted(BAUD_CODES.values()))   # §1.5.1: 1200 … 115200

# typical commands (Tables 4-17) and result payloads: what the reference traffic
# is made of. The bytes that matter are the start byte, small address bytes, the
# length, ASCII payloads and the answer bytes; which commands exactly does not.
_REF_COMMANDS = ("P?", "P?", "P0FA0FC18", "P?01", "S?01", "V?", "AW", "D?", "G?", "E?", "RP0401", "RT0401",
                 "HO", "I?", "L?", "B?", "IX", "V0A0123", "GRP0F", "LS0000FF0000FF")
_REF_RESULTS = ("03E8FE0C", "0FA0FC18", "FE0C03E8", "0000", "1", "C3", "G?0F0F0000", "0A0123",
                "0101PTZ-200             SN000123            ")


# a character on the wire, one level per bit: start bit, 8 data bits LSB first, stop bit
_CHAR_BITS = [bytes((0, *((v >> b) & 1 for b in range(8)), 1)) for v in range(256)]
_FALL = re.compile(b"\x01\x00")


def line_levels(messages: list[tuple[int, bytes]]) -> tuple[bytearray, list[int]]:
    """A line's levels, one per sender bit time (1 idle), and its falling edges (the
    bit indexes where it goes low), from ``messages``: (its first bit's index; its
    bytes, 8N1, sent back to back), in order and not overlapping."""
    end = max((at + 10 * len(data) for at, data in messages), default=0)
    levels = bytearray(b"\x01") * (end + 1)          # and one idle bit after the last
    for at, data in messages:
        levels[at:at + 10 * len(data)] = b"".join(_CHAR_BITS[v] for v in data)
    edges = [m.start() + 1 for m in _FALL.finditer(levels)]
    if levels and levels[0] == 0:
        edges.insert(0, 0)
    return levels, edges


def read_as_uart(levels: bytearray, edges: list[int], sent: int, read: int, framing_errors: bool = True,
                 resync: bool = False) -> bytes:
    """The bytes a UART at ``read`` bit/s makes of a line sent at ``sent`` bit/s
    (``line_levels``). The reader starts a character at a falling edge (seen 1/32
    of its bit late, as a 16x-oversampling UART does on average), samples its 8
    data bits and its stop bit in their middles, and hunts for the next falling
    edge from the middle of the stop bit. A character whose stop bit reads low (a
    framing error) is kept with ``framing_errors`` (a Linux tty in raw mode passes
    it on; a line held low reads 00) or dropped; with ``resync`` the low stop bit
    is taken as the next start bit (a 16550 does), else the reader waits for the
    next falling edge."""
    # time in units of 1 / (2 * sent * read) s: sender bit i starts at i * 2 * read,
    # a reader's bit lasts 2 * sent
    sent_bit, read_bit = 2 * read, 2 * sent
    n = len(levels)

    def level(t: int) -> int:
        i = t // sent_bit
        return levels[i] if i < n else 1

    out = bytearray()
    e = 0
    t0 = edges[0] * sent_bit + read_bit // 32 if edges else None
    while t0 is not None:
        value = 0
        for m in range(8):
            value |= level(t0 + (2 * m + 3) * read_bit // 2) << m
        stop = t0 + 19 * read_bit // 2                  # the middle of its stop bit
        good = level(stop)
        if good or framing_errors:
            out.append(value)
        if not good and resync:
            t0 = stop - read_bit // 2                   # the low "stop bit" starts the next character
            continue
        e = bisect_left(edges, -(-stop // sent_bit), e + 1)   # the next falling edge from there
        t0 = edges[e] * sent_bit + read_bit // 32 if e < len(edges) else None
    return bytes(out)


def _reference_traffic(sent: int, rng: random.Random) -> tuple[list[tuple[int, bytes]], list[tuple[int, bytes]]]:
    """A controller's commands (line A) and the devices' answers (line B) at ``sent``
    bit/s: frames of Table 1, ACK/NAK/NIC bytes, the silences between them."""
    a: list[tuple[int, bytes]] = []
    b: list[tuple[int, bytes]] = []
    t = 0.0                                           # seconds
    bit = 1 / sent
    for _ in range(120):
        dst = (rng.choice((1, 1, 1, 2, 255)), rng.choice((1, 1, 2)), rng.choice((1, 2, 3)))
        cmd = build_frame(dst, 0, rng.choice(_REF_COMMANDS))
        a.append((round(t / bit), cmd))
        t += len(cmd) * 10 * bit + rng.uniform(0.001, 0.010)       # the device's latency
        answer = rng.random()
        if answer < 0.08:
            b.append((round(t / bit), bytes((NAK_BYTE,))))
        elif answer < 0.16:
            b.append((round(t / bit), bytes((ACK_BYTE, NIC_BYTE))))
        else:
            b.append((round(t / bit), bytes((ACK_BYTE,))))
            if answer > 0.4:
                t += 10 * bit + rng.uniform(0.0005, 0.003)
                res = build_frame((0, dst[1], dst[2]), dst[0], rng.choice(_REF_RESULTS))
                b.append((round(t / bit), res))
                t += len(res) * 10 * bit
        t += 10 * bit + rng.uniform(0.005, 0.08)                   # until the next command
    return a, b


@cache
def misread_profile(sent: int, read: int) -> tuple[float, ...]:
    """For each byte value, log2 of how much likelier a UART at ``read`` reads it
    from protocol traffic sent at ``sent`` than from random bytes (1/256)."""
    rng = random.Random(0x1F8)
    counts = [0] * 256
    total = 0
    for _ in range(40):                              # enough bytes read, however few a fast line gives
        for messages in _reference_traffic(sent, rng):
            levels, edges = line_levels(messages)
            # what UARTs do on a framing error differs: each way counts
            for framing_errors, resync in ((True, False), (True, True), (False, False)):
                for value in read_as_uart(levels, edges, sent, read, framing_errors, resync):
                    counts[value] += 1
                    total += 1
        if total >= 6000:
            break
    # half a count each (Jeffreys): a value never read is unlikely, not impossible
    return tuple(math.log2((c + 0.5) / (total + 128) * 256) for c in counts)


def rate_scores(sample: bytes, read: int) -> dict[int, float]:
    """For each standard rate but ``read``: bits per byte by which ``sample``, read
    at ``read``, is likelier to be that rate's traffic misread than random bytes."""
    if not sample:
        return {}
    counts = Counter(sample)
    n = len(sample)
    out = {}
    for sent in PROTOCOL_RATES:
        if sent == read:
            continue
        profile = misread_profile(sent, read)
        out[sent] = sum(profile[v] * c for v, c in counts.items()) / n
    return out
