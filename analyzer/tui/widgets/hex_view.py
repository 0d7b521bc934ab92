"""The hex pane: hex and ASCII of the selected event's bytes, the selected
field's bytes highlighted."""

from __future__ import annotations

from typing import Any

from rich.text import Text
from textual.widgets import Static

from ..detail import hex_lines


class HexView(Static):
    """Hex and ASCII of the selected event; the selected field's bytes highlighted."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._shown: tuple[bytes, tuple[int, int] | None] | None = None   # what ``show`` was last given

    def show(self, raw: bytes | None, span: tuple[int, int] | None = None) -> None:
        if raw is None:
            self._shown = None
            self.update("")
            return
        self._shown = (raw, span)
        # 16 bytes a line when there is room (4 columns a byte: hex, space, ASCII)
        per = 16 if self.size.width - 2 >= 72 else 8 if self.size.width - 2 >= 40 else 4
        lines = []
        for off, hx, asc, marks in hex_lines(raw, span, per):
            line = Text(f"{off}  ", style="dim")
            h = Text(hx.ljust(per * 3 - 1))
            for a, b in marks:
                h.stylize("reverse bold yellow", a, b)
            line.append_text(h)
            line.append("  " + asc, style="green")
            lines.append(line)
        self.update(Text("\n").join(lines))

    def on_resize(self) -> None:
        shown = self._shown
        if shown is not None:
            self.show(*shown)
