"""Sinks that print events: JSON Lines for scripts, a tshark-like text line for
people (coloured on a terminal through Rich, plain when piped).

A sink that cannot write says where in one line: ``StdoutError`` for standard
output (a full disk behind ``> file``, ``> /dev/full``, EIO), ``OutputError``
naming the file otherwise. A reader that went away (``| head``) stays a
``BrokenPipeError``: that is no error (``cli/main.py``).
"""

from __future__ import annotations

import sys
from functools import partial
from typing import IO, Callable

from dissectors import summarize
from dissectors.event import ACK, COMMAND, NAK, NIC, NOISE, RATE, RESULT, Event
from dissectors.problems import MALFORMED
from dissectors.wire import payload_text

from .errors import StdoutError
from .outfile import OutputError, reason, write_error
from .styles import ROW_STYLE, row_class

try:
    import orjson

    _NL = orjson.OPT_APPEND_NEWLINE

    def dumps(obj) -> bytes:
        return orjson.dumps(obj)

    def dumps_line(obj) -> bytes:
        return orjson.dumps(obj, option=_NL)

    # the sink's per-event call: orjson itself, without a Python frame around it
    _dumps_line = partial(orjson.dumps, option=_NL)
except ImportError:  # pragma: no cover - orjson is a dependency; keep working without it
    import json

    def dumps(obj) -> bytes:
        return json.dumps(obj, ensure_ascii=False, separators=(",", ":")).encode()

    def dumps_line(obj) -> bytes:
        return dumps(obj) + b"\n"

    _dumps_line = dumps_line


STDOUT = "standard output"


def stdout_error(e: OSError) -> StdoutError:
    return StdoutError(f"{STDOUT}: cannot write: {reason(e)}")


def output_error(name: str, e: OSError) -> OutputError:
    """The one-line error for a failed write to ``name`` (STDOUT or a file name)."""
    if name == STDOUT:
        return stdout_error(e)
    return write_error(name, e)


class Writing:
    """A guard around writes (``with guard:``): a reader that went away stays a
    ``BrokenPipeError`` (quiet, ``cli/main.py``); any other failed write becomes the
    one-line ``error(e)``. A class made once per output, not a generator context
    manager: the text sink enters it for every event."""

    __slots__ = ("error",)

    def __init__(self, error: Callable[[OSError], OutputError]) -> None:
        self.error = error

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind, e, tb) -> bool:
        if kind is None or not issubclass(kind, OSError) or issubclass(kind, BrokenPipeError):
            return False
        raise self.error(e) from None


_STDOUT_WRITES = Writing(stdout_error)


def flush_stdout() -> None:
    """Flush standard output now, so that a failure is ours to report rather than
    the interpreter's at exit."""
    if sys.stdout is None:
        return
    with _STDOUT_WRITES:
        sys.stdout.flush()


def print_out(text: str) -> None:
    """Print a line of a report (stats, doctor) to standard output; a failed
    write is a ``StdoutError``, one line in ``cli/main.py``."""
    with _STDOUT_WRITES:
        sys.stdout.write(text + "\n")


class _Sink:
    """What both sinks share: where they write, and one error for a failed write
    (after which they write nothing more, so closing does not fail again)."""

    def __init__(self, out, name: str | None) -> None:
        if name is None:
            stdout = out is None or out is sys.stdout or out is getattr(sys.stdout, "buffer", None)
            name = STDOUT if stdout else str(getattr(out, "name", "output"))
        self.name = name
        self.broken = False
        self._writes = Writing(self._failed)

    def _failed(self, e: OSError) -> OutputError:
        self.broken = True
        return output_error(self.name, e)


class JsonLinesSink(_Sink):
    """One JSON object per event (docs/json-lines.md). Lines are written
    in blocks; ``flush_each`` (live taps) writes and flushes every event.
    ``name`` names ``out`` in errors (default: standard output)."""

    BLOCK = 512

    def __init__(self, out: IO[bytes] | None = None, flush_each: bool = False, name: str | None = None) -> None:
        super().__init__(out, name)
        self.out = out or sys.stdout.buffer
        self.flush_each = flush_each
        self._lines: list[bytes] = []
        self._block = 1 if flush_each else self.BLOCK   # events per write

    def __call__(self, ev: Event) -> None:
        lines = self._lines
        lines.append(_dumps_line(ev.to_dict()))
        if len(lines) >= self._block:
            self._write(self.flush_each)

    def _write(self, flush: bool) -> None:
        if self.broken:
            self._lines.clear()
            return
        with self._writes:
            self.out.write(b"".join(self._lines))
            self._lines.clear()
            if flush:
                self.out.flush()

    def close(self) -> None:
        self._write(True)


def device_address(ev: Event) -> str:
    """The device's group.port.device (``Event.device``: an answer's is its command's), or ""."""
    return ev.device or ""


def direction(ev: Event) -> str:
    if ev.line == "A":
        return "→"
    if ev.line == "B":
        return "←"
    if ev.kind == COMMAND:
        return "→"
    return "·" if ev.kind in (NOISE, RATE) else "←"


def summary(ev: Event) -> str:
    kind = ev.kind
    if kind == COMMAND:
        entry = ev.entry
        text = summarize(entry.summary, ev.fields) if entry is not None and ev.fields else (
            entry.name.lower() if entry is not None else "")
        if entry is None or not ev.fields and ev.problems and MALFORMED.matches(ev.problems[0]):
            text = f"'{payload_text(ev.payload)}'"
        return text
    if kind == RESULT:
        entry = ev.entry
        if entry is not None and ev.fields:
            return summarize(entry.result_summary, ev.fields)
        return f"'{payload_text(ev.payload)}'"
    if kind in (ACK, NAK, NIC):
        return kind.upper()
    if kind == RATE:
        f = ev.fields
        return f"link rate {f.get('previous_baud')} → {f.get('baud')} bps"
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
    """The Rich style of ``ev``'s line: its row's, as the TUI colours it (``styles``)."""
    return ROW_STYLE[row_class(ev)]


class TextSink(_Sink):
    """tshark-like lines; colour only when writing to a terminal (or ``color=True``).
    ``name`` names ``out`` in errors (default: standard output).

    Colour is each row style's escape codes, rendered once by Rich (``SgrCodes``)
    and written around the line: one Rich print per line cost ten times the
    plain output. A line that is not all printable characters (none of ours:
    wire bytes are shown as ``\\xNN``) goes through Rich's console as before, so
    control characters are handled exactly as Rich handles them.
    """

    def __init__(self, out: IO[str] | None = None, color: bool | None = None, flush_each: bool = False,
                 name: str | None = None) -> None:
        super().__init__(out, name)
        self.out = out or sys.stdout
        is_tty = hasattr(self.out, "isatty") and self.out.isatty()
        self.color = is_tty if color is None else color
        self.flush_each = flush_each
        self._console = None
        self._codes: SgrCodes | None = None
        if self.color:
            from rich.console import Console
            self._console = Console(file=self.out, highlight=False, soft_wrap=True, force_terminal=True)
            self._codes = SgrCodes(self._console)

    def __call__(self, ev: Event) -> None:
        if self.broken:
            return
        text, style = text_line(ev)
        with self._writes:
            codes = self._codes
            if codes is None:
                self.out.write(text + "\n")
            elif text.isprintable():
                start, end = codes[style]
                self.out.write(start + text + end + "\n")
            else:
                from rich.text import Text
                self._console.print(Text(text, style=style or None))
            if self.flush_each:
                self.out.flush()

    def close(self) -> None:
        if self.broken:
            return
        with self._writes:
            self.out.flush()


class SgrCodes(dict):
    """Style name → (the escape codes that start it, those that end it), each
    rendered once by Rich for ``console``'s colour system (so ``styles.py`` stays
    the one table of looks, and a 256-colour style is downgraded as Rich would
    on a 16-colour terminal). The plain style has none."""

    def __init__(self, console) -> None:
        super().__init__()
        from rich.console import (
            COLOR_SYSTEMS,  # Rich's names ("256") to its ColorSystem
        )
        system = console.color_system
        self._system = COLOR_SYSTEMS[system] if system else None
        self._no_color = console.no_color

    def __missing__(self, name: str) -> tuple[str, str]:
        from rich.style import Style
        codes = ("", "")
        if name and self._system is not None:
            style = Style.parse(name)
            if self._no_color:          # NO_COLOR: Rich keeps bold, dim, ... and drops colours
                style = style.without_color
            rendered = style.render("\0", color_system=self._system)
            start, _, end = rendered.partition("\0")
            codes = (start, end)
        self[name] = codes
        return codes
