"""The gimbalscope TUI: termshark's three linked panes (event list, detail tree,
hex) plus a timeline of both lines, over a ``CaptureModel`` fed through batched
messages by a capture thread or a decoding process (a ``ScreenFeed``).

The app holds the keys, the capture's feed and the replay's pace; the main
screen (screens/capture.py) holds the panes and bars. The keys are the app's,
not the main screen's, so that they work (and show in the footer) over every
screen. They have ids (``Binding(id=...)``) so a keymap file can rebind them
(``--keymap FILE``, TOML: ``"app.filter" = "ctrl+l"``). Styles are in
gimbalscope.tcss.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from functools import partial
from typing import TYPE_CHECKING, ClassVar

from textual import on
from textual.app import App
from textual.binding import Binding, BindingType
from textual.message import Message
from textual.timer import Timer

from .feed import FeedBatch, ScreenFeed
from .model import CaptureModel
from .model.marks_kept import MarksKept
from .screens.capture import CaptureScreen
from .screens.redraw import Redrawn
from .widgets import EventList, NoteBar, RecordControl, TalkBar

if TYPE_CHECKING:
    from textual.app import SystemCommand
    from textual.screen import Screen

    from ..talk.session import TalkSession

PACE = 0.1   # seconds between a playing replay's steps


class FeedMessage(Message):
    def __init__(self, batch: FeedBatch) -> None:
        super().__init__()
        self.batch = batch


class GimbalscopeApp(App):
    TITLE = "gimbalscope"
    CSS_PATH = "gimbalscope.tcss"

    # q quits with App.action_quit; run_app then stops the capture and finalises any recording
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("q,ctrl+c", "quit", "Quit", id="app.quit"),
        Binding("slash", "open('filter')", "Filter", id="app.filter"),
        Binding("e", "jump('error', 1)", "Next error", id="app.next_error"),
        Binding("E", "jump('error', -1)", "Prev error", show=False, id="app.prev_error"),
        Binding("p", "jump('pair', 1)", "Pair", id="app.pair"),
        Binding("d", "jump('device', 1)", "Same device", show=False, id="app.next_device"),
        Binding("D", "jump('device', -1)", "Same device back", show=False, id="app.prev_device"),
        Binding("m", "mark", "Mark", show=False, id="app.mark"),
        Binding("M", "note", "Note", show=False, id="app.note"),
        Binding("apostrophe", "jump('mark', 1)", "Next mark", show=False, id="app.next_mark"),
        Binding("ctrl+f", "open('search')", "Search", show=False, id="app.search"),
        Binding("ctrl+g", "open('goto')", "Go to #", show=False, id="app.goto"),
        # live --talk: the talk prompt; elsewhere the go-to prompt, as ":" has always been
        Binding("colon", "talk", "Send / go to #", show=False, id="app.talk"),
        Binding("n", "jump('hit', 1)", "Next hit", show=False, id="app.search_next"),
        Binding("N", "jump('hit', -1)", "Prev hit", show=False, id="app.search_prev"),
        Binding("end,G", "follow", "Follow", id="app.follow"),
        Binding("t", "time_mode", "Time", id="app.time_mode"),
        Binding("z", "zoom(-1)", "Zoom in", show=False, id="app.zoom_in"),
        Binding("Z", "zoom(1)", "Zoom out", show=False, id="app.zoom_out"),
        Binding("S", "show('stats')", "Stats", id="app.stats"),
        Binding("P", "show('plots')", "Plots", id="app.plots"),
        Binding("w", "show('findings')", "Doctor", id="app.findings"),
        Binding("x", "swap_lines", "Swap A/B", show=False, id="app.swap_lines"),
        Binding("r", "record", "Record", id="app.record"),
        Binding("space", "replay('play')", "Play/pause", id="app.play"),
        Binding("plus", "replay('speed', 2)", "Faster", show=False, id="app.faster"),
        Binding("minus", "replay('speed', 0.5)", "Slower", show=False, id="app.slower"),
        Binding("greater_than_sign", "replay('seek', 10)", "+10 s", show=False, id="app.seek_forward"),
        Binding("less_than_sign", "replay('seek', -10)", "-10 s", show=False, id="app.seek_back"),
        Binding("full_stop", "replay('seek', 1)", "+1 s", show=False, id="app.seek_forward_1"),
        Binding("comma", "replay('seek', -1)", "-1 s", show=False, id="app.seek_back_1"),
        Binding("question_mark", "show('help')", "Help", id="app.help"),
        # (the id keeps its first name: keymap files and the help screen say it)
        Binding("escape", "cancel_sweep", "Stop filter/search", show=False, id="app.cancel_scan"),
    ]

    # Actions that only make sense in one mode are hidden from the footer (and
    # refused) in the others: check_action returning False hides, None would dim.
    _MODE_ACTIONS: ClassVar[dict[str, set[str]]] = {"record": {"live"}, "swap_lines": {"live"}, "replay": {"replay"}}

    def __init__(self, model: CaptureModel, feed_factory: Callable[[Callable[[FeedBatch], None]], ScreenFeed], *,
                 mode: str, source: str, settings: str = "", record_path: str | None = None,
                 keymap: dict[str, str] | None = None, talk: TalkSession | None = None,
                 marks_kept: MarksKept | None = None) -> None:
        """``feed_factory(deliver)``: the capture's feed, made once the screen has
        mounted, which hands its batches to ``deliver``. ``marks_kept``: where a
        file's marks are kept (its sidecar); a live tap keeps them in its recording."""
        super().__init__()
        self.model = model
        self._feed_factory = feed_factory
        self.feed: ScreenFeed | None = None
        self.mode = mode                 # live, replay, view
        self.talk = talk                 # live --talk: the port the : prompt sends on
        self.marks_kept = marks_kept     # a file's marks: its sidecar (analyzer/formats/marks.py)
        self._said_unkept = False        # a live tap not recording was told its marks are not kept
        self.keymap = keymap or {}       # binding id -> keys (--keymap), as the help screen shows them
        self.last: FeedBatch | None = None
        self._pace: Timer | None = None  # a replay's steps (``_tick``), running only while it plays
        self.main = CaptureScreen(model, mode=mode, source=source, settings=settings, record_path=record_path)
        self.status_bar = self.main.status_bar

    def get_system_commands(self, screen: Screen) -> Iterable[SystemCommand]:
        """The command palette (ctrl+p): every bound action of this mode, by name."""
        from textual.app import SystemCommand

        yield from super().get_system_commands(screen)
        for b in self.BINDINGS:
            if not isinstance(b, Binding):   # all of them are: keymaps rebind them by id
                continue
            name = b.action.partition("(")[0]
            if not self.check_action(name, ()) or name == "quit":
                continue
            yield SystemCommand(b.description, f"key: {b.key}", partial(self.run_action, b.action))

    def check_action(self, action: str, parameters: tuple) -> bool | None:
        modes = self._MODE_ACTIONS.get(action)
        return modes is None or self.mode in modes

    @property
    def sweep_text(self) -> str:
        """A filter or search sweeping in the background: its progress ("" when none)."""
        return self.main.sweep.text

    @property
    def messages(self):
        """The feed's warnings, newest last (the status bar shows the last): as the
        app has always offered them to whoever drives it."""
        return self.status_bar.messages

    def get_default_screen(self) -> CaptureScreen:
        return self.main

    def on_mount(self) -> None:
        if self.keymap:
            self.set_keymap(self.keymap)
        # the main screen composes in its own turn: the capture starts once it has
        # (a callback waits in the screen's queue until it has mounted)
        self.main.call_later(self._start_feed)
        if self.marks_kept is not None:   # the marks the file kept, on screen with its first rows
            notes, why = self.marks_kept.read()
            self.model.marks.load(notes)
            if why:
                self.notify(f"{why}: opened without its marks", severity="warning", timeout=8)

    def _start_feed(self) -> None:
        self.feed = self._feed_factory(self._deliver)
        self.feed.start()
        # nothing ticks while nothing changes: the screen moves on the feed's
        # messages and on keys; a replay is paced only while it plays
        self._pace = self.set_interval(PACE, self._tick, pause=True, name="replay pace")
        self._pace_while_playing()
        self.main.refresh_status()

    # ------------------------------------------------------------ the feed
    def _deliver(self, batch: FeedBatch) -> None:
        """From the capture thread: hand the batch to the UI thread (never blocks)."""
        self.post_message(FeedMessage(batch))

    def on_feed_message(self, message: FeedMessage) -> None:
        b, m = message.batch, self.model
        if b.chunk is not None:
            m.add_chunk(b.chunk)
        else:
            m.add(b.events, b.unsettled)
        if b.findings is not None:
            m.findings = b.findings
            m.findings_known = True
        if b.doctor_error is not None:
            m.doctor_error = b.doctor_error
        self.last = b
        self.status_bar.from_feed(b)
        if b.done and not m.done:
            m.done = True
            self.status_bar.capture_ended()
        self.main.rows_changed()
        self.main.refresh_status()
        self._capture_changed()
        if b.done:
            self._pace_while_playing()

    def _capture_changed(self) -> None:
        """A full screen on top (statistics, plots, findings) is redrawn when the
        capture has changed, not on a timer."""
        if isinstance(self.screen, Redrawn):
            self.screen.capture_changed()

    def _tick(self) -> None:
        """A replay's pace: the rows up to the playback's position, and the position."""
        if self.model.replay.playback is not None and self.model.replay.advance(time.monotonic()):
            self.main.rows_changed()
            self._capture_changed()
        self.main.refresh_status()
        self._pace_while_playing()

    def _pace_while_playing(self) -> None:
        """The pace runs while a replay plays; at full speed (``--speed max``) only
        until every event of the loaded file is shown."""
        pace, pb, m = self._pace, self.model.replay.playback, self.model
        if pace is None:
            return
        if pb is not None and pb.playing and not (pb.speed == 0 and m.done and m.shown >= len(m.store)):
            pace.resume()
        else:
            pace.pause()

    @on(RecordControl.Toggled)
    def _record_toggled(self, message: RecordControl.Toggled) -> None:
        if self.feed is None:
            return
        if message.path is None:
            self.feed.stop_recording()
        else:
            self.feed.start_recording(message.path)

    # ------------------------------------------------------------- actions
    def action_open(self, bar: str) -> None:
        """The filter bar, or the search or go-to prompt."""
        self.main.open_bar(bar)

    def action_talk(self) -> None:
        """The talk prompt when the tap may talk (``live --talk``), else the go-to prompt."""
        self.main.open_bar("talk" if self.talk is not None else "goto")

    @on(TalkBar.Send)
    def _send(self, message: TalkBar.Send) -> None:
        if self.talk is not None:
            # in a thread of its own: a long frame at a low rate takes a while to write
            self.run_worker(partial(self._send_line, self.talk, message.line), thread=True, group="talk")

    def _send_line(self, talk: TalkSession, line: str) -> None:
        from ..errors import CaptureError
        from ..talk.request import TalkError

        try:
            sent = talk.send(line)
        except (TalkError, CaptureError) as e:
            self.call_from_thread(self.notify, str(e), severity="error", timeout=8)
            return
        self.call_from_thread(self.notify, str(sent), timeout=3)

    def action_jump(self, to: str, step: int) -> None:
        self.main.jump(to, step)

    @on(EventList.FollowEnd)
    def action_follow(self) -> None:
        self.model.following.resume()
        self.main.rows_changed()
        self.main.refresh_status()

    def action_mark(self) -> None:
        if self.main.event_list.selected is not None:
            self.model.marks.toggle(self.main.current)
            self._marks_changed()

    def action_note(self) -> None:
        if self.main.event_list.selected is not None:
            number = self.main.current
            self.main.note_bar.open_for(number, self.model.marks.note(number) or "")

    @on(NoteBar.Written)
    def _note_written(self, message: NoteBar.Written) -> None:
        self.model.marks.write(message.number, message.note)
        self._marks_changed()

    def _marks_changed(self) -> None:
        """Keep what changed: a file's marks in its sidecar, a live tap's in its
        recording (none: said once, the marks stay on screen)."""
        self.main.event_list.refresh()
        self.main.show_selected(self.main.current)
        model = self.model
        changes = model.marks.changed()
        if self.marks_kept is not None:
            try:
                self.marks_kept.keep([model.as_mark(number, note) for number, note in model.marks.notes.items()])
            except OSError as e:
                self.notify(f"marks not kept: {e}", severity="error", timeout=6)
            return
        if self.feed is None or not self._recording():
            if not self._said_unkept:
                self._said_unkept = True
                self.notify("marks stay on this screen only: a recording keeps them (r records)", timeout=5)
            return
        for number, note in changes:
            self.feed.mark(model.as_mark(number, note))

    def action_time_mode(self) -> None:
        mode = self.model.text.cycle_time_mode()
        self.notify(f"time: {mode}", timeout=1.5)
        self.main.event_list.refresh()

    def action_zoom(self, step: int) -> None:
        self.main.timeline.zoom(step)

    def action_show(self, name: str) -> None:
        """A full screen over the main one: statistics, plots, findings, help."""
        if name == "stats":
            from .screens.stats import StatsScreen
            self.push_screen(StatsScreen(self.model))
        elif name == "plots":
            from .screens.plots import PlotScreen
            self.push_screen(PlotScreen(self.model))
        elif name == "findings":
            from .screens.findings import FindingsScreen
            self.push_screen(FindingsScreen(self.model), self._to_evidence)
        elif name == "help":
            from .screens.help import HelpScreen
            self.push_screen(HelpScreen(self))

    def _to_evidence(self, number: int | None) -> None:
        """Enter on a finding's evidence line closes the findings screen with that event's number."""
        if number is not None:
            self.main.go(number, "such event shown yet")

    def action_swap_lines(self) -> None:
        """The tap's ports were the other way round: read A as B from now on (the
        runner says so on screen and on the recording's /log topic)."""
        feed = self.feed
        if feed is None or tuple(feed.lines) != ("A", "B"):
            self.notify("swapping needs a two-line tap", timeout=2)
            return
        feed.swap_lines()
        self.notify("swapping lines A and B", timeout=3)

    def action_record(self) -> None:
        if self.mode != "live" or self.feed is None:
            self.notify("recording is for live taps (replays are recordings already)", timeout=2)
            return
        self.main.record.toggle(self._recording())

    def _recording(self) -> bool:
        """Does the live tap record now (its feed's recorder, or the last batch says so)?"""
        return self.feed is not None and bool(self.feed.recording or (self.last is not None and self.last.recording))

    def action_replay(self, what: str, amount: float = 0) -> None:
        """Play or pause; change the speed by a factor; seek by seconds."""
        pb, replay = self.model.replay.playback, self.model.replay
        if pb is None:
            if what == "play":
                self.notify("play/pause is for replays", timeout=2)
            return
        if what == "play":
            pb.toggle(time.monotonic())
        elif what == "speed":
            pb.tick(time.monotonic())
            pb.speed = min(64.0, max(0.125, (pb.speed or 64.0) * amount))
        elif what == "seek":
            replay.seek(amount)
            self.main.rows_changed()
        self.main.refresh_status()
        self._pace_while_playing()

    def action_cancel_sweep(self) -> None:
        """Esc: stop a filter or search that is still running."""
        self.main.cancel_sweep()
