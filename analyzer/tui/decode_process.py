"""A file viewed is decoded in a process of its own, which hands the screen its
events as store columns.

Loading a file means decoding, pairing and storing its events. In one process
the capture thread (decode, pair) and the screen's thread (store the events,
one by one, as columns) take turns on one interpreter lock, so their times add
up. Here the decoding process also stores the events (``ChunkMaker``: the
same columns the screen's store keeps) and sends what it stored every quarter
of a second; the screen's thread copies arrays (``CaptureModel.add_chunk``).
The two run side by side, and the screen stays free for keys while a file
loads.

The decoding process runs the capture with a ``Feed`` as any capture thread
does (its batches, line states, warnings, read progress); only the events of
its batches become a chunk on the way. What pairing still holds is not sent:
while a file loads nothing waits on the wire, and its end settles everything.

Only for a file viewed whose inputs can be opened again
(``readable_by_another_process``); live taps, replays and pipes keep their
capture thread (feed.py). The wiring doctor runs in a process of its own beside
this one (doctor_process.py). Both processes are started by
analyzer/worker_process.py.
"""

from __future__ import annotations

import dataclasses
import os
import threading
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

from .. import worker_process
from ..capture import Options
from ..formats.marks import Mark
from .doctor_process import DoctorProcess
from .feed import FILE_INTERVAL, FeedBatch, ScreenFeed
from .model.chunks import ChunkMaker

if TYPE_CHECKING:
    from ..capture.stored import StoredEvents
    from ..formats.store import StoreChunk
    from ..runner import TapRunner

# cores enough for the wiring doctor's process beside the decoding one and the
# screen: with fewer, the doctor waits until the file has loaded (on two cores,
# running beside the load, it cost the load a quarter of its speed)
DOCTOR_BESIDE_CORES = 4


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


class BatchSender:
    """The decoding process's ``deliver``: the feed's batches, their events made
    into chunks and sent at most every ``FILE_INTERVAL`` (the first at once)."""

    def __init__(self, sender: worker_process.Sender) -> None:
        self.sender = sender
        self.maker = ChunkMaker()
        self.warnings: list[str] = []
        self.findings: list | None = None
        self.last = 0.0
        self.sent = False
        self.failed = False   # a chunk could not be sent: the ones after it would not follow it

    def __call__(self, batch: FeedBatch) -> None:
        if self.failed:   # the run ends on that failure: only its last word goes, without events
            if batch.done:
                self.sender.send(dataclasses.replace(batch, events=[], unsettled=[], chunk=None))
            return
        self.maker.add(batch.events)
        self.warnings += batch.warnings
        if batch.findings is not None:
            self.findings = batch.findings
        now = time.monotonic()
        if not (batch.done or now - self.last >= FILE_INTERVAL or (len(self.maker) and not self.sent)):
            return
        self.sent = self.sent or bool(len(self.maker))
        self.last = now
        warnings, self.warnings = self.warnings, []
        findings, self.findings = self.findings, None
        try:
            self.sender.send(dataclasses.replace(batch, events=[], unsettled=[], warnings=warnings,
                                                 findings=findings, chunk=self.maker.take()))
        except BaseException:
            self.failed = True
            raise


def _decode(inputs: tuple[str, ...], options: Options, command: str | None, sender: worker_process.Sender) -> None:
    """The decoding process: the capture's batches, to the last one; a capture
    that fails says so in it."""
    try:
        from ..capture import open as open_capture
        from ..capture.stored import stored_events
        from ..info import CaptureInfo
        from ..runner import TapRunner
        from .feed import Feed

        capture = open_capture(*inputs, options=options)
        runner = TapRunner(capture, [], info=CaptureInfo.of(capture, command=command))
        stored, _why = stored_events(capture)   # the capture says why not, as it runs
        if stored is not None:
            _send_stored(stored, runner, sender)
            return
        feed = Feed(runner, BatchSender(sender), None)   # the doctor is in a process of its own
        runner.add_listener(feed)
        feed.run()
    # KeyboardInterrupt too: a Ctrl-C that reaches this process (it shares the
    # terminal's process group) is said to the screen as what stopped it
    # ("KeyboardInterrupt: "), not left for it to hear as an end without a word
    except (Exception, KeyboardInterrupt) as e:   # noqa: BLE001 - whatever it is, the screen hears of it, in one line
        sender.send(FeedBatch([], [], [], done=True, error=f"{type(e).__name__}: {e}"))


def _send_stored(stored: StoredEvents, runner: TapRunner, sender: worker_process.Sender) -> None:
    """A recording's stored columns (analyzer/capture/stored.py), sent chunk by
    chunk as they are read: no decoding, and nothing for a ``Feed`` to time."""
    from ..formats.store_ipc import ColumnsError, Joiner
    from .feed import FeedBatch, LineStatus
    from .model.chunks import stored_model_chunk

    names = runner.info.line_names
    lines = {line: LineStatus(line, names[line], state="file") for line in runner.lines}
    line_codes: list[str | None] = [None]
    joiner = Joiner()
    error = None
    sent = 0

    # the status line says how much of the file has loaded, in bytes: the share of its events read
    try:
        size = sum(os.path.getsize(path) for path in runner.info.inputs) or None
    except OSError:   # gone since it was opened: the share is not said
        size = None

    def read(events: int) -> int:
        return (size or 0) * events // max(stored.events, 1)

    def status() -> list[LineStatus]:
        return [LineStatus(s.line, s.port, s.state, s.bytes) for s in lines.values()]

    try:
        for chunk in stored.chunks(joiner):
            line_codes += chunk.lines
            counted = _bytes_by_line(chunk, line_codes)
            for line, n in counted.items():
                if line in lines:
                    lines[line].bytes += n
            sent += len(chunk.columns["kind"])
            sender.send(FeedBatch([], [], status(), settings=runner.serial_settings, read=read(sent), total=size,
                                  chunk=stored_model_chunk(chunk, joiner.known(), joiner.positions)))
    except ColumnsError as e:
        error = f"the stored columns stop after event {sent}: {e}"
    sender.send(FeedBatch([], [], status(), settings=runner.serial_settings, done=True, error=error,
                          read=read(sent), total=size))


def _bytes_by_line(chunk: StoreChunk, line_codes: list[str | None]) -> dict[str | None, int]:
    """The raw bytes of the chunk's events, by line."""
    import numpy as np

    from ..formats.store_ipc import raw_offsets

    lengths = np.diff(raw_offsets(chunk))
    codes = np.frombuffer(chunk.columns["line"], chunk.columns["line"].typecode)
    if not len(codes):
        return {}
    sums = np.bincount(codes, weights=lengths, minlength=len(line_codes))
    return {line_codes[c]: int(n) for c, n in enumerate(sums) if n}


class ProcessFeed(ScreenFeed):
    """The screen's side of the decoding process: its batches, received by a
    thread of its own and handed to ``deliver``, with the doctor's word (its
    ``DoctorProcess``) in the next one. A file viewed is not recorded, and has
    no lines to swap."""

    def __init__(self, inputs: tuple[str, ...], options: Options, deliver: Callable[[FeedBatch], None], *,
                 command: str | None = "view", doctor: DoctorProcess | None = None,
                 started: worker_process.Worker | None = None) -> None:
        """``doctor``: the wiring doctor's process, started beside the decoding
        where there are cores enough, else once the file has loaded. ``started``:
        the decoding process of these inputs, started already (``start_process``):
        ``spawn`` adopts it rather than start another."""
        self.inputs, self.options, self.command = inputs, options, command
        self.deliver = deliver
        self.doctor_process = doctor
        self._doctor_started = False
        self.notes: list[str] = []
        self.lines = {}
        self.process: worker_process.Worker | None = started
        self.messages: worker_process.Receiver | None = None   # the batches, from ``spawn``
        self._thread = threading.Thread(target=self._receive, daemon=True, name="gimbalscope-decode-wait")
        self._stopping_by_screen = False

    @staticmethod
    def start_process(inputs: tuple[str, ...], options: Options, command: str | None = "view") -> (
            worker_process.Worker | None):
        """The decoding process of ``inputs``, started before its ``ProcessFeed`` is
        made (hand it over as ``started``): it then imports and decodes while the
        screen is still being made. None if no process can be had."""
        return worker_process.start(_decode, (inputs, options, command))

    def spawn(self) -> bool:
        """Start the decoding process, or adopt the one ``started`` already; False
        if no process can be had."""
        worker = self.process
        if worker is None:
            worker = self.start_process(self.inputs, self.options, self.command)
        if worker is None:
            return False
        self.process, self.messages = worker, worker.messages
        if _cores() >= DOCTOR_BESIDE_CORES:
            self._start_doctor()
        return True

    def _start_doctor(self) -> None:
        doctor, self._doctor_started = self.doctor_process, True
        if doctor is not None and not doctor.start():
            doctor.tell(None, "no process could be started for it")

    # ------------------------------------------------------------- the screen's
    @property
    def recording(self) -> str | None:
        return None

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        """End the decoding and the doctor (the screen is closing): nothing of them needs finishing."""
        self._stopping_by_screen = True   # the decoding's silence is then no news
        if self.doctor_process is not None:
            self.doctor_process.stop()
        self._end()

    def _end(self) -> None:
        if self.process is not None:
            self.process.end()

    def join(self, timeout: float | None = None) -> None:
        if self._thread.is_alive():
            self._thread.join(timeout)

    def is_alive(self) -> bool:
        return self._thread.is_alive()

    def start_recording(self, path: str) -> None:
        raise RuntimeError("a file viewed is not recorded")

    def stop_recording(self) -> None:
        pass

    def swap_lines(self) -> None:
        pass

    def mark(self, mark: Mark) -> None:
        pass   # a file's marks are kept in its sidecar (tui/model/marks_kept.py), not by its feed

    # --------------------------------------------------------------- thread
    def _receive(self) -> None:
        messages = self.messages
        assert messages is not None, "spawn() before start()"
        expected = 0   # the next event a chunk must start at
        while True:
            batch, expected = self._next(messages, expected)
            if batch.error and not self._stopping_by_screen:
                self.notes.append(f"capture stopped: {batch.error}")
            self.lines = {s.line: s for s in batch.lines}
            if batch.done:
                break
            self._pass_on(batch)
        messages.close()
        self._end()   # it has said its last word: reaped now, not left a zombie until the screen closes
        # the doctor's word after the load ended: one more last batch
        again = partial(self._pass_on, dataclasses.replace(batch, chunk=None, warnings=[], error=None))
        if self.doctor_process is None:
            self._pass_on(batch)
        else:
            self.doctor_process.last_batch(partial(self._pass_on, batch), again)
        if not self._doctor_started:   # the file has loaded: the doctor's turn
            self._start_doctor()

    def _next(self, messages: worker_process.Receiver, expected: int) -> tuple[FeedBatch, int]:
        """The next batch of the decoding process and the event the chunk after it
        must start at; a last batch saying why when what came cannot be used."""
        error = None
        try:
            batch = messages.recv()
        except (EOFError, OSError):   # killed, or out of memory: keep what came
            error = "the decoding process ended without a word"
        except Exception as e:   # noqa: BLE001 - a message that cannot be read: the rest cannot be trusted
            error = f"a batch from the decoding process could not be read: {type(e).__name__}: {e}"
        else:
            if not isinstance(batch, FeedBatch):
                error = f"the decoding process sent a {type(batch).__name__}, not a batch"
            elif batch.chunk is not None and batch.chunk.stored.start != expected:
                error = f"the decoding process lost events {expected + 1} to {batch.chunk.stored.start}"
            else:
                if batch.chunk is not None:
                    expected = batch.chunk.stored.start + len(batch.chunk.stored.columns["kind"])
                return batch, expected
        self._end()   # it may be waiting to send more
        return FeedBatch([], [], list(self.lines.values()), done=True,
                         error=None if self._stopping_by_screen else error), expected

    def _pass_on(self, batch: FeedBatch) -> None:
        """Deliver ``batch`` with the doctor's word, if it has come."""
        if self.doctor_process is not None:
            batch.hear(self.doctor_process.take())
        self.deliver(batch)
