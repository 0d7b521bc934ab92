"""The decoding options shared by the API and every CLI command (``Options``),
and the line settings a capture makes of them (dissectors/wire.py, ``LineSettings``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from dissectors.wire import LineSettings, byte_time

from ..analysis.pairing import Timeouts
from ..sources import InstrumentSettings, ReadSettings


@dataclass
class Options:
    """Decoding options shared by the API and every CLI command."""
    baud: int = 9600
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1
    frame_gap: float | None = None        # seconds; default max(50 ms, 20 characters)
    timeouts: Timeouts = field(default_factory=Timeouts)
    tune_gc: bool = True                  # raise the GC's young threshold while iterating
    strip_echo: bool = True               # drop line B's copies of line A's frames (analyzer.analysis.echo)
    swap_lines: bool = False              # the tap's ports were given the other way round
    follow_rate: bool = True              # follow ACKed rate-set commands (docs/time.md, "Rate changes")
    tz: str | None = None                 # the zone of a socat log's stamps (None: this machine's)
    start_time: float | None = None       # epoch of a raw dump's first byte (None: from its mtime)
    # instruments (docs/instruments.md): the channel of each line ({"A": "TX"}), a
    # USB capture's adapter and device, a bare sample stream's rate
    channels: dict[str, str] | None = None
    adapter: str | None = None
    usb_device: str | None = None
    samplerate: float | None = None       # given: the inputs are bare streams of logic samples
    unitsize: int = 1                     # ... of this many bytes a sample
    # read a recording's raw bytes even when it carries its decoded columns
    # (docs/mcap.md, "Stored columns"): ``--redecode``
    redecode: bool = False
    # the options the user gave (flags, keywords): they win over what a recording
    # says of itself (docs/time.md, "Recordings"); the rest may be taken from it
    explicit: frozenset[str] = frozenset()

    @property
    def byte_time(self) -> float:
        """Seconds per character at the starting rate."""
        return byte_time(self.baud, self.data_bits, self.parity, self.stop_bits)

    def settings(self) -> dict:
        """The settings a recording keeps and a flag overrides, by one name each
        (the ``Options`` field, or the ``Timeouts`` one with its unit)."""
        t = self.timeouts
        return {"baud": self.baud, "data_bits": self.data_bits, "parity": self.parity,
                "stop_bits": self.stop_bits, "ack_timeout": t.ack, "result_timeout": t.result,
                "timeouts": t.result_by_command, "frame_gap": self.frame_gap, "follow_rate": self.follow_rate,
                "swap_lines": self.swap_lines}

    @property
    def read_settings(self) -> ReadSettings:
        """What a reader needs to open its inputs (the byte time at the starting rate)."""
        return ReadSettings(self.byte_time, tz=self.tz, start_time=self.start_time, instrument=self.instrument)

    @property
    def instrument(self) -> InstrumentSettings:
        """How to read an instrument's capture: the serial settings given
        explicitly are the software UART's; the others it finds out."""
        given = self.explicit
        return InstrumentSettings(
            channels=tuple(sorted((self.channels or {}).items())),
            baud=self.baud if "baud" in given else None,
            data_bits=self.data_bits if "data_bits" in given else None,
            parity=self.parity if "parity" in given else None,
            stop_bits=self.stop_bits if "stop_bits" in given else None,
            adapter=self.adapter, usb_device=self.usb_device, samplerate=self.samplerate,
            unitsize=self.unitsize)

    def line_settings(self, lines: tuple[str, ...]) -> dict[str, LineSettings]:
        """Each line's settings at the start: one object per line, which the capture
        changes as it follows the link's rate (docs/time.md, "Rate changes")."""
        return {line: LineSettings(self.baud, self.data_bits, self.parity, self.stop_bits, self.frame_gap)
                for line in lines}
