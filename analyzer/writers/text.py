"""Text output: one tshark-like line per event for people (``decode``, ``live``
and ``replay`` with ``--format text``), on standard output or into a given text
file; the line itself is ``output.text_line``.

Colour only when writing to a terminal (or ``color=True``): each row style's
escape codes, rendered once by Rich (``output.SgrCodes``) and written around
the line, since one Rich print per line cost ten times the plain output. A line
that is not all printable characters (none of ours: wire bytes are shown as
``\\xNN``) goes through Rich's console as before, so control characters are
handled exactly as Rich handles them.

On a terminal each line is out at once (standard output is line-buffered
there); ``flush_each`` flushes every line wherever it goes (a live tap or a
replay into a pipe).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import IO, TYPE_CHECKING

from dissectors.event import Event

from ..formats.marks import marked_text
from ..info import CaptureInfo
from ..outfile import one_line
from ..output import SgrCodes, text_line
from .base import EventLines

if TYPE_CHECKING:   # Rich is imported only for colour
    from rich.console import Console


class TextWriter(EventLines):
    """``write(event)`` writes one line (the printer's call, after its filter)."""

    noun = "lines"
    binary = False
    file: IO[str]   # the target's: standard output or the given file (never None)

    def __init__(self, path: str | None = None, info: CaptureInfo | None = None, *, file: IO[str] | None = None,
                 color: bool | None = None, flush_each: bool = False, marks: Mapping[int, str] | None = None) -> None:
        if path is not None and file is None:
            raise ValueError("the text output goes to standard output or an open text file")
        self.color = color
        # the capture's marks (number -> note, analyzer/formats/marks.py): a line under each marked event
        self.marks = marks or {}
        self.flush_each = flush_each
        self._console: Console | None = None
        self._codes: SgrCodes | None = None
        super().__init__(path, info, file=file)

    def begin(self) -> None:
        out = self.file
        if self.color is None:
            self.color = hasattr(out, "isatty") and out.isatty()
        if self.color:
            from rich.console import Console
            self._console = Console(file=out, highlight=False, soft_wrap=True, force_terminal=True)
            self._codes = SgrCodes(self._console)

    def write(self, ev: Event) -> None:
        if self.broken:
            return
        text, style = text_line(ev)
        with self.writes:
            codes = self._codes
            if codes is None:
                self.file.write(text + "\n")
            elif text.isprintable():
                start, end = codes[style]
                self.file.write(start + text + end + "\n")
            else:
                from rich.text import Text
                assert self._console is not None   # made with the codes (begin)
                self._console.print(Text(text, style=style))
            note = self.marks.get(ev.number) if ev.number is not None else None
            if note is not None:
                self.file.write(f"        {marked_text(one_line(note))}\n")
            if self.flush_each:
                self.file.flush()
        self.count += 1
