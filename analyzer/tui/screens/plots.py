"""The plots screen (``P``): commanded (go-to) vs reported (position query)
azimuth and elevation per device, as dots on a character grid."""

from __future__ import annotations

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.widgets import Footer, Static

from ..model import CaptureModel
from ..model.plots import Series
from .back import BACK
from .redraw import Redrawn


def plot(series: dict[str, Series], width: int, height: int) -> Text:
    """Series as dots on a character grid (one colour each), with the value range."""
    colours = ["cyan", "bright_green", "magenta", "yellow"]
    filled = [s for s in series.values() if len(s)]
    if not filled:
        return Text("no positions yet (go-to commands and position queries)", style="dim")
    # the ranges from the columns (plots.Series), at C speed: a day of polling is
    # millions of points
    t0, t1 = min(min(s.t) for s in filled), max(max(s.t) for s in filled)
    v0, v1 = min(min(s.v) for s in filled), max(max(s.v) for s in filled)
    if t1 - t0 < 1e-9:
        t1 = t0 + 1
    if v1 - v0 < 1e-9:
        v0, v1 = v0 - 1, v1 + 1
    grid = [[(" ", "")] * width for _ in range(height)]
    for k, (name, pts) in enumerate(series.items()):
        ch = "•" if k % 2 else "·"
        for t, v in pts:
            x = min(width - 1, int((t - t0) / (t1 - t0) * (width - 1)))
            y = height - 1 - min(height - 1, int((v - v0) / (v1 - v0) * (height - 1)))
            grid[y][x] = (ch if "commanded" in name else "●", colours[k % len(colours)])
    out = Text()
    for r, row in enumerate(grid):
        label = f"{v1:8.2f}°" if r == 0 else f"{v0:8.2f}°" if r == height - 1 else " " * 9
        out.append(label + " │", style="dim")
        for ch, colour in row:
            out.append(ch, style=colour)
        out.append("\n")
    out.append(" " * 10 + f"└ {t0:.1f} s" + " " * max(1, width - 20) + f"{t1:.1f} s\n", style="dim")
    for k, name in enumerate(series):
        out.append(f"  {'●' if 'reported' in name else '·'} {name}", style=colours[k % len(colours)])
    out.append("\n")
    return out


class PlotScreen(Redrawn):
    """Commanded (go-to) vs reported (position query) azimuth and elevation per device."""

    BINDINGS = BACK

    def __init__(self, model: CaptureModel) -> None:
        super().__init__()
        self.model = model

    def compose(self) -> ComposeResult:
        yield VerticalScroll(id="plots")
        yield Footer()

    def redraw(self) -> None:
        box = self.query_one("#plots", VerticalScroll)
        width = max(30, self.size.width - 14)
        parts = []
        for addr, series in sorted(self.model.series.items()):
            for axis in ("azimuth", "elevation"):
                sel = {k: v for k, v in series.items() if k.endswith(axis)}
                if sel:
                    parts.append(Text(f"device {addr}: {axis}", style="bold"))
                    parts.append(plot(sel, width, 8))
        if not parts:
            parts = [Text("no positions yet: plots need go-to commands (P) and position queries (P?)",
                          style="dim")]
        box.remove_children()
        box.mount_all([Static(p) for p in parts])
