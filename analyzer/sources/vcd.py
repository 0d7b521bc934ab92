"""Value Change Dumps (``.vcd``, IEEE 1364-2005 §18): what simulators, PulseView
(``sigrok-cli -O vcd``) and most logic analysers export (docs/instruments.md,
"VCD").

The header (``$timescale``, ``$scope``/``$var``, ``$enddefinitions``) is read
whole; the body is streamed in blocks of a few MB, each cut just before a
``#time`` so that a time's changes are never split, and read vectorised
(analyzer/sources/vcd_body.py). The channels are the 1-bit variables, named as
the file names them (``numbers``: their order, "0", "1", …); wider variables
are left out, with a note.

A tick is the time scale's unit, so the sample rate is 1/timescale and the
file's times are not samples (``sampled`` False: a simulator's transitions are
exact). A dump sigrok wrote says the rate it sampled at
(``$comment Acquisition with 2/2 channels at 1 MHz $end``): then the ticks are
those samples and the 4-samples-a-bit rule applies.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

import numpy as np

from ..errors import CaptureError
from ..physical.edges import Block, Edges, Waveform
from ..words import counted
from .base import ReadSettings, Source
from .files import Input
from .sigrok import parse_samplerate
from .vcd_body import BodyParser

BLOCK_BYTES = 4 << 20        # body read this much at a time
# A list of transitions need not say when the capture ended: after the last one
# (or a damaged line) the levels are taken to hold this long, so that the
# character in flight is read (12 bits at 600 bit/s).
LEVELS_HOLD = 0.020
HEADER_LIMIT = 64 << 20      # a header longer than this is not a VCD's
# Changes at one time are never split between blocks, so the body is read on until
# a #time to cut at: this much without one is no dump's (it would be held whole).
UNCUT_LIMIT = 64 << 20
_TIMESCALE = re.compile(r"^\s*(1|10|100)\s*(s|ms|us|ns|ps|fs)\s*$")
_UNIT = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "ps": 1e-12, "fs": 1e-15}
_TIME = re.compile(rb"#([0-9]{1,18})\s")
_SIGROK_RATE = re.compile(r"Acquisition with \d+/\d+ channels at ([0-9.]+\s*[kKmMgG]?Hz)")
NOT_CHANNELS = {"real", "realtime", "event", "string", "parameter"}


class Header:
    """What ``$enddefinitions`` closes: the time unit, the 1-bit variables."""

    def __init__(self, text: str, name: str) -> None:
        self.unit: float | None = None      # seconds a tick
        self.sampled_at: float | None = None
        self.channels: list[str] = []
        # each channel's variable as declared: its kind (wire, reg, …) and its
        # reference without the scope (what sigrok's VCD input names it by)
        self.kinds: list[str] = []
        self.references: list[str] = []
        self.ids: dict[bytes, int] = {}
        self.wide: list[str] = []           # variables left out
        self.date = ""
        scope: list[str] = []
        words = text.split()
        i = 0
        while i < len(words):
            word = words[i]
            j = i + 1
            while j < len(words) and words[j] != "$end":
                j += 1
            body = words[i + 1:j]
            if word == "$timescale":
                m = _TIMESCALE.match("".join(body))
                if not m:
                    raise CaptureError(f"{name}: $timescale {' '.join(body)!r} is not a time unit (e.g. 1 ns)")
                self.unit = int(m.group(1)) * _UNIT[m.group(2)]
            elif word == "$scope" and len(body) >= 2:
                scope.append(body[1])
            elif word == "$upscope" and scope:
                scope.pop()
            elif word == "$var":
                self._variable(body, scope)
            elif word == "$comment":
                m = _SIGROK_RATE.search(" ".join(body))
                try:
                    rate = parse_samplerate(m.group(1)) if m else 0.0
                except ValueError:
                    rate = 0.0            # a comment is no promise: read the times as they are
                if rate >= 1:
                    self.sampled_at = rate
            elif word == "$date":
                self.date = " ".join(body)
            i = j + 1

    def _variable(self, body: list[str], scope: list[str]) -> None:
        if len(body) < 4:
            return
        kind, size, ident, ref = body[0], body[1], body[2], " ".join(body[3:])
        ref = ref.replace(" [", "[")
        if size != "1" or kind in NOT_CHANNELS:
            self.wide.append(ref)
            return
        key = ident.encode("latin-1")
        if key in self.ids:          # the same signal seen in another scope: one channel
            return
        self.kinds.append(kind)
        self.references.append(ref)
        if ref in self.channels:     # the same name in two scopes: the path tells them apart
            ref = ".".join(scope + [ref])
        self.ids[key] = len(self.channels)
        self.channels.append(ref)


class ValueChangeDump(Waveform):
    """A VCD's 1-bit variables as edges, streamed."""

    def __init__(self, inp: Input) -> None:
        super().__init__()
        self.input = inp
        self.name = inp.name
        self.stream = inp.stream()
        text, self.rest = self._header()
        self.body_line = 1 + text.count("\n")   # the line the body starts on
        self.header = header = Header(text, inp.name)
        self.notes: list[str] = []
        if header.unit is None:
            header.unit = 1e-9
            self.notes.append(f"{inp.name}: no $timescale: times read as nanoseconds")
        self.unit: float = header.unit          # seconds a tick
        if header.wide:
            shown = ", ".join(header.wide[:5]) + (", …" if len(header.wide) > 5 else "")
            self.notes.append(f"{inp.name}: {counted(len(header.wide), 'variable')} wider than 1 bit left out "
                              f"({shown})")
        if not header.channels:
            raise CaptureError(f"{inp.name}: the VCD declares no 1-bit variable ($var wire 1 …): no channel to read")
        self.channels = list(header.channels)
        self.numbers = [str(i) for i in range(len(self.channels))]
        self.scale = 1.0                       # ticks a file time unit
        if header.sampled_at and header.sampled_at * header.unit > 1 + 1e-9:
            # sigrok's time unit is never shorter than a sample (1 MHz: 1 us; 24 MHz: 1 ns);
            # finer samples than ticks are a comment not to believe, and their ticks
            # could pass int64 (a time of 18 digits times the ratio)
            self.notes.append(f"{inp.name}: the comment's rate of {header.sampled_at:g} Hz is finer than the "
                              f"$timescale: times read as they are")
            header.sampled_at = None
        if header.sampled_at:
            self.samplerate, self.sampled = header.sampled_at, True
            self.scale = header.sampled_at * header.unit
        else:
            self.samplerate, self.sampled = 1.0 / header.unit, False

    def _header(self) -> tuple[str, bytes]:
        data = b""
        while True:
            at = data.find(b"$enddefinitions")
            end = data.find(b"$end", at + len(b"$enddefinitions")) if at >= 0 else -1
            if end >= 0:
                cut = end + len(b"$end")
                return data[:cut].decode("latin-1"), data[cut:]
            more = self.stream.read(1 << 20)
            if not more or len(data) > HEADER_LIMIT:
                what = "cut short in its header" if not more else "a header over 64 MB"
                raise CaptureError(f"{self.name}: no $enddefinitions: {what}, no value change to read")
            data += more

    def blocks(self) -> Iterator[Block]:
        parser = BodyParser(self.header.ids, len(self.channels))
        line = self.body_line
        data, ended = self.rest, False
        searched = 0                            # data[:searched] has no #time to cut at
        while not ended:
            more = self.stream.read(BLOCK_BYTES)
            ended = not more
            data += more
            if ended:
                if data and not data[-1:].isspace():
                    cut_at = max(data.rfind(b" "), data.rfind(b"\n"), data.rfind(b"\t"))
                    last = line + data.count(b"\n")
                    self.problem = f"{self.name}: ends in the middle of line {last} (cut short?): read up to there"
                    data = data[:cut_at + 1]
                body, data = data, b""
            else:
                cut = _before_last_time(data, searched)
                if cut <= 0 and len(data) <= UNCUT_LIMIT:
                    searched = len(data)        # the next look starts from what comes next
                    continue                    # no #time to cut at yet: read on
                if cut <= 0:
                    self.problem = (f"{self.name}: line {line}: {UNCUT_LIMIT >> 20} MB without a #time from "
                                    "there: read up to there")
                    body, data, ended = b"", b"", True
                else:
                    body, data = data[:cut], data[cut:]
                searched = 0
            levels = {ch: parser.level[ch] for ch in range(len(self.channels))}
            times = parser.parse(body)
            if parser.bad is not None:
                at, why = parser.bad
                where = line + body.count(b"\n", 0, at)
                self.problem = f"{self.name}: line {where}: {why}: read up to there"
            m = _TIME.match(data)
            if m and parser.bad is None and not ended:
                end = int(m.group(1))
            elif parser.ends_bare and parser.bad is None:
                end = parser.time + 1          # a last #time with no change: the capture's end
            else:
                end = parser.time + 1 + int(LEVELS_HOLD / self.unit)
            if ended and self.input.problem and self.problem is None:
                self.problem = self.input.problem
            yield self._block(times, levels, parser, end)
            if parser.bad is not None:
                return
            line += body.count(b"\n")

    def _block(self, times: list[np.ndarray], levels: dict[int, int], parser: BodyParser, end: int) -> Block:
        edges = {}
        for ch, t in enumerate(times):
            level = levels[ch] if levels[ch] >= 0 else parser.first_level.get(ch, 1)
            if self.scale != 1.0:
                t = np.rint(t * self.scale).astype(np.int64)
            edges[ch] = Edges(t, level)
        if self.scale != 1.0:
            end = round(end * self.scale)
        return Block(end, edges)

    def close(self) -> None:
        self.input.close()


def _before_last_time(data: bytes, since: int = 0) -> int:
    """Where the last ``#time`` token of ``data`` starts (0: none), looking from
    ``since`` on (before it, an earlier look found none: each look is then over
    the new bytes only, not the whole body read so far again)."""
    at = len(data)
    while True:
        at = data.rfind(b"#", since, at)
        if at <= 0:
            return 0
        if data[at - 1:at].isspace():
            return at


def open_vcd(inputs: list[Input], settings: ReadSettings) -> Source:
    from .sampled import SampledSource
    dump = ValueChangeDump(inputs[0])
    what = f"VCD, {counted(len(dump.channels), 'channel')}" + (", sampled" if dump.sampled else "")
    source = SampledSource(dump, settings, inputs[0].describe(what))
    for note in dump.notes:
        source.warn_later(note)
    return source
