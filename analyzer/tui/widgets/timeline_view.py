"""The timeline pane: lanes A and B on a time axis around the selected event,
each answer linked to its command (the layout is timeline.py's)."""

from __future__ import annotations

from itertools import groupby
from typing import Any

from rich.text import Text
from textual.widgets import Static

from ...styles import TIMELINE_STYLE, row_class
from ..model import CaptureModel
from ..timeline import SCALES, layout


class TimelineView(Static):
    """Lanes A and B on a time axis around the selected event; z / Z zoom."""

    def __init__(self, model: CaptureModel, **kw: Any) -> None:
        super().__init__(**kw)
        self.model = model
        self.scale_index = SCALES.index(0.002)
        self.center: float | None = None
        self.selected: int | None = None

    @property
    def scale(self) -> float:
        return SCALES[self.scale_index]

    def zoom(self, step: int) -> None:
        self.scale_index = max(0, min(len(SCALES) - 1, self.scale_index + step))
        self.redraw()

    def redraw(self) -> None:
        width = max(20, self.size.width - 8)
        if self.center is None:
            self.update(Text("timeline: no timed event selected", style="dim"))
            return
        start = self.center - width * self.scale / 2
        events = self.model.window(start, start + width * self.scale)
        slow = self.model.slow
        rows = layout(events, start, self.scale, width, self.selected, lambda e: row_class(e, slow))
        labels = [f"{self.scale * 1000:g} ms/c"[:7].ljust(7), "A →".ljust(7), "".ljust(7), "B ←".ljust(7)]
        out = Text()
        for label, lane in zip(labels, rows):
            out.append(label + " ", style="bold")
            # runs of one style as one span: the same picture whatever Rich's caches hold
            for style, run in groupby(zip(lane.chars, lane.styles), key=lambda cs: cs[1]):
                out.append("".join(ch for ch, _ in run), style=TIMELINE_STYLE.get(style, ""))
            out.append("\n")
        self.update(out)

    def on_resize(self) -> None:
        self.redraw()
