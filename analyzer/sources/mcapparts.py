"""Several MCAP recordings of one tap read as one capture: the parts of a
recording in parts (``rec-0001.mcap``, ``rec-0002.mcap``, …), or recordings a tap
made one after the other. The time model is docs/time.md, "Parts".

- The parts are read in time order, whatever order they are given in: by each
  one's first raw chunk (every part of one recording counts its times from the
  capture's start, so their starts are all the same), then the start time and
  part number of their metadata, then the order given.
- Chunk times move onto the earliest part's clock: ``t`` plus how much later the
  part's t = 0 is (none for the parts of one recording); untimed chunks stay
  untimed. The capture deframes and pairs the chunks of every part as one
  stream, so events number on across a boundary and a command answered in the
  next part pairs with its answer.
- Recordings of another tap, the same recording twice, and recordings whose
  times overlap are refused, in one line naming both files. Recordings without
  metadata are read, with one warning that their tap could not be checked.

Each part is an ``McapSource`` as it would be alone: damage is said per file, and
a large part is read by its own reader process.

What the capture's source knew below the bytes (docs/mcap.md, "Below the bytes")
comes from the parts: the line reports of the latest part that has them (each
part's count from the tap's start), and the line errors of every part, their
offsets moved on by the bytes of the parts before it.
"""

from __future__ import annotations

import datetime
import io
import os
from collections.abc import Callable, Iterable, Iterator
from itertools import chain

from ..errors import CaptureError
from ..lines import Chunk, LineFault
from ..words import counted
from .base import ReadSettings, Source, StoredColumns
from .files import Input
from .mcapfile import EPOCH, McapSource, last_log_time, open_mcap

# Slack for the end of one part against the start of the next: a part's last
# message can be an event a little later than its last raw chunk (a frame begun
# in that chunk), and two adapters' clocks disagree by milliseconds.
OVERLAP_SLACK_NS = 1_000_000_000
_EPOCH_NS = tuple(int(s * 1e9) for s in EPOCH)   # log times in this range are dates


class McapPartsSource(Source):
    """``parts`` (opened, in any order) as one capture; refused with a
    ``CaptureError`` when they cannot be (module doc)."""

    carries_metadata = True

    def __init__(self, parts: list[McapSource]) -> None:
        super().__init__()
        check_one_tap(parts)
        self.parts = in_time_order(parts)
        check_no_overlap(self.parts)
        first = self.parts[0]
        self.lines, self.timed, self.clocks = first.lines, first.timed, first.clocks
        self.wire_times = first.wire_times
        self.metadata, self.metadata_problem = first.metadata, first.metadata_problem
        self.start_time = first.start_time
        self.physical = next((p.physical for p in reversed(self.parts) if p.physical), None)
        self.faults: list[LineFault] | None = [] if any(p.faults is not None for p in self.parts) else None
        self._shifts = _shifts(self.parts)
        more = len(self.parts) - 1
        self.description = f"{first.label} + {counted(more, 'more part')} (MCAP)"
        unchecked = _unchecked(self.parts)
        if unchecked:
            self.warn_later(unchecked)

    def stored_columns(self) -> StoredColumns:
        """Every part's stored columns, in order, when each part has its own
        complete ones from one decoder and no part's times are moved (parts of
        one recording never are); the chunks join them (``store_ipc.Joiner``)."""
        if any(self._shifts):
            return StoredColumns(None, None)
        stored = [p.stored_columns() for p in self.parts]
        why = next((s.why for s in stored if s.why), None)
        records = [s.record for s in stored]
        if any(r is None for r in records):
            return StoredColumns(None, why)
        decoders = {r.get("decoder") for r in records if r is not None}
        if len(decoders) != 1:
            return StoredColumns(None, "stored columns not used: the parts were made by different decoders")
        first = records[-1]   # the last part's: what it says of the whole so far (the wiring signs)
        assert first is not None
        counts = [r.get("events", "") for r in records if r is not None]
        total = sum(int(c) for c in counts) if all(c.isdigit() for c in counts) else -1
        record = {**first, "events": str(total)}
        return StoredColumns(record, None, lambda: chain.from_iterable(s.messages() for s in stored))

    def report_to(self, handler: Callable[[str], None]) -> None:
        """Every part's warnings go where the source's go."""
        super().report_to(handler)
        for part in self.parts:
            part.report_to(handler)

    def chunks(self) -> Iterator[Chunk]:
        if self.faults is not None:
            return self._with_line_errors(lambda part: part.chunks())
        return chain.from_iterable(_shifted(part.chunks(), shift) for part, shift in zip(self.parts, self._shifts))

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        if self.faults is not None:
            return self._with_line_errors(lambda part: part.line_chunks(line), line)
        return chain.from_iterable(_shifted(part.line_chunks(line), shift)
                                   for part, shift in zip(self.parts, self._shifts))

    def _with_line_errors(self, chunks_of: Callable[[McapSource], Iterable[Chunk]],
                          line: str | None = None) -> Iterator[Chunk]:
        """The parts' chunks, each part's line errors told (of ``line`` only, when
        one line is read) before the chunk holding their byte, at their offset
        on the line across the parts: a part counts its bytes from its own first."""
        sent: dict[str, int] = {}
        told = self.faults
        assert told is not None   # read this way only when a part keeps line errors
        for part, shift in zip(self.parts, self._shifts):
            base = dict(sent)
            faults, taken = part.faults, 0
            for chunk in _shifted(chunks_of(part), shift):
                if faults is not None and taken < len(faults):
                    told.extend(f._replace(offset=f.offset + base.get(f.line, 0)) for f in faults[taken:]
                                if line is None or f.line == line)
                    taken = len(faults)
                sent[chunk.line] = sent.get(chunk.line, 0) + len(chunk.data)
                yield chunk

    def close(self) -> None:
        for part in self.parts:
            part.close()
        super().close()


def open_mcap_parts(inputs: list[Input], settings: ReadSettings) -> Source:
    """The source of several MCAP inputs (analyzer/sources/registry.py): each opened
    as it would be alone, then read as one capture. A part in which nothing was
    recorded (its tap stopped before the part's first flush) is passed over with
    a warning; one part left is read on its own."""
    parts: list[McapSource] = []
    empty: list[tuple[str, CaptureError]] = []   # (name, why it cannot be read) of parts holding nothing
    try:
        for inp in inputs:
            try:
                parts.append(open_mcap([inp], settings))
            except CaptureError as e:
                if not _nothing_recorded(inp):
                    raise
                empty.append((inp.name, e))
        if not parts:
            raise empty[0][1]
        source = parts[0] if len(parts) == 1 else McapPartsSource(parts)
    except BaseException:
        for part in parts:
            part.close()
        raise
    if empty:
        source.warn_later(f"{', '.join(name for name, _e in empty)}: nothing recorded (a part opened just before "
                          "its tap stopped?); read the other parts")
    return source


def _nothing_recorded(inp: Input) -> bool:
    """Does the input hold no message at all? Such a part is small enough to be
    all in its head."""
    return inp.complete and last_log_time(io.BytesIO(inp.head), len(inp.head)) is None


# ------------------------------------------------------------------ order and time
def in_time_order(parts: list[McapSource]) -> list[McapSource]:
    """``parts`` in the order they were recorded (module doc); unknowns last."""
    def key(item: tuple[int, McapSource]) -> tuple:
        given, part = item
        meta = part.metadata or {}
        return (_known(part.first_log_ns), _known(part.start_time), _known(_iso_time(meta.get("start_time"))),
                _known(_part_number(meta.get("part"))), given)
    return [part for _given, part in sorted(enumerate(parts), key=key)]


def _known(value: float | None) -> tuple[int, float]:
    """A sort key that puts what is not known after everything known."""
    return (0, value) if value is not None else (1, 0)


def _iso_time(text: str | None) -> float | None:
    """Epoch seconds of the metadata's ``start_time`` (ISO 8601), if it is one."""
    try:
        return datetime.datetime.fromisoformat(text).timestamp() if text else None
    except (ValueError, OverflowError, OSError):
        return None


def _part_number(text: str | None) -> int | None:
    return int(text) if text and text.isdigit() and len(text) < 10 else None


def _shifts(parts: list[McapSource]) -> list[float]:
    """Seconds to add to each part's chunk times to count them from the earliest
    part's t = 0 (differences of whole log-time nanoseconds: the parts of one
    recording shift by exactly nothing)."""
    origins = [p.origin_ns for p in parts]
    first = next((o for o in origins if o is not None), None)
    if not parts[0].timed or first is None:
        return [0.0] * len(parts)
    return [0.0 if o is None else (o - first) / 1e9 for o in origins]


def _shifted(chunks: Iterable[Chunk], shift: float) -> Iterable[Chunk]:
    if not shift:
        return chunks
    return (Chunk(c.line, c.data, c.t + shift) if c.t is not None else c for c in chunks)


# ------------------------------------------------------------------ one tap
def check_one_tap(parts: list[McapSource]) -> None:
    """Refuse, in one line, a part recorded by another tap than the first one
    given whose tap is known (from its metadata), or a part given twice."""
    ruler = next((p for p in parts if p.metadata is not None), parts[0])
    for part in parts:
        why = None if part is ruler else _other_tap(ruler, part)
        if why is not None:
            raise CaptureError(f"{part.label}: recorded by another tap than {ruler.label} ({why}): "
                               "give one tap's recordings together")
    _refuse_twice(parts)


def _other_tap(a: McapSource, b: McapSource) -> str | None:
    """How ``b``'s tap differs from ``a``'s, or None when nothing says it does."""
    if a.lines != b.lines:
        return f"lines {','.join(b.lines)}, not {','.join(a.lines)}"
    # a part without a raw chunk (an empty capture) does not say whether it has time
    if a.timed != b.timed and a.first_log_ns is not None and b.first_log_ns is not None:
        return "with time, not without" if b.timed else "without time, not with"
    ma, mb = a.metadata, b.metadata
    if ma is None or mb is None:
        return None
    ida, idb = ma.get("capture_id"), mb.get("capture_id")
    if ida and idb:   # one id per run of a tap: the surest word
        return None if ida == idb else f"capture {idb}, not {ida}"
    with_ports = bool(ma.get("ports")) and bool(mb.get("ports"))
    tap_a, tap_b = _tap(ma, with_ports), _tap(mb, with_ports)
    if tap_a == tap_b:
        return None
    return f"ports {tap_b}, not {tap_a}" if with_ports else f"host {tap_b}, not {tap_a}"


def _tap(meta: dict[str, str], with_ports: bool) -> str:
    """The tap as its metadata names it: its ports (live ones) on its host."""
    host = meta.get("host") or "(unknown)"
    return f"{' '.join(meta['ports'].split())} on host {host}" if with_ports else host


def _refuse_twice(parts: list[McapSource]) -> None:
    """The same file, or the same part of one recording, given twice."""
    files: dict[tuple[int, int], McapSource] = {}
    numbered: dict[tuple[str, str], McapSource] = {}
    for part in parts:
        try:
            st = os.stat(part.path)
        except OSError:
            st = None
        seen = files.setdefault((st.st_dev, st.st_ino), part) if st is not None else part
        if seen is not part:
            twice = "given twice" if seen.label == part.label else f"the same file as {seen.label}"
            raise CaptureError(f"{part.label}: {twice}: give each recording once")
        meta = part.metadata or {}
        if meta.get("capture_id") and meta.get("part"):
            seen = numbered.setdefault((meta["capture_id"], meta["part"]), part)
            if seen is not part:
                raise CaptureError(f"{part.label}: the same part ({meta['part']}) of the same recording as "
                                   f"{seen.label}: give each part once")


def check_no_overlap(ordered: list[McapSource]) -> None:
    """Refuse, in one line, a part that starts before an earlier one ended: the
    parts of one capture follow each other. Untimed recordings have no span to
    compare (their log times only keep order)."""
    if not ordered[0].timed:
        return
    latest: tuple[int, McapSource] | None = None   # the latest end so far, and whose
    for part in ordered:
        start = part.first_log_ns
        if latest is not None and start is not None and start < latest[0] - OVERLAP_SLACK_NS:
            end, owner = latest
            raise CaptureError(f"{part.label}: starts at {_when(start)}, before {owner.label} ends "
                               f"({_when(end)}): recordings whose times overlap cannot be parts of one capture")
        if part is ordered[-1]:
            break   # the last one's end is never compared: spare reading it
        ends = part.last_log_ns()
        if ends is not None and (latest is None or ends > latest[0]):
            latest = (ends, part)


def _when(ns: int) -> str:
    """A log time as a date (UTC) when it is one, else seconds on the recording's clock."""
    if _EPOCH_NS[0] <= ns <= _EPOCH_NS[1]:
        when = datetime.datetime.fromtimestamp(ns / 1e9, datetime.UTC)
        return when.isoformat(timespec="milliseconds").replace("+00:00", "Z")
    return f"{ns / 1e9:.3f} s on its clock"


def _unchecked(parts: list[McapSource]) -> str | None:
    """The warning for parts whose tap could not be checked (no readable metadata)."""
    blind = [p for p in parts if p.metadata is None]
    if not blind:
        return None
    names = ", ".join(p.label for p in blind)
    why = "; ".join(f"{p.label}: {p.metadata_problem}" for p in blind if p.metadata_problem)
    known = next((p for p in parts if p.metadata is not None), None)
    against = f"the same tap as {known.label}" if known is not None else "one tap"
    return (f"{names}: no readable gimbalscope metadata{f' ({why})' if why else ''}: not checked to be "
            f"recordings of {against}; read as parts of one capture")
