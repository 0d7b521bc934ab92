"""The status bar: a file and how much of it has loaded (bytes read of its
size), or ports and their state, bytes/s per line; settings, skew, the
recording and its size, elapsed time (line 1). A logic capture (a sample
stream, a sigrok session, a VCD or Saleae export) names its input once, with
what it is, then each line's channel and the rate and format its software UART
measured ("measuring" until it has; model/sampled.py) in place of the ports
and the settings. Line 2: events, errors, checksum errors, the doctor's
findings, the filter, replay position and speed, follow state or "+N new", a
running sweep's progress or the feed's last warning. It only shows: it reads
the model and what the app hands it, and has no messages of its own. Counts have thousands separators (8,671), as
everywhere on the TUI.

It is two rows at any width: each line is made of parts with a rank (what a
user needs to see first ranks highest; ``fit``). A line too long for the bar
shortens its paths (keeping their ends), then, rank by rank from the lowest,
shortens free texts (a note, a finding's title, the filter) with an ellipsis and
leaves out parts (settings, the clock, skew, port names, the checksum count,
rates); the lines' states, the recording, the counts, follow and "capture
ended" stay, cropped last. A logic capture's line parts shorten every line
alike: " bit/s" goes first, then the channels, then its input's description
is cut between words, then the formats; its input's name is never cut inside a
word (a long path loses whole folders), nor the lines' rates. A live tap's
clock is redrawn once a second, and only while the bar is on screen; nothing
else here runs on a timer."""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from rich.cells import cell_len
from rich.text import Text
from textual.timer import Timer
from textual.widgets import Static

from ...styles import ERROR, INFO, PORT_STATE_STYLE, SEVERITY_BADGE, WARNING
from ...words import byte_size, counted
from ..feed import FeedBatch
from ..model import CaptureModel
from ..model.sampled import SampledInput

ELLIPSIS = "…"
SHORTEST = 8        # cells a shortened free text keeps at least (its ellipsis included)


@dataclass
class Part:
    """A piece of a status line: ``head`` and ``tail`` as they are, ``free`` a
    free text that may be shortened (cut at its end, or at its start for a path:
    ``cut_start``); ``rank``: the higher, the later it is left out (MUST: never),
    and its free text shortened (unless ``cut_rank`` says when: a path, which
    keeps its file's name, early); ``sep``: what separates it from the part before."""
    rank: int
    head: str = ""
    style: str = ""
    free: str = ""
    tail: str = ""
    sep: str = "  "
    cut_start: bool = False
    sep_style: str | None = None     # the separator's style (None: the part's; PREVIOUS: the part before's)
    cut_rank: int | None = None      # the rank at which the free text is shortened (None: ``rank``)
    words: bool = False              # the free text is cut between words (a path: between folders), never in one
    group: str = ""                  # parts of one group are left out together (every line's channel)

    def __post_init__(self) -> None:
        self.full = self.free

    @property
    def cut_at(self) -> int:
        """The rank at which the free text is shortened."""
        return self.rank if self.cut_rank is None else self.cut_rank

    def width(self, first: bool) -> int:
        return cell_len(self.head) + cell_len(self.free) + cell_len(self.tail) + (0 if first else cell_len(self.sep))

    def shorten(self, by: int) -> None:
        """The free text ``by`` cells shorter (a negative ``by``: longer, up to
        its whole), and no shorter than SHORTEST."""
        now, whole = cell_len(self.free), cell_len(self.full)
        self.free = _cut(self.full, min(whole, max(min(whole, SHORTEST), now - by)), self.cut_start, self.words)


MUST = 9            # a part of this rank is never left out, only cropped
PREVIOUS = "previous"


def _cut(text: str, width: int, start: bool, words: bool = False) -> str:
    """``text`` in ``width`` cells with an ellipsis where it was cut (its start or its end);
    ``words``: cut only between words (at its start, between folders too), so
    that no word is cut in two: as near ``width`` as that allows."""
    if cell_len(text) <= width:
        return text
    if words:
        return _cut_words(text, width, start)
    chars = list(text)
    if start:
        while chars and cell_len("".join(chars)) > width - 1:
            chars.pop(0)
        return ELLIPSIS + "".join(chars).lstrip()
    while chars and cell_len("".join(chars)) > width - 1:
        chars.pop()
    return "".join(chars).rstrip() + ELLIPSIS


def _cut_words(text: str, width: int, start: bool) -> str:
    """``_cut`` between words: the most whole words (a path's end: whole folders
    and the file's name) that fit with the ellipsis; when not even one does, the
    one word nearest the kept end, whole (the line is cropped last, in ``fit``)."""
    if start:
        # "…/rig-7/tap.sr": a path keeps the slash before the folders it keeps
        cuts = [i + (c == " ") for i, c in enumerate(text) if c in " /" and 0 < i < len(text) - 1]
        kept = [text[i:].lstrip() for i in cuts]
        fitting = [k for k in kept if cell_len(k) + 1 <= width]
        return ELLIPSIS + (fitting[0] if fitting else kept[-1]) if kept else text
    # not between a number and its unit ("1 MHz")
    cuts = [i for i, c in enumerate(text) if c == " " and i > 0 and not text[i - 1].isdigit()]
    kept = [text[:i].rstrip(" ,;:·-") for i in cuts]
    kept = [k for k in kept if k]
    fitting = [k for k in kept if cell_len(k) + 1 <= width]
    return (fitting[-1] if fitting else kept[0]) + ELLIPSIS if kept else text


def _share_cut(group: list[Part], over: int) -> None:
    """Shorten the free texts of ``group`` by ``over`` cells in all, the longest
    first, so that they end as long as each other (two long port names keep as
    much of each)."""
    if over <= 0 or not group:
        return
    lengths = [cell_len(p.free) for p in group]
    floors = [min(n, SHORTEST) for n in lengths]
    level = max(lengths)
    while level > 0 and sum(n - max(f, min(n, level)) for n, f in zip(lengths, floors)) < over:
        level -= 1
    for p, n, f in zip(group, lengths, floors):
        p.shorten(n - max(f, min(n, level)))


def fit(parts: list[Part], width: int | None) -> Text:
    """The parts on one line of at most ``width`` cells (None: any). Rank by
    rank from the lowest, while the line is too long: the free texts of that
    (cut) rank are shortened, then the parts of that rank left out (the
    rightmost first, with the rest of its group; never a MUST part);
    a shortened text then takes back any room left; last, the line is cropped
    with an ellipsis."""
    parts = [p for p in parts if p.head or p.free or p.tail]
    if width is not None and width > 0:
        _make_room(parts, width)
    spans: list[list[str]] = []   # [text, style]
    for i, p in enumerate(parts):
        text = p.head + p.free + p.tail
        if i and p.sep_style == PREVIOUS:
            spans[-1][0] += p.sep
        elif i and p.sep_style is not None:
            spans.append([p.sep, p.sep_style])
        elif i:
            text = p.sep + text   # in the part's span (a badge's margin)
        spans.append([text, p.style])
    line = Text(no_wrap=True, overflow="ellipsis")
    for text, style in spans:
        line.append(text, style=style)
    if width is not None and width > 0 and line.cell_len > width:
        line.truncate(width, overflow="ellipsis")
    return line


def _make_room(parts: list[Part], width: int) -> None:
    """``fit``'s shortening and leaving out, in place, until ``parts`` fit in
    ``width`` cells or nothing more can go."""
    def over() -> int:
        return sum(p.width(i == 0) for i, p in enumerate(parts)) - width
    for rank in sorted({p.rank for p in parts} | {p.cut_at for p in parts}):
        if over() <= 0:
            break
        _share_cut([p for p in parts if p.cut_at == rank and p.free], over())
        for p in reversed([p for p in parts if p.rank == rank and rank < MUST]):
            if over() <= 0:
                break
            if any(q is p for q in parts):   # (not gone with its group)
                parts[:] = [q for q in parts if q is not p and not (p.group and q.group == p.group)]
    for p in sorted((p for p in parts if p.free != p.full), key=lambda p: -p.rank):
        if over() >= 0:
            break
        p.shorten(over())


class StatusBar(Static):
    def __init__(self, model: CaptureModel, *, mode: str, source: str, settings: str = "", **kw: Any) -> None:
        super().__init__(**kw)
        self.model = model
        self.mode = mode                 # live, replay, view
        self.source_name = source
        self.settings = settings
        self.last: FeedBatch | None = None
        self.sampled: SampledInput | None = None   # a logic capture: its input and lines, as last measured
        self.messages: deque[str] = deque(maxlen=100)   # the feed's warnings, newest last (the last shows)
        self.started = time.monotonic()
        self.ended = self.started        # when the capture ended (model.done)
        self.sweep = ""                  # a filter or search sweeping in a worker: its progress
        self._shown: Text | None = None
        self._on_screen = False          # the main screen is showing (not under a full screen)
        self._clock: Timer | None = None

    def from_feed(self, batch: FeedBatch) -> None:
        """A batch from the feed: the lines' state, and what it had to say."""
        self.last = batch
        if batch.sampled is not None:   # (a last word without it keeps what was measured)
            self.sampled = batch.sampled
        self.messages.extend(batch.warnings)
        if batch.error:
            self.messages.append(f"capture stopped: {batch.error}")

    def capture_ended(self) -> None:
        self.ended = time.monotonic()
        self._tick_clock()

    # --------------------------------------------------------------- clock
    def shown(self, on_screen: bool) -> None:
        """The main screen is showing (True) or under a full screen (False): the
        clock runs only while the bar can be seen."""
        self._on_screen = on_screen
        if on_screen:
            self.redraw()
        self._tick_clock()

    def _tick_clock(self) -> None:
        """A live tap's elapsed time changes once a second: the bar is redrawn
        then, while it is on screen and the capture runs; nothing else ticks."""
        if self._clock is not None:
            self._clock.stop()
            self._clock = None
        if self.mode != "live" or self.model.done or not self._on_screen or not self.is_mounted:
            return
        elapsed = time.monotonic() - self.started
        self._clock = self.set_timer(1.0 - elapsed % 1.0 + 0.005, self._clock_ticked, name="status clock")

    def _clock_ticked(self) -> None:
        self._clock = None
        self.redraw()
        self._tick_clock()

    @property
    def clock_running(self) -> bool:
        return self._clock is not None

    # -------------------------------------------------------------- drawing
    def on_mount(self) -> None:
        self._tick_clock()

    def on_resize(self) -> None:
        self.redraw()

    def redraw(self) -> None:
        width = self.content_size.width or None
        text = Text.assemble(fit(self._wire(), width), "\n", fit(self._events(), width),
                             no_wrap=True, overflow="ellipsis")
        # an unchanged line is not redrawn (an ended capture's screen was
        # repainted forever, a tenth of a core)
        if text != self._shown:
            self._shown = text
            # its size is fixed (two rows, the screen's width): no layout, only
            # the bar is repainted (a layout of the screen a second was most
            # of what an idle live screen cost)
            self.update(text, layout=False)

    def _wire(self) -> list[Part]:
        """Line 1: where the events come from."""
        m, b, live = self.model, self.last, self.mode == "live"
        parts: list[Part] = []
        if self.sampled is not None:
            parts += self._sampled(self.sampled)
        elif not live:
            # a long path keeps its end, the file's name
            parts.append(Part(6, free=self.source_name, cut_start=True, cut_rank=1))
            load = self._load()
            if load:
                parts.append(Part(8, load, style="dim" if m.done else "bold", sep_style=""))
        elif b is not None:
            for st in b.lines:
                parts.append(Part(MUST, st.line, style="bold", sep_style=""))
                parts.append(Part(4, free=st.port, cut_start=True, sep=" ", sep_style=PREVIOUS, cut_rank=1))
                parts.append(Part(MUST, st.state, style=PORT_STATE_STYLE.get(st.state, "white"), sep=" "))
                if not m.done:   # nothing is read once it ended
                    parts.append(Part(5, f"{byte_size(st.rate)}/s", sep=" "))
        if self.sampled is None:   # (a logic capture's lines say theirs)
            parts.append(Part(2, b.settings if b is not None and b.settings else self.settings, style="dim",
                              sep_style=PREVIOUS if parts and not live else ""))
        if b is not None and b.skew:
            parts.append(Part(3, f"skew +{b.skew * 1000:.1f} ms", style="yellow"))
        if b is not None and b.recording:
            parts.append(Part(MUST, "● REC ", style="bold red", free=b.recording, cut_start=True, cut_rank=1,
                              tail=f" {byte_size(b.recording_bytes)}"))
        if b is not None and b.windows:   # live --keep: windows kept, matches, bytes dropped
            parts.append(Part(MUST, "◆ KEEP ", style="bold magenta", free=b.windows, cut_rank=1))
        if live:   # how long the tap has run (a file's duration is in its stats)
            elapsed = (self.ended if m.done else time.monotonic()) - self.started
            parts.append(Part(3, f"{int(elapsed // 3600):02d}:{int(elapsed % 3600 // 60):02d}:"
                                 f"{int(elapsed % 60):02d}", style="dim"))
        return parts

    def _sampled(self, s: SampledInput) -> list[Part]:
        """A logic capture's input, once and whole (``stdin: logic samples at 1
        MHz, 8 channels``; a file viewed, how much has loaded), then each line's
        channel and what its UART measured (``A D0 9,888 bit/s 8N1``). Short of
        room, every line loses its " bit/s", then its channel; then the input's
        description is cut between words, then the lines' formats go; the name
        only ever loses whole folders."""
        m = self.model
        parts = [Part(MUST, free=s.name, cut_start=True, words=True, cut_rank=7)]
        if s.kind:
            parts.append(Part(6, free=s.kind, words=True, sep=": ", sep_style=PREVIOUS))
        load = self._load() if self.mode != "live" else ""
        if load:
            parts.append(Part(8, load, style="dim" if m.done else "bold", sep_style=""))
        for ln in s.lines:
            parts.append(Part(MUST, ln.line, style="bold", sep_style=""))
            parts.append(Part(5, ln.channel_label, sep=" ", sep_style=PREVIOUS, group="channel"))
            rate = ln.rate()
            if rate is None:
                parts.append(Part(MUST, ln.waiting(m.done), style="italic yellow", sep=" "))
                continue
            parts.append(Part(MUST, rate, sep=" "))
            parts.append(Part(4, "bit/s", sep=" ", group="unit"))
            parts.append(Part(7, ln.format, sep=" ", group="format"))
            if ln.inverted:
                parts.append(Part(7, "inverted", style="yellow", sep=" ", group="inverted"))
        return parts

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
            return f"{word} · {byte_size(b.read)} of traffic" if b.read else word
        if done and not b.error:
            return f"{word} {byte_size(b.total)}"
        return f"{word} {100 * b.read // b.total}% · {byte_size(b.read)} of {byte_size(b.total)}"

    def _events(self) -> list[Part]:
        """Line 2: what the events are, and what the screen is doing."""
        m = self.model
        errors = m.totals.errors
        parts = [Part(MUST, counted(m.shown + len(m.unsettled), "event"), style="bold"),
                 Part(MUST, counted(errors, "error"), style=SEVERITY_BADGE[ERROR] if errors else ""),
                 Part(4, f"{m.totals.checksum_errors:,} checksum")]
        problems = [f for f in m.findings if f.severity != INFO]
        if problems:
            worst = ERROR if any(f.severity == ERROR for f in problems) else WARNING
            parts.append(Part(6, f"⚠ {counted(len(problems), 'finding')} (w): ", free=problems[0].title,
                              style=SEVERITY_BADGE[worst]))
        if m.filter_text:
            shown = f" ({m.row_count:,} shown, {counted(m.totals.shown_errors, 'error')})"
            parts.append(Part(7, "filter: ", free=m.filter_text, tail=shown, style="cyan"))
        pb = m.replay.playback
        if pb is not None:
            speed = "max" if pb.speed == 0 else f"{pb.speed:g}×"
            parts.append(Part(8, f"replay {'▶' if pb.playing else '⏸'} {speed} at {pb.position:.1f} s",
                              style="bold"))
        if m.follow:
            parts.append(Part(8, "FOLLOW", style="bold green"))
        elif m.new_while_away:
            parts.append(Part(8, f"+{m.new_while_away:,} new", style="bold yellow"))
            parts.append(Part(3, "(End follows)", style="bold yellow", sep=" "))
        if m.done and self.mode == "live":
            parts.append(Part(MUST, "capture ended", style="red"))
        if self.sweep:
            parts.append(Part(7, free=self.sweep, style="bold cyan"))
        elif self.messages:
            parts.append(Part(5, free=" ".join(self.messages[-1].splitlines()), style="italic"))
        return parts
