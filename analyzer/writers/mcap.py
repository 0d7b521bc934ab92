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

Times follow docs/time.md: message log times are capture times (the source's
start time plus wire time; raw dumps: from byte offsets). A rate change is an
event on ``/events`` like any other, and each later part of a recording in parts
gives the new rate in its metadata, so a part decoded alone starts right.
"""

from __future__ import annotations

from typing import BinaryIO

from dissectors.event import RATE, Event
from dissectors.wire import byte_time

from ..formats import mcap_schemas as S
from ..info import CaptureInfo
from ..runner import ERROR, INFO, RECORDING, WARNING, Note
from ..sources import Chunk
from .base import FileWriter, Target
from .mcap_recorder import McapRecorder, RotatingRecorder

# note level -> foxglove.Log level
LOG_LEVELS = {ERROR: S.ERROR, WARNING: S.WARNING, INFO: S.INFO}


# How a run maps onto topic messages (analyzer/formats/mcap_messages.py), shared with the live
# Foxglove server (analyzer/listeners/foxglove.py) so both carry the same messages.

def message_clock(info: CaptureInfo) -> dict:
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

    def __init__(self, path: str, info: CaptureInfo, *, file: BinaryIO | None = None, live: bool = False,
                 rotate_bytes: int | None = None, rotate_seconds: float | None = None,
                 metadata: dict[str, str] | None = None, lean: bool = False) -> None:
        self.live = live
        self.lean = lean   # docs/mcap.md, "Lean recordings"; said in the metadata record
        self._runner = None
        self._extra = {**(metadata or {}), **({"profile": S.LEAN} if lean else {})}
        self._rotate = (rotate_bytes, rotate_seconds) if rotate_bytes or rotate_seconds else None
        # live (and in parts): in place, the recorder's own files (module doc)
        super().__init__(path, info, file=file, atomic=not (live or self._rotate))

    def in_place(self, path: str) -> Target:
        """A live recording, or one in parts: the recorder opens its files itself,
        in place, flushes them every second when live, and after a failed write
        closes them as well as it can (analyzer/writers/mcap_recorder.py)."""
        kw = dict(message_clock(self.info), lines=self.info.lines, lean=self.lean)
        if self.live:
            kw.update(metadata=self.info.metadata(**self._extra), flush_interval=1.0, on_error=self._failed)
        else:
            kw.update(metadata={})
        if self._rotate:
            max_bytes, max_seconds = self._rotate
            self.recorder = RotatingRecorder(path, max_bytes=max_bytes, max_seconds=max_seconds, **kw)
        else:
            self.recorder = McapRecorder(path, **kw)
        return Recording(self.recorder, path)

    def begin(self) -> None:
        """A recording into the target's file (a conversion)."""
        if self.file is not None:
            self.recorder = McapRecorder(self.path, metadata={}, file=self.file, lines=self.info.lines,
                                         lean=self.lean, **message_clock(self.info))

    @property
    def failed(self) -> str | None:
        return self.recorder.failed

    @property
    def count(self) -> int:
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
    def on_start(self, runner) -> None:
        self._runner = runner

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        self.recorder.raw(chunk, offset)

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
