"""What the status bar's first line says of a logic capture (a sample stream, a
sigrok session, a VCD or Saleae export): its input, named once, and each line's
channel and what the software UART measured on it (its ``LineReport``,
analyzer/physical/report.py): ``stdin: logic samples at 1 MHz, 8 channels
A D0 9,888 bit/s 8N1  B D1 9,600 bit/s 8N1``.

``SampledInput.of`` is made in the capture thread, from the source's reports
as they are then (the feed puts it in its batches, analyzer/tui/feed.py); it
holds plain values only, so a batch carries it from a decoding process too
(decode_process.py). A serial port's capture has none.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from ...physical.report import LineReport

# the input's name as the header says it (the sources say "standard input")
SHORT_NAMES = {"standard input": "stdin"}
_OTHER = {"A": "B", "B": "A"}


@dataclass(frozen=True)
class LineMeasure:
    """One line as its UART measured it, so far."""
    line: str                       # as the events show it ("A", "B", "AB"): after a swap, the other
    channel: str                    # the channel as the capture names it ("D0")
    measured: float | None = None   # bit/s, from the edges
    nominal: int | None = None      # the standard rate nearest, or the --baud given; None: not measured yet
    given: bool = False             # the rate was given (--baud)
    format: str = ""                # "8N1", once measured
    inverted: bool = False          # idle low

    @classmethod
    def of(cls, report: LineReport, line: str | None = None) -> LineMeasure:
        """From a ``LineReport`` (read in the thread that updates it)."""
        known = report.nominal is not None
        return cls(line or report.line, report.channel, report.measured, report.nominal, report.given,
                   report.format if known else "", report.inverted if known else False)

    @property
    def channel_label(self) -> str:
        """The channel as the header says it: its name, or ``ch0`` for a bare
        number (a sigrok session made from raw samples names its channels so)."""
        return f"ch{self.channel}" if self.channel.isdigit() else self.channel

    def rate(self) -> str | None:
        """The rate in bit/s with thousands separators (``9,888``): as measured, or
        as given when no clock was measured; None before the measure."""
        if self.measured:
            return f"{round(self.measured):,}"
        if self.nominal:
            return f"{self.nominal:,}"
        return None

    def waiting(self, ended: bool) -> str:
        """What stands for the rate while there is none: the UART is still
        measuring, or the capture ended before it could."""
        return "no rate" if ended else "measuring"


@dataclass(frozen=True)
class SampledInput:
    name: str                        # "stdin", "captures/rig.sr"
    kind: str                        # "logic samples at 1 MHz, 8 channels" ("" when the description says none)
    lines: tuple[LineMeasure, ...]

    @classmethod
    def of(cls, description: str, reports: Iterable[LineReport], swapped: bool = False,
           named: tuple[str, str] | None = None) -> SampledInput:
        """``description``: the source's own (``standard input (logic samples at
        1 MHz, 8 channels)``); ``reports``: its ``LineReport``s; ``swapped``:
        line A is read as B (the capture's ``swap_lines``); ``named``: the
        description already split (``split_description``)."""
        name, kind = named or split_description(description)
        lines = [LineMeasure.of(r, _OTHER.get(r.line, r.line) if swapped else None) for r in reports]
        return cls(name, kind, tuple(sorted(lines, key=lambda m: m.line)))

    @property
    def title(self) -> str:
        """The input as one text: ``stdin: logic samples at 1 MHz, 8 channels``."""
        return f"{self.name}: {self.kind}" if self.kind else self.name


def split_description(description: str) -> tuple[str, str]:
    """A source's description, ``NAME (WHAT)`` (analyzer/sources/files.py,
    ``Input.describe``), as (NAME, WHAT): ``("stdin", "logic samples at 1 MHz,
    8 channels")``. Inputs of one kind joined by " + " (a Saleae export in a file
    a channel) are named together; anything else is the name, with no kind."""
    pieces = [_one(p) for p in _top_level(description, " + ")]
    kinds = {kind for _name, kind in pieces}
    if len(kinds) == 1:
        return " + ".join(name for name, _kind in pieces), kinds.pop()
    return description, ""


def _one(text: str) -> tuple[str, str]:
    """``NAME (WHAT)``: the last parenthesis, as a whole (WHAT may hold others)."""
    if text.endswith(")"):
        depth = 0
        for i in range(len(text) - 1, -1, -1):
            depth += {")": 1, "(": -1}.get(text[i], 0)
            if depth == 0:
                name = text[:i].rstrip()
                if name:
                    return SHORT_NAMES.get(name, name), text[i + 1:-1]
                break
    return SHORT_NAMES.get(text, text), ""


def _top_level(text: str, sep: str) -> list[str]:
    """``text`` split at ``sep`` outside parentheses."""
    out, depth, start, i = [], 0, 0, 0
    while i < len(text):
        c = text[i]
        if c == "(":
            depth += 1
        elif c == ")":
            depth = max(0, depth - 1)
        elif depth == 0 and text.startswith(sep, i):
            out.append(text[start:i])
            i += len(sep)
            start = i
            continue
        i += 1
    out.append(text[start:])
    return out
