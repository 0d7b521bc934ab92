"""A row's text: its cells (number, time, lane, address, kind, command,
summary, status, latency) and the time column's mode (absolute, relative to
the first event, delta to the row above). The event list draws them; search
looks for its text in them."""

from __future__ import annotations

from typing import Protocol

from dissectors.event import COMMAND, Event

from ...formats.store import EventStore
from ...output import device_address, fmt_seconds, summary

TIME_MODES = ("absolute", "relative", "delta")


class ShownRows(Protocol):
    """The rows shown, as a row's text reads them of the model (capture.py)."""
    store: EventStore

    def row(self, i: int) -> Event | None: ...


class RowText:
    def __init__(self, model: ShownRows) -> None:
        self.model = model
        self.time_mode = "absolute"

    def cycle_time_mode(self) -> str:
        self.time_mode = TIME_MODES[(TIME_MODES.index(self.time_mode) + 1) % len(TIME_MODES)]
        return self.time_mode

    def time_text(self, ev: Event, row: int) -> str:
        t = ev.t
        if t is None:
            return "-"
        mode = self.time_mode
        if mode == "relative":
            store = self.model.store
            first = store.t[0] if len(store) and store.timed(0) else 0.0
            return f"+{t - first:.6f}"
        if mode == "delta":
            prev = self.model.row(row - 1) if row > 0 else None
            if prev is None or prev.t is None:
                return "+0.000000"
            return f"+{t - prev.t:.6f}"
        return f"{t:.6f}"

    def cells(self, ev: Event, row: int) -> tuple[str, ...]:
        """No., time, lane, address, kind, command, summary, status, latency."""
        if ev.kind == COMMAND:
            status = ev.status or "…"
            if ev.retransmission:
                status += " retx"
        elif ev.request is not None:
            status = f"#{ev.request}"
        else:
            status = ""
        lane = "→ A" if ev.line == "A" else "← B" if ev.line == "B" else ("→" if ev.kind == COMMAND else "←")
        text = summary(ev)
        if ev.problems:
            text += "  ! " + "; ".join(ev.problems)
        return (str(ev.number), self.time_text(ev, row), lane, device_address(ev), ev.kind,
                ev.command or "", text, status, fmt_seconds(ev.latency))
