"""Wire-level constants and helpers for the gimbal serial protocol (spec §1.4, Table 1).

A frame is ``F8 G P D S L payload… C``: destination group, port and device, source
group, payload length (1–256, where 0 means 256) and a checksum that is the sum of
every byte from G through the last payload byte, modulo 256 (§1.4.1.3).
Simple responses are single bytes without header (§1.4.2).
"""

from __future__ import annotations

START = 0xF8
ACK = 0x06
NAK = 0x15
NIC = 0x3F  # "?": follows an ACK when the command has no meaning to the device

WILDCARD = 0xFF


def checksum(body: bytes | bytearray | memoryview) -> int:
    """Straight sum of G through the last payload byte, ignoring overflow (§1.4.1.3)."""
    return sum(body) & 0xFF


def build_frame(dst: tuple[int, int, int], src: int, payload: bytes | str) -> bytes:
    """Encode one frame; used by tests, sample generators and the simulator."""
    if isinstance(payload, str):
        payload = payload.encode("latin-1")
    if not 1 <= len(payload) <= 256:
        raise ValueError(f"payload must be 1..256 bytes, got {len(payload)}")
    group, port, device = dst
    body = bytes((group, port, device, src, len(payload) & 0xFF)) + payload
    return bytes((START,)) + body + bytes((checksum(body),))


def bits_per_byte(data_bits: int = 8, parity: str = "N", stop_bits: float = 1) -> float:
    """UART character length on the wire: start bit, data, parity, stop bits."""
    return 1 + data_bits + (0 if parity.upper() == "N" else 1) + stop_bits


def byte_time(baud: int, data_bits: int = 8, parity: str = "N", stop_bits: float = 1) -> float:
    """Seconds one character occupies on the wire (9600 8N1: 1.0417 ms)."""
    return bits_per_byte(data_bits, parity, stop_bits) / baud


_PRINTABLE = [chr(b) if 0x20 <= b < 0x7F and b != 0x5C else f"\\x{b:02x}" for b in range(256)]
_PRINTABLE[0x5C] = "\\\\"


def payload_text(payload: bytes) -> str:
    """Payload as text: printable ASCII kept, anything else as ``\\xNN`` (backslash doubled)."""
    try:
        text = payload.decode("ascii")
    except UnicodeDecodeError:
        return "".join([_PRINTABLE[b] for b in payload])
    if text.isprintable() and "\\" not in text:
        return text
    return "".join([_PRINTABLE[b] for b in payload])
