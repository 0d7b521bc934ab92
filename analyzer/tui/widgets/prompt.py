"""A one-line prompt under the panes (search, go to): ``open()`` shows it and
takes the keys; Enter or Esc hides it again (``Closed``)."""

from __future__ import annotations

from textual import events
from textual.message import Message
from textual.widgets import Input


class Prompt(Input):
    class Closed(Message):
        """The prompt was hidden: the event list takes the keys again."""

    def open(self, value: str = "") -> None:
        self.add_class("shown")
        self.value = value
        self.focus()

    def close(self) -> None:
        self.remove_class("shown")
        self.post_message(self.Closed())

    def on_key(self, event: events.Key) -> None:
        if event.key == "escape":
            self.close()
            event.stop()
