"""pcapng output, for Wireshark and tshark (docs/wireshark.md): one interface per
line of the capture (A and B, or AB), one packet per event on the wire (a
frame, an ACK, NAK or NIC, a run of noise) at its wire time, its problems as
the packet's comment. The packets' data is ``analyzer.formats.pdu``: the
exported-PDU link type naming the ``gimbal`` dissector that
``gimbalscope wireshark install`` puts in place.

A rate change (docs/time.md, "Rate changes") is not bytes on the wire and makes
no packet. Times are those of the MCAP writer (docs/time.md, "Message times"):
the capture's start plus each event's wire time; raw dumps, which carry none,
from byte offsets at the line's rate, and their section says so (``pdu.UNTIMED``),
so reading the file back does not take those times for measured ones.

Several captures can share one file (``gimbalscope export A B -o F.pcapng``):
each is a section of its own with a capture number in its packets, because
pairing (transaction numbers) is per capture.
"""

from __future__ import annotations

from typing import BinaryIO

from dissectors.event import Event

from ..formats import pdu
from ..formats.mcap_messages import WireClock
from ..formats.pcapng import PcapngStream
from ..info import LINE_ROLES, CaptureInfo
from .base import FileWriter
from .mcap import message_clock

APPLICATION = "gimbalscope"


def open_stream(file: BinaryIO, info: CaptureInfo) -> PcapngStream:
    """A new section for the capture ``info`` describes; an untimed one says so."""
    from ..version import __version__
    return PcapngStream(file, f"{APPLICATION} {__version__}", comment=None if info.timed else pdu.UNTIMED)


class PcapngWriter(FileWriter):
    """The registry's ``.pcapng`` writer: one section, for the capture ``info``
    describes. ``capture``: its number in a file of several (``export``);
    ``flush``: push each batch out as it comes (a live FIFO)."""

    many_captures = True   # export may put several captures in one file
    noun = "packets"
    file: BinaryIO   # the target's: a path's, the given file or standard output (never None)
    info: CaptureInfo

    def __init__(self, path: str, info: CaptureInfo, *, file: BinaryIO | None = None, capture: int = 0,
                 flush: bool = False, atomic: bool = True) -> None:
        self.capture = capture
        self.flush = flush
        super().__init__(path, info, file=file, atomic=atomic)

    def begin(self) -> None:
        info = self.info
        self.stream = open_stream(self.file, info)
        names = info.line_names
        self.interface = {
            line: self.stream.add_interface(pdu.LINKTYPE, line, f"{LINE_ROLES.get(line, line)}: {names.get(line, '')}")
            for line in info.lines}
        self.clock = WireClock(**message_clock(info))

    @property
    def packets(self) -> int:
        return self.count

    # Writes are not guarded (``self.writes``): a packet at a time, and the FIFO's
    # tap (analyzer/wireshark/extcap.py) stops on the OSError of a reader gone.
    def on_events(self, events: list[Event]) -> None:
        packet, encode, comment, time_ns = self.stream.packet, pdu.encode, pdu.comment, self.clock.time_ns
        interface, capture = self.interface, self.capture
        first = next(iter(interface.values()))
        n = 0
        for ev in events:
            if not pdu.on_the_wire(ev):
                continue
            packet(interface.get(ev.line, first), time_ns(ev.t, ev.number, ev.offset), encode(ev, capture), comment(ev))
            n += 1
        self.count += n
        if self.flush and n:
            self.stream.flush()
