"""The event list: number, time, lane, address, kind, command, summary,
status and latency of each row the model shows, coloured by rule.

A Line API widget (``ScrollView.render_line``): it renders only the rows on
screen, so a million events cost no more than a hundred.
"""

from __future__ import annotations

from typing import Any, ClassVar

from rich.segment import Segment
from rich.style import Style
from rich.text import Text
from textual import events
from textual.binding import Binding, BindingType
from textual.geometry import Size
from textual.message import Message
from textual.scroll_view import ScrollView
from textual.strip import Strip

from ...styles import ROW_STYLE, row_class
from ..model import CaptureModel

# the rows' styles (analyzer.styles), parsed once: rows are drawn on every scroll
ROW_STYLES = {name: Style.parse(style) for name, style in ROW_STYLE.items()}
CURSOR = Style(reverse=True)
MARK = Style(underline=True)
HEADER = Style(bold=True, color="bright_white", bgcolor="grey23")

# column: (title, minimum width, flexible)
COLUMNS = (("No.", 6), ("Time", 11), ("Dir", 3), ("Address", 9), ("Kind", 7), ("Cmd", 5),
           ("Summary", 0), ("Status", 9), ("Latency", 8))


def _fit(text: str, width: int, right: bool = False) -> str:
    if len(text) > width:
        return text[:max(0, width - 1)] + "…" if width > 0 else ""
    return text.rjust(width) if right else text.ljust(width)


class EventList(ScrollView, can_focus=True):
    """Number, time, lane, address, kind, command, summary, status, latency."""

    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("up,k", "move(-1)", "Up", show=False, id="list.up"),
        Binding("down,j", "move(1)", "Down", show=False, id="list.down"),
        Binding("pageup", "page(-1)", "Page up", show=False, id="list.page_up"),
        Binding("pagedown", "page(1)", "Page down", show=False, id="list.page_down"),
        Binding("home", "first", "First", show=False, id="list.first"),
    ]

    class Selected(Message):
        def __init__(self, number: int | None) -> None:
            super().__init__()
            self.number = number

    class Navigated(Message):
        """The user moved: follow mode stops."""

    class FollowEnd(Message):
        """End in the list: go to the last event and follow (a file still
        loading: until it has loaded), as the app's End does."""

    def __init__(self, model: CaptureModel, **kw: Any) -> None:
        super().__init__(**kw)
        self.model = model
        self.cursor = 0
        self.selected: int | None = None   # event number under the cursor

    # ------------------------------------------------------------ layout
    def column_widths(self) -> list[int]:
        """The columns' widths in cells: the number column fits the largest
        number, the summary takes what the others leave."""
        width = max(self.scrollable_content_region.width, 40)
        widths = [w for _t, w in COLUMNS]
        widths[0] = max(widths[0], len(str(self.model.largest_number)))   # the number column fits No. 10000000
        fixed = sum(w + 1 for w in widths)
        return [w if w else max(10, width - fixed) for w in widths]

    def header_text(self) -> Text:
        cells = [_fit(t, w, right=k in (0, 8)) for k, ((t, _), w) in enumerate(zip(COLUMNS, self.column_widths()))]
        return Text(" ".join(cells), style=HEADER)

    def render_line(self, y: int) -> Strip:
        scroll_y = self.scroll_offset.y
        width = self.size.width
        if y == 0:
            return Strip([Segment(_fit(self.header_text().plain, width), HEADER)]).crop(0, width)
        row = scroll_y + y - 1
        ev = self.model.row(row)
        if ev is None:
            return Strip.blank(width)
        cells = self.model.text.cells(ev, row)
        text = " ".join(_fit(c, w, right=k in (0, 8)) for k, (c, w) in enumerate(zip(cells, self.column_widths())))
        style = ROW_STYLES[row_class(ev, self.model.slow)]
        if ev.number in self.model.marks:
            style = style + MARK
        if row == self.cursor:
            style = style + CURSOR
        return Strip([Segment(_fit(text, width), style)]).crop(0, width)

    # ----------------------------------------------------------- updates
    def rows_changed(self) -> None:
        """The model has more (or other) rows: resize, and in follow mode go to the end."""
        n = self.model.row_count
        self.virtual_size = Size(self.size.width, n + 1)
        if self.model.follow and n:
            self._set_cursor(n - 1, announce=True)
            self.scroll_to(y=max(0, n + 1 - self.size.height), animate=False)
        elif self.selected is not None:
            row = self.model.row_of(self.selected)
            if row is not None and row != self.cursor:
                self.cursor = row
        self.refresh()

    def _set_cursor(self, row: int, announce: bool = True) -> None:
        n = self.model.row_count
        row = max(0, min(row, n - 1)) if n else 0
        self.cursor = row
        ev = self.model.row(row)
        number = ev.number if ev is not None else None
        if announce and number != self.selected:
            self.selected = number
            self.post_message(self.Selected(number))
        self.selected = number
        # keep the cursor on screen (one line is the header)
        visible = max(1, self.size.height - 1)
        top = int(self.scroll_y)
        if row < top:
            self.scroll_to(y=row, animate=False)
        elif row >= top + visible:
            self.scroll_to(y=row - visible + 1, animate=False)
        self.refresh()

    def go_to(self, number: int) -> bool:
        """Put the cursor on event ``number`` (the nearest shown one if filtered out)."""
        if not self.model.row_count:
            return False
        self._set_cursor(self.model.nearest_row(number))
        return True

    def _navigate(self) -> None:
        self.post_message(self.Navigated())

    def action_move(self, step: int) -> None:
        self._navigate()
        self._set_cursor(self.cursor + step)

    def action_page(self, step: int) -> None:
        self._navigate()
        self._set_cursor(self.cursor + step * max(1, self.size.height - 2))

    def action_scroll_end(self) -> None:
        # ScrollView binds End to scrolling to the end of the rows there are now,
        # which stopped at the rows loaded so far while a file loads
        self.post_message(self.FollowEnd())

    def action_first(self) -> None:
        self._navigate()
        self._set_cursor(0)

    def on_click(self, event: events.Click) -> None:
        row = int(self.scroll_y) + event.y - 1
        if 0 <= row < self.model.row_count:
            self._navigate()
            self._set_cursor(row)

    def on_resize(self) -> None:
        self.virtual_size = Size(self.size.width, self.model.row_count + 1)
