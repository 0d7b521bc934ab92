"""The record control (``r``, live taps): starts recording to MCAP, to the
``--record`` file or a new one named by the time, or stops, and says so. It
holds no recording itself: ``Toggled`` asks the app, which owns the capture
thread, to start or stop one. It draws nothing (the status line shows the
recording). ``live --lean`` makes the recordings it starts lean (docs/mcap.md,
"Lean recordings"): the profile is the tap's, chosen on the command line, like
the ``--record`` file."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from textual.message import Message
from textual.widget import Widget


class RecordControl(Widget):
    class Toggled(Message):
        """Record to ``path`` from now on; ``path`` None: stop recording."""

        def __init__(self, path: str | None) -> None:
            super().__init__()
            self.path = path

    def __init__(self, record_path: str | None, **kw: Any) -> None:
        super().__init__(**kw)
        self.record_path = record_path   # where the record key writes (--record), or None

    def toggle(self, recording: bool) -> None:
        """The record key: stop the recording running, or start one."""
        if recording:
            self.post_message(self.Toggled(None))
            self.notify("recording stopped", timeout=2)
            return
        path = self.record_path or datetime.now().strftime("gimbalscope-%Y%m%d-%H%M%S.mcap")
        self.post_message(self.Toggled(path))
        self.notify(f"recording to {path}", timeout=2)
