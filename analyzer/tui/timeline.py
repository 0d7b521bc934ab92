"""The timeline pane's layout, without Textual: the two lines as lanes on a time
axis, each command linked to its answers like a sequence diagram. Pure: given
events in a time window, it returns text rows and the styles of their cells.

    12.300 s   │12.310        │12.320        │
    A →   ███████                    ████
          └────┐ └──────┐
    B ←        ▌        ▓▓▓▓▓▓
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from dissectors.event import ACK, COMMAND, NAK, NIC, NOISE, RESULT, Event

SCALES = (0.0001, 0.0002, 0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)
GLYPH = {COMMAND: "█", RESULT: "▓", ACK: "▌", NAK: "▌", NIC: "?", NOISE: "░"}


@dataclass
class Lane:
    chars: list[str]
    styles: list[str]

    @classmethod
    def blank(cls, width: int) -> Lane:
        return cls([" "] * width, [""] * width)

    def put(self, col: int, ch: str, style: str) -> None:
        if 0 <= col < len(self.chars):
            self.chars[col] = ch
            self.styles[col] = style

    @property
    def text(self) -> str:
        return "".join(self.chars)


def lane_of(ev: Event) -> int:
    """0 for line A (controller → device), 2 for line B; a single-line tap puts
    commands on the upper lane and answers on the lower."""
    if ev.line == "A" or (ev.line == "AB" and ev.kind == COMMAND):
        return 0
    return 2


def layout(events: list[Event], start: float, scale: float, width: int, selected: int | None,
           style_of: Callable[[Event], str | None]) -> list[Lane]:
    """Rows: axis, lane A, links, lane B, and a legend of silences. ``start`` is the
    time at column 0, ``scale`` seconds per column; ``style_of(ev)`` names a style."""
    axis, upper, links, lower = (Lane.blank(width) for _ in range(4))
    # axis: a tick every 14 columns, labelled with its time
    for col in range(0, width, 14):
        label = f"│{_fmt(start + col * scale, scale)}"
        for k, ch in enumerate(label):
            axis.put(col + k, ch, "axis")
    by_number = {ev.number: ev for ev in events}
    sel = by_number.get(selected) if selected is not None else None
    sel_txn = sel.txn if sel is not None else None
    prev_end: float | None = None
    gaps: list[tuple[int, float]] = []
    for ev in events:
        if ev.t is None:
            continue
        c0 = int((ev.t - start) / scale)
        c1 = max(c0, int(((ev.t_end or ev.t) - start) / scale - 1e-9))
        style = style_of(ev) or ev.kind
        if sel_txn is not None and ev.txn == sel_txn or ev.number == selected:
            style = "selected"
        row = upper if lane_of(ev) == 0 else lower
        for c in range(c0, c1 + 1):
            row.put(c, GLYPH.get(ev.kind, "·"), style)
        if prev_end is not None and ev.t - prev_end > 20 * scale:
            gaps.append((int((prev_end - start) / scale) + 1, ev.t - prev_end))
        prev_end = max(prev_end or ev.t, ev.t_end or ev.t)
        # a link from the command's end to each of its answers
        if ev.request is not None and ev.request in by_number:
            cmd = by_number[ev.request]
            if cmd.t_end is None:
                continue
            a = int((cmd.t_end - start) / scale)
            b = c0
            lstyle = "selected" if sel_txn is not None and ev.txn == sel_txn else "link"
            if a >= b:
                links.put(b, "│", lstyle)
                continue
            links.put(a, "└", lstyle)
            for c in range(a + 1, b):
                links.put(c, "─", lstyle)
            links.put(b, "┐", lstyle)
    # silences: the gap's length written into the link row where there is room
    for col, seconds in gaps:
        label = f" ⋯ {_fmt_span(seconds)} "
        if all(0 <= col + k < width and links.chars[col + k] == " " for k in range(len(label))):
            for k, ch in enumerate(label):
                links.put(col + k, ch, "gap")
    return [axis, upper, links, lower]


def _fmt(t: float, scale: float) -> str:
    if scale < 0.001:
        return f"{t:.4f}"
    if scale < 0.1:
        return f"{t:.3f}"
    return f"{t:.1f}"


def _fmt_span(s: float) -> str:
    return f"{s * 1000:.0f} ms" if s < 1 else f"{s:.1f} s"
