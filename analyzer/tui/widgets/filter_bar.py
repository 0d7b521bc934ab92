"""The filter bar (``/``): the ``--filter`` language, checked as you type, with
the error's column pointed at; ↑/↓ go through the filters applied before.
Enter on a valid filter asks for it (``Applied``); Esc closes the bar
(``Closed``). Applying it is the screen's: a large capture is filtered in
the background."""

from __future__ import annotations

from typing import Any

from textual import events, on
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.message import Message
from textual.widgets import Input, Static

from ...analysis.filter import FilterError, compile_filter

PLACEHOLDER = ("filter: kind == \"command\" and status != \"ok\"   (Enter applies, Esc cancels, "
               "↑/↓ history)")


class FilterBar(Vertical):
    class Applied(Message):
        """Enter on a valid filter (an empty one shows every event)."""

        def __init__(self, text: str) -> None:
            super().__init__()
            self.text = text

    class Closed(Message):
        """The bar was closed: the event list takes the keys again."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._history: list[str] = []
        self._history_pos: int | None = None

    def compose(self) -> ComposeResult:
        yield Input(placeholder=PLACEHOLDER, id="filter")
        yield Static("", id="filter-error")

    def open(self, text: str, history: list[str]) -> None:
        """Show the bar on ``text`` (the filter applied now); ``history`` is
        the filters applied before, oldest first."""
        self.add_class("shown")
        box = self.query_one("#filter", Input)
        box.value = text
        self._history = history
        self._history_pos = None
        box.focus()

    def close(self) -> None:
        self.remove_class("shown")
        self.post_message(self.Closed())

    @on(Input.Changed, "#filter")
    def _changed(self, event: Input.Changed) -> None:
        err = self.query_one("#filter-error", Static)
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
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        text = event.value
        try:
            compile_filter(text) if text.strip() else None
        except FilterError:
            self.app.bell()
            return
        self.close()
        self.post_message(self.Applied(text))

    def on_key(self, event: events.Key) -> None:
        hist = self._history
        if event.key == "escape":
            self.close()
            event.stop()
        elif event.key in ("up", "down") and hist:
            box = self.query_one("#filter", Input)
            pos = len(hist) if self._history_pos is None else self._history_pos
            pos = max(0, min(len(hist) - 1, pos + (-1 if event.key == "up" else 1)))
            self._history_pos = pos
            box.value = hist[pos]
            box.cursor_position = len(box.value)
            event.stop()
