"""Logic captures as a source: the channels of a ``Waveform`` (a sigrok session,
a VCD file, a Saleae export, a sample stream) read by a software UART each
(analyzer/physical/uart.py), their characters merged in wire order into chunks
(docs/instruments.md).

Which channels: ``--channels A=NAME,B=NAME`` (names or numbers as the file gives
them; ``AB=NAME`` or ``A=NAME`` alone: one line carrying both directions), or
else the first two that toggle (the first one alone if only one does). The
source looks at the capture's first blocks to choose, and to measure each
line's rate and format before the capture decodes (the options' rate is then
the nominal rate measured, unless ``--baud`` was given: ``measured_settings``).

Times come from the samples: a chunk is a run of characters sent back to back,
its time the first start bit's edge. The receiver's errors go to ``faults``;
each line's ``LineReport`` (``physical``) feeds the wiring doctor.
"""

from __future__ import annotations

import heapq
from bisect import bisect_left
from collections.abc import Callable, Iterator
from operator import attrgetter
from typing import Any

from dissectors.wire import LineSettings

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk, LineFault
from ..physical.bitrate import SURE_INTERVALS, named_rate, nominal_rate, power_of_ten_off
from ..physical.charformat import LineFormat
from ..physical.edges import NO_EDGES, Block, Edges, Waveform
from ..physical.report import LineReport
from ..physical.uart import Char, SoftUart
from ..words import counted
from .base import ReadSettings, Source

MIN_SAMPLES_A_BIT = 4
_tick = attrgetter("tick")
LOOK_AHEAD_EDGES = 400       # edges looked at on the busiest channel before choosing channels
LOOK_AHEAD_BLOCKS = 64       # ... or this many blocks, whichever first


class SampledSource(Source):
    timed = True
    clocks = 1                   # one analyser samples every channel
    wire_times = True            # a chunk's time is its first start bit's edge

    def __init__(self, waveform: Waveform, settings: ReadSettings, description: str,
                 samplerate_given: bool = False) -> None:
        """``samplerate_given``: the sample rate was typed by hand (a bare stream
        of samples has none of its own), so a wrong one is worth a word."""
        super().__init__()
        self.samplerate_given = samplerate_given
        self.waveform = waveform
        self.name = waveform.name
        self.description = description
        self.on_close(waveform.close)
        self.faults: list[LineFault] = []
        inst = settings.instrument
        self._blocks = waveform.blocks()
        self._ahead: list[Block] = []
        self._ended = False
        self._look_ahead()
        self.channel_of = self._choose(dict(inst.channels))
        self.lines = tuple(self.channel_of)
        rate = waveform.samplerate
        bit = rate / inst.baud if inst.baud else None
        fmt = None
        if inst.data_bits is not None or inst.parity is not None or inst.stop_bits is not None:
            fmt = LineFormat(inst.data_bits or 8, inst.parity or "N", inst.stop_bits or 1)
        self.physical: dict[str, LineReport] = {}
        self._uarts: dict[str, SoftUart] = {}
        min_bit = MIN_SAMPLES_A_BIT if waveform.sampled else 0.0
        for line, ch in self.channel_of.items():
            report = LineReport(line, waveform.channels[ch], samplerate=rate)
            self.physical[line] = report
            self._uarts[line] = SoftUart(report, bit, fmt, min_bit=min_bit)
        self.start_time = settings.start_time if settings.start_time is not None else waveform.start_time
        self._pending: dict[str, list[Char]] = {line: [] for line in self.lines}
        self._sent: dict[str, int] = {}      # bytes yielded on each line (the faults' offsets)
        self._said = False                   # what the UARTs could not find out is said once
        self._rate_checked: set[str] = set()  # lines whose measure was checked against the sample rate given
        self._measure()

    # ------------------------------------------------------------------ opening
    def _look_ahead(self) -> None:
        """Read the first blocks (kept, to be decoded): enough to see which channels
        toggle and to measure their rates."""
        edges: dict[int, int] = {}
        while len(self._ahead) < LOOK_AHEAD_BLOCKS:
            try:
                block = next(self._blocks)
            except StopIteration:
                self._ended = True
                break
            self._ahead.append(block)
            for ch, e in block.edges.items():
                edges[ch] = edges.get(ch, 0) + int(e.ticks.size)
            if sorted(edges.values(), reverse=True)[1:2] >= [LOOK_AHEAD_EDGES]:
                break
        self._seen = edges

    def _choose(self, given: dict[str, str]) -> dict[str, int]:
        """line → channel index."""
        w = self.waveform
        if given:
            chosen = {LINE_AB if line == LINE_A and len(given) == 1 else line: self._channel(name)
                      for line, name in given.items()}
            if set(chosen) == {LINE_B}:
                raise CaptureError(f"{self.name}: --channels names line B alone: give line A too "
                                   f"(or A=CHANNEL for one line carrying both directions)")
            for line, ch in chosen.items():
                if not self._seen.get(ch):
                    self.warn_later(f"{self.name}: channel {w.channels[ch]} (line {line}) never toggles in the "
                                    f"first {self._looked()}: is the probe on the wire?")
            return dict(sorted(chosen.items()))
        toggling = [ch for ch in range(len(w.channels)) if self._seen.get(ch)]
        if not toggling:
            raise CaptureError(f"{self.name}: no channel toggles in the first {self._looked()} "
                               f"(channels: {self._listing()}): nothing was sent, or the probes are not on the wires")
        if len(toggling) == 1:
            return {LINE_AB: toggling[0]}
        if len(toggling) > 2:
            self.warn_later(f"{self.name}: {len(toggling)} channels toggle; lines A and B are "
                            f"{w.channels[toggling[0]]} and {w.channels[toggling[1]]} (--channels A=NAME,B=NAME "
                            f"chooses others)")
        return {LINE_A: toggling[0], LINE_B: toggling[1]}

    def _channel(self, name: str) -> int:
        w = self.waveform
        for names in (w.channels, w.numbers):
            if name in names:
                return names.index(name)
        low = name.lower()
        for names in (w.channels, w.numbers):
            found = [i for i, n in enumerate(names) if n.lower() == low]
            if found:
                return found[0]
        raise CaptureError(f"{self.name}: no channel {name!r}; the channels are {self._listing()}")

    def _listing(self) -> str:
        w = self.waveform
        out = []
        for i, name in enumerate(w.channels):
            number = w.numbers[i] if i < len(w.numbers) else ""
            out.append(f"{name} ({number})" if number and number != name else name)
        return ", ".join(out) or "none"

    def _looked(self) -> str:
        end = self._ahead[-1].end if self._ahead else 0
        secs = end / self.waveform.samplerate if self.waveform.samplerate else 0.0
        return f"{secs:.3g} s" if not self._ended else "capture"

    def _measure(self) -> None:
        """Give every UART the blocks looked at (it measures its rate on them), and
        refuse a capture sampled too slowly to read."""
        for block in self._ahead:
            self._feed(block)
        self._ahead = []
        for line, uart in self._uarts.items():
            if not uart.started and uart.ticks.size and uart.measure(final=self._ended):
                self._pending[line] += uart.decode()
            self._check_samplerate(line, uart)
            self._check_rate(line, uart)
        if self._ended:                 # the whole capture was looked at: said before it is read
            self._say_lines(self.warn_later)

    def _say_lines(self, say: Callable[[str], None]) -> None:
        """What each line's UART could not find out by itself, once."""
        if self._said:
            return
        self._said = True
        for line, uart in self._uarts.items():
            r = uart.report
            if uart.started and not r.given and (r.possible_formats or not r.rate_sure):
                say(self._guessed(line, r))
            elif not uart.started and uart.too_fast:
                say(f"{self._sampled_too_slowly(line, named_rate(uart.too_fast))}: nothing decoded")
            elif not uart.started and r.toggles:
                say(f"{self.name}: line {line} ({r.channel}): no bit rate in its {counted(r.edges, 'edge')}; "
                    "give it with --baud")

    def _guessed(self, line: str, r: LineReport) -> str:
        """What a line was read as when its few characters leave the rate or the
        format a guess: how sure, and which options settle it."""
        said = f"{self.name}: line {line} ({r.channel}) read as {r.nominal:,} bit/s {r.format}"
        options = ["--data-bits", "--parity", "--stop-bits"]
        if not r.rate_sure:
            if r.measured_from < SURE_INTERVALS:
                said += f"; the rate is a guess from only {counted(r.measured_from, 'interval')} between edges"
            else:
                said += (f"; the rate is a guess: {r.rate_fit:.0%} of its {r.measured_from:,} intervals between "
                         "edges are whole bits")
            options.insert(0, "--baud")
        if r.possible_formats:
            said += f"; {_either(r.possible_formats)} would read its few characters as well"
        elif r.rate_sure:
            options = []
        return said + f" ({', '.join(options[:-1])} and {options[-1]} say which)" if options else said

    def _check_samplerate(self, line: str, uart: SoftUart) -> None:
        """A sample rate typed by hand that is a power of ten off makes every line's
        rate that far off too, and decoding goes on at it without an error (answers
        a hundred times late): said when a line's measure fits no standard rate
        while the rate times a power of ten would. Once a line, when it has started."""
        if not self.samplerate_given or not uart.started or line in self._rate_checked:
            return
        self._rate_checked.add(line)
        r = uart.report
        if r.given or not r.measured:
            return
        factor = power_of_ten_off(r.measured)
        if factor is None:
            return
        self._rate_checked.update(self.lines)   # one sample rate for every line: said once
        meant = hz(self.waveform.samplerate * factor).replace(" ", "")   # as the option is typed
        self.warn_later(
            f"{self.name}: line {line} ({r.channel}) measures {_bits_per_second(r.measured)} bit/s, near no "
            "standard rate; "
            f"at --samplerate {meant} it would be {nominal_rate(r.measured * factor):,} bit/s: "
            f"did you mean --samplerate {meant}?")

    def _feed(self, block: Block) -> None:
        for line, uart in self._uarts.items():
            e = block.edges.get(self.channel_of[line])
            self._pending[line] += uart.feed(e if e is not None else Edges(NO_EDGES, uart.level), block.end)
            self._check_samplerate(line, uart)

    def _check_rate(self, line: str, uart: SoftUart) -> None:
        """Under 4 samples a bit, only when the line's clean traffic says so: a
        rate given that fast, or a line whose only well-fitting rate is that fast
        (glitches and a burst of ringing are no rate: the UART measures past them)."""
        w = self.waveform
        if not w.sampled:
            return
        # judged on the samples a bit, not on the rate's name: at a sample rate
        # typed far too low, 104 samples a bit measure 0.0096 bit/s, named 1 bit/s
        if uart.started:
            samples, baud = uart.bit, uart.report.nominal
            assert baud is not None   # a UART names the rate it starts at
        elif uart.too_fast and self._ended:   # a line not started may still start past its junk
            samples, baud = w.samplerate / uart.too_fast, named_rate(uart.too_fast)
        else:
            return
        if samples is not None and samples < MIN_SAMPLES_A_BIT:
            raise CaptureError(self._sampled_too_slowly(line, baud))

    def _sampled_too_slowly(self, line: str, baud: int) -> str:
        rate = self.waveform.samplerate
        return (f"{self.name}: sampled at {hz(rate)}, under {MIN_SAMPLES_A_BIT} samples a bit at {baud:,} bit/s "
                f"(line {line}): capture at {hz(MIN_SAMPLES_A_BIT * baud)} or more")

    def read_with(self, settings: dict[str, LineSettings]) -> None:
        """The capture's settings; a rate change it follows (an acknowledged
        rate-set command) tells every line's UART to measure again from there."""
        super().read_with(settings)
        if settings:     # a change changes every line's settings: one of them tells
            next(iter(settings.values())).watch(self._rate_set)

    def _rate_set(self, settings: LineSettings) -> None:
        t = settings.changed_at
        if t is None or not settings.baud:
            return
        for uart in self._uarts.values():
            uart.hint_rate(t * self.waveform.samplerate, settings.baud)

    def measured_settings(self) -> dict[str, Any]:
        """The serial settings the capture decodes with, as measured (the first
        line's): the options take them unless given (analyzer/capture/recorded.py)."""
        for report in self.physical.values():
            if report.nominal:
                return {"baud": int(report.nominal), "data_bits": report.data_bits, "parity": report.parity,
                        "stop_bits": report.stop_bits}
        return {}

    # ------------------------------------------------------------------ reading
    def chunks(self) -> Iterator[Chunk]:
        rate = self.waveform.samplerate
        uarts = self._uarts
        # the characters read while looking ahead come first
        yield from self._release(self._watermark(), rate)
        for block in self._blocks:      # (the blocks looked ahead were fed while opening)
            self._feed(block)
            out = list(self._release(self._watermark(), rate))
            if out:
                yield from out
            else:
                yield Chunk(self.lines[0], b"", block.end / rate)   # time passed: timeouts expire
        for line, uart in uarts.items():
            self._pending[line] += uart.finish()
        self._say_lines(self.warn)
        yield from self._release(None, rate)
        if self.waveform.problem:
            self.warn(self.waveform.problem)

    def _watermark(self) -> float | None:
        """Characters starting before this tick are all known, on every line."""
        marks = []
        for uart in self._uarts.values():
            marks.append(int(uart.ticks[0]) if uart.ticks.size else uart.end)
        return min(marks) if marks else None

    def _release(self, upto: float | None, rate: float) -> Iterator[Chunk]:
        """The pending characters before ``upto`` (all: None), in wire order, as
        chunks: a run of one line's characters back to back is one chunk."""
        ready = []
        for line, chars in self._pending.items():
            n = len(chars) if upto is None else bisect_left(chars, upto, key=_tick)
            if n:
                ready.append([(c.tick, line, c) for c in chars[:n]])
                self._pending[line] = chars[n:]
        if not ready:
            return
        run_line, run_start, run_bytes, last = None, 0, bytearray(), 0
        sent = self._sent
        for tick, line, c in heapq.merge(*ready):
            uart = self._uarts[line]
            assert uart.bit is not None   # its characters came: it knows its bit
            char_ticks = (uart.fmt.bits + 1) * uart.bit
            if run_line is not None and (line != run_line or tick - last > 1.5 * char_ticks):
                yield Chunk(run_line, bytes(run_bytes), run_start / rate)
                run_line = None
            if c.fault is not None:
                self.faults.append(LineFault(line, sent.get(line, 0), c.fault))
            if c.value is None:        # a break: no byte, its fault goes on the next one
                continue
            if run_line is None:
                run_line, run_start, run_bytes = line, tick, bytearray()
            if uart.fmt.data_bits > 8:   # nine data bits: two bytes, high first, as sigrok's uart gives them
                run_bytes += c.value.to_bytes(2, "big")
                sent[line] = sent.get(line, 0) + 2
            else:
                run_bytes.append(c.value)
                sent[line] = sent.get(line, 0) + 1
            last = tick
        if run_line is not None:
            yield Chunk(run_line, bytes(run_bytes), run_start / rate)


def _bits_per_second(rate: float) -> str:
    """A measured rate as a message says it: whole with separators, or its first
    figures when under 100 (0.0096 bit/s, of a sample rate typed a million off)."""
    return f"{rate:,.0f}" if rate >= 100 else f"{rate:.3g}"


def _either(names: list[str]) -> str:
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"


def hz(rate: float) -> str:
    for unit, scale in (("GHz", 1e9), ("MHz", 1e6), ("kHz", 1e3)):
        if rate >= scale:
            return f"{rate / scale:g} {unit}"
    return f"{rate:g} Hz"
