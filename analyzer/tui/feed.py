"""The TUI's capture thread: runs a capture (live tap, replay, or file), hands
every settled event to the recorder in this thread, and delivers batches to the
screen at most every ``interval`` seconds, so recording never waits for the
screen and the screen is never flooded with one message per event.

No Textual here: ``deliver`` is any callable (the app posts a message with it).

A recording that fails (a full disk) is said once, on screen and after the
screen closes, and dropped; the capture goes on (analyzer/recording closes the
file as well as it can).
"""

from __future__ import annotations

import os
import queue
from collections import deque
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from dissectors.event import Event

from .. import __version__
from ..capture import Capture
from ..doctor import LiveDoctor, log_level, one_line
from ..outfile import show
from ..recording import McapRecorder, RecordingError, RotatingRecorder


MAX_BATCH = 20_000


@dataclass
class LineStatus:
    line: str
    port: str
    state: str = "open"        # open, lost, reconnecting (live); file
    bytes: int = 0
    rate: float = 0.0          # bytes/s over the last second


@dataclass
class FeedBatch:
    events: list[Event]
    unsettled: list[Event]
    lines: list[LineStatus]
    skew: float = 0.0
    recording: str | None = None
    recording_bytes: int = 0
    warnings: list[str] = field(default_factory=list)
    findings: list | None = None     # the wiring doctor's findings when re-checked (analyzer.doctor)
    done: bool = False
    error: str | None = None


class Feed(threading.Thread):
    def __init__(self, capture: Capture, deliver: Callable[[FeedBatch], None], *, ports: list[str] | None = None,
                 interval: float = 0.03, metadata: Callable[[], dict[str, str]] | None = None,
                 recorder: McapRecorder | RotatingRecorder | None = None, recording: str | None = None) -> None:
        super().__init__(daemon=True, name="gimbalscope-feed")
        self.capture = capture
        self.deliver = deliver
        self.interval = interval
        self._metadata = metadata or (lambda: {})
        names = ports or [capture.source.description] * len(capture.lines)
        self.lines = {line: LineStatus(line, port) for line, port in zip(capture.lines, names)}
        self._window: dict[str, deque[tuple[float, int]]] = {line: deque() for line in capture.lines}
        self._requests: queue.Queue = queue.Queue()
        self._stopped = threading.Event()   # a file source has no stop of its own
        self._sent_any = False
        self._warnings: list[str] = []
        self.recorder: McapRecorder | RotatingRecorder | None = recorder   # --record: made (and checked)
        self.recording: str | None = recording                              # before the screen opens
        if recorder is not None:
            recorder.on_error = self._recording_failed
        self.notes: list[str] = []   # what to say when the screen has closed (recordings written)
        capture.on_chunk = self._chunk
        capture.on_warning = self._warn
        self.doctor = LiveDoctor(capture, self._found, tui=True)
        self._findings: list | None = None

    # ------------------------------------------------------------ controls
    def start_recording(self, path: str) -> None:
        """Record from now on (handled in the capture thread, between batches)."""
        self._requests.put(("record", path))

    def stop_recording(self) -> None:
        self._requests.put(("stop", None))

    def stop(self) -> None:
        self._stopped.set()
        stop = getattr(self.capture.source, "stop", None)
        if stop is not None:
            stop()

    # ------------------------------------------------------------- thread
    def _chunk(self, chunk, offset: int) -> None:
        st = self.lines.get(chunk.line)
        if st is not None:
            st.bytes += len(chunk.data)
            self._window[chunk.line].append((time.monotonic(), len(chunk.data)))
        if self.recorder is not None:
            self.recorder.raw(chunk, offset)

    def _warn(self, msg: str) -> None:
        self._warnings.append(msg)
        if self.recorder is not None:
            self.recorder.note(msg, self.capture.latest)

    def _found(self, f) -> None:
        if self.recorder is not None:
            self.recorder.note(one_line(f), self.capture.latest, log_level(f))

    def _handle_requests(self) -> None:
        while True:
            try:
                what, path = self._requests.get_nowait()
            except queue.Empty:
                return
            if what == "record" and self.recorder is None:
                cap = self.capture
                # a recording always says what it is (and readers expect a metadata record)
                meta = {"tool": f"gimbalscope {__version__}", "lines": ",".join(cap.lines),
                        "recorded_from": "the TUI's record key", **self._metadata()}
                try:
                    self.recorder = McapRecorder(path, metadata=meta, flush_interval=1.0,
                                                 start_time=cap.source.start_time, lines=cap.lines,
                                                 on_error=self._recording_failed)
                    self.recording = path
                    self._warnings.append(f"recording to {show(path)}")
                except RecordingError as e:
                    self._warnings.append(str(e))
            elif what == "stop" and self.recorder is not None:
                self._close_recorder()

    def _recording_failed(self, message: str) -> None:
        """The recorder stopped (it has closed its file): say it once, record no
        more; the capture goes on. Called in this thread, from inside the recorder."""
        self._warnings.append(message)
        self.notes.append(message)
        self.recorder = None
        self.recording = None

    def _close_recorder(self) -> None:
        rec, self.recorder = self.recorder, None
        rec.end_marker(self.capture.latest)
        rec.close()
        if rec.failed:   # failed while closing: _recording_failed said so
            return
        note = rec.summary()
        self._warnings.append(note)
        self.notes.append(note)
        self.recording = None

    def _status(self) -> list[LineStatus]:
        now = time.monotonic()
        state = getattr(self.capture.source, "state", None)
        for line, st in self.lines.items():
            win = self._window[line]
            while win and win[0][0] < now - 1.0:
                win.popleft()
            st.rate = float(sum(n for _t, n in win))
            if state is not None:
                st.state = state.get(line, st.state)
        return [LineStatus(s.line, s.port, s.state, s.bytes, s.rate) for s in self.lines.values()]

    def _send(self, events: list[Event], done: bool = False, error: str | None = None) -> None:
        rec = self.recorder
        size = 0
        if rec is not None and self.recording and os.path.exists(self.recording):
            size = os.path.getsize(self.recording)
        warnings, self._warnings = self._warnings, []
        findings, self._findings = self._findings, None
        self.deliver(FeedBatch(events, [] if done else self.capture.unsettled(), self._status(),
                               self.capture.skew, self.recording, size, warnings, findings, done, error))

    def run(self) -> None:
        pending: list[Event] = []
        last = time.monotonic()
        error = None
        try:
            for batch in self.capture.batches():
                if self._stopped.is_set() and not getattr(self.capture.source, "live", False):
                    break
                if batch:
                    rec = self.recorder
                    if rec is not None:
                        for ev in batch:
                            rec.event(ev)
                    pending.extend(batch)
                if self.doctor.add_batch(batch):
                    self._findings = self.doctor.findings
                now = time.monotonic()
                # the first events go out at once (the first screen), then at most every
                # interval; a file loading flat out sends at most MAX_BATCH events a message
                if now - last >= self.interval or (pending and not self._sent_any) or len(pending) >= MAX_BATCH:
                    self._sent_any = self._sent_any or bool(pending)
                    self._handle_requests()
                    self._send(pending)
                    pending = []
                    last = now
        except Exception as e:   # a source failing mid-capture: say it on screen, keep what came
            error = f"{type(e).__name__}: {e}"
            self.notes.append(f"capture stopped: {error}")
        finally:
            close = getattr(self.capture.source, "close", None)
            if close is not None:
                close()
            self._findings = self.doctor.findings = self.doctor.doctor.findings()   # the last word
            if self.recorder is not None:
                self._close_recorder()
            self._send(pending, done=True, error=error)
