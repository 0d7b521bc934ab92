"""socat ``-x -v`` hex logs: the common software tap of a serial link.

``socat -x -v PTY,… /dev/ttyUSB0,… 2> tap.log`` writes, per chunk it forwards::

    > 2026/11/21 08:35:52.000321418  length=9 from=0 to=8
     f8 01 01 01 00 02 50 3f 92                       ......P?.
    --

``>`` chunks travel from the first address to the second (line A, controller→
device, when the controller is on the first address); ``<`` the other way
(line B). Hex sits in the first 49 columns, the text column after it (absent with
``-x`` alone, which also drops the ``--`` separators).

Timestamps, as Debian's socat 1.7.4 really writes them: local time, and the
fraction printed with 9 digits but holding *microseconds* (``.000321418`` is
0.321418 s). A file whose fractions ever reach 1 000 000 carries real
nanoseconds (newer socat) and is read that way. The time is when socat read the
chunk, about when its last byte arrived, so the first byte started
``length × byte_time`` earlier (``--baud``; the byte time is read from the line's
``LineSettings`` as each chunk is made, so when the capture follows a change of
the link's rate, later chunks are back-dated with the new one).
The time unit is decided from the first 2000 headers, read with the head used for
detection, so the log is read once (it may be a pipe or compressed:
analyzer/sources/files.py).

The product's time model (one clock or two, start time, rate changes) is in
docs/time.md; what is particular to socat logs:

- Zone. Nothing in the log says which zone its local times are in: ``tz`` (the
  ``--tz`` option, an IANA name read with ``zoneinfo``) names it, and without it
  the zone of the decoding machine is used (``TZ`` respected). ``time_zone()``
  checks a name.
- Summer time. At a fall-back the stamps repeat an hour (Europe/Berlin,
  2026-10-25: 03:00 CEST is followed by 02:00 CET). A stamp in the repeated hour
  has two readings; the one nearer the time before it is taken, so the step back
  is read as the repeated hour, said once, and times and latencies across it stay
  true. A log that begins inside the repeated hour is read as its first pass:
  nothing in it tells the passes apart.
- Other steps back (the clock set by hand or by NTP) of more than
  ``STEP_TOLERANCE`` are said once, counted, and later stamps are moved forward
  so times follow on from the latest one: chunk times never go back across a
  step, and their spacing after it is kept. Smaller steps are the jitter between
  the two directions, left alone here.
- Start time. t = 0 is the first byte of the first chunk (its stamp less its
  length × byte time); it is found in the head when the log is opened, so
  ``start_time`` is known before any chunk is read.

A log is often cut, edited or shared with other output: a stray line, a garbled
header or one with an impossible date loses only what it spoils. Each kind of
problem is one warning at the end, counted, with the line of its first
occurrence, and decoding goes on (after a bad header, at the next good one).
Only a file that does not start like a socat log at all is an error.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterator
from datetime import UTC, datetime, timedelta, tzinfo
from typing import BinaryIO

from dissectors.wire import LineSettings

from ..errors import CaptureError
from ..lines import LINE_A, LINE_B, Chunk
from ..words import counted
from .base import Reader, ReadSettings, Source
from .files import HEAD, Input

HEADER = re.compile(
    rb"^([<>]) (\d{4}/\d\d/\d\d \d\d:\d\d:\d\d)\.(\d+)\s+length=(\d+) from=(\d+) to=(\d+)\s*$")
# a header (as HEADER, on one line) followed by a hex line: where a log's time starts
_HEADER_WITH_HEX = re.compile(
    rb"^([<>]) (\d{4}/\d\d/\d\d \d\d:\d\d:\d\d)\.(\d+)[ \t]+length=(\d+) from=(\d+) to=(\d+)[ \t\r]*\n(?= )", re.MULTILINE)
DIAGNOSTIC = re.compile(rb"^\d{4}/\d\d/\d\d \d\d:\d\d:\d\d socat\[\d+\] ")
HEX_COLUMNS = 49
UNIT_HEADERS = 2000       # headers that decide the fraction's unit
UNIT_HEAD_MAX = 1 << 20   # bytes read at most to find them
START_LINES = 50          # a log shows its first header within these lines
_NO_SHIFT = (0, 0.0)      # no step back yet (tested by identity: once per chunk)
STEP_TOLERANCE = 1.0      # s: a smaller step back of the stamps is jitter between the directions
ZONE_HINT_STEP = 900.0    # s: a step back this long may be a log from another zone

# kinds of problem, as said when there are several: "tap.log: 3 lines ... (first at line 152: ...)"
PLURALS = {
    "stray": "lines that are not socat -x -v output skipped",
    "hex": "hex lines that do not parse skipped",
    "garbled": "garbled chunk headers skipped, with their chunks",
    "time": "headers with an impossible date or time skipped, with their chunks",
    "length": "chunks whose bytes differ from their length=",
    "jump": "jumps in a line's byte count",
    "fall-back": "fall-backs of the clock read as the repeated hour",
    "step": "steps back of the clock, later times moved forward to follow on",
}
DETAILED = {"time", "length", "jump", "fall-back", "step"}   # kinds whose first case says more than the count


def looks_like_socat(head: bytes) -> bool:
    """Is this the start of a socat -x log? (first non-diagnostic line is a header)"""
    for line in head.splitlines()[:START_LINES]:
        if not line.strip() or DIAGNOSTIC.match(line):
            continue
        return HEADER.match(line) is not None
    return False


def nanosecond_fractions(head: bytes) -> bool:
    """True when 9-digit fractions are real nanoseconds (see module doc): one of the
    first ``UNIT_HEADERS`` headers reaches 1 000 000."""
    seen = 0
    for line in head.splitlines():
        m = HEADER.match(line)
        if m is None:
            continue
        frac = m.group(3)
        if len(frac) == 9 and int(frac) >= 1_000_000:
            return True
        seen += 1
        if seen >= UNIT_HEADERS:
            break
    return False


def time_zone(name: str | None) -> tzinfo | None:
    """The zone a log's local times are read in: an IANA zone name, or None for
    this machine's own zone (returned as None, which datetime reads as local time).
    ValueError, with a one-line message, for a name that is not a zone."""
    if name is None:
        return None
    try:
        from zoneinfo import ZoneInfo  # here: only a zone given by name needs the package
        return ZoneInfo(name)
    except (LookupError, ValueError, OSError):   # ZoneInfoNotFoundError is a KeyError
        raise ValueError(f"unknown time zone {name!r} "
                         f"(give an IANA name such as Europe/Berlin or UTC)") from None


def _span(seconds: float) -> str:
    """A length of time as the warnings say it: 1 h, 30 min, 10.0 s."""
    if seconds >= 60 and seconds == int(seconds):
        whole = int(seconds)
        if whole % 3600 == 0:
            return f"{whole // 3600} h"
        if whole % 60 == 0:
            return f"{whole // 60} min"
    if round(seconds, 1) < 120:
        return f"{seconds:.1f} s"
    if round(seconds / 60, 1) < 60:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


class _Tally:
    """Problems counted by kind and said once each, at the end: the first one with
    its line number, and how many there were."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.kinds: dict[str, list] = {}   # kind -> [count, line of the first, its text]

    def add(self, kind: str, line_no: int, text: str) -> None:
        entry = self.kinds.get(kind)
        if entry is None:
            self.kinds[kind] = [1, line_no, text]
        else:
            entry[0] += 1

    def report(self, warn: Callable[[str], None]) -> None:
        for kind, (count, line_no, text) in self.kinds.items():
            if count == 1:
                warn(f"{self.name}:{line_no}: {text}")
            elif kind in DETAILED:
                warn(f"{self.name}: {count} {PLURALS[kind]} (first at line {line_no}: {text})")
            else:
                warn(f"{self.name}: {count} {PLURALS[kind]} (first at line {line_no})")


class _Readings:
    """What a header's local date and time mean in the log's zone: epoch seconds,
    two of them for a time in a fall-back's repeated hour (datetime's ``fold``)."""

    def __init__(self, zone: tzinfo | None, nanoseconds: bool) -> None:
        self.zone = zone
        self.nanoseconds = nanoseconds
        # both readings per date and time: which one a header takes depends on the
        # stamps before it, and a second holds many headers
        self.cache: dict[bytes, tuple[int, int]] = {}

    @property
    def zone_name(self) -> str:
        if self.zone is None:
            return "this machine's zone"
        return str(self.zone)   # a ZoneInfo (``time_zone``): its key

    def of(self, m: re.Match) -> tuple[int, int, float]:
        """(first-pass epoch, repeated-hour epoch, fraction) of header ``m``. The
        epochs are whole seconds, kept apart from the fraction so relative times
        stay exact, and equal outside a repeated hour. ValueError or OverflowError
        for a date or time that cannot be."""
        key = m.group(2)
        passes = self.cache.get(key)
        if passes is None:
            passes = self._passes(key)
            if len(self.cache) > 4096:
                self.cache.clear()
            self.cache[key] = passes
        return passes[0], passes[1], self.fraction(m.group(3))

    def fraction(self, digits: bytes) -> float:
        """The fraction of a second a header's digits say (microseconds in nine
        digits, unless the log carries nanoseconds: module doc)."""
        if len(digits) == 9 and not self.nanoseconds:
            return int(digits) / 1e6
        return int(digits) / 10 ** len(digits)

    def _passes(self, key: bytes) -> tuple[int, int]:
        date_hour_minute = (int(key[0:4]), int(key[5:7]), int(key[8:10]), int(key[11:13]), int(key[14:16]))
        second = int(key[17:19])
        leap = 1 if second == 60 else 0   # a leap second reads as the next second's start
        first = self._epoch(date_hour_minute, second - leap, 0) + leap
        repeated = self._epoch(date_hour_minute, second - leap, 1) + leap
        # a time skipped at a spring-forward reads earlier with fold=1: keep one reading
        return first, max(first, repeated)

    def _epoch(self, date_hour_minute: tuple[int, int, int, int, int], second: int, fold: int) -> int:
        year, month, day, hour, minute = date_hour_minute
        return int(datetime(year, month, day, hour, minute, second, tzinfo=self.zone, fold=fold).timestamp())

    def _wall(self, epoch: float) -> datetime:
        """The epoch as the zone's clock shows it (aware, with the offset of the moment)."""
        return datetime.fromtimestamp(epoch, UTC).astimezone(self.zone)

    def _summer_time(self, epoch: float) -> bool:
        if self.zone is None:
            return time.localtime(epoch).tm_isdst > 0
        return bool(self._wall(epoch).dst())

    def fall_back_at(self, first: int, repeated: int) -> int:
        """The first second after the clock fell back, found between the two
        readings of a time in the repeated hour."""
        old_offset = self._wall(first).utcoffset()
        before, after = first, repeated
        while after - before > 1:
            middle = (before + after) // 2
            if self._wall(middle).utcoffset() == old_offset:
                before = middle
            else:
                after = middle
        return after

    def fall_back_text(self, at: int, first: int, repeated: int) -> str:
        """The warning for the fall-back at epoch ``at``."""
        last_old = self._wall(at - 1)
        wall = (last_old + timedelta(seconds=1)).strftime("%Y/%m/%d %H:%M:%S")
        where = self.zone_name
        if self.zone is None:
            where += f", {last_old.tzname()} to {self._wall(at).tzname()}"
        if self._summer_time(at - 1):
            why = f"summer time ends in {where}"
        else:
            why = f"the offset changes in {where}"
        return f"the clock steps back {_span(repeated - first)} at {wall} ({why}): read as the repeated hour"


class _Timeline:
    """The stamps of one pass through a log, placed on one time line: a time in a
    repeated hour takes the reading nearer the stamps before it, and a step back
    is said and evened out (see module doc). Stamps are (whole epoch seconds,
    fraction)."""

    def __init__(self, readings: _Readings, tally: _Tally) -> None:
        self.readings = readings
        self.tally = tally
        self.latest: tuple[int, float] | None = None   # the latest stamp placed
        self.shift: tuple[int, float] = _NO_SHIFT       # moves stamps forward past the steps back so far
        self.repeating = False                          # the last stamp was read in a repeated hour
        self.fall_backs_said: set[int] = set()

    def place_header(self, m: re.Match, line_no: int) -> tuple[int, float]:
        """Where header ``m`` (line ``line_no``) sits: ``_Readings.of`` then ``place``,
        with the common case in one call, as this runs once per chunk (ValueError
        or OverflowError for a date or time that cannot be)."""
        readings = self.readings
        passes = readings.cache.get(m.group(2))
        latest = self.latest
        if passes is None or passes[0] != passes[1] or latest is None or self.shift is not _NO_SHIFT:
            return self.place(readings.of(m), m, line_no)
        self.repeating = False
        return self._after_latest(passes[0], readings.fraction(m.group(3)), latest, m, line_no)

    def place(self, readings: tuple[int, int, float], m: re.Match, line_no: int) -> tuple[int, float]:
        """Where header ``m`` (line ``line_no``, ``readings`` from ``_Readings.of``) sits.
        (Once per chunk: written for speed.)"""
        first, repeated, frac = readings
        if first == repeated:
            sec = first
            self.repeating = False
        else:
            sec = self._reading_of_repeated_time(readings, line_no)
            self.repeating = sec != first
        shift = self.shift
        if shift[0] or shift[1]:
            sec += shift[0]
            frac += shift[1]
        latest = self.latest
        if latest is None:
            self.latest = (sec, frac)
            return self.latest
        return self._after_latest(sec, frac, latest, m, line_no)

    def _after_latest(self, sec: int, frac: float, latest: tuple[int, float], m: re.Match,
                      line_no: int) -> tuple[int, float]:
        """The stamp (sec, frac) placed after ``latest``: the new latest, or within
        the jitter allowed, or a step back said and evened out."""
        ahead = (sec - latest[0]) + (frac - latest[1])
        if ahead > 0:
            self.latest = (sec, frac)
            return self.latest
        if ahead < -STEP_TOLERANCE:
            return self._step_back((sec, frac), -ahead, latest, m, line_no)
        return sec, frac

    def _reading_of_repeated_time(self, readings: tuple[int, int, float], line_no: int) -> int:
        """The reading of a time in a repeated hour nearer the latest stamp: just
        after a fall-back the repeated one (said once); a stamp of the first pass
        written a little late (jitter) stays in the first pass."""
        first, repeated, frac = readings
        latest = self.latest
        if latest is None:
            return first   # nothing before it tells: the first pass
        first_ahead = _ahead((first + self.shift[0], frac + self.shift[1]), latest)
        if abs(first_ahead + (repeated - first)) >= abs(first_ahead):
            return first
        if not self.repeating:
            self._say_fall_back(first, repeated, line_no)
        return repeated

    def _say_fall_back(self, first: int, repeated: int, line_no: int) -> None:
        at = self.readings.fall_back_at(first, repeated)
        if at not in self.fall_backs_said:   # once, even if jitter crosses it again
            self.fall_backs_said.add(at)
            self.tally.add("fall-back", line_no, self.readings.fall_back_text(at, first, repeated))

    def _step_back(self, stamp: tuple[int, float], back: float, latest: tuple[int, float], m: re.Match,
                   line_no: int) -> tuple[int, float]:
        """The clock was set back by ``back`` s at ``stamp``: it and later stamps
        move forward so the time line follows on from the ``latest`` stamp."""
        self.shift = (self.shift[0] + latest[0] - stamp[0], self.shift[1] + latest[1] - stamp[1])
        when = m.group(2).decode("ascii")
        hint = f" (a log from another zone than {self.readings.zone_name}?)" if back >= ZONE_HINT_STEP else ""
        self.tally.add("step", line_no, f"the clock steps back {_span(back)} at {when}{hint}: "
                                        f"read as following on from the time before")
        return latest


def _ahead(stamp: tuple[int, float], latest: tuple[int, float]) -> float:
    """How far ``stamp`` is after ``latest`` (negative: before it)."""
    return (stamp[0] - latest[0]) + (stamp[1] - latest[1])


# the chunk being read, from its header: line, (whole seconds, fraction) of its
# stamp, the length it says, the line number of the header
_Current = tuple[str, tuple[int, float], int, int]


class SocatLogSource(Source):
    timed = True
    clocks = 1   # one socat process stamps both directions
    lines = (LINE_A, LINE_B)

    def __init__(self, source: str | Input, byte_time: float, tz: str | None = None) -> None:
        super().__init__()
        zone = time_zone(tz)   # before opening: a bad name leaves nothing open
        self.input = source if isinstance(source, Input) else Input(source)
        self.path = self.input.path
        self.name = self.input.name
        # each line's settings: the byte time given until the capture gives its own
        # (read_with), which follow the link's rate changes
        self.line_settings = {line: LineSettings.timed_by(byte_time) for line in self.lines}
        self.tz = tz
        self.description = self.input.describe("socat -x log")
        head = self._unit_head()
        self._readings = _Readings(zone, nanosecond_fractions(head))
        # (whole epoch seconds, fraction) of t = 0; known now so a recorder made
        # before reading has the start time
        self._origin = self._origin_in(head, byte_time)
        if self._origin is not None:
            self.start_time = self._origin[0] + self._origin[1]
        self.on_close(self.input.close)

    def _unit_head(self) -> bytes:
        """The head, read further until it holds ``UNIT_HEADERS`` headers (or 1 MiB)."""
        size = max(HEAD, len(self.input.head))
        head = self.input.head
        while not self.input.complete and size < UNIT_HEAD_MAX and head.count(b"length=") < UNIT_HEADERS:
            size *= 2
            head = self.input.read_head(size)
        return head

    def _origin_in(self, head: bytes, byte_time: float) -> tuple[int, float] | None:
        """t = 0 as ``_parse`` will find it: the first byte of the first good header
        with hex after it in ``head`` (its stamp less its length × byte time); None
        when the head holds none."""
        for m in _HEADER_WITH_HEX.finditer(head):   # a search, not a split: the head can be 1 MiB
            try:
                sec, _, frac = self._readings.of(m)
            except (ValueError, OverflowError):
                continue
            return sec, frac - int(m.group(4)) * byte_time
        return None

    def chunks(self) -> Iterator[Chunk]:
        tally = _Tally(self.name)
        try:
            yield from self._parse(self.input.stream(), tally)
        except OSError as e:   # a disk or USB stick failing under the log
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None
        tally.report(self.warn)
        if self.input.problem:
            self.warn(self.input.problem)

    def _parse(self, f: BinaryIO, tally: _Tally) -> Iterator[Chunk]:
        """The chunks of the log ``f``; problems go to ``tally`` (see module doc).
        The loop runs once a line of the log and reads hex lines, the most
        common, itself; a header and any other line go to the methods below."""
        timeline = _Timeline(self._readings, tally)
        line_no = 0
        headers = 0          # chunk headers seen (good or not)
        hex_seen = False     # a hex line was read: the log was made with -x
        current: _Current | None = None   # the chunk being read (its header's facts)
        data = bytearray()
        expected_from = {LINE_A: 0, LINE_B: 0}
        for raw_line in f:
            line_no += 1
            first = raw_line[:1]
            if first == b" ":
                if current is not None:
                    # hex sits in the first 49 columns; fromhex skips the spaces
                    try:
                        data += bytes.fromhex(raw_line[:HEX_COLUMNS].decode("ascii"))
                        hex_seen = True
                    except (ValueError, UnicodeDecodeError):
                        tally.add("hex", line_no, "not a socat hex line, skipped")
                # else: the hex of a chunk whose header was bad or lost, skipped with it
                continue
            if first == b">" or first == b"<":
                if current is not None:
                    chunk, current = self._chunk(current, data, tally), None
                    if chunk is not None:
                        yield chunk
                m = HEADER.match(raw_line)
                if m is None:
                    self._garbled(headers, line_no, tally)
                    continue
                headers += 1
                current = self._header(m, first, line_no, expected_from, timeline, tally)
                data = bytearray()
                continue
            if self._closes(raw_line, line_no, headers, hex_seen, current, data, tally) and current is not None:
                chunk, current = self._chunk(current, data, tally), None
                if chunk is not None:
                    yield chunk
        if current is not None:
            chunk = self._chunk(current, data, tally)
            if chunk is not None:
                yield chunk

    def _chunk(self, current: _Current, data: bytearray, tally: _Tally) -> Chunk | None:
        """The chunk ``current`` names, of the bytes collected for it (None when
        it carries none)."""
        line, (sec, frac), length, at = current
        if len(data) != length:
            tally.add("length", at, f"chunk says length={length} but carries {counted(len(data), 'byte')} "
                                    "(log cut short?)")
        if not data:
            return None
        # the first byte started this long before the read, at the line's byte
        # time now: the capture changes it when the link's rate changes
        first = frac - length * self.line_settings[line].byte_time
        if self._origin is None:
            self._origin = (sec, first)
            self.start_time = sec + first
        t0 = self._origin
        return Chunk(line, bytes(data), round((sec - t0[0]) + (first - t0[1]), 9))

    def _header(self, m: re.Match, arrow: bytes, line_no: int, expected_from: dict[str, int],
                timeline: _Timeline, tally: _Tally) -> _Current | None:
        """The chunk a good header ``m`` begins, or None when its time is impossible
        (skipped with its chunk). Bytes missing before it are said."""
        line = LINE_A if arrow == b">" else LINE_B
        frm = int(m.group(5))
        if frm != expected_from[line]:
            tally.add("jump", line_no, f"line {line} jumps from byte {expected_from[line]} to {frm}: "
                                       f"bytes missing from the log")
        expected_from[line] = int(m.group(6)) + 1
        try:
            stamp = timeline.place_header(m, line_no)
        except (ValueError, OverflowError):
            when = m.group(2).decode("ascii")
            tally.add("time", line_no, f"header with an impossible date or time ({when}), skipped with its chunk")
            return None
        return line, stamp, int(m.group(4)), line_no

    def _garbled(self, headers: int, line_no: int, tally: _Tally) -> None:
        """A line that starts like a header and is not one."""
        if headers == 0 and line_no <= START_LINES:
            raise self._not_socat(line_no)
        tally.add("garbled", line_no, "garbled chunk header, skipped with its chunk")

    def _closes(self, raw_line: bytes, line_no: int, headers: int, hex_seen: bool, current: _Current | None,
                data: bytearray, tally: _Tally) -> bool:
        """A line neither hex nor a header: does it end the chunk being read? A
        separator does; a blank line or socat's own diagnostics are passed over;
        anything else is stray, and ends a chunk that is already whole (hex lines
        before the next header belong to a header this line replaced, and would
        spoil it)."""
        stripped = raw_line.strip()
        if not stripped or DIAGNOSTIC.match(raw_line):
            return False
        if stripped == b"--":
            return True
        if headers == 0 and line_no <= START_LINES:
            raise self._not_socat(line_no)
        if current is not None and not data and not hex_seen:
            raise CaptureError(f"{self.name}:{line_no}: socat log without hex dump; record it with socat -x -v")
        tally.add("stray", line_no, "not socat -x -v output, skipped")
        return current is not None and len(data) >= current[2]

    def _not_socat(self, line_no: int) -> CaptureError:
        return CaptureError(f"{self.name}:{line_no}: not a socat -x -v log "
                            f"(expected a '> YYYY/MM/DD hh:mm:ss.ffffff  length=…' header)")


def open_socat_log(inputs: list[Input], settings: ReadSettings) -> SocatLogSource:
    inp, = inputs
    return SocatLogSource(inp, settings.byte_time, settings.tz)


READER = Reader(
    "socat -x -v log", open_socat_log, looks=looks_like_socat, given_as=" (both lines)",
    crowded="a socat log carries both lines; give it on its own",
)
