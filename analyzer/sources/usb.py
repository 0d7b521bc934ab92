"""USB captures of the controller PC's own USB-serial adapter (usbmon on Linux,
USBPcap on Windows; pcap or pcapng) read as the serial line it drives
(docs/instruments.md, "USB captures").

The host's bulk OUT data is line A (what the controller sends), the bulk IN
data line B (what the gimbals answer). The adapter's framing of IN data is
taken off (analyzer/formats/usbserial.py: FTDI's status bytes, CP210x's event
escapes) and the line errors it reports become line faults.

Times. OUT data is handed to the adapter at the URB's submission and goes on
the wire about then, unless the bytes before it are still being sent: its
first byte starts at the later of the submission and the end of the previous
OUT data (at the line's byte time). IN data is given to the host at the URB's
completion, after its last byte arrived: its first byte started
``len × byte_time`` before the completion (as a socat log's read), and not
before the previous IN data ended. An adapter holds IN bytes until its buffer
fills or its latency timer runs out (FTDI: 16 ms unless the host set it lower),
so IN times are late by up to that much: latencies are measured long by as
much, and stay comparable with each other.

The whole capture is surveyed before it is read (analyzer/sources/usbsurvey.py):
a capture arriving through a pipe or compressed is copied to a temporary file
first, removed when the source is closed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator

from dissectors import problems
from dissectors.wire import LineSettings

from ..errors import CaptureError
from ..formats import usb
from ..formats.usbserial import (
    BREAK,
    CP210X,
    CP210X_EMBED_EVENTS,
    CP210X_IFC_ENABLE,
    CP210X_REQUEST_TYPE,
    FRAMING,
    FTDI,
    NAMES,
    OVERRUN,
    PARITY,
    Cp210xIn,
    FtdiIn,
    Raw,
)
from ..lines import LINE_A, LINE_B, Chunk, LineFault
from .base import Reader, ReadSettings, Source
from .files import Input, open_input
from .usbsurvey import Choice, choose, survey

_PROBLEMS = {
    FRAMING: (problems.LINE_FRAMING, "framing error reported by the USB adapter"),
    PARITY: (problems.LINE_PARITY, "parity error reported by the USB adapter"),
    BREAK: (problems.LINE_BREAK, "break reported by the USB adapter"),
    OVERRUN: (problems.LINE_OVERRUN, "overrun reported by the USB adapter: bytes were lost before this one"),
}


class USBSerialSource(Source):
    timed = True
    clocks = 1   # the host stamps both directions
    lines = (LINE_A, LINE_B)

    def __init__(self, inp: Input, settings: ReadSettings) -> None:
        super().__init__()
        self.name = inp.name
        self.faults: list[LineFault] = []
        self.line_settings = {line: LineSettings.timed_by(settings.byte_time) for line in self.lines}
        path, temporary = inp.as_regular_file()
        inp.close()
        self.path = path
        if temporary:
            self.on_close(lambda: _remove(path))
        try:   # a capture refused here is never closed: its copy goes now
            cut: list[str] = []
            found = survey(self._urbs(cut.append))
            found.cut = cut[0] if cut else None
            instrument = settings.instrument
            self.choice: Choice = choose(found, self.name, instrument.usb_device, instrument.adapter)
        except BaseException:
            if temporary:
                _remove(path)
            raise
        for note in self.choice.notes:
            self.warn_later(note)
        dev = self.choice.device
        self.description = inp.describe(f"USB capture of {NAMES[self.choice.adapter]} adapter {dev.key}")
        # t = 0: the capture's first packet (IN bytes back-dated before it are put at it)
        self._origin_ns = found.first_ns or 0
        self.start_time = self._origin_ns / 1e9

    def _urbs(self, warn: Callable[[str], None], counted: bool = False) -> Iterator[usb.Urb]:
        """The capture's URB events; ``counted``: the read the progress meter
        follows (the survey before it is not)."""
        try:
            with (open_input(self.path) if counted else open(self.path, "rb")) as f:
                for link_type, ns, endian, packet in usb.packets(f, self.name, warn):
                    u = usb.urb_of(link_type, ns, endian, packet)
                    if u is not None:
                        yield u
        except OSError as e:
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None

    def chunks(self) -> Iterator[Chunk]:
        choice = self.choice
        dev = choice.device
        bus, address = dev.bus, dev.address
        decoder = _decoder(choice)
        cp210x = decoder if isinstance(decoder, Cp210xIn) else None   # (its event insertion is asked for)
        origin = self._origin_ns
        sent: dict[int, tuple[int, bytes]] = {}    # OUT data waiting for its completion, by URB id
        asked: dict[int, usb.Setup] = {}           # CP210x requests waiting for theirs
        a_free = b_free = 0.0                      # when each line's previous bytes ended
        for u in self._urbs(self.warn, counted=True):
            if u.bus != bus or u.device != address:
                continue
            if u.transfer == usb.BULK:
                if u.incoming and u.endpoint == choice.in_endpoint and u.completion:
                    if u.status != 0 or not u.data:
                        continue
                    data, faults = decoder.decode(u.data)
                    for offset, kind in faults:
                        info, detail = _PROBLEMS[kind]
                        self.faults.append(LineFault(LINE_B, offset, info.problem(detail)))
                    if not data:
                        continue   # FTDI's idle polls: the two status bytes alone
                    byte_time = self.line_settings[LINE_B].byte_time
                    t = max((u.ns - origin) / 1e9 - len(data) * byte_time, b_free)
                    b_free = t + len(data) * byte_time
                    yield Chunk(LINE_B, data, round(t, 9))
                elif not u.incoming and u.endpoint == choice.out_endpoint:
                    if not u.completion:
                        if u.data:
                            sent[u.urb_id] = (u.ns, u.data)
                        continue
                    submitted = sent.pop(u.urb_id, None)
                    if submitted is None or u.status != 0:
                        continue   # failed: the adapter did not take the bytes
                    ns, data = submitted
                    if u.length is not None and 0 < u.length < len(data):
                        data = data[:u.length]   # taken only in part
                    chunk, a_free = self._out_chunk(ns, data, a_free)
                    yield chunk
            elif u.transfer == usb.CONTROL and cp210x is not None:
                self._cp210x_request(u, asked, cp210x)
        for ns, data in sorted(sent.values(), key=lambda s: s[0]):   # the capture ended before they completed
            chunk, a_free = self._out_chunk(ns, data, a_free)
            yield chunk

    def _out_chunk(self, ns: int, data: bytes, a_free: float) -> tuple[Chunk, float]:
        byte_time = self.line_settings[LINE_A].byte_time
        t = max((ns - self._origin_ns) / 1e9, a_free)
        return Chunk(LINE_A, data, round(t, 9)), t + len(data) * byte_time

    @staticmethod
    def _cp210x_request(u: usb.Urb, asked: dict[int, usb.Setup], decoder: Cp210xIn) -> None:
        """Event insertion turned on or off, once the request succeeded."""
        if u.setup is not None:
            setup = usb.setup_of(u.setup)
            if setup.request_type == CP210X_REQUEST_TYPE and setup.request in (CP210X_EMBED_EVENTS,
                                                                                CP210X_IFC_ENABLE):
                asked[u.urb_id] = setup
            return
        done = asked.pop(u.urb_id, None) if u.completion else None
        if done is None or u.status != 0:
            return
        if done.request == CP210X_EMBED_EVENTS:
            decoder.events(done.value & 0xFF or None)
        elif done.value == 0:   # the UART turned off: event insertion ends with it
            decoder.events(None)


def _decoder(choice: Choice) -> FtdiIn | Cp210xIn | Raw:
    if choice.adapter == FTDI:
        return FtdiIn(choice.max_packet)
    if choice.adapter == CP210X:
        return Cp210xIn()
    return Raw()


def _remove(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def looks_like_usb(head: bytes) -> bool:
    """A pcap file of a USB link type, or a pcapng whose first section has an
    interface of one."""
    found = usb.link_types(head)
    return bool(found and found & set(usb.LINK_TYPES))


def open_usb(inputs: list[Input], settings: ReadSettings) -> USBSerialSource:
    return USBSerialSource(inputs[0], settings)


READER = Reader(
    "USB capture (usbmon, USBPcap)", open_usb, looks=looks_like_usb, reads=frozenset({"adapter", "usb_device"}),
    given_as=" of a serial adapter",
    crowded="a USB capture carries both lines; give it on its own",
)
