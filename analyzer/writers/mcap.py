"""MCAP output: the recording of a run (analyzer/writers/mcap_recorder.py): raw bytes per line,
events, transactions and the run's notes on ``/log``, with the run's
``CaptureInfo`` as the ``gimbalscope`` metadata record.

Two ways to record:

- a conversion (``convert``, the default): written atomically by the writer base
  (analyzer/writers/base.py), metadata at the end (with what reading learnt); a
  write error raises ``RecordingError`` and the file is thrown away;
- a live recording (``live=True``: ``--record``, the TUI's record key): written in
  place (``atomic=False``) and flushed every second, so a killed tap leaves a file
  that opens;
  metadata first; optionally in parts (``rotate_bytes``, ``rotate_seconds``). A
  write error stops the recording, not the tap: it is posted as a note once.

Either way, ``lean=True`` writes a lean recording (docs/mcap.md, "Lean
recordings": no ``/events``, the raw reads batched on ``/serial/reads``), and
its metadata record says ``profile: lean``.

Either way, the file is created when the writer is made: a path that cannot be
written is an error before the tap starts.

Either way, what the source knows below the bytes is kept (docs/mcap.md, "Below
the bytes"; analyzer/formats/mcap_lines.py): a logic capture's line reports as
the ``gimbalscope.lines`` metadata record (at the end; a live recording also
as it flushes, every ten seconds while they change), and the line's own errors
(a logic or USB capture's) on the raw chunk holding their byte.

Times follow docs/time.md: message log times are capture times (the source's
start time plus wire time; raw dumps: from byte offsets). A rate change is an
event on ``/events`` like any other, and each later part of a recording in parts
gives the new rate in its metadata, so a part decoded alone starts right.
"""

from __future__ import annotations

import os
from collections import deque
from typing import IO, Any

from dissectors.event import RATE, Event
from dissectors.wire import byte_time

from ..capture.merge import SWAP
from ..formats import mcap_schemas as S
from ..formats.marks import Mark
from ..formats.mcap_lines import LINES_RECORD, line_error, lines_record
from ..info import CaptureInfo
from ..lines import LineFault
from ..runner import ERROR, INFO, RECORDING, WARNING, Note, TapRunner
from ..sources import Chunk
from .base import FileWriter, Target
from .mcap_recorder import McapRecorder, RotatingRecorder

FLUSH_INTERVAL = 1.0   # seconds: a killed tap's recording loses at most about that much

# note level -> foxglove.Log level
LOG_LEVELS = {ERROR: S.ERROR, WARNING: S.WARNING, INFO: S.INFO}


# How a run maps onto topic messages (analyzer/formats/mcap_messages.py), shared with the live
# Foxglove server (analyzer/listeners/foxglove.py) so both carry the same messages.

def message_clock(info: CaptureInfo) -> dict[str, Any]:
    """``Messages``' times for the run ``info`` describes: from its start time and,
    for untimed input, from byte offsets at its rate (docs/time.md, "Message times")."""
    untimed = None if info.timed else byte_time(info.baud, info.data_bits, info.parity, info.stop_bits)
    return {"start_time": info.start_time, "wire_byte_time": untimed}


def log_level(note: Note) -> int | None:
    """The /log level of ``note``, or None when it is no message: an output's word
    about itself (origin RECORDING: a recording written or stopped, a server
    serving) is for people, not for the topics."""
    if note.origin == RECORDING:
        return None
    return LOG_LEVELS.get(note.level, S.WARNING)


class McapWriter(FileWriter):
    """The registry's ``.mcap`` writer (module doc): a conversion is written
    atomically by the writer base; a live recording, or one in parts, in place."""

    path: str
    info: CaptureInfo
    recorder: McapRecorder | RotatingRecorder

    def __init__(self, path: str, info: CaptureInfo, *, file: IO[bytes] | None = None, live: bool = False,
                 rotate_bytes: int | None = None, rotate_seconds: float | None = None,
                 metadata: dict[str, str] | None = None, lean: bool = False, columns: bool = True,
                 flush_interval: float = FLUSH_INTERVAL) -> None:
        self.live = live
        # the decoded columns (docs/mcap.md, "Stored columns"): left out of a recording
        # whose bytes decoded alone are not its events (a window cut from a tap)
        self.columns = columns
        self.flush_interval = flush_interval   # seconds between a live recording's flushes
        self.lean = lean   # docs/mcap.md, "Lean recordings"; said in the metadata record
        self._runner: TapRunner | None = None
        # the source's line errors (a list it adds to as it reads; None: it sees none),
        # how many of them were taken, and those taken waiting for their byte, by line
        self._faults: list[LineFault] | None = None
        self._taken = 0
        self._waiting: dict[str, deque[LineFault]] = {}
        self._extra = {**(metadata or {}), **({"profile": S.LEAN} if lean else {})}
        self._rotate = (rotate_bytes, rotate_seconds) if rotate_bytes or rotate_seconds else None
        # live (and in parts): in place, the recorder's own files (module doc)
        super().__init__(path, info, file=file, atomic=not (live or self._rotate))

    def in_place(self, path: str | os.PathLike[str]) -> Target:
        """A live recording, or one in parts: the recorder opens its files itself,
        in place, flushes them every ``flush_interval`` when live, and after a failed write
        closes them as well as it can (analyzer/writers/mcap_recorder.py)."""
        kw: dict[str, Any] = dict(message_clock(self.info), lines=self.info.lines, lean=self.lean,
                                  records=self._records, ack_timeout=self.info.ack_timeout, columns=self.columns)
        if self.live:
            kw.update(metadata=self.info.metadata(**self._extra), flush_interval=self.flush_interval,
                      on_error=self._failed)
        else:
            kw.update(metadata={})
        if self._rotate:
            max_bytes, max_seconds = self._rotate
            self.recorder = RotatingRecorder(os.fspath(path), max_bytes=max_bytes, max_seconds=max_seconds, **kw)
        else:
            self.recorder = McapRecorder(os.fspath(path), **kw)
        return Recording(self.recorder, os.fspath(path))

    def begin(self) -> None:
        """A recording into the target's file (a conversion)."""
        if self.file is not None:
            self.recorder = McapRecorder(self.path, metadata={}, file=self.file, lines=self.info.lines,
                                         lean=self.lean, columns=self.columns, records=self._records, ack_timeout=self.info.ack_timeout,
                                         **message_clock(self.info))

    @property
    def failed(self) -> str | None:
        return self.recorder.failed

    @property
    def count(self) -> int:   # type: ignore[override]  # read-only here: the recorder counts, not the writer
        """Messages recorded (the recorder counts them)."""
        return self.recorder.messages

    def summary(self) -> str:
        return self.recorder.summary()

    @property
    def current_path(self) -> str | None:
        """The file being written now: the current part of a recording in parts
        (None once it has stopped)."""
        rec = self.recorder
        if isinstance(rec, RotatingRecorder):
            return rec.current.path if rec.current is not None else None
        return None if rec.failed else rec.path

    # ------------------------------------------------------------ listener
    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner
        self._faults = runner.faults

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        runner, faults = self._runner, self._faults
        errors = None
        if runner is not None and faults is not None:
            errors = self._line_errors(runner, faults, chunk, offset)
        self.recorder.raw(chunk, offset, errors)

    def _line_errors(self, runner: TapRunner, faults: list[LineFault], chunk: Chunk,
                     offset: int) -> list[dict[str, Any]] | None:
        """The line errors on ``chunk``'s bytes (``offset``: its first byte's on its
        line), as its raw message keeps them. The source tells each before the
        chunk holding its byte, naming the line as wired; one whose byte was read
        before the recording started is left out."""
        if self._taken < len(faults):
            for f in faults[self._taken:]:
                self._waiting.setdefault(f.line, deque()).append(f)
            self._taken = len(faults)
        if not chunk.data:
            return None
        line = chunk.line
        queue = self._waiting.get(SWAP.get(line, line) if runner.swapped else line)
        if not queue:
            return None
        end = offset + len(chunk.data)
        out = []
        while queue and queue[0].offset < end:
            f = queue.popleft()
            if f.offset >= offset:
                out.append(line_error(f.problem, f.offset - offset))
        return out or None

    def _records(self) -> dict[str, dict[str, str]]:
        """The metadata records the recording learns as it goes: a logic capture's
        line reports, under the lines its bytes are recorded on."""
        runner = self._runner
        if runner is None:
            return {}
        reports = runner.physical
        if not reports:
            return {}
        return {LINES_RECORD: lines_record(reports, runner.swapped)}

    def on_events(self, events: list[Event]) -> None:
        event = self.recorder.event
        for ev in events:
            event(ev)
            if ev.kind == RATE:
                self._rate_changed(ev.fields["baud"])

    def _rate_changed(self, baud: int) -> None:
        """Parts written from now on start at ``baud``."""
        rec = self.recorder
        if isinstance(rec, RotatingRecorder) and self.live:
            rec.update_metadata(baud=str(baud))

    def on_mark(self, mark: Mark) -> None:
        self.recorder.mark(mark)

    def on_note(self, note: Note) -> None:
        level = log_level(note)
        if level is not None:
            self.recorder.note(note.text, note.t, level)

    def finish(self) -> None:
        rec = self.recorder
        runner = self._runner
        if self.live:
            if runner is not None:
                # time ran on to here: decoding the file expires the timeouts the tap did
                rec.end_marker(runner.latest)
            rec.close()
            if not rec.failed and runner is not None:   # a failure was said when it happened
                runner.post(rec.summary(), INFO, origin=RECORDING)
        else:
            info = runner.info if runner is not None else self.info
            rec.close(info.metadata(**self._extra))

    def _failed(self, message: str) -> None:
        """The recording stopped (the file closed as well as it could); the tap goes on."""
        if self._runner is not None:
            self._runner.post(message, WARNING, origin=RECORDING)


class Recording(Target):
    """The target of a recording whose files the recorder opened itself: it
    closes them (``finish``); a failed run leaves them as they are, in place."""

    def __init__(self, recorder: McapRecorder | RotatingRecorder, path: str) -> None:
        super().__init__(None, path)
        self.recorder = recorder

    def close(self) -> None:
        self.recorder.close()   # done by ``finish``: closing again does nothing

    def discard(self) -> None:
        self.recorder.close()
