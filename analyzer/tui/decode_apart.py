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

Only for a file viewed whose inputs can be opened again (``apart_possible``);
live taps, replays and pipes keep their capture thread (feed.py). The wiring
doctor runs in a process of its own beside this one (doctor_apart.py).
"""

from __future__ import annotations

import dataclasses
import os
import threading
import time
from collections.abc import Callable

from .apart import end, helper_started, spawn
from .doctor_apart import ApartFindings, DoctorApart, HearsTheDoctorApart
from .feed import FILE_INTERVAL, FeedBatch, LineStatus
from .model.chunks import ChunkMaker

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


class _Sender:
    """The decoding process's ``deliver``: the feed's batches, their events made
    into chunks and sent at most every ``FILE_INTERVAL`` (the first at once)."""

    def __init__(self, conn) -> None:
        self.conn = conn
        self.maker = ChunkMaker()
        self.warnings: list[str] = []
        self.findings: list | None = None
        self.last = 0.0
        self.sent = False
        self.failed = False   # a chunk could not be sent: the ones after it would not follow it

    def __call__(self, batch: FeedBatch) -> None:
        if self.failed:   # the run ends on that failure: only its last word goes, without events
            if batch.done:
                self.conn.send(dataclasses.replace(batch, events=[], unsettled=[], chunk=None))
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
            self.conn.send(dataclasses.replace(batch, events=[], unsettled=[], warnings=warnings,
                                               findings=findings, chunk=self.maker.take()))
        except BaseException:
            self.failed = True
            raise


def _child(inputs, options, command, conn) -> None:
    helper_started()
    try:
        from ..capture import open as open_capture
        from ..info import CaptureInfo
        from ..runner import TapRunner
        from .feed import Feed

        capture = open_capture(*inputs, options=options)
        runner = TapRunner(capture, [], info=CaptureInfo.of(capture, command=command))
        feed = Feed(runner, _Sender(conn), ApartFindings())
        runner.add_listener(feed)
        feed.run()   # to the last batch; a capture that fails says so in it
    except SystemExit:   # stopped by the screen, which is closing: nothing to say
        pass
    except BaseException as e:   # whatever it is, the screen hears of it, in one line
        conn.send(FeedBatch([], [], [], done=True, error=f"{type(e).__name__}: {e}"))
    finally:
        conn.close()


class DecodeApart(HearsTheDoctorApart):
    """The screen's side: what the app asks of a feed (``start``, ``stop``,
    ``join``, ``is_alive``, ``notes``; recording and swapping are for live taps),
    its batches received from the decoding process by a thread of its own and
    handed to ``deliver``, the doctor's findings (``findings_arrived``) put in
    the next one."""

    def __init__(self, inputs: tuple[str, ...], options, deliver: Callable[[FeedBatch], None], *,
                 command: str = "view", doctor: DoctorApart | None = None) -> None:
        """``doctor``: the wiring doctor's process, started beside the decoding
        where there are cores enough, else once the file has loaded."""
        self.inputs, self.options, self.command = inputs, options, command
        self.deliver = deliver
        self.doctor = ApartFindings()
        self.doctor_apart = doctor
        self._doctor_started = False
        self.notes: list[str] = []
        self.lines: dict[str, LineStatus] = {}
        self.recording = None
        self.process = None
        self._conn = None
        self._thread = threading.Thread(target=self._receive, daemon=True, name="gimbalscope-decode-wait")
        self._end_lock = threading.Lock()
        self._ended = False
        self._stopping_by_screen = False
        self._last: FeedBatch | None = None
        self._warnings: list[str] = []
        self._findings: list | None = None
        self._doctor_error: str | None = None

    def spawn(self) -> bool:
        """Start the decoding process; False if no process can be had."""
        started = spawn(_child, (self.inputs, self.options, self.command), "gimbalscope-decode")
        if started is None:
            return False
        self.process, self._conn = started
        if _cores() >= DOCTOR_BESIDE_CORES:
            self._start_doctor()
        return True

    def _start_doctor(self) -> None:
        apart, self._doctor_started = self.doctor_apart, True
        if apart is None:
            return
        if apart.start():
            apart.deliver_to(self.findings_arrived)
        elif not apart.stopped:
            self.findings_arrived(None, "no process could be started for it")

    # ------------------------------------------------------------- the app's
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        """End the decoding (the screen is closing): nothing of it needs finishing."""
        self._stopping_by_screen = True   # its silence is then no news
        self._end()

    def _end(self) -> None:
        end(self.process)

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

    def _send_last(self) -> None:
        """One more last batch: the doctor's word after the load ended (``findings_arrived``)."""
        self._pass_on(dataclasses.replace(self._last, chunk=None, warnings=[], error=None))

    # --------------------------------------------------------------- thread
    def _receive(self) -> None:
        conn = self._conn
        batch = None
        expected = 0   # the next event a chunk must start at
        while True:
            error = None
            try:
                batch = conn.recv()
            except (EOFError, OSError):   # killed, or out of memory: keep what came
                error = "the decoding process ended without a word"
            except Exception as e:   # a message that cannot be read: the rest cannot be trusted
                error = f"a batch from the decoding process could not be read: {type(e).__name__}: {e}"
            else:
                chunk = batch.chunk
                if chunk is not None:
                    if chunk.stored.start != expected:
                        error = (f"the decoding process lost events {expected + 1} to "
                                 f"{chunk.stored.start}")
                    expected = chunk.stored.start + len(chunk.stored.columns["kind"])
            if error is not None:
                self._end()   # it may be waiting to send more
                batch = FeedBatch([], [], list(self.lines.values()), done=True,
                                  error=None if self._stopping_by_screen else error)
            if batch.error and not self._stopping_by_screen:
                self.notes.append(f"capture stopped: {batch.error}")
            self.lines = {s.line: s for s in batch.lines}
            with self._end_lock:
                self._pass_on(batch)
                if batch.done:
                    self._ended = True
                    self._last = batch
                    break
        conn.close()
        if not self._doctor_started:   # the file has loaded: the doctor's turn
            self._start_doctor()

    def _pass_on(self, batch: FeedBatch) -> None:
        """Deliver ``batch`` with the doctor's news (under the end lock)."""
        if self._warnings:
            batch.warnings = batch.warnings + self._warnings
            self._warnings = []
        if self._findings is not None:
            batch.findings, self._findings = self._findings, None
        if self._doctor_error is not None:
            batch.doctor_error, self._doctor_error = self._doctor_error, None
        self.deliver(batch)
