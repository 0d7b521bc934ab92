"""The gimbalscope TUI: termshark's three linked panes (event list, detail tree,
hex) plus a timeline of both lines, over a ``CaptureModel`` fed by a capture
thread (``Feed``) through batched messages.

Keys have ids (``Binding(id=...)``) so a keymap file can rebind them
(``--keymap FILE``, TOML: ``"app.filter" = "ctrl+l"``).
"""

from __future__ import annotations

import time
from collections import deque
from datetime import datetime

from rich.text import Text
from textual import on
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.message import Message
from textual.widgets import Footer, Input, Static

from ..analysis.filter import FilterError, compile_filter
from ..styles import ERROR, INFO, PORT_STATE_STYLE, SEVERITY_BADGE, WARNING
from .feed import Feed, FeedBatch
from .model import Cancelled, CaptureModel
from .widgets import DetailTree, EventList, HexView, TimelineView


class ScanProgress(Message):
    """How far a filter or search running in a worker thread has got."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.text = text


# Filters and searches over more rows than this run in a worker thread, with
# progress on the status line and Esc to stop them.
BACKGROUND_ROWS = 50_000


class FeedMessage(Message):
    def __init__(self, batch: FeedBatch) -> None:
        super().__init__()
        self.batch = batch


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return ""


class GimbalscopeApp(App):
    TITLE = "gimbalscope"
    CSS = """
    #status { height: auto; max-height: 4; background: $panel; padding: 0 1; }
    EventList { height: 1fr; min-height: 6; overflow-x: hidden; }
    #lower { height: 30%; min-height: 6; }
    DetailTree { width: 1fr; border-top: solid $primary; }
    HexView { width: 40%; max-width: 74; border-top: solid $primary; padding: 0 1; }
    TimelineView { height: 5; border-top: solid $primary; }
    #filterbar { height: auto; display: none; }
    #filterbar.shown { display: block; }
    #filter-error { color: $error; height: auto; padding: 0 1; }
    #filter-error.ok { color: $success; }
    #search, #goto { display: none; }
    #search.shown, #goto.shown { display: block; }
    """

    BINDINGS = [
        Binding("q,ctrl+c", "quit", "Quit", id="app.quit"),
        Binding("slash", "filter", "Filter", id="app.filter"),
        Binding("e", "error(1)", "Next error", id="app.next_error"),
        Binding("E", "error(-1)", "Prev error", show=False, id="app.prev_error"),
        Binding("p", "partner", "Pair", id="app.pair"),
        Binding("d", "device(1)", "Same device", show=False, id="app.next_device"),
        Binding("D", "device(-1)", "Same device back", show=False, id="app.prev_device"),
        Binding("m", "mark", "Mark", show=False, id="app.mark"),
        Binding("apostrophe", "next_mark", "Next mark", show=False, id="app.next_mark"),
        Binding("ctrl+f", "search", "Search", show=False, id="app.search"),
        Binding("ctrl+g,colon", "goto", "Go to #", show=False, id="app.goto"),
        Binding("n", "search_next(1)", "Next hit", show=False, id="app.search_next"),
        Binding("N", "search_next(-1)", "Prev hit", show=False, id="app.search_prev"),
        Binding("end,G", "follow", "Follow", id="app.follow"),
        Binding("t", "time_mode", "Time", id="app.time_mode"),
        Binding("z", "zoom(-1)", "Zoom in", show=False, id="app.zoom_in"),
        Binding("Z", "zoom(1)", "Zoom out", show=False, id="app.zoom_out"),
        Binding("S", "stats", "Stats", id="app.stats"),
        Binding("P", "plots", "Plots", id="app.plots"),
        Binding("w", "findings", "Doctor", id="app.findings"),
        Binding("x", "swap_lines", "Swap A/B", show=False, id="app.swap_lines"),
        Binding("r", "record", "Record", id="app.record"),
        Binding("space", "play_pause", "Play/pause", id="app.play"),
        Binding("plus", "speed(2)", "Faster", show=False, id="app.faster"),
        Binding("minus", "speed(0.5)", "Slower", show=False, id="app.slower"),
        Binding("greater_than_sign", "seek(10)", "+10 s", show=False, id="app.seek_forward"),
        Binding("less_than_sign", "seek(-10)", "-10 s", show=False, id="app.seek_back"),
        Binding("full_stop", "seek(1)", "+1 s", show=False, id="app.seek_forward_1"),
        Binding("comma", "seek(-1)", "-1 s", show=False, id="app.seek_back_1"),
        Binding("question_mark", "help", "Help", id="app.help"),
        Binding("escape", "cancel_scan", "Stop filter/search", show=False, id="app.cancel_scan"),
    ]

    def __init__(self, model: CaptureModel, feed_factory, *, mode: str, source: str, settings: str = "",
                 record_path: str | None = None, keymap: dict[str, str] | None = None) -> None:
        super().__init__()
        self.model = model
        self._feed_factory = feed_factory
        self.feed: Feed | None = None
        self.mode = mode                 # live, replay, view
        self.source_name = source
        self.settings = settings
        self.record_path = record_path   # where the record key writes
        self._keymap = keymap or {}
        self.last: FeedBatch | None = None
        self.messages: deque[str] = deque(maxlen=100)   # the feed's warnings, newest last (the last shows)
        self.started = time.monotonic()
        self.ended = self.started          # when the capture ended (model.done)
        self._status_text: Text | None = None
        self._search_text = ""
        self._history_pos: int | None = None
        self._detail_due = False   # follow mode: the lower panes are refreshed on a timer
        self._scan_text = ""       # a filter or search running in a worker: its progress

    # Actions that only make sense in one mode are hidden from the footer (and
    # refused) in the others: check_action returning False hides, None would dim.
    _MODE_ACTIONS = {"record": {"live"}, "swap_lines": {"live"}, "play_pause": {"replay"}, "speed": {"replay"},
                     "seek": {"replay"}}

    def get_system_commands(self, screen):
        """The command palette (ctrl+p): every bound action of this mode, by name."""
        from textual.app import SystemCommand

        yield from super().get_system_commands(screen)
        for b in self.BINDINGS:
            name, _, arg = b.action.partition("(")
            if not self.check_action(name, ()) or name == "quit":
                continue
            params = arg.rstrip(")")
            run = getattr(self, f"action_{name}")
            callback = (lambda run=run, p=params: run(float(p))) if params else run
            yield SystemCommand(b.description, f"key: {b.key}", callback)

    def check_action(self, action: str, parameters: tuple) -> bool | None:
        modes = self._MODE_ACTIONS.get(action)
        return modes is None or self.mode in modes

    # ------------------------------------------------------------- layout
    def compose(self) -> ComposeResult:
        # The panes are kept as attributes: App.query_one looks at the active screen,
        # which is the statistics or plots screen while one is open.
        self.status_bar = Static(id="status")
        self.event_list = EventList(self.model, id="events")
        self.detail = DetailTree(id="detail")
        self.hex = HexView(id="hex")
        self.timeline = TimelineView(self.model, id="timeline")
        self.filter_bar = Vertical(id="filterbar")
        self.filter_box = Input(placeholder="filter: kind == \"command\" and status != \"ok\"   (Enter "
                                            "applies, Esc cancels, ↑/↓ history)", id="filter")
        self.filter_error = Static("", id="filter-error")
        self.search_box = Input(placeholder="search text (Enter finds, n/N next/previous)", id="search")
        self.goto_box = Input(placeholder="go to event number (Enter goes, Esc cancels)", id="goto",
                              type="integer")
        yield self.status_bar
        yield self.event_list
        with Horizontal(id="lower"):
            yield self.detail
            yield self.hex
        yield self.timeline
        with self.filter_bar:
            yield self.filter_box
            yield self.filter_error
        yield self.search_box
        yield self.goto_box
        yield Footer()

    def on_mount(self) -> None:
        if self._keymap:
            self.set_keymap(self._keymap)
        self.event_list.focus()
        self.feed = self._feed_factory(self._deliver)
        self.feed.start()
        self.set_interval(0.1, self._tick)
        self.set_interval(0.2, self._catch_up_detail)
        self._refresh_status()

    def _deliver(self, batch: FeedBatch) -> None:
        """From the capture thread: hand the batch to the UI thread (never blocks)."""
        self.post_message(FeedMessage(batch))

    # -------------------------------------------------------------- input
    def on_feed_message(self, message: FeedMessage) -> None:
        b = message.batch
        m = self.model
        m.add(b.events, b.unsettled)
        if b.findings is not None:
            m.findings = b.findings
        self.last = b
        self.messages.extend(b.warnings)
        if b.error:
            self.messages.append(f"capture stopped: {b.error}")
        if b.done and not m.done:
            m.done = True
            self.ended = time.monotonic()
        self._rows_changed()
        self._refresh_status()

    def _tick(self) -> None:
        if self.model.playback is not None and self.model.advance_playback(time.monotonic()):
            self._rows_changed()
        self._refresh_status()

    def _catch_up_detail(self) -> None:
        if self._detail_due:
            self._detail_due = False
            self._show_selected(self.event_list.selected)

    def _rows_changed(self) -> None:
        lst = self.event_list
        before = lst.selected
        lst.rows_changed()
        if lst.selected is None and self.model.row_count:
            lst.go_to(self.model.row(0).number)   # a file opens on its first event
        if lst.selected is not None and (lst.selected != before or self._selected_unsettled(lst.selected)):
            if self.model.follow:
                # following a busy line the selection moves with every batch; rebuilding
                # the detail tree each time kept the screen's thread busy and the list
                # fell behind the wire: the lower panes catch up five times a second
                self._detail_due = True
            else:
                self._show_selected(lst.selected)

    def _selected_unsettled(self, number: int) -> bool:
        return bool(self.model.unsettled) and number >= self.model.unsettled[0].number

    # -------------------------------------------------------------- status
    def _refresh_status(self) -> None:
        m = self.model
        b = self.last
        line1 = Text()
        if b is not None and self.mode != "live":
            line1.append(self.source_name + "  ")
        elif b is not None:
            for st in b.lines:
                colour = PORT_STATE_STYLE.get(st.state, "white")
                state = "" if self.mode != "live" else f" {st.state}"
                line1.append(f"{st.line} ", style="bold")
                line1.append(f"{st.port}")
                line1.append(state, style=colour)
                if self.mode == "live" and not m.done:   # nothing is read once it ended
                    line1.append(f" {_size(st.rate)}/s")
                line1.append("  ")
        line1.append(b.settings if b is not None and b.settings else self.settings, style="dim")
        if b is not None and b.skew:
            line1.append(f"  skew +{b.skew * 1000:.1f} ms", style="yellow")
        if b is not None and b.recording:
            line1.append(f"  ● REC {b.recording} {_size(b.recording_bytes)}", style="bold red")
        if self.mode == "live":   # how long the tap has run (a file's duration is in its stats)
            elapsed = (self.ended if m.done else time.monotonic()) - self.started
            line1.append(f"  {int(elapsed // 3600):02d}:{int(elapsed % 3600 // 60):02d}:{int(elapsed % 60):02d}",
                         style="dim")
        line2 = Text()
        errors = m.error_count
        shown = m.shown + len(m.unsettled)
        line2.append(f"{shown:,} event{'' if shown == 1 else 's'}", style="bold")
        line2.append(f"  {errors:,} error{'' if errors == 1 else 's'}", style=SEVERITY_BADGE[ERROR] if errors else "")
        line2.append(f"  {m.stats.checksum_errors} checksum")
        problems = [f for f in m.findings if f.severity != INFO]
        if problems:
            worst = ERROR if any(f.severity == ERROR for f in problems) else WARNING
            line2.append(f"  ⚠ {len(problems)} finding{'s' if len(problems) != 1 else ''} (w): {problems[0].title}",
                         style=SEVERITY_BADGE[worst])
        if m.filter_text:
            line2.append(f"  filter: {m.filter_text} ({m.row_count:,} shown)", style="cyan")
        if m.playback is not None:
            pb = m.playback
            state = "▶" if pb.playing else "⏸"
            speed = "max" if pb.speed == 0 else f"{pb.speed:g}×"
            line2.append(f"  replay {state} {speed} at {pb.position:.1f} s", style="bold")
        if m.follow:
            line2.append("  FOLLOW", style="bold green")
        elif m.new_while_away:
            line2.append(f"  +{m.new_while_away:,} new (End follows)", style="bold yellow")
        if m.done and self.mode == "live":
            line2.append("  capture ended", style="red")
        elif m.done and self.mode != "replay":
            line2.append("  loaded", style="dim")
        if self._scan_text:
            line2.append(f"  {self._scan_text}", style="bold cyan")
        elif self.messages:
            line2.append(f"  {self.messages[-1]}", style="italic")
        text = Text.assemble(line1, "\n", line2)
        # refreshed ten times a second: an unchanged line is not redrawn (an ended
        # capture's screen was repainted forever, a tenth of a core)
        if text != self._status_text:
            self._status_text = text
            self.status_bar.update(text)

    # ----------------------------------------------------------- selection
    @on(EventList.Selected)
    def _selected(self, message: EventList.Selected) -> None:
        if self.model.follow:
            # following, the cursor moves with every batch: the lower panes catch
            # up on their timer (``_catch_up_detail``), not once a batch
            self._detail_due = True
            return
        self._show_selected(message.number)

    def _show_selected(self, number: int | None) -> None:
        m = self.model
        ev = m.event(number) if number is not None else None
        tree = self.detail
        hexv = self.hex
        tl = self.timeline
        if ev is None:
            tree.show([], "no event selected")
            hexv.show(None)
            return
        tree.show(m.detail(ev), f"#{ev.number}")
        hexv.show(ev.raw)
        tl.selected = ev.number
        if ev.t is not None:
            tl.center = ev.t
        tl.redraw()

    @on(EventList.Navigated)
    def _navigated(self) -> None:
        self.model.stop_following()

    @on(EventList.FollowEnd)
    def _follow_end(self) -> None:
        self.action_follow()

    @on(DetailTree.Jump)
    def _jump(self, message: DetailTree.Jump) -> None:
        self._go(message.number)

    @on(DetailTree.FieldBytes)
    def _field_bytes(self, message: DetailTree.FieldBytes) -> None:
        lst = self.event_list
        ev = self.model.event(lst.selected) if lst.selected is not None else None
        if ev is not None:
            self.hex.show(ev.raw, message.span)

    def _go(self, number: int | None, what: str = "") -> None:
        if number is None:
            self.bell()
            if what:
                self.notify(f"no {what}", timeout=1.5)
            return
        self.model.stop_following()
        lst = self.event_list
        if lst.go_to(number):
            lst.focus()

    # -------------------------------------------------------------- actions
    def _current(self) -> int:
        sel = self.event_list.selected
        return sel if sel is not None else 0

    def action_error(self, step: int) -> None:
        self._go(self.model.next_error(self._current(), forward=step > 0),
                 "later error (E goes back)" if step > 0 else "earlier error")

    def action_partner(self) -> None:
        self._go(self.model.partner(self._current()), "paired event")

    def action_device(self, step: int) -> None:
        self._go(self.model.same_device(self._current(), forward=step > 0), "other event of this device")

    def action_mark(self) -> None:
        if self.event_list.selected is not None:
            self.model.toggle_mark(self._current())
            self.event_list.refresh()

    def action_next_mark(self) -> None:
        self._go(self.model.next_mark(self._current()), "marks (m marks a row)")

    def action_follow(self) -> None:
        self.model.resume_following()
        self._rows_changed()
        self._refresh_status()

    def action_time_mode(self) -> None:
        mode = self.model.cycle_time_mode()
        self.notify(f"time: {mode}", timeout=1.5)
        self.event_list.refresh()

    def action_zoom(self, step: int) -> None:
        self.timeline.zoom(step)

    def action_stats(self) -> None:
        from .screens import StatsScreen
        self.push_screen(StatsScreen(self.model))

    def action_plots(self) -> None:
        from .screens import PlotScreen
        self.push_screen(PlotScreen(self.model))

    def action_findings(self) -> None:
        from .screens import FindingsScreen
        self.push_screen(FindingsScreen(self.model), self._findings_closed)

    def _findings_closed(self, number: int | None) -> None:
        if number is not None:
            self._go(number, "such event shown yet")

    def action_swap_lines(self) -> None:
        """The tap's ports were the other way round: read A as B from now on (the
        runner says so on screen and on the recording's /log topic)."""
        feed = self.feed
        if feed is None or tuple(feed.lines) != ("A", "B"):
            self.notify("swapping needs a two-line tap", timeout=2)
            return
        feed.swap_lines()
        self.notify("swapping lines A and B", timeout=3)

    def action_help(self) -> None:
        from .screens import HelpScreen
        self.push_screen(HelpScreen(self))

    # ------------------------------------------------------------- replay
    def action_play_pause(self) -> None:
        pb = self.model.playback
        if pb is None:
            self.notify("play/pause is for replays", timeout=2)
            return
        pb.playing = not pb.playing
        pb.tick(time.monotonic())
        self._refresh_status()

    def action_speed(self, factor: float) -> None:
        pb = self.model.playback
        if pb is None:
            return
        pb.tick(time.monotonic())
        pb.speed = min(64.0, max(0.125, (pb.speed or 64.0) * factor))
        self._refresh_status()

    def action_seek(self, seconds: float) -> None:
        if self.model.playback is None:
            return
        self.model.seek(seconds)
        self._rows_changed()
        self._refresh_status()

    # ------------------------------------------------------------ record
    def action_record(self) -> None:
        if self.mode != "live" or self.feed is None:
            self.notify("recording is for live taps (replays are recordings already)", timeout=2)
            return
        if self.feed.recording or (self.last is not None and self.last.recording):
            self.feed.stop_recording()
            self.notify("recording stopped", timeout=2)
            return
        path = self.record_path or datetime.now().strftime("gimbalscope-%Y%m%d-%H%M%S.mcap")
        self.feed.start_recording(path)
        self.notify(f"recording to {path}", timeout=2)

    # ------------------------------------------------------------- filter
    def action_filter(self) -> None:
        bar = self.filter_bar
        bar.add_class("shown")
        box = self.filter_box
        box.value = self.model.filter_text
        self._history_pos = None
        box.focus()

    @on(Input.Changed, "#filter")
    def _filter_changed(self, event: Input.Changed) -> None:
        err = self.filter_error
        text = event.value.strip()
        if not text:
            err.update("empty: shows every event")
            err.add_class("ok")
            return
        try:
            compile_filter(text)
        except FilterError as e:
            err.update(f"{e}\n{e.pointer()}")
            err.remove_class("ok")
        else:
            err.update("ok")
            err.add_class("ok")

    @on(Input.Submitted, "#filter")
    def _filter_submitted(self, event: Input.Submitted) -> None:
        text = event.value
        try:
            compile_filter(text) if text.strip() else None
        except FilterError:
            self.bell()
            return
        self.filter_bar.remove_class("shown")
        self.event_list.focus()
        if self.model.shown < BACKGROUND_ROWS:
            self._filter_ready(text, *self.model.prepare_filter(text))
            return
        # a large capture is scanned in a worker thread: the screen (and the capture)
        # go on, the status line shows how far it got, and Esc stops it
        self._scan("filtering", lambda progress, cancelled: self.model.prepare_filter(
            text, progress=progress, cancelled=cancelled), lambda result: self._filter_ready(text, *result))

    def _scan(self, what: str, work, done) -> None:
        """Run ``work(progress, cancelled)`` in a worker thread, then ``done(result)``
        on the screen's thread; progress goes to the status line."""
        from textual.worker import get_current_worker

        self._scan_text = f"{what} …"
        self._refresh_status()
        last = [0.0]

        def progress(n: int, total: int) -> None:
            now = time.monotonic()
            if now - last[0] >= 0.1:   # a message at most ten times a second
                last[0] = now
                # a message, not call_from_thread: the scan never waits for the screen
                self.post_message(ScanProgress(f"{what} {n:,} of {total:,} events "
                                               f"({100 * n // max(1, total)}%), Esc stops"))

        def run() -> None:
            worker = get_current_worker()
            try:
                result = work(progress, lambda: worker.is_cancelled)
            except Cancelled:
                return
            self.call_from_thread(self._scan_done, done, result)

        self.run_worker(run, thread=True, exclusive=True, group="scan")

    def on_scan_progress(self, message: "ScanProgress") -> None:
        if self._scan_text:   # not stopped meanwhile
            self._scan_text = message.text
            self._refresh_status()

    def _scan_done(self, done, result) -> None:
        self._scan_text = ""
        done(result)
        self._refresh_status()

    def action_cancel_scan(self) -> None:
        """Esc: stop a filter or search that is still running."""
        if not self._scan_text:
            return
        self.workers.cancel_group(self, "scan")
        self._scan_text = ""
        self.notify("stopped", timeout=1.5)
        self._refresh_status()

    def _filter_ready(self, text: str, pred, upto: int, view) -> None:
        lst = self.event_list
        keep = lst.selected
        self.model.apply_filter(text, pred, upto, view)
        if keep is not None and not self.model.follow:
            lst.go_to(keep)
        lst.rows_changed()
        lst.focus()
        self._refresh_status()

    def on_key(self, event) -> None:
        box = self.filter_box
        if self.focused is box:
            hist = self.model.filter_history
            if event.key == "escape":
                self.filter_bar.remove_class("shown")
                self.event_list.focus()
                event.stop()
            elif event.key in ("up", "down") and hist:
                pos = len(hist) if self._history_pos is None else self._history_pos
                pos = max(0, min(len(hist) - 1, pos + (-1 if event.key == "up" else 1)))
                self._history_pos = pos
                box.value = hist[pos]
                box.cursor_position = len(box.value)
                event.stop()
        for box in (self.search_box, self.goto_box):
            if self.focused is box and event.key == "escape":
                box.remove_class("shown")
                self.event_list.focus()
                event.stop()

    # -------------------------------------------------------------- go to
    def action_goto(self) -> None:
        box = self.goto_box
        box.add_class("shown")
        box.value = ""
        box.focus()

    @on(Input.Submitted, "#goto")
    def _goto_submitted(self, event: Input.Submitted) -> None:
        event.input.remove_class("shown")
        self.event_list.focus()
        try:
            number = int(event.value)
        except ValueError:
            self.bell()
            return
        if self.model.event(number) is None:
            self.bell()
            self.notify(f"no event #{number} shown (1 to {self.model.largest_number:,})", timeout=2)
            return
        self._go(number)
        if self.model.row_of(number) is None:
            self.notify(f"#{number} is filtered out: at the nearest shown event", timeout=2)

    # ------------------------------------------------------------- search
    def action_search(self) -> None:
        box = self.search_box
        box.add_class("shown")
        box.value = self._search_text
        box.focus()

    @on(Input.Submitted, "#search")
    def _search_submitted(self, event: Input.Submitted) -> None:
        self._search_text = event.value
        event.input.remove_class("shown")
        self.event_list.focus()
        self.action_search_next(1)

    def action_search_next(self, step: int) -> None:
        text = self._search_text
        if not text:
            return
        what = f"row contains {text!r}"
        after, forward = self._current(), step > 0
        if self.model.row_count < BACKGROUND_ROWS:
            self._go(self.model.search(text, after, forward), what)
            return
        self._scan(f"searching for {text!r}", lambda progress, cancelled: self.model.search(
            text, after, forward, progress=progress, cancelled=cancelled), lambda number: self._go(number, what))

    # -------------------------------------------------------------- quit
    async def action_quit(self) -> None:
        self.exit()   # run_app stops the capture and finalises any recording
