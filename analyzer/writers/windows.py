"""Recording windows around the events that matter (``live … --record DIR --keep
FILTER``, docs/live.md, "Keeping windows"): an unattended tap keeps only the raw
bytes and events from ``before`` ahead of a matching event to ``after`` beyond it,
as ordinary recordings, one file a window (``window-0001.mcap``, ...).

Memory is bounded by ``before``: the bytes of both lines and the events of the last
``before`` seconds wait in a ring, and are written when a match opens a window.
Windows that would overlap are one: a window stays open to ``after`` beyond its
last match, and for ``before`` more the bytes past its end wait in the ring, so
that a match in that time continues the same file with them (a gap-free window)
rather than starting a new one that repeats them. Bytes that leave the ring
without being written are counted as dropped, and said at the end.

A window's file is one recording of its own: its raw bytes are the ground truth,
its events those the tap decoded. It carries no stored columns: its first bytes
may cut a frame, so decoding the file alone differs at its start from what the
tap decoded, and a reader decodes the bytes (docs/mcap.md).
"""

from __future__ import annotations

import os
from collections import deque

from dissectors.event import Event

from ..analysis.filter import Predicate
from ..info import CaptureInfo
from ..lines import Chunk
from ..runner import INFO, RECORDING, Listener, TapRunner
from ..words import byte_size, counted
from .mcap import McapWriter

_IDLE, _OPEN, _CLOSING = "idle", "open", "closing"


def window_path(folder: str, n: int) -> str:
    return os.path.join(folder, f"window-{n:04d}.mcap")


class WindowKeeper(Listener):
    """Keeps a window of ``before`` + ``after`` seconds around each event ``keep``
    matches, one recording a window in ``folder``; ``max_windows``: the tap stops
    once that many are written (as dumpcap's ``-a files:N``)."""

    def __init__(self, folder: str, info: CaptureInfo, keep: Predicate, trigger: str, *, before: float,
                 after: float, max_windows: int | None = None, lean: bool = False) -> None:
        self.folder = folder
        self.info = info
        self.keep = keep
        self.trigger = trigger
        self.before = before
        self.after = after
        self.max_windows = max_windows
        self.lean = lean
        self._runner: TapRunner | None = None
        # the ring: what came in the last ``before`` seconds, in the order it came, and
        # how much of each is written to the window (everything up to that place)
        self._chunks: deque[tuple[float, Chunk, int]] = deque()   # (time, chunk, offset on its line)
        self._events: deque[tuple[float, Event]] = deque()
        self._chunks_written = 0   # of the ring's first chunks
        self._events_written = 0
        self._state = _IDLE
        self._writer: McapWriter | None = None
        self._end = 0.0            # the open window's end: ``after`` beyond its last match
        self._now = float("-inf")  # the latest event's time
        self.windows = 0           # windows opened
        self.matched = 0           # events that matched
        self.missed = 0            # matches after the last window allowed (``max_windows``)
        self.seen_bytes = 0
        self.kept_bytes = 0
        self.paths: list[str] = []

    @property
    def dropped_bytes(self) -> int:
        """Bytes read that are in no window (counted, not kept)."""
        return self.seen_bytes - self.kept_bytes

    # ------------------------------------------------------------ the runner's calls
    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        if not chunk.data:
            return
        t = chunk.t if chunk.t is not None else self._now
        self.seen_bytes += len(chunk.data)
        self._chunks.append((t, chunk, offset))
        if self._state == _OPEN:
            self._write_waiting()

    def on_events(self, events: list[Event]) -> None:
        keep = self.keep
        for ev in events:
            t = ev.t if ev.t is not None else self._now
            self._events.append((t, ev))
            self._advance(t)
            if keep(ev):
                self.matched += 1
                self._match(t)
            elif self._state == _OPEN:
                self._write_waiting()

    def on_stop(self) -> None:
        self._close()
        self._chunks.clear()
        self._events.clear()
        if self._runner is not None:
            self._runner.post(self.summary(), INFO, origin=RECORDING)

    # ------------------------------------------------------------ windows
    def _match(self, t: float) -> None:
        if self._state == _OPEN:
            self._end = max(self._end, t + self.after)
        elif self._state == _CLOSING:   # within ``before`` of the last window's end: the same window
            self._state = _OPEN
            self._end = t + self.after
        elif self.max_windows is not None and self.windows >= self.max_windows:
            self.missed += 1
            return
        else:
            self._open(t)
        self._write_waiting()

    def _open(self, t: float) -> None:
        self.windows += 1
        path = window_path(self.folder, self.windows)
        self.paths.append(path)
        self._writer = McapWriter(path, self.info, live=True, lean=self.lean, columns=False,
                                  metadata={"trigger": self.trigger, "window": str(self.windows),
                                            "before": repr(self.before), "after": repr(self.after)})
        if self._runner is not None:
            self._writer.on_start(self._runner)
        self._state = _OPEN
        self._end = t + self.after
        # the ring's first ``before`` seconds ahead of the match are left out of the window
        start = t - self.before
        self._chunks_written = sum(1 for ct, _c, _o in self._chunks if ct < start)
        self._events_written = sum(1 for et, _e in self._events if et < start)

    def _write_waiting(self) -> None:
        """What waits in the ring up to the window's end, in the order it came (times
        of two lines' reads may step back a little: the first past the end waits)."""
        writer = self._writer
        if writer is None:
            return
        end = self._end
        chunks = self._chunks
        k = self._chunks_written
        while k < len(chunks) and chunks[k][0] <= end:
            _t, chunk, offset = chunks[k]
            writer.on_chunk(chunk, offset)
            self.kept_bytes += len(chunk.data)
            k += 1
        self._chunks_written = k
        events = self._events
        k = first = self._events_written
        while k < len(events) and events[k][0] <= end:
            k += 1
        if k > first:
            writer.on_events([ev for _t, ev in list(events)[first:k]])
        self._events_written = k

    def _advance(self, t: float) -> None:
        """The events ran on to ``t``: the window closes; the ring forgets what is
        older than ``before``. Events, not reads, keep the time: the bytes are read
        ahead of the events decoded from them, and a match is an event."""
        self._now = max(self._now, t)
        now = self._now
        if self._state == _OPEN and now > self._end:
            self._state = _CLOSING
        if self._state == _CLOSING and now > self._end + self.before:
            self._close()
        horizon = now - self.before
        chunks, events = self._chunks, self._events
        while chunks and chunks[0][0] < horizon and (self._state == _IDLE or self._chunks_written):
            chunks.popleft()
            self._chunks_written = max(0, self._chunks_written - 1)
        while events and events[0][0] < horizon and (self._state == _IDLE or self._events_written):
            events.popleft()
            self._events_written = max(0, self._events_written - 1)

    def _close(self) -> None:
        writer = self._writer
        if writer is None:
            return
        self._writer = None
        self._state = _IDLE
        self._chunks_written = self._events_written = 0
        writer.on_stop()
        if self._runner is not None and self.max_windows is not None and self.windows >= self.max_windows:
            self._runner.stop()

    def status(self) -> str:
        """What the status line shows: ``2 windows, 5 matched, 30.1 kB dropped``."""
        return (f"{counted(self.windows, 'window')}, {self.matched:,} matched, "
                f"{byte_size(self.dropped_bytes)} dropped")

    def summary(self) -> str:
        """``2 windows kept in DIR: 5 events matched 'status == "nak"', 1,200 bytes kept, 30,000 dropped``."""
        said = (f"{counted(self.windows, 'window')} kept in {self.folder}: {counted(self.matched, 'event')} "
                f"matched {self.trigger!r}, {self.kept_bytes:,} bytes kept, {self.dropped_bytes:,} dropped")
        if self.missed:
            said += f" ({counted(self.missed, 'match', 'matches')} after the last window allowed)"
        return said

