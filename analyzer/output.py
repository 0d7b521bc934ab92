"""How an event is shown, whoever writes it: as a JSON object (``dumps``,
``dumps_line``: the encoding of docs/json-lines.md) and as a tshark-like text line
(``text_line``, its style's escape codes ``SgrCodes``), for the writers of
analyzer/writers, the TUI and the reports; and writing to standard output.

A write that fails says where in one line: ``StdoutError`` for standard output (a
full disk behind ``> file``, ``> /dev/full``, EIO), ``OutputError`` naming the
file otherwise (``Writing``). A reader that went away (``| head``) stays a
``BrokenPipeError``: that is no error (``cli/main.py``).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from functools import partial
from types import TracebackType
from typing import TYPE_CHECKING

import orjson

from dissectors import summarize
from dissectors.event import ACK, COMMAND, NAK, NIC, NOISE, RATE, RESULT, Event
from dissectors.problems import MALFORMED
from dissectors.wire import payload_text

from .errors import StdoutError
from .outfile import OutputError, reason, write_error
from .styles import ROW_STYLE, row_class
from .words import counted

if TYPE_CHECKING:
    from rich.console import Console


def dumps(obj: object) -> bytes:
    return orjson.dumps(obj)


# one object's JSON and a newline: a writer's per-event call, orjson itself, without a Python frame around it
dumps_line: Callable[[object], bytes] = partial(orjson.dumps, option=orjson.OPT_APPEND_NEWLINE)


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
    manager: the text writer enters it for every event."""

    __slots__ = ("error",)

    def __init__(self, error: Callable[[OSError], OutputError]) -> None:
        self.error = error

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type[BaseException] | None, e: BaseException | None,
                 tb: TracebackType | None) -> None:
        if kind is None or not isinstance(e, OSError) or isinstance(e, BrokenPipeError):
            return
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
            text = f"'{_payload_shown(ev)}'"
        return text
    if kind == RESULT:
        entry = ev.entry
        if entry is not None and ev.fields:
            return summarize(entry.result_summary, ev.fields)
        return f"'{_payload_shown(ev)}'"
    if kind in (ACK, NAK, NIC):
        return kind.upper()
    if kind == RATE:
        f = ev.fields
        return f"link rate {f.get('previous_baud')} → {f.get('baud')} bps"
    preview = ev.raw[:12].hex(" ")
    n = len(ev.raw)
    return f"{counted(n, 'byte')}: {preview}{' …' if n > 12 else ''}"


def _payload_shown(ev: Event) -> str:
    assert ev.payload is not None, "a frame (a command, a result) has a payload"
    return payload_text(ev.payload)


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


class SgrCodes(dict[str, tuple[str, str]]):
    """Style name → (the escape codes that start it, those that end it), each
    rendered once by Rich for ``console``'s colour system (so ``styles.py`` stays
    the one table of looks, and a 256-colour style is downgraded as Rich would
    on a 16-colour terminal). The plain style has none."""

    def __init__(self, console: Console) -> None:
        super().__init__()
        from rich.console import COLOR_SYSTEMS  # Rich's names ("256") to its ColorSystem
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
