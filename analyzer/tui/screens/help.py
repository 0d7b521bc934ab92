"""The help screen (``?``): every key with what it does and its id (for
``--keymap``), and the row colours. Keys show as typed and as the footer shows
them (``>``, ``.``, ``^c``: Textual's ``App.get_key_display``), a rebound one
with the keys the keymap gave it."""

from __future__ import annotations

from typing import ClassVar, Protocol

from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.screen import Screen
from textual.widgets import Footer, Static

from ...styles import LEGEND, ROW_STYLE
from .back import BACK


class KeyedApp(Protocol):
    """What the help screen reads of the app (app.py): its keys, the keymap's
    keys for them, and how Textual shows a key."""
    BINDINGS: ClassVar[list[BindingType]]
    keymap: dict[str, str]

    def get_key_display(self, binding: Binding) -> str: ...


class HelpScreen(Screen):
    BINDINGS = BACK

    def __init__(self, app: KeyedApp) -> None:
        super().__init__()
        self._app = app

    def keys_of(self, binding: Binding) -> str:
        """The binding's keys (the keymap's, if it rebinds the id) as typed: "q or ^c"."""
        keys = self._app.keymap.get(binding.id, binding.key) if binding.id else binding.key
        return " or ".join(self._app.get_key_display(Binding(key.strip(), "")) for key in keys.split(","))

    def compose(self) -> ComposeResult:
        from ..widgets import EventList

        t = Table(title="Keys (ids rebind with --keymap)", title_justify="left", header_style="bold")
        t.add_column("key")
        t.add_column("does")
        t.add_column("id", style="dim")
        for b in [*EventList.BINDINGS, *type(self._app).BINDINGS]:
            assert isinstance(b, Binding)   # (every key here is declared as a Binding)
            t.add_row(self.keys_of(b), b.description, b.id or "")
        rules = Text("\nRow colours: ", style="bold")
        for name, row in LEGEND:
            rules.append(f" {name} ", style=ROW_STYLE[row])
        with VerticalScroll():
            yield Static(t)
            yield Static(rules)
        yield Footer()
