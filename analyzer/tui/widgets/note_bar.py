"""The note prompt (``M``): a note for the selected event, which marks it;
Enter keeps the note (``Written``), Esc leaves it as it was."""

from __future__ import annotations

from typing import Any

from textual import on
from textual.message import Message
from textual.widgets import Input

from .prompt import Prompt


class NoteBar(Prompt):
    class Written(Message):
        def __init__(self, number: int, note: str) -> None:
            super().__init__()
            self.number = number
            self.note = note

    def __init__(self, **kw: Any) -> None:
        super().__init__(placeholder="note for the selected event (Enter keeps it, Esc cancels)", **kw)
        self.number: int | None = None

    def open_for(self, number: int, note: str) -> None:
        self.number = number
        self.placeholder = f"note for #{number} (Enter keeps it and marks the event, Esc cancels)"
        self.open(note)

    @on(Input.Submitted)
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.close()
        if self.number is not None:
            self.post_message(self.Written(self.number, event.value.strip()))
