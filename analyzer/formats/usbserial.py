"""What USB-serial adapters put in their bulk IN data besides the line's bytes,
and how to take it off: pure decoders, one per adapter, each reading one line's
transfers in order and giving the line's bytes with the receiver's errors at
byte offsets (counted from the first byte it gave).

- FTDI (Linux drivers/usb/serial/ftdi_sio.c, ``ftdi_process_read_urb`` and
  ``ftdi_process_packet``; Wireshark's packet-ftdi-ft.c): a transfer is cut in
  packets of the endpoint's max-packet size (64 at full speed, 512 at high
  speed); every packet starts with two status bytes, the modem status and the
  line status, whose bits OE 0x02, PE 0x04, FE 0x08 and BI 0x10 are the
  receiver's errors. A packet of the two status bytes alone is the chip's
  answer to the host's polling while the line is idle: nothing was received.
  The line status belongs to the packet, not to a byte: as the Linux driver
  does, a parity or framing error (parity first) and an overrun are put on the
  packet's first byte, and a break on its last byte when that is a NUL (the
  character a break reads as); a break flag with any other last byte is left
  over from a break already told, and dropped. The errors of a status-only
  packet go on the next byte received, once however many such packets repeat
  them.
- CP210x (Linux drivers/usb/serial/cp210x.c, ``cp210x_process_char``): raw
  bytes, unless the host turned on event insertion (the vendor request
  EMBED_EVENTS, 0x15, whose value is the escape character): then the escape
  character followed by 0x00 is the escape character itself, by 0x01 a line
  status byte and the data byte it concerns, by 0x02 a line status byte alone,
  by 0x03 a modem status byte. Line status bits: overrun 0x02, parity 0x04,
  framing 0x08, break 0x10 (break before parity before framing, as the driver
  flags them). Turning the UART off (IFC_ENABLE with 0) ends event insertion.
- CH340/CH341 (drivers/usb/serial/ch341.c): raw bytes.
"""

from __future__ import annotations

FTDI, CP210X, CH34X = "ftdi", "cp210x", "ch34x"
NAMES = {FTDI: "FTDI", CP210X: "CP210x", CH34X: "CH340/CH341", None: "unknown"}
VENDORS = {0x0403: FTDI, 0x10C4: CP210X, 0x1A86: CH34X}   # idVendor of each maker

FRAMING, PARITY, BREAK, OVERRUN = "framing", "parity", "break", "overrun"

Fault = tuple[int, str]   # (byte offset on the line, FRAMING/PARITY/BREAK/OVERRUN)

# FTDI line status (ftdi_sio.h: FTDI_RS_*)
_FTDI_OE, _FTDI_PE, _FTDI_FE, _FTDI_BI = 0x02, 0x04, 0x08, 0x10
# the modem status's low bits, as Wireshark's ftdi-ft dissector reads them: the
# chip's max packet (full speed 64, high speed 512)
_FTDI_FULL_SPEED, _FTDI_HIGH_SPEED = 0x01, 0x02

# CP210x (cp210x.c)
CP210X_IFC_ENABLE, CP210X_EMBED_EVENTS = 0x00, 0x15
CP210X_REQUEST_TYPE = 0x41   # vendor, host to interface
_CP_OE, _CP_PE, _CP_FE, _CP_BI = 0x02, 0x04, 0x08, 0x10


class Raw:
    """An adapter that passes the line's bytes as they are."""

    def decode(self, data: bytes) -> tuple[bytes, list[Fault]]:
        return data, []


class FtdiIn:
    """An FTDI chip's bulk IN transfers: status bytes off, errors out."""

    def __init__(self, max_packet: int) -> None:
        self.max_packet = max_packet
        self.taken = 0                  # bytes given so far: the line offset of the next
        self._pending: set[str] = set()  # errors of status-only packets, for the next byte

    def decode(self, transfer: bytes) -> tuple[bytes, list[Fault]]:
        out = bytearray()
        faults: list[Fault] = []
        size = self.max_packet
        for at in range(0, len(transfer), size):
            packet = transfer[at:at + size]
            if len(packet) < 2:
                break   # no status bytes: malformed, as the driver skips it
            status, payload = packet[1], packet[2:]
            here = self.taken + len(out)
            if not payload:
                self._pending.update(kind for kind, _ in _ftdi_errors(status, None))
                continue
            kinds = _ftdi_errors(status, payload)
            faults += [(here, k) for k in sorted(self._pending - {k for k, _ in kinds})]
            self._pending.clear()
            faults += [(here + last, k) for k, last in kinds]
            out += payload
        self.taken += len(out)
        return bytes(out), faults


def _ftdi_errors(status: int, payload: bytes | None) -> list[tuple[str, int]]:
    """The errors a packet's line status tells, each with its byte in the packet
    (0 the first, and the last for a break); ``payload`` None: a status-only
    packet (every error is for the next byte)."""
    found: list[tuple[str, int]] = []
    if status & _FTDI_BI:
        if payload is None:
            found.append((BREAK, 0))
        elif payload[-1] == 0:
            found.append((BREAK, len(payload) - 1))
    if status & _FTDI_PE:
        found.append((PARITY, 0))
    elif status & _FTDI_FE:
        found.append((FRAMING, 0))
    if status & _FTDI_OE:
        found.append((OVERRUN, 0))
    return found


def looks_like_ftdi_status(transfer: bytes) -> bool:
    """Does a bulk IN transfer start as an FTDI packet does: a modem status with
    the max-packet bit of full or high speed and nothing in its reserved bits?"""
    return len(transfer) >= 2 and (transfer[0] & 0x0F) in (_FTDI_FULL_SPEED, _FTDI_HIGH_SPEED)


def ftdi_max_packet(transfer: bytes) -> int | None:
    """The max-packet size an FTDI transfer's first modem status says (64 or
    512), or None when it says neither."""
    if len(transfer) < 2:
        return None
    bits = transfer[0] & 0x03
    return 64 if bits == _FTDI_FULL_SPEED else 512 if bits == _FTDI_HIGH_SPEED else None


def ftdi_payload(length: int, max_packet: int) -> int:
    """How many line bytes an FTDI transfer of ``length`` bytes carries."""
    packets = -(-length // max_packet)
    return max(0, length - 2 * packets)


class Cp210xIn:
    """A CP210x's bulk IN transfers, raw until event insertion is turned on."""

    def __init__(self) -> None:
        self.escape: int | None = None   # the escape character while event insertion is on
        self.taken = 0
        self._state = "data"
        self._pending: list[str] = []    # a line status's errors, for the next byte

    def events(self, escape: int | None) -> None:
        """Event insertion on (with this escape character) or off (None)."""
        self.escape = escape
        self._state = "data"

    def decode(self, data: bytes) -> tuple[bytes, list[Fault]]:
        if self.escape is None and self._state == "data":
            self.taken += len(data)
            return data, []
        out = bytearray()
        faults: list[Fault] = []
        for byte in data:
            state = self._state
            if state == "data":
                if byte == self.escape:
                    self._state = "escape"
                    continue
            elif state == "escape":
                self._state = {0: "data", 1: "lsr data", 2: "lsr", 3: "msr"}.get(byte, "data")
                if byte != 0:
                    continue   # an unknown code is dropped, as the driver drops it
                assert self.escape is not None   # an escape is read only while insertion is on
                byte = self.escape
            elif state in ("lsr data", "lsr"):
                self._pending += _cp210x_errors(byte)
                self._state = "data byte" if state == "lsr data" else "data"
                continue
            elif state == "msr":
                self._state = "data"
                continue
            else:   # "data byte": the byte a line status concerns
                self._state = "data"
            here = self.taken + len(out)
            faults += [(here, k) for k in self._pending]
            self._pending = []
            out.append(byte)
        self.taken += len(out)
        return bytes(out), faults


def _cp210x_errors(lsr: int) -> list[str]:
    found = []
    if lsr & _CP_BI:
        found.append(BREAK)
    elif lsr & _CP_PE:
        found.append(PARITY)
    elif lsr & _CP_FE:
        found.append(FRAMING)
    if lsr & _CP_OE:
        found.append(OVERRUN)
    return found


def adapter_of_request(request_type: int, request: int) -> str | None:
    """The adapter a vendor control request belongs to, when it is one of the
    requests its Linux driver sends (a capture started after the adapter was
    plugged in still shows the requests of opening the port)."""
    if request_type == CP210X_REQUEST_TYPE and request in (CP210X_IFC_ENABLE, 0x01, 0x03, 0x07, 0x13,
                                                           CP210X_EMBED_EVENTS, 0x1E):
        return CP210X
    if request_type in (0x40, 0xC0) and request in (0x5F, 0x95, 0x9A, 0xA1, 0xA4):   # ch341.c CH341_REQ_*
        return CH34X
    if request_type in (0x40, 0xC0) and request <= 0x0C:   # ftdi_sio.h FTDI_SIO_* requests
        return FTDI
    return None
