"""The search prompt (``ctrl+f``): a text to find in the rows; Enter asks for
the next row holding it (``Find``). It keeps the text for ``n``/``N``."""

from __future__ import annotations

from textual import on
from textual.message import Message
from textual.widgets import Input

from .prompt import Prompt


class SearchBar(Prompt):
    class Find(Message):
        def __init__(self, text: str) -> None:
            super().__init__()
            self.text = text

    def __init__(self, **kw) -> None:
        super().__init__(placeholder="search text (Enter finds, n/N next/previous)", **kw)
        self.text = ""     # the last text searched for

    def open(self, value: str | None = None) -> None:
        super().open(self.text if value is None else value)

    @on(Input.Submitted)
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.text = event.value
        self.close()
        self.post_message(self.Find(event.value))
