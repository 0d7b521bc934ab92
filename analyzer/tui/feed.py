"""The TUI's capture thread: runs the tap runner (live tap, replay, or file) with
the doctor, any recording, and ``Feed``, the listener that delivers batches to the
screen at most every ``interval`` seconds, so recording never waits for the
screen and the screen is never flooded with one message per event. A file's
batches also say how far its input has been read (``READS``, the meter the CLI's
progress bar reads), for the status bar's load progress; an input with no size
(a pipe), which the meter cannot measure, is measured by its traffic's bytes
(``StreamFeed``).

No Textual here: ``deliver`` is any callable (the app posts a message with it).
What the screen asks of a feed is ``ScreenFeed``; a file viewed is fed by a
decoding process instead (decode_process.py ``ProcessFeed``), with the same batches.

A recording that fails (a full disk) is said once, on screen and after the
screen closes, and dropped; the capture goes on (analyzer/writers/mcap.py).
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from dissectors.event import Event

from ..formats.marks import Mark
from ..lines import Chunk
from ..listeners import DoctorListener
from ..outfile import show
from ..runner import DOCTOR, RECORDING, Listener, Note, TapRunner
from ..sources.meter import READS, ReadMeter
from .doctor_process import DoctorProcess, DoctorWord
from .model.chunks import ModelChunk
from .model.sampled import SampledInput, split_description

if TYPE_CHECKING:
    from ..writers.mcap import McapWriter

# events a message at most: a batch waits as event objects (about 100 bytes an
# event once stored, several times that before), so a big one raises the peak
MAX_BATCH = 5_000
# seconds between batches: a live tap's screen stays close to the wire; a file
# loading flat out needs no more than a few screens a second, and each batch costs
# the screen's thread a refresh (at every 30 ms, a tenth of a 1M-event load)
LIVE_INTERVAL = 0.03
FILE_INTERVAL = 0.25
RATE_BUCKET = 0.05   # seconds: the line rate is summed over the last second in buckets this long
IDLE_CHECK = 0.25    # seconds: how often a quiet capture's state (rates, ports) is compared with the screen's


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
    findings: list | None = None     # the wiring doctor's findings when re-checked (analyzer.analysis.doctor)
    done: bool = False
    error: str | None = None
    settings: str = ""               # the link's serial settings now (the rate follows rate changes)
    read: int = 0                    # a file: bytes of its input read so far (a pipe: of its traffic); live: 0
    total: int | None = None         # a file: its input's size; None when it has none (a pipe) or live
    chunk: ModelChunk | None = None  # a file decoded in a process: its events as columns (``events`` is empty)
    doctor_error: str | None = None  # the wiring doctor's process failed: why
    sampled: SampledInput | None = None   # a logic capture: its input, and each line's channel and measure
    windows: str | None = None       # live --keep: the windows kept so far (``KeptWindows.status``)

    def hear(self, word: DoctorWord | None) -> None:
        """Carry the word of the doctor's process (doctor_process.py), if it has
        come: its findings, or why it failed (a warning on screen)."""
        if word is None:
            return
        if word.warning is not None:
            self.warnings = [*self.warnings, word.warning]
            self.doctor_error = word.error
        else:
            self.findings = word.findings


class KeptWindows(Protocol):
    """``live --keep``'s keeper (analyzer/writers/windows.py), as the status line reads it."""

    def status(self) -> str: ...


class ScreenFeed(Protocol):
    """What the screen asks of a feed, whoever drives it: a capture thread
    (``Feed``) or a decoding process (``ProcessFeed``). It hands its batches to
    the ``deliver`` it was made with, from a thread of its own, from ``start()``
    to a last batch (``done``); then perhaps one more, with the word of a doctor
    in a process of its own."""

    notes: list[str]   # what to say when the screen has closed (recordings written, a capture that stopped)
    lines: Mapping[str, LineStatus]   # the capture's lines, by name

    @property
    def recording(self) -> str | None:
        """The file being recorded to now (a live tap's)."""
        ...

    def start(self) -> None:
        """Start the capture (in a thread of its own)."""
        ...

    def stop(self) -> None:
        """End the capture and any process of it (the screen is closing)."""
        ...

    def join(self, timeout: float | None = None) -> None:
        """Wait for the capture's thread to end."""
        ...

    def is_alive(self) -> bool:
        """Is the capture's thread running?"""
        ...

    def start_recording(self, path: str) -> None:
        """Record from now on (a live tap)."""
        ...

    def stop_recording(self) -> None:
        """Stop recording, if it records."""
        ...

    def swap_lines(self) -> None:
        """Read line A as B and B as A from now on (a live tap)."""
        ...

    def mark(self, mark: Mark) -> None:
        """An event marked: a live tap's recording keeps it (its listeners hear it)."""
        ...


class Feed(ScreenFeed, Listener):
    """Collects what the runner hears and hands it to ``deliver`` in batches.
    ``start()`` runs the runner in a thread of its own; the screen's thread calls
    only ``start_recording``, ``stop_recording``, ``swap_lines`` and ``stop``
    (requests to the runner). ``doctor``: the doctor in the runner, read at every
    step; or ``doctor_process``, a file's doctor in a process of its own."""

    def __init__(self, runner: TapRunner, deliver: Callable[[FeedBatch], None], doctor: DoctorListener | None, *,
                 interval: float | None = None, recorder: McapWriter | None = None,
                 meter: ReadMeter = READS, record_lean: bool = False,
                 doctor_process: DoctorProcess | None = None, windows: KeptWindows | None = None) -> None:
        self.runner = runner
        self.deliver = deliver
        self.doctor = doctor
        self.doctor_process = doctor_process
        self.interval = (LIVE_INTERVAL if runner.live else FILE_INTERVAL) if interval is None else interval
        names = runner.info.line_names
        self.lines = {line: LineStatus(line, names[line]) for line in runner.lines}
        self._window: dict[str, deque[list]] = {line: deque() for line in runner.lines}   # [start, bytes]
        self._pending: list[Event] = []
        self._last = time.monotonic()
        self._sent_any = False
        self._state: tuple | None = None     # what the last batch reported beside its events (see _send)
        self._warnings: list[str] = []
        self._findings: list | None = None
        self._named: tuple[str, str] | None = None   # a logic capture's input, named (``_sampled``)
        self.recorder = recorder             # --record: made (and checked) before the screen opens
        self.windows = windows               # --keep: the keeper, among the runner's listeners
        self.record_lean = record_lean       # the record key writes lean recordings (live --lean)
        self.meter = meter                   # how far the input files have been read: asked once a batch
        self.notes: list[str] = []           # what to say when the screen has closed (recordings written)
        self._thread = threading.Thread(target=self.run, daemon=True, name="gimbalscope-feed")

    # ------------------------------------------------------------- thread
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        """End the run (a file stops at the next step), and the doctor's process."""
        if self.doctor_process is not None:
            self.doctor_process.stop()
        self.runner.stop()

    def join(self, timeout: float | None = None) -> None:
        self._thread.join(timeout)

    def is_alive(self) -> bool:
        return self._thread.is_alive()

    def run(self) -> None:
        """The capture, in this thread, to its last batch (``start`` runs it in a thread of its own)."""
        error = None
        try:
            self.runner.run()
        except Exception as e:   # noqa: BLE001 - a source failing mid-capture: said on screen, what came kept
            error = f"{type(e).__name__}: {e}"
            self.notes.append(f"capture stopped: {error}")
        if self.doctor_process is None:
            self._send(done=True, error=error)
        else:   # the doctor's word after the capture ended: one more last batch
            self.doctor_process.last_batch(lambda: self._send(done=True, error=error), lambda: self._send(done=True))

    # ------------------------------------------------------------ controls
    @property
    def recording(self) -> str | None:
        """The file being recorded to now (a recording in parts: the current part)."""
        rec = self.recorder
        return rec.current_path if rec is not None else None

    def start_recording(self, path: str) -> None:
        """Record from the next step on; a path that cannot be written is said on screen."""
        if self.recorder is not None and not self.recorder.failed:
            return
        # imported to record only: the writer's modules took a tenth of a second of every view's start
        from ..writers.mcap import McapWriter
        from ..writers.mcap_recorder import RecordingError

        try:
            self.recorder = McapWriter(path, self.runner.info, live=True, lean=self.record_lean,
                                       metadata={"recorded_from": "the TUI's record key"})
        except RecordingError as e:
            self.runner.post(str(e))
            return
        self.runner.add_listener(self.recorder)
        self.runner.post(f"recording to {show(path)}" + (" (lean)" if self.record_lean else ""))

    def stop_recording(self) -> None:
        rec, self.recorder = self.recorder, None
        if rec is not None:
            self.runner.remove_listener(rec)   # it closes in the runner's thread and says so

    def swap_lines(self) -> None:
        self.runner.request_swap()

    def mark(self, mark: Mark) -> None:
        self.runner.mark(mark)

    # ------------------------------------------------------------ listener
    def on_note(self, note: Note) -> None:
        if note.origin == DOCTOR:
            return   # findings reach the screen as the doctor's list
        self._warnings.append(note.text)
        if note.origin == RECORDING:
            self.notes.append(note.text)
            if self.recorder is not None and self.recorder.failed:
                self.recorder = None

    def on_events(self, events: list[Event]) -> None:
        if events:
            self._pending.extend(events)
        if self.doctor is not None and self.doctor.checked:
            self._findings = self.doctor.findings
        now = time.monotonic()
        pending = self._pending
        # the first events go out at once (the first screen), then at most every
        # interval; a file loading flat out sends at most MAX_BATCH events a message.
        # A quiet line's idle ticks send nothing unless what the screen shows has
        # changed (a rate falling to 0, a port lost), looked at every IDLE_CHECK:
        # an idle screen is not woken
        news = pending or self._warnings or self._findings is not None
        if now - self._last >= (self.interval if news else max(self.interval, IDLE_CHECK)) \
                or (pending and not self._sent_any) or len(pending) >= MAX_BATCH:
            self._sent_any = self._sent_any or bool(pending)
            self._send(changed_only=True)
            self._last = now

    def on_stop(self) -> None:
        if self.doctor is not None:
            self._findings = self.doctor.findings   # the last word

    # ------------------------------------------------------------- batches
    def _status(self) -> list[LineStatus]:
        now = time.monotonic()
        state = self.runner.line_states()
        for line, st in self.lines.items():
            win = self._window[line]
            while win and win[0][0] < now - 1.0:
                win.popleft()
            st.rate = float(sum(n for _t, n in win))
            st.state = state.get(line, st.state)
        return [LineStatus(s.line, s.port, s.state, s.bytes, s.rate) for s in self.lines.values()]

    def _send(self, done: bool = False, error: str | None = None, *, changed_only: bool = False) -> bool:
        """Deliver a batch; with ``changed_only``, only if it holds events, warnings,
        findings or the doctor's word, or the state it reports differs from the
        last one delivered. Returns whether it delivered."""
        path = self.recording
        size = os.path.getsize(path) if path and os.path.exists(path) else 0
        unsettled = [] if done else self.runner.unsettled()
        status, skew, settings, read = self._status(), self.runner.skew, self.runner.serial_settings, self._read()
        sampled = self._sampled()
        windows = self.windows.status() if self.windows is not None else None
        state = ([id(e) for e in unsettled], [(s.state, s.rate) for s in status], skew, path, size, settings, read,
                 sampled, windows)
        word = self.doctor_process.take() if self.doctor_process is not None else None
        if changed_only and word is None and not (self._pending or self._warnings or self._findings is not None) \
                and state == self._state:
            return False
        self._state = state
        events, self._pending = self._pending, []
        warnings, self._warnings = self._warnings, []
        findings, self._findings = self._findings, None
        batch = FeedBatch(events, unsettled, status, skew, path, size, warnings, findings, done, error,
                          settings, *read, sampled=sampled, windows=windows)
        batch.hear(word)
        self.deliver(batch)
        return True

    def _sampled(self) -> SampledInput | None:
        """A logic capture's input and what each line's UART has measured so far
        (its reports are updated in this thread, as it decodes); None for bytes."""
        reports = self.runner.physical
        if reports is None:
            return None
        if self._named is None:
            self._named = split_description(self.runner.info.source)
        return SampledInput.of(self.runner.info.source, reports.values(), self.runner.swapped, self._named)

    def _read(self) -> tuple[int, int | None]:
        """Bytes of the input read so far, of its size (None: it has none)."""
        total = self.meter.total()
        return (self.meter.done(), total) if total else (0, None)


class StreamFeed(Feed):
    """A file's feed whose input has no size (a pipe, a FIFO): what has been read
    is counted by the bytes of traffic it held (decompressed, and a socat log's
    data without its text), chunk by chunk. Only for such inputs: a file read flat
    out gives up to a million chunks a second."""

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        st = self.lines.get(chunk.line)
        if st is not None:
            st.bytes += len(chunk.data)

    def _read(self) -> tuple[int, int | None]:
        return sum(st.bytes for st in self.lines.values()), None


class LiveFeed(Feed):
    """A live tap's feed: it also counts each line's bytes for the status line's
    rate. A file's feed does not hear chunks at all (a file read flat out gives a
    million a second, and the rate of reading a file says nothing); nor does it
    say how much of an input has been read (a live tap reads no file)."""

    def _read(self) -> tuple[int, int | None]:
        return 0, None

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        st = self.lines.get(chunk.line)
        if st is not None:
            n = len(chunk.data)
            st.bytes += n
            # the last second's bytes in 50 ms buckets, not one entry a chunk: a
            # flooded port gives many chunks a second, summed at every batch
            win = self._window[chunk.line]
            now = time.monotonic()
            if win and now - win[-1][0] < RATE_BUCKET:
                win[-1][1] += n
            else:
                win.append([now, n])


def feed_class(runner: TapRunner, meter: ReadMeter = READS) -> type[Feed]:
    """The feed a runner needs: a live tap's, a file's, or (an input with no size)
    one that counts the traffic's bytes, as the meter cannot tell how much of a
    pipe has been read."""
    if runner.live:
        return LiveFeed
    return Feed if meter.total() else StreamFeed
