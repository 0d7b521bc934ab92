"""Wire-level constants and helpers for the gimbal serial protocol (spec §1.4, Table 1).

A frame is ``F8 G P D S L payload… C``: destination group, port and device, source
group, payload length (1–256, where 0 means 256) and a checksum that is the sum of
every byte from G through the last payload byte, modulo 256 (§1.4.1.3).
Simple responses are single bytes without header (§1.4.2).
"""

from __future__ import annotations

from collections.abc import Callable

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


def default_frame_gap(byte_time: float) -> float:
    """The silence that cuts a frame unless one is given: 20 characters, at least 50 ms."""
    return max(0.05, 20 * byte_time)


class LineSettings:
    """One line's serial settings as a capture follows them (docs/time.md, "Rate
    changes"): the rate and framing, the byte time they give, the frame gap, and
    the rate changes followed so far.

    It is the one owner of them: the source back-dating its reads, the deframer
    spacing the bytes, and the merge of two lines all hold this object and read
    ``byte_time`` when they need it, so a followed rate change (``set_rate``) is
    seen by every reader at once. Whoever must act on a change (a live tap's
    port) asks to be told (``watch``).

    ``frame_gap`` given explicitly stays; else it follows the byte time
    (``default_frame_gap``). A settings object made from a byte time alone
    (``timed_by``: a deframer on its own, the simulator) has no baud."""

    __slots__ = (
        "_given_gap",
        "_watchers",
        "baud",
        "byte_time",
        "changed_at",
        "changes",
        "data_bits",
        "frame_gap",
        "parity",
        "stop_bits",
    )

    def __init__(self, baud: int = 9600, data_bits: int = 8, parity: str = "N", stop_bits: float = 1,
                 frame_gap: float | None = None) -> None:
        self.baud: int | None = baud
        self.data_bits = data_bits
        self.parity = parity
        self.stop_bits = stop_bits
        self._given_gap = frame_gap
        self.byte_time = 0.0
        self.frame_gap = 0.0
        self.changes: list = []    # the rate changes followed (``analyzer.analysis.rate.RateChange``), in order
        self.changed_at: float | None = None   # capture seconds of the latest change, when known
        self._watchers: list[Callable[[LineSettings], None]] = []
        self.set_byte_time(byte_time(baud, data_bits, parity, stop_bits))

    @classmethod
    def timed_by(cls, byte_time: float, frame_gap: float | None = None) -> LineSettings:
        """Settings known only by their byte time (seconds per character)."""
        settings = cls(frame_gap=frame_gap)
        settings.baud = None
        settings.set_byte_time(byte_time)
        return settings

    def set_rate(self, baud: int, change: object = None, at: float | None = None) -> None:
        """The link's rate is ``baud`` from now on (``change``: the rate change
        followed, kept in ``changes``; ``at``: when, in capture seconds, for a
        source that reads the wire itself); watchers are told."""
        self.baud = baud
        self.changed_at = at
        self.set_byte_time(byte_time(baud, self.data_bits, self.parity, self.stop_bits))
        if change is not None:
            self.changes.append(change)
        for watcher in self._watchers:
            watcher(self)

    def watch(self, watcher: Callable[[LineSettings], None]) -> None:
        """Call ``watcher(settings)`` after every ``set_rate``."""
        self._watchers.append(watcher)

    def set_byte_time(self, seconds: float) -> None:
        """A new byte time (a rate change, or given directly: a deframer's
        ``set_byte_time``); the frame gap follows unless it was given."""
        self.byte_time = seconds
        self.frame_gap = self._given_gap if self._given_gap is not None else default_frame_gap(seconds)

    def __repr__(self) -> str:
        return (f"LineSettings({self.baud} {self.data_bits}{self.parity}{self.stop_bits:g}, "
                f"byte_time={self.byte_time!r}, frame_gap={self.frame_gap!r})")


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
