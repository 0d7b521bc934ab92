"""pcapng files gimbalscope wrote (docs/wireshark.md): an export, or a live
capture saved by Wireshark or tshark through the extcap, read back as a
capture.

Every byte on the wire is in exactly one packet (a frame, an ACK, NAK or NIC,
a run of noise), after the exported-PDU tags and gimbalscope's header
(analyzer/formats/pdu.py). Each packet is a chunk of its line at its time,
so decoding the file decodes the conversation afresh, with this version's
command table and pairing, rather than trusting the header. What the header
decided is not read back.

The lines are the first section's interfaces (``A`` and ``B``, or ``AB``). A
file holding several captures (sections) is read as one, in order; packets of
a line the first capture does not have are skipped and said once. Packets that
are not gimbalscope's (another link type or dissector) are skipped and counted.
A file cut short (a capture killed while writing) is read up to its cut and
said.

A capture that had no time (raw dumps) was written with times made from byte
offsets, and its section says so (``pdu.UNTIMED``): it is read untimed again,
as the dumps were (no latencies; two lines aligned by addresses and layouts,
each line read by a stream of its own, so such a file must be a file, not a
pipe).
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator
from typing import BinaryIO

from ..errors import CaptureError
from ..formats import pdu
from ..formats.pcapng_blocks import EPB as _EPB
from ..formats.pcapng_blocks import IDB as _IDB
from ..formats.pcapng_blocks import MAGIC
from ..formats.pcapng_blocks import SHB as _SHB
from ..formats.pcapng_blocks import blocks as _blocks
from ..formats.pcapng_blocks import options as _options
from ..formats.pcapng_blocks import ts_scale as _scale
from ..lines import LINE_A, LINE_B, Chunk
from ..words import counted
from .base import Reader, ReadSettings, Source
from .files import Input

_LINES = {LINE_A: LINE_A, LINE_B: LINE_B, "AB": "AB"}


class _Interface:
    __slots__ = ("link_type", "name", "scale")

    def __init__(self, link_type: int, name: str, scale: float) -> None:
        self.link_type = link_type
        self.name = name
        self.scale = scale   # seconds per timestamp unit

    def ns(self, ticks: int) -> int:
        """A timestamp in integer nanoseconds: times stay exact (an epoch in float
        seconds holds only about a quarter of a microsecond)."""
        return ticks if self.scale == 1e-9 else round(ticks * self.scale * 1e9)


class PcapngSource(Source):
    timed = True
    clocks = 1   # the file's times are one time line (a two-port tap's were aligned when written)

    def __init__(self, inp: Input) -> None:
        super().__init__()
        self.input = inp
        self.name = inp.name
        self.description = inp.describe("pcapng (gimbalscope packets)")
        self.on_close(inp.close)
        self._start_ns: int | None = None   # the first packet's time: t = 0
        self.lines, self.start_time = self._first_section(inp.head)

    def _first_section(self, head: bytes) -> tuple[tuple[str, ...], float | None]:
        """The first section's lines and its first packet's time, from the head;
        whether it is timed."""
        lines: list[str] = []
        start = None
        interfaces: list[_Interface] = []
        for kind, endian, body in _blocks(io.BytesIO(head), self.name, _quiet):   # a head ends mid-block
            if kind == _SHB and (lines or interfaces):
                break
            if kind == _SHB:
                comment = _options(body[16:], endian).get(1, b"")
                if comment.startswith(pdu.UNTIMED.encode()):
                    self.timed = False
                    self.clocks = 0
            elif kind == _IDB:
                interfaces.append(self._interface(body, endian))
                line = _LINES.get(interfaces[-1].name)
                if interfaces[-1].link_type == pdu.LINKTYPE and line and line not in lines:
                    lines.append(line)
            elif kind == _EPB and start is None:
                iface, hi, lo = struct.unpack_from(endian + "III", body, 0)
                if iface < len(interfaces) and interfaces[iface].link_type == pdu.LINKTYPE:
                    self._start_ns = start = interfaces[iface].ns((hi << 32) | lo)
        if not lines:
            raise CaptureError(f"{self.name}: a pcapng file without gimbalscope's interfaces (link type "
                               f"{pdu.LINKTYPE} named A, B or AB): not written by gimbalscope")
        if "AB" in lines and len(lines) > 1:
            raise CaptureError(f"{self.name}: mixes a single-line tap (AB) with lines A/B in one capture")
        order = ("AB",) if "AB" in lines else (LINE_A, LINE_B)
        return order, start / 1e9 if start is not None else None

    @staticmethod
    def _interface(body: bytes, endian: str) -> _Interface:
        link_type = struct.unpack_from(endian + "H", body, 0)[0]
        opts = _options(body[8:], endian)
        name = opts.get(2, b"").split(b"\0", 1)[0].decode("utf-8", "replace")
        return _Interface(link_type, name, _scale(opts.get(9)))

    def chunks(self) -> Iterator[Chunk]:
        try:
            yield from self._read(self.input.stream())
        except OSError as e:
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        """One line's chunks, by a stream of its own: untimed lines are read side
        by side, each at its own pace (analyzer/analysis/align.py)."""
        if self.timed or len(self.lines) == 1:
            yield from super().line_chunks(line)
            return
        if not self.input.regular:
            raise CaptureError(f"{self.name}: an untimed capture of two lines is read one line at a time: "
                               "give it as a file, not through a pipe")
        own = Input(self.input.path)
        try:
            for chunk in self._read(own.stream(), say=line == self.lines[0]):   # warnings once
                if chunk.line == line:
                    yield chunk
        except OSError as e:
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None
        finally:
            own.close()

    def _read(self, f: BinaryIO, say: bool = True) -> Iterator[Chunk]:
        interfaces: list[_Interface] = []
        start = self._start_ns
        foreign = other_lines = 0
        for kind, endian, body in _blocks(f, self.name, self.warn if say else _quiet):
            if kind == _SHB:
                interfaces = []
            elif kind == _IDB:
                interfaces.append(self._interface(body, endian))
            elif kind == _EPB:
                iface, hi, lo, caplen = struct.unpack_from(endian + "IIII", body, 0)
                info = interfaces[iface] if iface < len(interfaces) else None
                got = pdu.wire_of(body[20:20 + caplen]) if info is not None and info.link_type == pdu.LINKTYPE else None
                if info is None or got is None:
                    foreign += 1
                    continue
                line, data = got
                if line not in self.lines:
                    other_lines += 1
                    continue
                if not data:
                    continue
                if not self.timed:
                    yield Chunk(line, data)
                    continue
                ns = info.ns((hi << 32) | lo)
                if start is None:
                    start = self._start_ns = ns
                    self.start_time = ns / 1e9
                yield Chunk(line, data, (ns - start) / 1e9)
        if foreign and say:
            self.warn(f"{self.name}: {counted(foreign, 'packet')} not gimbalscope's (another link type or "
                      "dissector); skipped")
        if other_lines and say:
            self.warn(f"{self.name}: {counted(other_lines, 'packet')} of lines the first capture does not have; "
                      "skipped")


def _quiet(_msg: str) -> None:
    pass


def open_pcapng(inputs: list[Input], settings: ReadSettings) -> PcapngSource:
    return PcapngSource(inputs[0])


READER = Reader(
    "pcapng (gimbalscope packets)", open_pcapng, magic=MAGIC, given_as=" as export and the Wireshark extcap write it",
    crowded="a pcapng file carries its lines; give it on its own",
    suffixes=(".pcapng",), misnamed="not a pcapng file (it does not start with a section header block)",
)
