"""A first look through a USB capture: which devices it holds, what each is
(from its enumeration, its vendor requests or its traffic), how much bulk data
each moved, and which one is the serial adapter to read (docs/instruments.md, "USB captures").

The reader (analyzer/sources/usb.py) surveys the whole capture before reading
it, so that a capture of several adapters is refused with the listing before
anything is decoded, and the adapter of a capture without its enumeration is
known from all of its traffic, not from its first packets.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from ..errors import CaptureError
from ..formats import usb
from ..formats.usbserial import (
    FTDI,
    NAMES,
    VENDORS,
    adapter_of_request,
    ftdi_max_packet,
    ftdi_payload,
    looks_like_ftdi_status,
)
from ..words import counted

_SERIAL_CLASSES = (0xFF, 0x02, 0x0A)   # vendor specific, CDC, CDC data: an interface a serial port can be


@dataclass
class Pipe:
    """One bulk endpoint's traffic."""
    moved: int = 0                    # bytes, every transfer
    transfers: int = 0
    status_only: int = 0              # IN transfers of two bytes (FTDI's idle polls)
    ftdi_like: bool = True            # every IN transfer starts as an FTDI packet does
    payload_64: int = 0               # the line bytes, were it FTDI at 64-byte packets ...
    payload_512: int = 0              # ... or at 512
    first_transfer: bytes = b""       # the first IN transfer's head: its modem status tells the packet size

    def took(self, data: bytes, incoming: bool) -> None:
        self.moved += len(data)
        self.transfers += 1
        if not incoming:
            return
        if not self.first_transfer:
            self.first_transfer = data[:2]
        if len(data) == 2:
            self.status_only += 1
        self.ftdi_like = self.ftdi_like and looks_like_ftdi_status(data)
        self.payload_64 += ftdi_payload(len(data), 64)
        self.payload_512 += ftdi_payload(len(data), 512)


@dataclass
class Device:
    bus: int
    address: int
    ids: tuple[int, int] | None = None            # (idVendor, idProduct) from its device descriptor
    endpoints: list[usb.Endpoint] = field(default_factory=list)   # from its configuration descriptor
    clue: str | None = None                       # the adapter its vendor requests belong to
    transfers: set[int] = field(default_factory=set)
    outs: dict[int, Pipe] = field(default_factory=dict)   # bulk OUT by endpoint number
    ins: dict[int, Pipe] = field(default_factory=dict)    # bulk IN by endpoint number

    @property
    def key(self) -> str:
        return f"{self.bus}.{self.address}"

    @property
    def ids_text(self) -> str:
        return f"{self.ids[0]:04x}:{self.ids[1]:04x}" if self.ids else "(not enumerated in the capture)"

    def found_adapter(self) -> tuple[str | None, str]:
        """The adapter as the capture shows it, and how it was known: "enumeration",
        "requests", "traffic", or "" (nothing tells: raw bytes)."""
        if self.ids is not None:
            return VENDORS.get(self.ids[0]), "enumeration"
        if self.clue is not None:
            return self.clue, "requests"
        pipes = self.ins.values()
        if pipes and all(p.ftdi_like for p in pipes) and sum(p.transfers for p in pipes) >= 2:
            return FTDI, "traffic"
        return None, ""

    def in_pipe(self) -> Pipe | None:
        """The IN endpoint that carried the most."""
        return max(self.ins.values(), key=lambda p: (p.moved - 2 * p.status_only, p.transfers), default=None)

    def max_packet(self, number: int) -> int:
        """An FTDI IN endpoint's packet size: its endpoint descriptor's, else what
        the chip's first modem status says (as Wireshark reads it), else 64."""
        for ep in self.endpoints:
            if ep.address == 0x80 | number and ep.max_packet in (64, 512):
                return ep.max_packet
        pipe = self.ins.get(number)
        return (ftdi_max_packet(pipe.first_transfer) if pipe else None) or 64

    def bytes_in(self, adapter: str | None) -> int:
        pipe = self.in_pipe()
        if pipe is None:
            return 0
        if adapter == FTDI:
            number = next(n for n, p in self.ins.items() if p is pipe)
            return pipe.payload_64 if self.max_packet(number) == 64 else pipe.payload_512
        return pipe.moved

    def bytes_out(self) -> int:
        return max((p.moved for p in self.outs.values()), default=0)

    def maybe_serial(self) -> bool:
        """Could its bulk endpoints be a serial port? Not when its configuration
        says they belong to another class (a USB stick's mass storage)."""
        bulk = [ep for ep in self.endpoints if ep.transfer == usb.BULK]
        return not bulk or any(ep.interface_class in _SERIAL_CLASSES for ep in bulk)

    def listing(self, adapter: str | None = None) -> str:
        """``3.7 0403:6001 FTDI, 40 bytes out, 22 bytes in``."""
        adapter = adapter if adapter is not None else self.found_adapter()[0]
        return (f"{self.key} {self.ids_text} {NAMES[adapter]}, {counted(self.bytes_out(), 'byte')} out, "
                f"{counted(self.bytes_in(adapter), 'byte')} in")

    def seen(self) -> str:
        """``1.4 046d:c52b (interrupt)``: a device as a capture without serial data shows it."""
        kinds = ", ".join(usb.TRANSFER_NAMES[t] for t in sorted(self.transfers) if t in usb.TRANSFER_NAMES)
        return f"{self.key} {self.ids_text}" + (f" ({kinds})" if kinds else "")


@dataclass
class Survey:
    devices: dict[tuple[int, int], Device] = field(default_factory=dict)
    first_ns: int | None = None
    packets: int = 0
    cut: str | None = None        # how the file ends early, when it does


def survey(urbs: Iterable[usb.Urb]) -> Survey:
    """What the capture's URB events show of each device."""
    found = Survey()
    devices = found.devices
    asked: dict[int, usb.Setup] = {}   # control requests waiting for their completion, by URB id
    for u in urbs:
        found.packets += 1
        if found.first_ns is None:
            found.first_ns = u.ns
        dev = devices.get((u.bus, u.device))
        if dev is None:
            dev = devices[(u.bus, u.device)] = Device(u.bus, u.device)
        dev.transfers.add(u.transfer)
        if u.transfer == usb.BULK:
            if u.incoming and u.completion and u.status == 0 and u.data:
                dev.ins.setdefault(u.endpoint, Pipe()).took(u.data, True)
            elif not u.incoming and not u.completion and u.data:
                dev.outs.setdefault(u.endpoint, Pipe()).took(u.data, False)
        elif u.transfer == usb.CONTROL:
            if u.setup is not None:
                setup = usb.setup_of(u.setup)
                asked[u.urb_id] = setup
                if setup.request_type & 0x60 == 0x40 and dev.clue is None:   # a vendor request
                    dev.clue = adapter_of_request(setup.request_type, setup.request)
            elif u.completion and u.urb_id in asked:
                _described(dev, asked.pop(u.urb_id), u)
    return found


def _described(dev: Device, setup: usb.Setup, u: usb.Urb) -> None:
    """A completed GET_DESCRIPTOR: the device's ids or its endpoints."""
    if u.status != 0:
        return
    kind = usb.descriptor_asked(setup)
    if kind == usb.DEVICE_DESCRIPTOR:
        ids = usb.device_ids(u.data)
        if ids is not None:
            dev.ids = ids
    elif kind == usb.CONFIGURATION_DESCRIPTOR:
        eps = usb.endpoints(u.data)
        if len(eps) > len(dev.endpoints):   # the full read, not the first 9 bytes
            dev.endpoints = eps


@dataclass(frozen=True)
class Choice:
    """The device read, and how."""
    device: Device
    adapter: str | None          # FTDI, CP210X, CH34X or None (raw)
    in_endpoint: int | None
    out_endpoint: int | None
    max_packet: int              # FTDI's packet size (unused by the others)
    notes: tuple[str, ...]       # warnings: how the adapter was found, endpoints left out


def choose(found: Survey, name: str, usb_device: str | None, adapter: str | None) -> Choice:
    """The serial adapter to read (``--usb-device``, else the one device with
    bulk data) and its adapter (``--adapter``, else as the capture shows it); a
    CaptureError of one line when there is none or a choice to make."""
    devices = sorted(found.devices.values(), key=lambda d: (d.bus, d.address))
    if usb_device is not None:
        dev = next((d for d in devices if d.key == usb_device), None)
        if dev is None:
            raise CaptureError(f"{name}: no USB device {usb_device} in the capture; "
                               f"{_candidates_text(devices)}")
        if not (dev.outs or dev.ins):
            raise CaptureError(f"{name}: USB device {usb_device} moves no bulk data; {_candidates_text(devices)}")
    else:
        serial = _candidates(devices)
        if not serial:
            seen = ", ".join(d.seen() for d in devices) or "none"
            cut = f"; {found.cut.removeprefix(name + ': ')}" if found.cut else ""
            raise CaptureError(f"{name}: a USB capture with no serial adapter in it (no bulk data to or from "
                               f"any device); devices seen: {seen}{cut}")
        if len(serial) > 1:
            raise CaptureError(f"{name}: {len(serial)} serial adapters move data: "
                               f"{'; '.join(d.listing() for d in serial)}: choose one with --usb-device BUS.DEV")
        dev = serial[0]
    return _how(dev, name, adapter)


def _candidates(devices: list[Device]) -> list[Device]:
    return [d for d in devices if d.maybe_serial() and (d.bytes_out() or d.bytes_in(d.found_adapter()[0]))]


def _candidates_text(devices: list[Device]) -> str:
    serial = _candidates(devices)
    if serial:
        return f"serial adapters in it: {'; '.join(d.listing() for d in serial)}"
    return f"devices in it: {', '.join(d.seen() for d in devices) or 'none'} (none moves bulk data)"


def _how(dev: Device, name: str, given: str | None) -> Choice:
    found, how = dev.found_adapter()
    adapter = given if given is not None else found
    notes: list[str] = []
    where = f"{name}: USB device {dev.key}"
    if given is not None and how == "enumeration" and given != found:
        notes.append(f"{where}: --adapter {given} overrides the enumeration's {NAMES[found]} ({dev.ids_text})")
    elif given is None and how == "enumeration" and found is None:
        notes.append(f"{where} ({dev.ids_text}) is no FTDI, CP210x or CH340: its bytes are read as they are "
                     "(--adapter ftdi|cp210x|ch34x says otherwise)")
    elif given is None and how != "enumeration":
        notes.append(f"{where}: {_guess_text(dev, adapter, how)}; --adapter ftdi|cp210x|ch34x says otherwise")
    in_ep = _busiest(dev.ins, lambda p: p.moved - 2 * p.status_only)
    out_ep = _out_of_same_port(dev, in_ep)
    others = sorted({0x80 | n for n, p in dev.ins.items() if n != in_ep and p.moved > 2 * p.status_only}
                    | {n for n in dev.outs if n != out_ep})
    if others:
        notes.append(f"{where}: bulk data on more endpoints than one port's: reading IN "
                     f"{_ep(0x80 | in_ep if in_ep is not None else None)} and OUT {_ep(out_ep)}, "
                     f"leaving out {', '.join(_ep(e) for e in others)}")
    max_packet = dev.max_packet(in_ep) if in_ep is not None else 64
    return Choice(dev, adapter, in_ep, out_ep, max_packet, tuple(notes))


def _guess_text(dev: Device, adapter: str | None, how: str) -> str:
    if how == "traffic":
        idle = sum(p.status_only for p in dev.ins.values())
        polls = f"; {counted(idle, 'idle poll')} of status alone" if idle else ""
        return (f"no enumeration in the capture; taken as an FTDI adapter from its traffic (two status bytes "
                f"at the start of every IN transfer{polls})")
    if how == "requests":
        return f"no enumeration in the capture; taken as a {NAMES[adapter]} adapter from its vendor requests"
    return ("no enumeration in the capture and nothing in its traffic names the adapter: its bytes are read as "
            "they are (a CH340, or a CP210x without event insertion)")


def _busiest(pipes: dict[int, Pipe], weight: Callable[[Pipe], int]) -> int | None:
    return max(pipes, key=lambda n: (weight(pipes[n]), -n), default=None)


def _out_of_same_port(dev: Device, in_ep: int | None) -> int | None:
    """The OUT endpoint of the IN endpoint's interface when the configuration is
    known (an FT2232H's port B is 0x83 and 0x04), else the busiest."""
    if in_ep is not None:
        interface = next((ep.interface for ep in dev.endpoints if ep.address == 0x80 | in_ep), None)
        if interface is not None:
            mine = [ep.address for ep in dev.endpoints
                    if ep.interface == interface and ep.transfer == usb.BULK and not ep.address & 0x80]
            if mine:
                return mine[0]
    return _busiest(dev.outs, lambda p: p.moved)


def _ep(address: int | None) -> str:
    return "none" if address is None else f"0x{address:02x}"
