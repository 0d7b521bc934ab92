"""Saleae Logic 2's Async Serial data table (the analyzer's ⋮ → Export Table, CSV):
a row a frame the analyzer decoded, ``name,type,start_time,duration,data``
and, when some row has them, ``error`` and ``address`` (docs/instruments.md,
"Saleae Logic 2"). Columns are found by their header name, in any order.

Logic 2 already read the bytes: this is no waveform, the rows are the bytes.
``name`` is the analyzer: one per wire, so the first name met is line A and the
second line B, unless ``--channels A=NAME,B=NAME`` names them; one analyzer
alone is a single-line capture. Rows of another type than ``data`` are skipped.
``data`` is the byte as the table shows it, in any radix: ``0xF8``, ``0b…``,
decimal, or the character itself (``A``, ``\\n``, ``\\x06``, ``' '``): hexadecimal
is what the docs tell to export, since Logic shows some control bytes alike in
ASCII. ``error`` (``framing``, ``parity``) becomes a line fault on the byte.

A run of one line's bytes sent back to back is one chunk, timed at its first
byte's start (a start within 1.5 of the previous byte's durations of it).
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator
from typing import Any

from dissectors import problems

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk, LineFault
from ..physical.bitrate import nominal_rate
from .base import ReadSettings, Source
from .files import Input
from .signatures import COLUMNS

LOOK_AHEAD_ROWS = 4096        # rows read before choosing the lines (the analyzers' names)
# A time or duration beyond this (or NaN) is damage, not a time: events' times stay
# finite (as the digital CSV's, saleae_csv.MAX_SECONDS).
MAX_SECONDS = 1e9
_ESCAPES = {"\\0": 0, "\\a": 7, "\\b": 8, "\\t": 9, "\\n": 10, "\\v": 11, "\\f": 12, "\\r": 13,
            "\\\\": 92, "\\'": 39, '\\"': 34, "\\e": 27}
_HEX_ESCAPE = re.compile(r"^\\x([0-9a-fA-F]{2})$")
_RADIX = {"0x": 16, "0b": 2}   # a number's prefix, and its radix
# an ``error`` cell's word -> the line error it is (any other text: a framing error); the Saleae
# analyzer (analyzer/saleae) words Logic 2's errors alike
FAULTS = (("framing", problems.LINE_FRAMING), ("parity", problems.LINE_PARITY), ("break", problems.LINE_BREAK),
          ("overrun", problems.LINE_OVERRUN))
OTHER_FAULT = problems.LINE_FRAMING
REPORTED_BY = "reported by Saleae's Async Serial analyzer"


def byte_of(text: str) -> int:
    """The byte a ``data`` cell shows (ValueError if it shows none)."""
    t = text.strip() if len(text.strip()) > 0 else text
    radix = _RADIX.get(t[:2].lower())
    if radix is not None and len(t) > 2:
        value = int(t[2:], radix)
    elif t.isdigit() and len(t) > 1:
        value = int(t)
    elif len(t) == 3 and t[0] == t[2] == "'":
        value = ord(t[1])
    elif t in _ESCAPES:
        value = _ESCAPES[t]
    elif (hex_escape := _HEX_ESCAPE.match(t)) is not None:
        value = int(hex_escape.group(1), 16)
    elif len(t) == 1:
        value = ord(t)           # a character (a lone digit too: Logic's ASCII radix)
    else:
        raise ValueError(text)
    if not 0 <= value <= 0xFF:
        raise ValueError(text)
    return value


def fault_of(text: str) -> problems.Problem | None:
    low = text.strip().lower()
    if not low:
        return None
    for word, case in FAULTS:
        if word in low:
            return case.problem(f"{text.strip()} error {REPORTED_BY}")
    return OTHER_FAULT.problem(f"{text.strip()!r} {REPORTED_BY}")


class AsyncSerialTable(Source):
    timed = True
    clocks = 1

    def __init__(self, inp: Input, settings: ReadSettings) -> None:
        super().__init__()
        self.input = inp
        self.name = inp.name
        self.on_close(inp.close)
        self.faults: list[LineFault] = []
        self.description = inp.describe("Saleae Async Serial table")
        self.start_time = settings.start_time
        self._text = io.TextIOWrapper(inp.stream(), encoding="utf-8-sig", errors="replace", newline="")
        self._rows = csv.reader(self._text)
        try:
            header = [h.strip().lower() for h in next(self._rows, [])]
        except csv.Error as e:     # a quote never closed, a field over csv's limit
            raise CaptureError(f"{inp.name}: line 1: {e}: not a data table's header") from None
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise CaptureError(f"{inp.name}: a data table without the column {missing[0]!r} "
                               f"(expected {','.join(COLUMNS)}, plus error and address)")
        self._col = {c: header.index(c) for c in (*COLUMNS, "error", "address") if c in header}
        self._width = len(header)
        self._ahead: list[tuple[int, list[str]]] = []
        self._names: list[str] = []          # the analyzers met, in order
        self._broken: csv.Error | None = None   # what ended the reading ahead: raised where the rows are read
        self._read_ahead()
        given = dict(settings.instrument.channels)
        self.line_of = self._lines(given)
        self.lines = tuple(sorted(set(self.line_of.values())))

    def _read_ahead(self) -> None:
        try:
            for row in self._rows:
                self._ahead.append((self._rows.line_num, row))
                if len(row) > self._col["name"]:
                    name = row[self._col["name"]]
                    if name not in self._names:
                        self._names.append(name)
                if len(self._ahead) >= LOOK_AHEAD_ROWS:
                    break
        except csv.Error as e:
            self._broken = e     # the rows before it are decoded, then chunks() says it

    def _lines(self, given: dict[str, str]) -> dict[str, str]:
        """analyzer name → line."""
        listing = ", ".join(self._names) or "none"
        if given:
            for name in given.values():
                if name not in self._names:
                    raise CaptureError(f"{self.name}: no analyzer {name!r} in the table; the analyzers are {listing}")
            if set(given) == {LINE_B}:
                raise CaptureError(f"{self.name}: --channels names line B alone: give line A too")
            if len(given) == 1:
                return {next(iter(given.values())): LINE_AB}
            return {name: line for line, name in given.items()}
        if not self._names:
            raise CaptureError(f"{self.name}: the data table has no rows")
        if len(self._names) > 2:
            self.warn_later(f"{self.name}: {len(self._names)} analyzers in the table; lines A and B are "
                            f"{self._names[0]} and {self._names[1]} (--channels A=NAME,B=NAME chooses others)")
        if len(self._names) == 1:
            return {self._names[0]: LINE_AB}
        return {self._names[0]: LINE_A, self._names[1]: LINE_B}

    def measured_settings(self) -> dict[str, Any]:
        """The rate the rows' durations give (a character of 8N1 lasting about
        ten bits), for the byte time; nothing when it is no standard rate."""
        durations = sorted(float(r[self._col["duration"]]) for _, r in self._ahead
                           if len(r) == self._width and _is_number(r[self._col["duration"]])
                           and 0 < float(r[self._col["duration"]]) < MAX_SECONDS)
        if not durations:
            return {}
        baud = nominal_rate(10 / durations[len(durations) // 2])
        return {"baud": baud} if baud else {}

    def _all_rows(self) -> Iterator[tuple[int, list[str]]]:
        yield from self._ahead
        self._ahead = []
        if self._broken is not None:
            raise self._broken
        for row in self._rows:
            yield self._rows.line_num, row

    def chunks(self) -> Iterator[Chunk]:
        col = self._col
        run_line: str | None = None
        run_start, run_bytes = 0.0, bytearray()
        run_faults: list[tuple[int, problems.Problem]] = []   # (offset in the run, fault)
        last_start, last_len = 0.0, 0.0
        sent: dict[str, int] = {}
        try:
            for number, row in self._all_rows():
                if not row or (len(row) == 1 and not row[0].strip()):
                    continue
                try:
                    if len(row) != self._width:
                        raise ValueError
                    if row[col["type"]].strip().lower() != "data":
                        continue
                    line = self.line_of.get(row[col["name"]])
                    start, length = float(row[col["start_time"]]), float(row[col["duration"]])
                    if not (abs(start) < MAX_SECONDS and abs(length) < MAX_SECONDS):   # NaN, inf, 1e300
                        raise ValueError
                    value = byte_of(row[col["data"]])
                except (ValueError, IndexError):
                    self.warn(f"{self.name}: line {number}: cannot read {','.join(row)[:60]!r} (a data table "
                              "row: name,type,start_time,duration,data): read up to there")
                    break
                if line is None:
                    continue
                fault = fault_of(row[col["error"]]) if "error" in col else None
                if run_line is not None and (line != run_line or start - last_start > 1.5 * max(last_len, 1e-12)):
                    yield from self._flush(run_line, run_start, run_bytes, run_faults, sent)
                    run_line = None
                if run_line is None:
                    run_line, run_start, run_bytes, run_faults = line, start, bytearray(), []
                if fault is not None:
                    run_faults.append((len(run_bytes), fault))
                run_bytes.append(value)
                last_start, last_len = start, length
        except csv.Error as e:
            self.warn(f"{self.name}: line {self._rows.line_num}: {e}: read up to there")
        if run_line is not None:
            yield from self._flush(run_line, run_start, run_bytes, run_faults, sent)
        if self.input.problem:
            self.warn(self.input.problem)

    def _flush(self, line: str, start: float, data: bytearray, faults: list[tuple[int, problems.Problem]],
               sent: dict[str, int]) -> Iterator[Chunk]:
        at = sent.get(line, 0)
        for k, fault in faults:
            self.faults.append(LineFault(line, at + k, fault))
        sent[line] = at + len(data)
        yield Chunk(line, bytes(data), start)


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False
