"""USB captures of a PC's USB-serial adapter, synthesised for the tests: URB
events written as the kernel's usbmon (link types 220 and 189, pcap or pcapng)
or Windows' USBPcap (249) writes them, with the enumeration (device and
configuration descriptors) when asked, vendor requests, and the adapters'
bulk data: FTDI's status bytes on every IN packet, CP210x's event escapes.

Layouts from their definitions, independent of analyzer/formats/usb.py:
Linux Documentation/usb/usbmon.rst (``struct mon_bin_hdr``), USBPcap's
``USBPCAP_BUFFER_PACKET_HEADER``, libpcap's file format, the pcapng draft.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

BT = 10 / 9600            # seconds a byte at 9600 8N1
START = 1_790_000_000     # epoch seconds of the capture's first packet
ISO, INTR, CTRL, BULK = 0, 1, 2, 3

FT232R = {"vid": 0x0403, "pid": 0x6001, "bcd": 0x0600, "ports": [(0xFF, [(0x81, BULK, 64), (0x02, BULK, 64)])]}
FT2232H = {"vid": 0x0403, "pid": 0x6010, "bcd": 0x0700, "ports": [(0xFF, [(0x81, BULK, 512), (0x02, BULK, 512)]),
                                                                  (0xFF, [(0x83, BULK, 512), (0x04, BULK, 512)])]}
CP2102 = {"vid": 0x10C4, "pid": 0xEA60, "bcd": 0x0100, "ports": [(0xFF, [(0x81, BULK, 64), (0x01, BULK, 64)])]}
CH340 = {"vid": 0x1A86, "pid": 0x7523, "bcd": 0x0254,
         "ports": [(0xFF, [(0x82, BULK, 32), (0x02, BULK, 32), (0x81, INTR, 8)])]}
MOUSE = {"vid": 0x046D, "pid": 0xC077, "bcd": 0x7200, "ports": [(0x03, [(0x81, INTR, 4)])]}
STICK = {"vid": 0x0781, "pid": 0x5567, "bcd": 0x0100, "ports": [(0x08, [(0x81, BULK, 512), (0x02, BULK, 512)])]}

FTDI_IDLE = b"\x01\x60"       # FT232R modem status (full-speed bit), line status THRE|TEMT
FTDI_HS_IDLE = b"\x02\x60"    # FT2232H: the high-speed bit
FTDI_FE = 0x08                # line status: framing error


@dataclass
class Event:
    t: float                  # seconds since START
    device: int
    endpoint: int             # with 0x80 for IN
    transfer: int
    completion: bool
    data: bytes
    urb_id: int
    setup: bytes | None = None
    status: int = 0
    length: int | None = None   # usbmon's URB length (default: the data's)


def device_descriptor(vid: int, pid: int, bcd: int) -> bytes:
    return struct.pack("<BBHBBBBHHHBBBB", 18, 1, 0x0200, 0, 0, 0, 64, vid, pid, bcd, 1, 2, 3, 1)


def config_descriptor(ports) -> bytes:
    body = b""
    for number, (cls, eps) in enumerate(ports):
        body += struct.pack("<BBBBBBBBB", 9, 4, number, 0, len(eps), cls, 0xFF if cls == 0xFF else 0, 0xFF, 2)
        for address, kind, size in eps:
            body += struct.pack("<BBBBHB", 7, 5, address, kind, size, 0)
    return struct.pack("<BBHBBBBB", 9, 2, 9 + len(body), len(ports), 1, 0, 0x80, 50) + body


class UsbCapture:
    """One bus's URB events; ``write_*`` writes them in time order."""

    def __init__(self, bus: int = 1) -> None:
        self.bus = bus
        self.events: list[Event] = []
        self._ids = 0xFFFF880012340000

    def _id(self) -> int:
        self._ids += 0x100
        return self._ids

    # ------------------------------------------------------------ transfers

    def control_in(self, t: float, device: int, setup: bytes, answer: bytes) -> None:
        urb = self._id()
        self.events.append(Event(t, device, 0x80, CTRL, False, b"", urb, setup, length=len(answer)))
        self.events.append(Event(t + 0.0001, device, 0x80, CTRL, True, answer, urb))

    def control_out(self, t: float, device: int, setup: bytes, status: int = 0) -> None:
        urb = self._id()
        self.events.append(Event(t, device, 0x00, CTRL, False, b"", urb, setup))
        self.events.append(Event(t + 0.0001, device, 0x00, CTRL, True, b"", urb, status=status))

    def enumerate(self, t: float, device: int, vid: int, pid: int, bcd: int, ports) -> None:
        """GET_DESCRIPTOR of the device, then of its configuration (9 bytes, then all)."""
        dev = device_descriptor(vid, pid, bcd)
        conf = config_descriptor(ports)
        self.control_in(t, device, struct.pack("<BBHHH", 0x80, 6, 0x0100, 0, 18), dev)
        self.control_in(t + 0.001, device, struct.pack("<BBHHH", 0x80, 6, 0x0200, 0, 9), conf[:9])
        self.control_in(t + 0.002, device, struct.pack("<BBHHH", 0x80, 6, 0x0200, 0, len(conf)), conf)

    def vendor(self, t: float, device: int, request_type: int, request: int, value: int, index: int = 0) -> None:
        self.control_out(t, device, struct.pack("<BBHHH", request_type, request, value, index, 0))

    def bulk_out(self, t: float, device: int, endpoint: int, data: bytes, status: int = 0) -> None:
        """The host hands ``data`` over at ``t``; the adapter takes it 0.2 ms later."""
        urb = self._id()
        self.events.append(Event(t, device, endpoint, BULK, False, data, urb))
        self.events.append(Event(t + 0.0002, device, endpoint, BULK, True, b"", urb, status=status,
                                 length=0 if status else len(data)))

    def bulk_in(self, t: float, device: int, endpoint: int, data: bytes, status: int = 0,
                size: int = 512) -> None:
        """An IN URB (submitted 1 ms before) completing at ``t`` with ``data``."""
        urb = self._id()
        self.events.append(Event(t - 0.001, device, 0x80 | endpoint, BULK, False, b"", urb, length=size))
        self.events.append(Event(t, device, 0x80 | endpoint, BULK, True, data, urb, status=status))

    def interrupt_in(self, t: float, device: int, endpoint: int, data: bytes) -> None:
        urb = self._id()
        self.events.append(Event(t - 0.001, device, 0x80 | endpoint, INTR, False, b"", urb, length=len(data)))
        self.events.append(Event(t, device, 0x80 | endpoint, INTR, True, data, urb))

    # ------------------------------------------------------------ packets

    def ordered(self) -> list[Event]:
        return sorted(self.events, key=lambda e: e.t)

    def usbmon(self, e: Event, size: int, endian: str) -> bytes:
        """``struct mon_bin_hdr`` (48 bytes, or 64 for the mmapped form) and the data."""
        ns = START * 10**9 + round(e.t * 1e9)
        sec, usec = divmod(ns // 1000, 1_000_000)
        length = e.length if e.length is not None else len(e.data)
        flag_data = 0 if e.data else ord("<" if e.endpoint & 0x80 else ">")
        head = struct.pack(endian + "QBBBBHbbqiiII8s", e.urb_id, ord("C" if e.completion else "S"), e.transfer,
                           e.endpoint, e.device, self.bus, 0 if e.setup else ord("-"), flag_data, sec, usec,
                           e.status if e.completion else -115, length, len(e.data), e.setup or bytes(8))
        if size == 64:
            head += struct.pack(endian + "iiII", 0, 0, 0, 0)
        return head + e.data

    def usbpcap(self, e: Event) -> bytes:
        """``USBPCAP_BUFFER_PACKET_HEADER`` (27 bytes; a control transfer's stage
        after it) and the data: a control submission is the setup stage."""
        data = e.setup if e.setup is not None else e.data
        stage = b""
        if e.transfer == CTRL:
            stage = b"\x00" if e.setup is not None else b"\x03"
        function = 0x0008 if e.transfer == CTRL else 0x0009
        status = 0 if e.status == 0 else 0xC0000004   # USBD_STATUS_STALL_PID
        head = struct.pack("<HQIHBHHBBI", 27 + len(stage), e.urb_id, status if e.completion else 0, function,
                           1 if e.completion else 0, self.bus, e.device, e.endpoint, e.transfer, len(data))
        return head + stage + data

    def packets(self, link_type: int, endian: str = "<") -> list[tuple[int, bytes]]:
        out = []
        for e in self.ordered():
            ns = START * 10**9 + round(e.t * 1e9)
            if link_type == 249:
                out.append((ns, self.usbpcap(e)))
            else:
                out.append((ns, self.usbmon(e, 64 if link_type == 220 else 48, endian)))
        return out

    # ------------------------------------------------------------ files

    def write_pcap(self, path, link_type: int = 220, endian: str = "<", nanos: bool = False) -> None:
        magic = 0xA1B23C4D if nanos else 0xA1B2C3D4
        with open(path, "wb") as f:
            f.write(struct.pack(endian + "IHHiIII", magic, 2, 4, 0, 0, 262144, link_type))
            for ns, data in self.packets(link_type, endian):
                sec, frac = divmod(ns, 1_000_000_000)
                f.write(struct.pack(endian + "IIII", sec, frac if nanos else frac // 1000, len(data), len(data)))
                f.write(data)

    def write_pcapng(self, path, link_type: int = 220, endian: str = "<") -> None:
        def block(kind: int, body: bytes) -> bytes:
            body += b"\0" * (-len(body) % 4)
            return struct.pack(endian + "II", kind, 12 + len(body)) + body + struct.pack(endian + "I", 12 + len(body))

        with open(path, "wb") as f:
            f.write(block(0x0A0D0D0A, struct.pack(endian + "IHHq", 0x1A2B3C4D, 1, 0, -1)))
            tsresol = struct.pack(endian + "HH", 9, 1) + b"\x09\0\0\0" + struct.pack(endian + "HH", 0, 0)
            f.write(block(1, struct.pack(endian + "HHI", link_type, 0, 262144) + tsresol))
            f.writelines(block(6, struct.pack(endian + "IIIII", 0, ns >> 32, ns & 0xFFFFFFFF, len(data), len(data)) + data)
                         for ns, data in self.packets(link_type, endian))


def ftdi_packets(data: bytes, status: bytes = FTDI_IDLE, size: int = 64) -> bytes:
    """``data`` as an FTDI chip sends it: packets of ``size``, each led by the two
    status bytes."""
    room = size - 2
    return b"".join(status + data[i:i + room] for i in range(0, len(data), room)) or status
