"""The status bar: a file and how much of it has loaded (bytes read of its
size), or ports and their state, bytes/s per line; settings, skew, the
recording and its size, elapsed time (line 1); events, errors, checksum
errors, the doctor's findings, the filter, replay position and speed, follow
state or "+N new", a running scan's progress or the feed's last warning
(line 2). It only shows: it reads the model and what the app hands it, and
has no messages of its own. Counts have thousands separators (8,671), as
everywhere on the TUI."""

from __future__ import annotations

import time
from collections import deque

from rich.text import Text
from textual.widgets import Static

from ...styles import ERROR, INFO, PORT_STATE_STYLE, SEVERITY_BADGE, WARNING
from ...words import counted
from ..feed import FeedBatch
from ..model import CaptureModel


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return ""


class StatusBar(Static):
    def __init__(self, model: CaptureModel, *, mode: str, source: str, settings: str = "", **kw) -> None:
        super().__init__(**kw)
        self.model = model
        self.mode = mode                 # live, replay, view
        self.source_name = source
        self.settings = settings
        self.last: FeedBatch | None = None
        self.messages: deque[str] = deque(maxlen=100)   # the feed's warnings, newest last (the last shows)
        self.started = time.monotonic()
        self.ended = self.started        # when the capture ended (model.done)
        self.scan = ""                   # a filter or search running in a worker: its progress
        self._shown: Text | None = None

    def batch(self, batch: FeedBatch) -> None:
        """A batch from the feed: the lines' state, and what it had to say."""
        self.last = batch
        self.messages.extend(batch.warnings)
        if batch.error:
            self.messages.append(f"capture stopped: {batch.error}")

    def capture_ended(self) -> None:
        self.ended = time.monotonic()

    def redraw(self) -> None:
        text = Text.assemble(self._wire(), "\n", self._events())
        # refreshed ten times a second: an unchanged line is not redrawn (an ended
        # capture's screen was repainted forever, a tenth of a core)
        if text != self._shown:
            self._shown = text
            self.update(text)

    def _wire(self) -> Text:
        """Line 1: where the events come from."""
        m, b, live = self.model, self.last, self.mode == "live"
        line = Text()
        if not live:
            line.append(self.source_name + "  ")
            load = self._load()
            if load:
                line.append(load + "  ", style="dim" if m.done else "bold")
        elif b is not None:
            for st in b.lines:
                line.append(f"{st.line} ", style="bold")
                line.append(f"{st.port}")
                line.append(f" {st.state}", style=PORT_STATE_STYLE.get(st.state, "white"))
                if not m.done:   # nothing is read once it ended
                    line.append(f" {_size(st.rate)}/s")
                line.append("  ")
        line.append(b.settings if b is not None and b.settings else self.settings, style="dim")
        if b is not None and b.skew:
            line.append(f"  skew +{b.skew * 1000:.1f} ms", style="yellow")
        if b is not None and b.recording:
            line.append(f"  ● REC {b.recording} {_size(b.recording_bytes)}", style="bold red")
        if live:   # how long the tap has run (a file's duration is in its stats)
            elapsed = (self.ended if m.done else time.monotonic()) - self.started
            line.append(f"  {int(elapsed // 3600):02d}:{int(elapsed % 3600 // 60):02d}:{int(elapsed % 60):02d}",
                        style="dim")
        return line

    def _load(self) -> str:
        """A file: how much of it has been read, from the feed's batches: bytes
        of its size while it loads, then its size. A pipe has no size: the bytes
        of traffic read so far, no share. A replay says nothing once loaded (its
        position is on line 2); a capture that stopped on an error, how far it got."""
        b, done = self.last, self.model.done
        if done and self.mode == "replay":
            return ""
        word = "loaded" if done else "loading"
        if b is None:
            return word
        if not b.total:
            return f"{word} · {_size(b.read)} of traffic" if b.read else word
        if done and not b.error:
            return f"{word} {_size(b.total)}"
        return f"{word} {100 * b.read // b.total}% · {_size(b.read)} of {_size(b.total)}"

    def _events(self) -> Text:
        """Line 2: what the events are, and what the screen is doing."""
        m = self.model
        line = Text()
        errors = m.error_count
        line.append(counted(m.shown + len(m.unsettled), "event"), style="bold")
        line.append(f"  {counted(errors, 'error')}", style=SEVERITY_BADGE[ERROR] if errors else "")
        line.append(f"  {m.checksum_errors:,} checksum")
        problems = [f for f in m.findings if f.severity != INFO]
        if problems:
            worst = ERROR if any(f.severity == ERROR for f in problems) else WARNING
            line.append(f"  ⚠ {counted(len(problems), 'finding')} (w): {problems[0].title}",
                        style=SEVERITY_BADGE[worst])
        if m.filter_text:
            line.append(f"  filter: {m.filter_text} ({m.row_count:,} shown)", style="cyan")
        pb = m.replay.playback
        if pb is not None:
            speed = "max" if pb.speed == 0 else f"{pb.speed:g}×"
            line.append(f"  replay {'▶' if pb.playing else '⏸'} {speed} at {pb.position:.1f} s", style="bold")
        if m.follow:
            line.append("  FOLLOW", style="bold green")
        elif m.new_while_away:
            line.append(f"  +{m.new_while_away:,} new (End follows)", style="bold yellow")
        if m.done and self.mode == "live":
            line.append("  capture ended", style="red")
        if self.scan:
            line.append(f"  {self.scan}", style="bold cyan")
        elif self.messages:
            line.append(f"  {self.messages[-1]}", style="italic")
        return line
