"""The search prompt (``ctrl+f``): a text to find in the rows, or ``=`` and a
filter expression to find the next row it selects; Enter asks for the next row
(``Find``). It keeps the text for ``n``/``N``. An expression that does not
compile is said, and the prompt stays open on it."""

from __future__ import annotations

from typing import Any

from textual import on
from textual.message import Message
from textual.widgets import Input

from ...analysis.filter import FilterError, compile_filter
from ..model.navigation import FIND_BY_FILTER
from .prompt import Prompt


class SearchBar(Prompt):
    class Find(Message):
        def __init__(self, text: str) -> None:
            super().__init__()
            self.text = text

    def __init__(self, **kw: Any) -> None:
        super().__init__(placeholder=f"search text, or {FIND_BY_FILTER}filter expression (Enter finds, "
                                     "n/N next/previous)", **kw)
        self.text = ""     # the last text searched for

    def open(self, value: str | None = None) -> None:
        super().open(self.text if value is None else value)

    @on(Input.Submitted)
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        if event.value.startswith(FIND_BY_FILTER):
            try:
                compile_filter(event.value[len(FIND_BY_FILTER):].strip())
            except FilterError as e:
                self.app.bell()
                self.notify(f"not a filter: {e}", severity="error", timeout=4)
                return
        self.text = event.value
        self.close()
        self.post_message(self.Find(event.value))
