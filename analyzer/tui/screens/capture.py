"""The main screen: the status bar, the event list, the detail tree and hex
pane, the timeline, and the filter, search and go-to bars. It keeps the panes
on the list's selection and carries out what the bars ask for: a filter or a
search over a large capture runs in the background (``BackgroundSweep``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from textual import on
from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.screen import Screen
from textual.widgets import Footer

from ..model import CaptureModel
from ..model.filter import PreparedFilter
from ..model.navigation import FIND_BY_FILTER
from ..widgets import (
    BackgroundSweep,
    DetailTree,
    EventList,
    FilterBar,
    GotoBar,
    HexView,
    NoteBar,
    RecordControl,
    SearchBar,
    StatusBar,
    TalkBar,
    TimelineView,
)
from ..widgets.background_sweep import Work
from ..widgets.prompt import Prompt

# Filters and searches over more rows than this run in a worker thread, with
# progress on the status line and Esc to stop them.
BACKGROUND_ROWS = 50_000
# seconds: following a busy line, how often the detail, hex and timeline panes
# catch up with the moving selection
DETAIL_EVERY = 0.2


def filtered_out(number: int, which: str = "") -> str:
    """What the go-to prompt and the pair key say of an event the filter hides:
    "#6 is filtered out", "#6, the partner, is filtered out"."""
    return f"#{number}, {which}, is filtered out" if which else f"#{number} is filtered out"


class CaptureScreen(Screen):
    def __init__(self, model: CaptureModel, *, mode: str, source: str, settings: str = "",
                 record_path: str | None = None) -> None:
        super().__init__()
        self.model = model
        # the panes and bars, made here so that the app can reach them before they mount
        self.status_bar = StatusBar(model, mode=mode, source=source, settings=settings, id="status")
        self.event_list = EventList(model, id="events")
        self.detail = DetailTree(id="detail")
        self.hex = HexView(id="hex")
        self.timeline = TimelineView(model, id="timeline")
        self.filter_bar = FilterBar(id="filterbar")
        self.search_bar = SearchBar(id="search")
        self.goto_bar = GotoBar(id="goto")
        self.talk_bar = TalkBar(id="talk")
        self.note_bar = NoteBar(id="note")
        self.record = RecordControl(record_path)
        self.sweep = BackgroundSweep()
        self._detail_due = False   # following: the lower panes catch up on a timer (_detail_later)

    def compose(self) -> ComposeResult:
        yield self.status_bar
        yield self.event_list
        with Horizontal(id="lower"):
            yield self.detail
            yield self.hex
        yield self.timeline
        yield self.filter_bar
        yield self.search_bar
        yield self.goto_bar
        yield self.talk_bar
        yield self.note_bar
        yield self.record
        yield self.sweep
        yield Footer()

    def on_mount(self) -> None:
        self.event_list.focus()

    def on_screen_suspend(self) -> None:
        self.status_bar.shown(False)    # under a full screen: its clock stops

    def on_screen_resume(self) -> None:
        self.status_bar.shown(True)

    def refresh_status(self) -> None:
        self.status_bar.sweep = self.sweep.text
        self.status_bar.redraw()

    # ----------------------------------------------------------- selection
    def rows_changed(self) -> None:
        """The model has more (or other) rows."""
        lst, m = self.event_list, self.model
        before = lst.selected
        lst.rows_changed()
        if lst.selected is None and (first := m.row(0)) is not None:
            lst.go_to(first.number)   # a file opens on its first event
        unsettled = lst.selected is not None and bool(m.unsettled) and lst.selected >= m.unsettled[0].number
        if lst.selected is not None and (lst.selected != before or unsettled):
            if m.follow:
                # following a busy line the selection moves with every batch; rebuilding
                # the detail tree each time kept the screen's thread busy and the list
                # fell behind the wire: the lower panes catch up five times a second
                self._detail_later()
            else:
                self.show_selected(lst.selected)

    def _detail_later(self) -> None:
        """Following: the lower panes catch up DETAIL_EVERY seconds from now (one
        timer at a time, and none while the selection stays)."""
        if not self._detail_due:
            self._detail_due = True
            self.set_timer(DETAIL_EVERY, self._catch_up_detail, name="detail catch-up")

    def _catch_up_detail(self) -> None:
        if self._detail_due:
            self._detail_due = False
            self.show_selected(self.event_list.selected)

    @on(EventList.Selected)
    def _selected(self, message: EventList.Selected) -> None:
        if self.model.follow:
            # following, the cursor moves with every batch: the lower panes catch
            # up on their timer (``_catch_up_detail``), not once a batch
            self._detail_later()
            return
        self.show_selected(message.number)

    def show_selected(self, number: int | None) -> None:
        m = self.model
        ev = m.event(number) if number is not None else None
        if ev is None:
            self.detail.show([], "no event selected")
            self.hex.show(None)
            return
        self.detail.show(m.detail(ev), f"#{ev.number}")
        self.hex.show(ev.raw)
        tl = self.timeline
        tl.selected = ev.number
        if ev.t is not None:
            tl.center = ev.t
        tl.redraw()

    @on(EventList.Navigated)
    def _navigated(self) -> None:
        self.model.following.stop()
        self.refresh_status()

    @on(DetailTree.Jump)
    def _jump(self, message: DetailTree.Jump) -> None:
        self.go(message.number)

    @on(DetailTree.FieldBytes)
    def _field_bytes(self, message: DetailTree.FieldBytes) -> None:
        lst = self.event_list
        ev = self.model.event(lst.selected) if lst.selected is not None else None
        if ev is not None:
            self.hex.show(ev.raw, message.span)

    @property
    def current(self) -> int:
        """The selected event's number (0: none)."""
        sel = self.event_list.selected
        return sel if sel is not None else 0

    def go(self, number: int | None, what: str = "") -> None:
        """To event ``number``; None: there is no ``what`` (the bell, and a word)."""
        if number is None:
            self.app.bell()
            if what:
                self.notify(f"no {what}", timeout=1.5)
            return
        self.model.following.stop()
        if self.event_list.go_to(number):
            self.event_list.focus()
        self.refresh_status()

    def jump(self, to: str, step: int) -> None:
        """To the next (step 1) or previous (-1) error, partner, event of the
        same device, mark or search hit."""
        nav, here, forward = self.model.nav, self.current, step > 0
        if to == "error":
            self.go(nav.next_error(here, forward=forward), "later error (E goes back)" if forward else "earlier error")
        elif to == "pair":
            self._go_partner(nav.partner(here))
        elif to == "device":
            self.go(nav.same_device(here, forward=forward), "other event of this device")
        elif to == "mark":
            self.go(nav.next_mark(here), "marks (m marks a row)")
        elif to == "hit":
            self._search(self.search_bar.text, here, forward)

    def _go_partner(self, partner: int | None) -> None:
        """To the paired event; one the filter hides is said, and the cursor
        stays (the nearest shown event is often the one the cursor is on)."""
        if partner is not None and self.model.row_of(partner) is None:
            self.app.bell()
            self.notify(f"{filtered_out(partner, 'the partner')} (/ changes the filter)", timeout=2)
            return
        self.go(partner, "paired event")

    # ----------------------------------------------------------------- bars
    def open_bar(self, name: str) -> None:
        if name == "filter":
            self.filter_bar.open(self.model.filter_text, self.model.filter.history)
        elif name == "search":
            self.search_bar.open()
        elif name == "goto":
            self.goto_bar.open()
        elif name == "talk":
            self.talk_bar.open()

    @on(FilterBar.Closed)
    @on(Prompt.Closed)
    def _bar_closed(self) -> None:
        self.event_list.focus()

    @on(FilterBar.Applied)
    def _filter(self, message: FilterBar.Applied) -> None:
        text, model = message.text, self.model
        if model.shown < BACKGROUND_ROWS:
            self._filter_ready(model.prepare_filter(text))
            return
        # a large capture is swept in a worker thread: the screen (and the capture)
        # go on, the status line shows how far it got, and Esc stops it
        self._background("filtering", lambda progress, cancelled: model.prepare_filter(
            text, progress=progress, cancelled=cancelled), self._filter_ready)

    def _filter_ready(self, prepared: PreparedFilter) -> None:
        lst = self.event_list
        keep = lst.selected
        self.model.apply_filter(prepared)
        if keep is not None and not self.model.follow:
            lst.go_to(keep)
        lst.rows_changed()
        lst.focus()
        self.refresh_status()

    @on(SearchBar.Find)
    def _find(self) -> None:
        self.jump("hit", 1)

    def _search(self, text: str, after: int, forward: bool) -> None:
        if not text:
            return
        what = f"row matches {text[1:].strip()}" if text.startswith(FIND_BY_FILTER) else f"row contains {text!r}"
        nav = self.model.nav
        if self.model.row_count < BACKGROUND_ROWS:
            self.go(nav.search(text, after, forward), what)
            return
        self._background(f"searching for {text!r}", lambda progress, cancelled: nav.search(
            text, after, forward, progress=progress, cancelled=cancelled), lambda number: self.go(number, what))

    @on(GotoBar.Go)
    def _goto(self, message: GotoBar.Go) -> None:
        number, model = message.number, self.model
        if model.event(number) is None:
            self.app.bell()
            self.notify(f"no event #{number} shown (1 to {model.largest_number:,})", timeout=2)
            return
        self.go(number)
        if model.row_of(number) is None:
            self.notify(f"{filtered_out(number)}: at the nearest shown event", timeout=2)

    # ---------------------------------------------------------- background
    def _background(self, what: str, work: Work, done: Callable[[Any], None]) -> None:
        def finished(result: Any) -> None:
            done(result)
            self.refresh_status()
        self.sweep.start(what, work, finished)
        self.refresh_status()

    @on(BackgroundSweep.Progress)
    def _sweep_progress(self) -> None:
        self.refresh_status()

    def cancel_sweep(self) -> None:
        """Esc: stop a filter or search that is still running."""
        if self.sweep.cancel():
            self.notify("stopped", timeout=1.5)
            self.refresh_status()
