"""CSV output (docs/json-lines.md, "CSV"): one row per event, both lines in wire
order (by time), to a file (``convert -o OUT.csv``) or to standard output
(``decode``, ``live`` and ``replay`` with ``--format csv``).

The columns are the event contract's keys, then one per decoded field of the
command table (``formats/field_columns.py``: the names JSON Lines and the
dataset use, a unit in the name where the field has one, ``azimuth_deg``);
``fields`` chooses and orders them. Every cell is a value, nothing nested, so
that a spreadsheet or ``pandas.read_csv`` reads it as it is:

- no value: an empty cell; ``true`` / ``false``; numbers as Python writes them
  (the shortest text that reads back to the same value);
- ``dst`` as ``group.port.device``; a list (``problems``, a list field) as its
  items joined by ``; ``; ``raw`` in hex, as JSON Lines has it.

Quoting is RFC 4180's (``csv.QUOTE_MINIMAL``, CRLF line ends), as the standard
library's ``csv`` module writes it.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from typing import IO, Any

from dissectors.event import Event

from ..formats.field_columns import field_columns
from ..info import CaptureInfo
from ..outfile import OutputRefused
from .base import EventLines

# the event contract's keys (docs/json-lines.md) as columns, in the dataset's order; ``fields`` is spread out
EVENT_COLUMNS = ("number", "t", "t_end", "line", "offset", "kind", "command", "device", "dst", "src", "payload",
                 "checksum_ok", "problems", "txn", "status", "latency", "retransmission", "request", "raw")
FIELD_COLUMNS = {column: name for name, column, _ft in field_columns(EVENT_COLUMNS)}   # column -> field name
COLUMNS = (*EVENT_COLUMNS, *FIELD_COLUMNS)
LIST_SEPARATOR = "; "


def chosen_columns(fields: str | Sequence[str] | None) -> tuple[str, ...]:
    """The columns ``--fields`` names (comma-separated, in its order), or all of
    them; an unknown name is refused in one line, naming the columns."""
    if fields is None:
        return COLUMNS
    names = [f.strip() for f in fields.split(",")] if isinstance(fields, str) else list(fields)
    names = [n for n in names if n]
    unknown = [n for n in names if n not in COLUMNS]
    if unknown or not names:
        what = f"unknown column {', '.join(map(repr, unknown))}" if unknown else "no column named"
        raise OutputRefused(f"--fields: {what}; the columns are {', '.join(EVENT_COLUMNS)} and the fields "
                            f"of the command table ({', '.join(FIELD_COLUMNS)})")
    return tuple(dict.fromkeys(names))


def cell(value: Any) -> Any:
    """A value as one cell: nothing nested (module doc)."""
    if value is None:
        return ""
    if value is True:
        return "true"
    if value is False:
        return "false"
    if isinstance(value, (list, tuple)):
        return LIST_SEPARATOR.join(str(cell(v)) for v in value)
    return value


class CsvWriter(EventLines):
    """Rows are written in blocks of ``BLOCK`` events; ``flush_each`` (live taps)
    writes and flushes every event."""

    BLOCK = 512
    file: IO[bytes]

    def __init__(self, path: str | os.PathLike | None = None, info: CaptureInfo | None = None, *,
                 file: IO[bytes] | None = None, flush_each: bool = False, atomic: bool = True,
                 fields: str | Sequence[str] | None = None) -> None:
        self.columns = chosen_columns(fields)
        self.flush_each = flush_each
        self._text = io.StringIO()
        self._csv = csv.writer(self._text, lineterminator="\r\n")
        self._rows = 0
        self._block = 1 if flush_each else self.BLOCK
        super().__init__(path, info, file=file, atomic=atomic)

    def begin(self) -> None:
        self._csv.writerow(self.columns)
        self._write(self.flush_each)

    def write(self, ev: Event) -> None:
        row = ev.to_dict()
        dst = row["dst"]
        row["dst"] = None if dst is None else ".".join(map(str, dst))
        fields = row["fields"]
        self._csv.writerow([cell(fields.get(FIELD_COLUMNS[c]) if c in FIELD_COLUMNS else row[c])
                            for c in self.columns])
        self._rows += 1
        if self._rows >= self._block:
            self._write(self.flush_each)

    def _write(self, flush: bool) -> None:
        text = self._text.getvalue()
        self._text.seek(0)
        self._text.truncate()
        rows, self._rows = self._rows, 0
        if self.broken or not text:
            return
        with self.writes:
            self.file.write(text.encode("utf-8"))
            self.count += rows
            if flush:
                self.file.flush()

    def finish(self) -> None:
        self._write(False)   # closing the target flushes it
