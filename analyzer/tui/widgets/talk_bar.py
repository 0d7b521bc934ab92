"""The talk prompt (``:`` in ``live --talk``): a line in ``send``'s words
(``D? --to 1.1.3``, ``P --to 1.1.3 azimuth_deg=10 elevation_deg=-5 --allow-motion``);
Enter asks to send it (``Send``), Esc cancels. The prompt keeps its history, so
the same request is one key away."""

from __future__ import annotations

from typing import Any

from textual import events, on
from textual.message import Message
from textual.widgets import Input

from .prompt import Prompt


class TalkBar(Prompt):
    class Send(Message):
        def __init__(self, line: str) -> None:
            super().__init__()
            self.line = line

    def __init__(self, **kw: Any) -> None:
        super().__init__(placeholder="send: COMMAND [FIELD=VALUE …] --to G.P.D (Enter sends, Esc cancels, ↑ last)",
                         **kw)
        self.history: list[str] = []

    @on(Input.Submitted)
    def _submitted(self, event: Input.Submitted) -> None:
        event.stop()
        line = event.value.strip()
        self.close()
        if not line:
            return
        if not self.history or self.history[-1] != line:
            self.history.append(line)
        self.post_message(self.Send(line))

    def on_key(self, event: events.Key) -> None:
        if event.key == "up" and self.history:
            self.value = self.history[-1]
            self.cursor_position = len(self.value)
            event.stop()
            return
        super().on_key(event)
