"""USB captures as files hold them: the pcap and pcapng containers, the URB
headers of Linux usbmon and of Windows' USBPcap, and the standard descriptors
that name a device. Pure functions of bytes; the reader that makes a serial
line of them is analyzer/sources/usb.py.

Header layouts, as their writers define them:

- usbmon, link types 189 (48-byte header) and 220 (the 64-byte header of the
  memory-mapped interface, what libpcap writes today): Linux
  Documentation/usb/usbmon.rst, ``struct mon_bin_hdr``: URB id (8 bytes),
  event type (``S`` submit, ``C`` complete, ``E`` submission error), transfer
  type (0 isochronous, 1 interrupt, 2 control, 3 bulk), endpoint (0x80: IN),
  device address, bus (2), setup flag (0: the setup packet is in the header),
  data flag, seconds (8), microseconds (4), status (4), URB length (4),
  captured length (4), setup packet (8); the 64-byte form adds interval,
  start frame, transfer flags and the number of isochronous descriptors,
  which come before the data (16 bytes each). The header is in the byte order
  of the machine that captured, which is the byte order libpcap wrote the file
  in (Wireshark reads it so too).
- USBPcap, link type 249 (``USBPCAP_BUFFER_PACKET_HEADER``, packed, little
  endian): header length (2), IRP id (8), USBD status (4), URB function (2),
  info (1; bit 0: the IRP is on its way back from the device, a completion),
  bus (2), device (2), endpoint (1; 0x80: IN), transfer type (1, as usbmon's),
  data length (4): 27 bytes; a control transfer adds its stage (0 setup, 1
  data, 2 status, 3 complete). The setup stage's data is the 8-byte setup
  packet.

Bytes from a file never raise anything but ``CaptureError``: a packet too short
for its header is no URB (``urb_of`` gives None), and a container cut or
damaged ends the walk with a warning.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Callable, Iterator
from typing import BinaryIO, NamedTuple

from ..errors import CaptureError
from . import pcapng_blocks as png

USBMON = 189            # LINKTYPE_USB_LINUX: 48-byte header
USBMON_MMAPPED = 220    # LINKTYPE_USB_LINUX_MMAPPED: 64-byte header
USBPCAP = 249           # LINKTYPE_USBPCAP
LINK_TYPES = (USBMON, USBMON_MMAPPED, USBPCAP)

ISOCHRONOUS, INTERRUPT, CONTROL, BULK = 0, 1, 2, 3
TRANSFER_NAMES = {ISOCHRONOUS: "isochronous", INTERRUPT: "interrupt", CONTROL: "control", BULK: "bulk"}

# the classic pcap header's magic, as the first four bytes read: byte order and
# whether the second timestamp word counts micro- or nanoseconds
PCAP_MAGICS = {
    b"\xd4\xc3\xb2\xa1": ("<", 1000),
    b"\xa1\xb2\xc3\xd4": (">", 1000),
    b"\x4d\x3c\xb2\xa1": ("<", 1),
    b"\xa1\xb2\x3c\x4d": (">", 1),
}
_MAX_RECORD = 1 << 26   # a pcap record longer than this is damage, not a URB


class Urb(NamedTuple):
    """One URB event of a capture: a submission or a completion."""
    ns: int               # capture time, nanoseconds since the epoch
    bus: int
    device: int           # the device's address on its bus
    endpoint: int         # endpoint number, 0-15
    incoming: bool        # IN: device to host
    transfer: int         # ISOCHRONOUS, INTERRUPT, CONTROL or BULK
    completion: bool      # False: submitted by the host; True: given back (or failed to submit)
    status: int           # 0: success (a submission's status says nothing yet)
    data: bytes
    urb_id: int           # the same for a URB's submission and completion
    setup: bytes | None = None   # a control transfer's 8-byte setup packet, with its submission
    length: int | None = None    # usbmon's URB length: asked for (submission) or done (completion)


class Setup(NamedTuple):
    """A control request's setup packet (USB 2.0, 9.3)."""
    request_type: int
    request: int
    value: int
    w_index: int   # wIndex (``index`` is a tuple's method)
    length: int


def setup_of(setup: bytes) -> Setup:
    return Setup(*struct.unpack("<BBHHH", setup[:8]))


# ------------------------------------------------------------------ containers

def link_types(head: bytes) -> set[int] | None:
    """The link types a capture file's head declares (a pcap file's one, the
    interfaces of a pcapng's first section), or None when it is neither."""
    form = PCAP_MAGICS.get(head[:4])
    if form is not None:
        if len(head) < 24:
            return set()
        return {struct.unpack_from(form[0] + "I", head, 20)[0] & 0xFFFF}
    if not head.startswith(png.MAGIC):
        return None
    found: set[int] = set()
    seen_section = False
    try:
        for kind, endian, body in png.blocks(io.BytesIO(head), "", _quiet):   # a head ends mid-block
            if kind == png.SHB:
                if seen_section:
                    break
                seen_section = True
            elif kind == png.IDB and len(body) >= 2:
                found.add(struct.unpack_from(endian + "H", body, 0)[0])
    except CaptureError:
        pass
    return found


def packets(f: BinaryIO, name: str, warn: Callable[[str], None]) -> Iterator[tuple[int, int, str, bytes]]:
    """Every packet of a pcap or pcapng stream as (link type, ns since the
    epoch, byte order of the file, bytes). A cut or damaged file ends the walk,
    said once through ``warn``."""
    head = f.read(4)
    form = PCAP_MAGICS.get(head)
    if form is not None:
        yield from _pcap_packets(f, name, warn, *form)
        return
    if head != png.MAGIC:
        raise CaptureError(f"{name}: neither a pcap nor a pcapng file")
    yield from _pcapng_packets(_Prefixed(head, f), name, warn)


def _pcap_packets(f: BinaryIO, name: str, warn: Callable[[str], None], endian: str,
                  unit_ns: int) -> Iterator[tuple[int, int, str, bytes]]:
    rest = f.read(20)
    if len(rest) < 20:
        warn(f"{name}: the file ends inside the pcap header: nothing to read")
        return
    link_type = struct.unpack_from(endian + "I", rest, 16)[0] & 0xFFFF
    record = struct.Struct(endian + "IIII")
    at = 24
    while True:
        head = f.read(16)
        if not head:
            return
        if len(head) < 16:
            warn(f"{name}: the file ends inside a packet record at byte {at:,} (cut short?): read up to there")
            return
        sec, frac, caplen, _ = record.unpack(head)
        if caplen > _MAX_RECORD:
            warn(f"{name}: a packet record of {caplen:,} bytes at byte {at:,}: the file is damaged there; "
                 "read up to there")
            return
        data = f.read(caplen)
        if len(data) < caplen:
            warn(f"{name}: the file ends inside a packet at byte {at:,} (cut short?): read up to there")
            return
        yield link_type, sec * 1_000_000_000 + frac * unit_ns, endian, data
        at += 16 + caplen


def _pcapng_packets(f: png.Reader, name: str, warn: Callable[[str], None]) -> Iterator[tuple[int, int, str, bytes]]:
    interfaces: list[tuple[int, float]] = []   # (link type, seconds per timestamp unit)
    try:
        for kind, endian, body in png.blocks(f, name, warn):
            if kind == png.SHB:
                interfaces = []
            elif kind == png.IDB and len(body) >= 8:
                link_type = struct.unpack_from(endian + "H", body, 0)[0]
                interfaces.append((link_type, png.ts_scale(png.options(body[8:], endian).get(png.IF_TSRESOL))))
            elif kind == png.EPB and len(body) >= 20:
                iface, hi, lo, caplen = struct.unpack_from(endian + "IIII", body, 0)
                if iface < len(interfaces):
                    link_type, scale = interfaces[iface]
                    ticks = (hi << 32) | lo
                    ns = ticks if scale == 1e-9 else round(ticks * scale * 1e9)
                    yield link_type, ns, endian, body[20:20 + caplen]
    except CaptureError as e:   # a block length that cannot be: nothing after it can be found again
        warn(f"{e}; read up to there")


class _Prefixed(io.RawIOBase):
    """``head`` (already read) and then the rest of ``f``."""

    def __init__(self, head: bytes, f: BinaryIO) -> None:
        super().__init__()
        self._head = head
        self._f = f

    def readable(self) -> bool:
        return True

    def read(self, n: int = -1) -> bytes:
        if n < 0:
            head, self._head = self._head, b""
            return head + self._f.read()
        if self._head:
            part, self._head = self._head[:n], self._head[n:]
            return part + self._f.read(n - len(part)) if len(part) < n else part
        return self._f.read(n)


def _quiet(_msg: str) -> None:
    pass


# ------------------------------------------------------------------ URB headers

_MON = struct.Struct("QBBBBHbbqiiII8s")   # struct mon_bin_hdr, its first 48 bytes
_MON_LE, _MON_BE = struct.Struct("<" + _MON.format), struct.Struct(">" + _MON.format)
_USBPCAP = struct.Struct("<HQIHBHHBBI")
_S = ord("S")   # a submission; "C" a completion, "E" a submission that failed


def urb_of(link_type: int, ns: int, endian: str, packet: bytes) -> Urb | None:
    """The URB event a packet of ``link_type`` holds, or None when it is too short
    for its header or of another link type."""
    if link_type == USBMON_MMAPPED or link_type == USBMON:
        return _usbmon(link_type, ns, endian, packet)
    if link_type == USBPCAP:
        return _usbpcap(ns, packet)
    return None


def _usbmon(link_type: int, ns: int, endian: str, packet: bytes) -> Urb | None:
    size = 64 if link_type == USBMON_MMAPPED else 48
    if len(packet) < size:
        return None
    header = _MON_BE if endian == ">" else _MON_LE
    (urb_id, event, transfer, epnum, device, bus, flag_setup, _flag_data, _sec, _usec, status,
     length, _captured, setup) = header.unpack_from(packet, 0)
    data_at = size
    if link_type == USBMON_MMAPPED and transfer == ISOCHRONOUS:
        ndesc = struct.unpack_from(endian + "I", packet, 60)[0]
        data_at += 16 * min(ndesc, len(packet) // 16)
    submitted = event == _S
    return Urb(ns, bus, device, epnum & 0x0F, bool(epnum & 0x80), transfer, not submitted,
               0 if submitted else status, packet[data_at:], urb_id,
               setup if submitted and transfer == CONTROL and flag_setup == 0 else None, length)


def _usbpcap(ns: int, packet: bytes) -> Urb | None:
    if len(packet) < _USBPCAP.size:
        return None
    (header_len, irp, status, _function, info, bus, device, endpoint, transfer,
     _length) = _USBPCAP.unpack_from(packet, 0)
    if header_len < _USBPCAP.size or header_len > len(packet):
        return None
    data = packet[header_len:]
    completion = bool(info & 1)
    setup = None
    if transfer == CONTROL and header_len > _USBPCAP.size and packet[_USBPCAP.size] == 0:   # the setup stage
        if len(data) < 8:
            return None
        setup, data = data[:8], data[8:]
    return Urb(ns, bus, device, endpoint & 0x0F, bool(endpoint & 0x80), transfer, completion,
               status if completion else 0, data, irp, setup)


# ------------------------------------------------------------------ descriptors

GET_DESCRIPTOR = 6
DEVICE_DESCRIPTOR, CONFIGURATION_DESCRIPTOR = 1, 2
_INTERFACE, _ENDPOINT = 4, 5


def descriptor_asked(setup: Setup) -> int | None:
    """The descriptor type a standard GET_DESCRIPTOR request asks for, or None."""
    if setup.request_type == 0x80 and setup.request == GET_DESCRIPTOR:
        return setup.value >> 8
    return None


def device_ids(descriptor: bytes) -> tuple[int, int] | None:
    """(idVendor, idProduct) of a device descriptor (USB 2.0, 9.6.1), or None
    when the bytes are not one or stop before them (a first 8-byte read)."""
    if len(descriptor) < 12 or descriptor[1] != DEVICE_DESCRIPTOR:
        return None
    return struct.unpack_from("<HH", descriptor, 8)


class Endpoint(NamedTuple):
    interface: int       # bInterfaceNumber
    interface_class: int
    address: int         # bEndpointAddress: number, 0x80 for IN
    transfer: int        # bmAttributes' transfer type
    max_packet: int      # wMaxPacketSize's size bits


def endpoints(configuration: bytes) -> list[Endpoint]:
    """The endpoints a configuration descriptor and the descriptors after it
    declare (USB 2.0, 9.6.3-9.6.6); a descriptor cut short ends the walk."""
    found: list[Endpoint] = []
    interface = interface_class = -1
    at = 0
    while at + 2 <= len(configuration):
        length, kind = configuration[at], configuration[at + 1]
        if length < 2 or at + length > len(configuration):
            break
        if kind == _INTERFACE and length >= 9:
            interface, interface_class = configuration[at + 2], configuration[at + 5]
        elif kind == _ENDPOINT and length >= 7:
            address, attributes = configuration[at + 2], configuration[at + 3]
            size = struct.unpack_from("<H", configuration, at + 4)[0] & 0x7FF
            found.append(Endpoint(interface, interface_class, address, attributes & 3, size))
        at += length
    return found
