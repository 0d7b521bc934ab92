"""What a line's waveform showed, below its bytes: the measure of its clock,
its idle level and format, and the receiver's errors and the signs of a sick
line, counted. One ``LineReport`` a line, kept up to date as the software UART
decodes (analyzer/physical/uart.py); the wiring doctor reads them
(analyzer/analysis/doctor.py, the waveform rules)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class RateChange:
    t: float          # capture seconds at the first character at the new rate
    before: float     # bit/s
    after: float


@dataclass
class LineReport:
    line: str                           # "A", "B" or "AB"
    channel: str                        # the channel as the file names it
    samplerate: float = 0.0
    measured: float | None = None       # bit/s, from the edges (None: too few)
    nominal: int | None = None          # the standard rate it is nearest, or the --baud given
    given: bool = False                 # the rate was given (--baud), not measured
    measured_from: int = 0              # the intervals between edges the measure rests on
    rate_fit: float = 0.0               # the share of them a whole number of bits long
    rate_sure: bool = False             # enough of them, nearly all whole bits (bitrate.Measured.sure)
    inverted: bool = False              # idle low: read without a transceiver, or wires crossed
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1
    possible_formats: list[str] = field(default_factory=list)   # formats that read the line as well (a guess)
    edges: int = 0
    characters: int = 0
    framing_errors: int = 0
    parity_errors: int = 0
    breaks: int = 0
    glitches: int = 0                   # pulses shorter than a quarter bit (removed before decoding)
    off_grid: int = 0                   # characters with an edge off the bit grid: two senders at once
    first_error: float | None = None    # capture seconds of the first framing or parity error
    rate_changes: list[RateChange] = field(default_factory=list)

    @property
    def toggles(self) -> bool:
        return self.edges > 0

    @property
    def error_pct(self) -> float | None:
        """How far the measured clock is from the nominal rate, in per cent (+: fast)."""
        if self.measured is None or not self.nominal:
            return None
        return (self.measured - self.nominal) / self.nominal * 100.0

    @property
    def format(self) -> str:
        return f"{self.data_bits}{self.parity}{self.stop_bits:g}"
