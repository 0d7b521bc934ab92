"""Sinks that print events: JSON Lines for scripts, a tshark-like text line for
people (coloured on a terminal through Rich, plain when piped)."""

from __future__ import annotations

import sys
from typing import IO

from dissectors import summarize
from dissectors.wire import payload_text
from dissectors.event import ACK, COMMAND, NAK, NIC, NOISE, RESULT, Event

try:
    import orjson

    _NL = orjson.OPT_APPEND_NEWLINE

    def dumps(obj) -> bytes:
        return orjson.dumps(obj)

    def dumps_line(obj) -> bytes:
        return orjson.dumps(obj, option=_NL)
except ImportError:  # pragma: no cover - orjson is a dependency; keep working without it
    import json

    def dumps(obj) -> bytes:
        return json.dumps(obj, ensure_ascii=False, separators=(",", ":")).encode()

    def dumps_line(obj) -> bytes:
        return dumps(obj) + b"\n"


class JsonLinesSink:
    """One JSON object per event (README, "Event contract"). Lines are written
    in blocks; ``flush_each`` (live taps) writes and flushes every event."""

    BLOCK = 512

    def __init__(self, out: IO[bytes] | None = None, flush_each: bool = False) -> None:
        self.out = out or sys.stdout.buffer
        self.flush_each = flush_each
        self._lines: list[bytes] = []

    def __call__(self, ev: Event) -> None:
        lines = self._lines
        lines.append(dumps_line(ev.to_dict()))
        if self.flush_each or len(lines) >= self.BLOCK:
            self.out.write(b"".join(lines))
            lines.clear()
            if self.flush_each:
                self.out.flush()

    def close(self) -> None:
        if self._lines:
            self.out.write(b"".join(self._lines))
            self._lines.clear()
        self.out.flush()


def device_address(ev: Event) -> str:
    """The device's group.port.device: a command's destination, a result's source."""
    if ev.dst is None:
        return ""
    g, p, d = ev.dst
    if ev.kind == RESULT:
        g = ev.src
    return f"{g}.{p}.{d}"


def direction(ev: Event) -> str:
    if ev.line == "A":
        return "→"
    if ev.line == "B":
        return "←"
    if ev.kind == COMMAND:
        return "→"
    return "·" if ev.kind == NOISE else "←"


def summary(ev: Event) -> str:
    kind = ev.kind
    if kind == COMMAND:
        entry = ev.entry
        text = summarize(entry.summary, ev.fields) if entry is not None and ev.fields else (
            entry.name.lower() if entry is not None else "")
        if entry is None or not ev.fields and ev.problems and "malformed" in ev.problems[0]:
            text = f"'{payload_text(ev.payload)}'"
        return text
    if kind == RESULT:
        entry = ev.entry
        if entry is not None and ev.fields:
            return summarize(entry.result_summary, ev.fields)
        return f"'{payload_text(ev.payload)}'"
    if kind in (ACK, NAK, NIC):
        return kind.upper()
    preview = ev.raw[:12].hex(" ")
    n = len(ev.raw)
    return f"{n} byte{'' if n == 1 else 's'}: {preview}{' …' if n > 12 else ''}"


def fmt_seconds(s: float | None) -> str:
    if s is None:
        return ""
    if abs(s) < 1.0:
        return f"{s * 1000:.1f} ms"
    return f"{s:.3f} s"


def text_line(ev: Event) -> tuple[str, str]:
    """(line text, style name) for one event."""
    t = f"{ev.t:11.6f}" if ev.t is not None else "          -"
    cmd = ev.command or ""
    if ev.kind == COMMAND:
        tail = ev.status or ""
        if ev.retransmission:
            tail += " retx"
    elif ev.txn is not None:
        tail = f"#{ev.request}" + (f" {fmt_seconds(ev.latency)}" if ev.latency is not None else "")
    else:
        tail = ""
    text = (f"{ev.number:>7} {t} {ev.line:<2}{direction(ev)} {device_address(ev):<11} {ev.kind:<7} "
            f"{cmd:<6} {summary(ev)}")
    if tail:
        text += f"  [{tail}]"
    if ev.problems:
        text += "  ! " + "; ".join(ev.problems)
    return text, style_of(ev)


def style_of(ev: Event) -> str:
    if ev.checksum_ok is False or ev.kind == NOISE:
        return "bold red"
    if ev.kind == NAK or ev.status == "nak":
        return "red"
    if ev.kind == NIC or ev.status == "nic":
        return "magenta"
    if ev.status in ("no_ack", "no_result", "pending") or ev.retransmission:
        return "yellow"
    if ev.problems:
        return "yellow"
    if ev.kind == COMMAND:
        return "cyan"
    return ""


class TextSink:
    """tshark-like lines; colour only when writing to a terminal (Rich decides)."""

    def __init__(self, out: IO[str] | None = None, color: bool | None = None, flush_each: bool = False) -> None:
        self.out = out or sys.stdout
        is_tty = hasattr(self.out, "isatty") and self.out.isatty()
        self.color = is_tty if color is None else color
        self.flush_each = flush_each
        self._console = None
        if self.color:
            from rich.console import Console
            self._console = Console(file=self.out, highlight=False, soft_wrap=True, force_terminal=True)

    def __call__(self, ev: Event) -> None:
        text, style = text_line(ev)
        if self._console is not None:
            from rich.text import Text
            self._console.print(Text(text, style=style or None))
        else:
            self.out.write(text + "\n")
        if self.flush_each:
            self.out.flush()

    def close(self) -> None:
        self.out.flush()
