"""One event as the data of one pcapng packet (docs/wireshark.md, "Packets").

The link type is Wireshark's exported PDU (LINKTYPE_WIRESHARK_UPPER_PDU, 252):
each packet starts with tags, one of which names the dissector to call
(``gimbal``), so Wireshark picks the dissector with no preference to set; the
same file opened without the plugin says which one it lacks.

After the tags comes what gimbalscope decided about the event, the header
below, then the event's bytes exactly as they were on the wire. The dissector
decodes the fields from those bytes itself (the command table, generated into
Lua); the header carries what the bytes alone cannot tell: the kind (on a
single-line tap a frame is a command or a result only by pairing), the
pairing (transaction, status, latency, which command a result answers), the
layout the payload matched and the problems. All integers are big-endian::

    0   u8   version (1)
    1   u8   kind          KINDS index
    2   u8   status        STATUSES index, 0 none
    3   u8   flags         RETRANSMISSION, CHECKSUM_KNOWN, CHECKSUM_OK, HAS_LATENCY, HAS_DEVICE
    4   u32  number        the event's number (JSON Lines ``number``)
    8   u32  txn           transaction number, 0 none
    12  u32  request       the command's event number on an answer, 0 none
    16  u16  capture       which capture of the file (pairing is per capture)
    18  u8   line          LINES index
    19  u8   layout        0 the command's parameters, k its k-th result layout, 255 none
    20  i64  latency       nanoseconds (HAS_LATENCY)
    28  u16  entry         command table index + 1, 0 not in the table
    30  u16  payload at    offset of the payload in the wire bytes, 65535 none
    32  u16  payload len
    34  u8×3 device        group, port, device (HAS_DEVICE)
    37  u8   n             length of the command id
    38  n    command id    (JSON Lines ``command``)
    ..  u8   m             problems, then m times:
            u16 problem    dissectors.problems.TABLE index
            u16 k, k bytes the problem's text (UTF-8)
    ..  the wire bytes, to the end of the packet
"""

from __future__ import annotations

import struct

from dissectors import problems as P
from dissectors.commands import COMMANDS
from dissectors.event import COMMAND, FRAME, KINDS, RATE, RESULT, STATUSES, Event

LINKTYPE = 252            # LINKTYPE_WIRESHARK_UPPER_PDU
DISSECTOR = "gimbal"      # the name the Lua dissector registers
VERSION = 1

# The section comment of a capture that had no time (raw dumps): its packet
# times are byte offsets at the line's rate, and reading the file back must not
# take them for measured times (analyzer/sources/pcapngfile.py).
UNTIMED = "gimbalscope: untimed capture; packet times are byte offsets at the line rate"

# Exported-PDU tags (Wireshark's epan/exported_pdu.h); values padded to 4 bytes
_TAG_DISSECTOR_NAME = 12
_TAG_END = 0


def _tags() -> bytes:
    name = DISSECTOR.encode("ascii")
    name += b"\0" * (-len(name) % 4)   # zero padding, counted in the length as the format allows
    return struct.pack(">HH", _TAG_DISSECTOR_NAME, len(name)) + name + struct.pack(">HH", _TAG_END, 0)


TAGS = _tags()

# the codes of the header; the Lua dissector is generated from the same tuples
KIND_CODES = (FRAME,) + tuple(k for k in KINDS if k != RATE)   # a rate event is no bytes on the wire
STATUS_CODES = (None,) + STATUSES
LINE_CODES = ("A", "B", "AB")
RETRANSMISSION, CHECKSUM_KNOWN, CHECKSUM_OK, HAS_LATENCY, HAS_DEVICE = 1, 2, 4, 8, 16
NO_LAYOUT = 255
NO_PAYLOAD = 0xFFFF

_KIND = {k: i for i, k in enumerate(KIND_CODES)}
_STATUS = {s: i for i, s in enumerate(STATUS_CODES)}
_LINE = {line: i for i, line in enumerate(LINE_CODES)}
_ENTRY = {id(c): i + 1 for i, c in enumerate(COMMANDS)}
_PROBLEM = {id(info): i for i, info in enumerate(P.TABLE)}
_FIXED = struct.Struct(">BBBBIIIHBBqHHHBBBB")


def on_the_wire(ev: Event) -> bool:
    """Is the event bytes on the wire (a packet)? A rate change is not."""
    return ev.kind != RATE


def layout_index(ev: Event) -> int:
    """Which layout of its command the event's payload matched: 0 the parameters,
    k the k-th result layout (the first that fits, as dissection chose), or
    NO_LAYOUT when none did (nothing decoded)."""
    entry, payload = ev.entry, ev.payload
    if entry is None or payload is None or not ev.fields:
        return NO_LAYOUT
    if ev.kind == COMMAND:
        return 0 if entry.layout.regex.fullmatch(payload) else NO_LAYOUT
    if ev.kind == RESULT:
        for k, layout in enumerate(entry.result, 1):
            if layout.regex.fullmatch(payload):
                return k
    return NO_LAYOUT


def _device(ev: Event) -> tuple[int, int, int] | None:
    text = ev.device
    if text is None:
        return None
    try:
        g, p, d = (int(x) for x in text.split("."))
    except ValueError:
        return None
    return g, p, d


def encode(ev: Event, capture: int = 0) -> bytes:
    """The packet data of ``ev`` (a wire event: ``on_the_wire``), tags included."""
    flags = RETRANSMISSION if ev.retransmission else 0
    if ev.checksum_ok is not None:
        flags |= CHECKSUM_KNOWN | (CHECKSUM_OK if ev.checksum_ok else 0)
    latency = 0
    if ev.latency is not None:
        flags |= HAS_LATENCY
        latency = round(ev.latency * 1e9)
    device = _device(ev)
    if device is not None:
        flags |= HAS_DEVICE
    raw, payload = ev.raw, ev.payload
    at, length = NO_PAYLOAD, 0
    if payload is not None:
        found = 6 if raw[6:6 + len(payload)] == payload else raw.find(payload)
        if found >= 0:
            at, length = found, len(payload)
    command = (ev.command or "").encode("utf-8")[:255]
    g, p, d = device or (0, 0, 0)
    out = [TAGS, _FIXED.pack(VERSION, _KIND.get(ev.kind, 0), _STATUS.get(ev.status, 0), flags,
                             ev.number & 0xFFFFFFFF, (ev.txn or 0) & 0xFFFFFFFF, (ev.request or 0) & 0xFFFFFFFF,
                             capture & 0xFFFF, _LINE.get(ev.line, 2), layout_index(ev), latency,
                             _ENTRY.get(id(ev.entry), 0), at, length, g & 0xFF, p & 0xFF, d & 0xFF,
                             len(command)),
           command, bytes((min(len(ev.problems), 255),))]
    for problem in ev.problems[:255]:
        text = str(problem).encode("utf-8")[:0xFFFF]
        index = _PROBLEM.get(id(problem.id)) if isinstance(problem, P.Problem) else None
        if index is None:   # a plain string from a hand-built event: its category names it
            index = _PROBLEM[id(P.parse(str(problem)).id)]
        out.append(struct.pack(">HH", index, len(text)))
        out.append(text)
    out.append(raw)
    return b"".join(out)


def wire_of(data: bytes) -> tuple[str, bytes] | None:
    """The line and the wire bytes of a packet ``encode`` made (tags included),
    or None when ``data`` is not one: the reverse of ``encode`` for what reading
    a file back needs (analyzer/sources/pcapngfile.py)."""
    if not data.startswith(TAGS):
        return None
    h = data[len(TAGS):]
    if len(h) < _FIXED.size + 1 or h[0] != VERSION or h[18] >= len(LINE_CODES):
        return None
    at = _FIXED.size + h[_FIXED.size - 1]   # past the command id
    if at >= len(h):
        return None
    count = h[at]
    at += 1
    for _ in range(count):   # the problems: (index, length, text) each
        if at + 4 > len(h):
            return None
        at += 4 + struct.unpack_from(">H", h, at + 2)[0]
    if at > len(h):
        return None
    return LINE_CODES[h[18]], h[at:]


def comment(ev: Event) -> str | None:
    """The packet's comment: its problems, one per line (None when clean)."""
    return "\n".join(ev.problems) if ev.problems else None
