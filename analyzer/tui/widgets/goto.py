"""The go-to prompt (``ctrl+g``; ``:`` where the tap does not talk): an event number; Enter asks to go
there (``Go``); anything but a number rings the bell."""

from __future__ import annotations

from typing import Any

from textual import on
from textual.message import Message
from textual.widgets import Input

from .prompt import Prompt


class GotoBar(Prompt):
    class Go(Message):
        def __init__(self, number: int) -> None:
            super().__init__()
            self.number = number

    def __init__(self, **kw: Any) -> None:
        super().__init__(placeholder="go to event number (Enter goes, Esc cancels)", type="integer", **kw)

    @on(Input.Submitted)
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.close()
        try:
            number = int(event.value)
        except ValueError:
            self.app.bell()
            return
        self.post_message(self.Go(number))
