"""Text that fits the width it is drawn in, for ``stats``, ``report`` and the TUI's
statistics screen: tables (``FitTable``) and lines of words (``FitLines``), neither
of which ends a line in spaces when the text is piped.

Rich fits a table that is too wide by shrinking its columns, which cuts cells
(``2…``) and headers (``no_a…``). A ``FitTable`` never does: its columns come in
groups (the statuses, the latencies, ...), and when they do not fit side by side
it is drawn as several tables, one under the other, each repeating the key column
(the command, the device, the day) and holding as many whole groups as fit; only a
group wider than the width by itself is split between its columns. When it takes
fewer tables, headers of several words are stacked a word a line (``ACK`` over
``median``): the same names, narrower. Each table has a box on both sides and its
title is a line of its own (a Rich table title is padded to the table's width).

Rich wraps a long line at a space and keeps the space at the end of the line;
``FitLines`` wraps with Rich and drops it. ``FitFields`` shows names and values a
pair a line (``query``'s records), a long value wrapped under itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

from rich.cells import cell_len
from rich.console import Console, ConsoleOptions, RenderResult
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text

_UNBOUNDED = 1 << 20   # a width to measure a table's natural width in


class FitTable:
    """``key`` names the first column; ``groups`` the others, in order, in the groups
    kept together; each row is its key cell, then one cell per column of the groups."""

    def __init__(self, key: str, groups: Sequence[Sequence[str]], rows: Sequence[Sequence[str]],
                 title: str | Text = "") -> None:
        self.headers = [key, *(name for group in groups for name in group)]
        self.groups: list[list[int]] = []
        start = 1
        for group in groups:
            self.groups.append(list(range(start, start + len(group))))
            start += len(group)
        self.rows = [list(row) for row in rows]
        for row in self.rows:
            if len(row) != len(self.headers):
                raise ValueError(f"a row of {len(row)} cells in a table of {len(self.headers)} columns")
        self.title = Text(title, style="bold") if isinstance(title, str) else title
        # a column's natural width, its header on one line or a word a line: nothing
        # in it is ever wrapped otherwise
        cells = [max((cell_len(cell) for cell in column), default=0) for column in zip(*self.rows)] \
            or [0] * len(self.headers)
        self.widths = [max(cell_len(h), c) for h, c in zip(self.headers, cells)]
        self.stacked_widths = [max(max(cell_len(w) for w in h.split(" ")), c) for h, c in zip(self.headers, cells)]

    def table(self, columns: Sequence[int], stacked: bool = False) -> Table:
        """The key column and ``columns`` (indexes into ``headers``) as one Rich table."""
        table = Table(header_style="bold")
        for i in (0, *columns):
            header = self.headers[i].replace(" ", "\n") if stacked else self.headers[i]
            # no_wrap: a cell is never folded onto a second line
            table.add_column(Text(header), justify="left" if i == 0 else "right", no_wrap=True)
        for row in self.rows:
            table.add_row(*(Text(row[i]) for i in (0, *columns)))   # Text: a cell is never markup
        return table

    def natural_width(self, columns: Sequence[int], stacked: bool = False) -> int:
        """The width of ``table(columns, stacked)`` with no column shrunk."""
        widths = self.stacked_widths if stacked else self.widths
        return sum(widths[i] for i in (0, *columns)) + _frame(1 + len(columns))

    def layout(self, width: int) -> tuple[list[list[int]], bool]:
        """The columns of each table drawn ``width`` wide, and whether the headers
        are stacked: on one line unless stacking them makes fewer tables."""
        flat = self.parts(width)
        if len(flat) == 1:
            return flat, False
        stacked = self.parts(width, stacked=True)
        return (stacked, True) if len(stacked) < len(flat) else (flat, False)

    def parts(self, width: int, stacked: bool = False) -> list[list[int]]:
        """The columns of each table drawn ``width`` wide: whole groups while they
        fit, a group too wide on its own split between its columns."""

        def fits(columns: list[int]) -> bool:
            return self.natural_width(columns, stacked) <= width

        parts: list[list[int]] = []
        current: list[int] = []
        for group in self.groups:
            if fits(current + group):
                current += group
                continue
            if current:
                parts.append(current)
            current = []
            if fits(group):
                current = list(group)
                continue
            for column in group:   # wider than the width alone: as many columns a table as fit
                if current and not fits(current + [column]):
                    parts.append(current)
                    current = []
                current.append(column)
        if current or not parts:
            parts.append(current)
        return parts

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        parts, stacked = self.layout(options.max_width)
        for n, columns in enumerate(parts):
            if self.title:
                title = self.title.copy()
                if n:
                    title.append(", continued", style="dim")
                yield title
            yield self.table(columns, stacked)

    def __rich_measure__(self, console: Console, options: ConsoleOptions) -> Measurement:
        parts, stacked = self.layout(options.max_width)
        widest = min(max(self.natural_width(columns, stacked) for columns in parts), options.max_width)
        return Measurement(widest, widest)


class FitFields:
    """Names and their values, a pair a line: the values aligned after the longest
    name, a long one wrapped at the width under itself (a hanging indent), and no
    line ending in spaces (an empty value leaves the name alone)."""

    ROOM = 10   # the least a value is given, however long the names

    def __init__(self, pairs: Sequence[tuple[str, str]], name_style: str = "bold") -> None:
        self.pairs = list(pairs)
        self.name_style = name_style

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        indent = max((cell_len(name) for name, _ in self.pairs), default=0) + 2
        room = max(options.max_width - indent, self.ROOM)
        for name, value in self.pairs:
            for n, part in enumerate(Text(value).wrap(console, room) if value else [Text()]):
                head = Text.assemble((name, self.name_style), " " * (indent - cell_len(name))) if n == 0 \
                    else Text(" " * indent)
                line = head + part
                line.rstrip()
                yield line


def table_width(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> int:
    """The width of a Rich table of these columns (its default box and padding)
    with no column shrunk and nothing wrapped: whether it fits side by side."""
    widths = [max((cell_len(cell) for cell in column), default=0) for column in zip(headers, *rows)]
    return sum(widths) + _frame(len(headers))


@cache
def _frame(columns: int) -> int:
    """What a table of ``columns`` columns adds to their widths (borders, padding),
    as Rich measures a table of that many empty columns."""
    table = Table(*([""] * columns))
    console = Console(width=_UNBOUNDED)
    return Measurement.get(console, console.options, table).maximum


class FitLines:
    """Lines of text (plain strings or styled ``Text``), each wrapped at spaces to the
    width, with no space left at the end of a wrapped line."""

    def __init__(self, *lines: str | Text) -> None:
        self.lines = [Text(line) if isinstance(line, str) else line for line in lines]

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        for text in self.lines:
            for line in text.wrap(console, options.max_width):
                line.rstrip()
                yield line
