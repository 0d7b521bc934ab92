"""The help screen (``?``): every key with what it does and its id (for
``--keymap``), and the row colours."""

from __future__ import annotations

from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.screen import Screen
from textual.widgets import Footer, Static

from ...styles import LEGEND, ROW_STYLE
from .back import BACK


class HelpScreen(Screen):
    BINDINGS = BACK

    def __init__(self, app) -> None:
        super().__init__()
        self._app = app

    def compose(self) -> ComposeResult:
        from ..widgets import EventList

        t = Table(title="Keys (ids rebind with --keymap)", title_justify="left", header_style="bold")
        t.add_column("key")
        t.add_column("does")
        t.add_column("id", style="dim")
        for b in list(EventList.BINDINGS) + list(type(self._app).BINDINGS):
            t.add_row(b.key, b.description, b.id or "")
        rules = Text("\nRow colours: ", style="bold")
        for name, row in LEGEND:
            rules.append(f" {name} ", style=ROW_STYLE[row])
        with VerticalScroll():
            yield Static(t)
            yield Static(rules)
        yield Footer()
